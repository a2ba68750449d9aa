//! Tests of `npy`.

use super::*;

fn tmp(name: &str) -> crate::files::Scratch {
    crate::files::scratch_file("npy", name)
}

#[test]
fn written_recordings_read_back() {
    let p = tmp("rt.npy");
    let mut w = DepthNpyWriter::create(&p, 3, 2).unwrap();
    w.push(&[1, 2, 3, 4, 5, 65535]).unwrap();
    w.push(&[0; 6]).unwrap();
    assert_eq!(w.finish().unwrap(), 2);
    let mut r = DepthNpy::open(&p).unwrap();
    assert_eq!((r.frames, r.height, r.width), (2, 2, 3));
    let mut b = Vec::new();
    assert!(r.read_into(&mut b).unwrap());
    assert_eq!(b, [1, 2, 3, 4, 5, 65535]);
    assert!(r.read_into(&mut b).unwrap());
    assert!(!r.read_into(&mut b).unwrap());
    let t = tmp("t.npy");
    write_f64_1d(&t, &[0.0, 0.011]).unwrap();
    assert_eq!(read_timestamps(&t).unwrap(), [0.0, 0.011]);
}

#[test]
fn colour_recordings_read_back_and_check_their_shape() {
    let p = tmp("rgb.npy");
    let mut w = ColourNpyWriter::create(&p, 2, 1).unwrap();
    w.push(&[1, 2, 3, 4, 5, 6]).unwrap();
    assert!(w.push(&[0; 5]).is_err());
    assert_eq!(w.finish().unwrap(), 1);
    let mut r = ColourNpy::open(&p).unwrap();
    assert_eq!((r.frames, r.height, r.width), (1, 1, 2));
    assert_eq!(r.read().unwrap().unwrap(), [1, 2, 3, 4, 5, 6]);
    assert!(r.read().unwrap().is_none());
    let e = ColourNpy::open(&tmp("rt.npy").with_file_name("missing.npy"))
        .err()
        .unwrap();
    assert!(!e.to_string().is_empty());
    std::fs::write(&p, header("|u1", &[1, 1, 2, 4], 128)).unwrap();
    let e = ColourNpy::open(&p).err().unwrap().to_string();
    assert!(e.contains("(frames, height, width, 3)"), "{e}");
}

#[test]
fn truncated_npy_is_an_input_error() {
    let p = tmp("trunc.npy");
    let mut w = DepthNpyWriter::create(&p, 4, 4).unwrap();
    w.push(&[7; 16]).unwrap();
    w.finish().unwrap();
    let bytes = std::fs::read(&p).unwrap();
    std::fs::write(&p, &bytes[..bytes.len() - 3]).unwrap();
    let e = DepthNpy::open(&p).err().unwrap().to_string();
    assert!(e.contains("truncated"), "{e}");
    std::fs::write(&p, &bytes[..20]).unwrap();
    assert!(DepthNpy::open(&p).is_err());
    std::fs::write(&p, b"").unwrap();
    assert!(DepthNpy::open(&p).is_err());
}

/// `bytes` written to `p`, then opened: the error's text.
fn open_error(p: &std::path::Path, bytes: &[u8]) -> String {
    std::fs::write(p, bytes).unwrap();
    DepthNpy::open(p).err().unwrap().to_string()
}

/// A header for `descr` and `shape`, then `data` zero bytes.
fn npy(descr: &str, shape: &str, data: usize) -> Vec<u8> {
    // Written by hand, so a malformed shape can be tested.
    let mut text = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    text.push_str(&" ".repeat(128 - 10 - text.len() - 1));
    text.push('\n');
    let mut h = b"\x93NUMPY\x01\x00".to_vec();
    h.extend_from_slice(&(text.len() as u16).to_le_bytes());
    h.extend_from_slice(text.as_bytes());
    h.extend_from_slice(&vec![0; data]);
    h
}

#[test]
fn wrong_dtype_shape_and_order_are_input_errors() {
    let p = tmp("dtype.npy");
    crate::npy::write_f64(&p, 2, 2, &[0.0; 4]).unwrap();
    let e = DepthNpy::open(&p).err().unwrap().to_string();
    assert!(e.contains("dtype `<f8`") && e.contains("uint16"), "{e}");
    let e = open_error(&p, &npy("<u2", "(4, 4)", 32));
    assert!(e.contains("(frames, height, width)"), "{e}");
    let mut h = header("<u2", &[1, 2, 2], 128);
    let at = h.windows(5).position(|w| w == b"False").unwrap();
    h[at..at + 5].copy_from_slice(b"True ");
    h.extend_from_slice(&[0; 8]);
    let e = open_error(&p, &h);
    assert!(e.contains("Fortran"), "{e}");
    let e = open_error(&p, &npy(">u2", "(1, 2, 2)", 8));
    assert!(e.contains("big-endian"), "{e}");
    // A huge shape in a tiny file: refused before any allocation.
    let e = open_error(&p, &npy("<u2", "(100000000, 8000, 8000)", 8));
    assert!(e.contains("truncated"), "{e}");
    // A header length beyond the file.
    let mut h = b"\x93NUMPY\x02\x00".to_vec();
    h.extend_from_slice(&u32::MAX.to_le_bytes());
    let e = open_error(&p, &h);
    assert!(e.contains("header"), "{e}");
}

#[test]
fn a_header_value_with_a_tail_is_not_the_value_it_starts_with() {
    let p = tmp("tail.npy");
    for (dict, needle) in [
        (
            "{'descr': '<u2'*2, 'fortran_order': False, 'shape': (1, 2, 2), }",
            "'descr' must be a quoted type such as '<u2', got `'<u2'*2`",
        ),
        (
            "{'descr': '<u2', 'fortran_order': Falsey, 'shape': (1, 2, 2), }",
            "'fortran_order' must be False or True, got `Falsey`",
        ),
        (
            "{'descr': '<u2', 'fortran_order': False, 'shape': (1, 2, 2)*2, }",
            "'shape' must be a tuple of sizes",
        ),
    ] {
        let mut text = dict.to_owned();
        text.push_str(&" ".repeat(128 - 10 - text.len() - 1));
        text.push('\n');
        let mut h = b"\x93NUMPY\x01\x00".to_vec();
        h.extend_from_slice(&(text.len() as u16).to_le_bytes());
        h.extend_from_slice(text.as_bytes());
        h.extend_from_slice(&[0; 8]);
        let e = open_error(&p, &h);
        assert!(e.contains(needle), "{dict}: {e}");
    }
    // What numpy writes still reads, a trailing comma in the shape too.
    let ok = npy("<u2", "(1, 2, 2,)", 8);
    std::fs::write(&p, ok).unwrap();
    assert!(DepthNpy::open(&p).is_ok());
}

#[test]
fn time_stamps_meet_a_streams_bounds_naming_the_file() {
    for (i, (t, needle)) in [
        (
            vec![-1.0, 0.0],
            "frame 0: time stamp -1 s is out of range: give 0 to 1e10 s",
        ),
        (vec![1e300], "frame 0: time stamp 1e300 s is out of range"),
        (
            vec![0.0, 61.0],
            "frame 1: time stamp 61 s is 61 s after the previous frame's; at most 60 s",
        ),
    ]
    .into_iter()
    .enumerate()
    {
        // One file each: a file read is never written over.
        let p = tmp(&format!("stamps{i}.npy"));
        write_f64_1d(&p, &t).unwrap();
        let e = read_timestamps(&p).unwrap_err().to_string();
        assert!(e.contains(needle) && e.contains("stamps"), "{e}");
    }
    let p = tmp("stamps_ok.npy");
    write_f64_1d(&p, &[1.8e9, 1.8e9 + 0.01]).unwrap();
    assert_eq!(read_timestamps(&p).unwrap().len(), 2);
}

#[test]
fn header_is_aligned_and_data_follows() {
    let b = encode_f64(2, 3, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
    assert_eq!(&b[..8], b"\x93NUMPY\x01\x00");
    let hl = u16::from_le_bytes([b[8], b[9]]) as usize;
    assert_eq!((10 + hl) % 64, 0);
    let h = std::str::from_utf8(&b[10..10 + hl]).unwrap();
    assert!(h.contains("'shape': (2, 3)"), "{h}");
    assert!(h.ends_with('\n'));
    assert_eq!(b.len(), 10 + hl + 48);
    assert_eq!(
        f64::from_le_bytes(b[10 + hl + 40..].try_into().unwrap()),
        6.0
    );
    assert!(encode_f64(2, 2, &[1.0]).is_err());
}
