//! The fixtures the cases name as `{dir}/NAME`, and the small full disk.

use super::*;

/// Scene files and streams the cases refer to as `{dir}/NAME`.
pub(crate) fn fixtures(dir: &Path) {
    let w = |name: &str, body: &[u8]| std::fs::write(dir.join(name), body).unwrap();
    for (name, rows) in [
        ("gap.csv", ["0,0,0,200,1", "1000,0,0,200,1"]),
        ("gap100k.csv", ["0,0,0,200,1", "100000,0,0,200,1"]),
        ("backwards.csv", ["0,0,0,200,1", "-1e300,0,0,200,1"]),
        ("ok.csv", ["0,0,0,200,1", "0.011,0,0,200,1"]),
    ] {
        w(name, csv(&rows).as_bytes());
    }
    // A real pause in a replay: the samples after it agree (one alone
    // would be dropped as a wild time stamp), so the replay waits 50 s.
    w(
        "pause50.csv",
        csv(&[
            "0,0,0,200,1",
            "50,0,0,200,1",
            "50.01,0,0,200,1",
            "50.02,0,0,200,1",
        ])
        .as_bytes(),
    );
    w("bin.csv", b"\xff\xfe\xfd\n0,0,0,200,1\n");
    let mut long = b"0,0,0,200,1\n".to_vec();
    long.extend(std::iter::repeat_n(b'7', 10_000));
    w("long.csv", &long);
    w("bin.toml", b"name = \"\xff\"\n");
    let dev = |c: &str| format!("[[device]]\ncenter_mm = {c}\n");
    w(
        "same_pose.toml",
        (dev("[0.0, 0.0, 0.0]") + &dev("[0.0, 0.0, 0.0]")).as_bytes(),
    );
    w(
        "overlap.toml",
        (dev("[0.0, 0.0, 0.0]") + &dev("[100.0, 0.0, 0.0]")).as_bytes(),
    );
    w(
        "abutting.toml",
        (dev("[0.0, 0.0, 0.0]") + &dev("[192.0, 0.0, 0.0]")).as_bytes(),
    );
    w("far.toml", dev("[1e300, 0.0, 0.0]").as_bytes());
    w(
        "far_rig.toml",
        (dev("[0.0, 0.0, 0.0]") + "[rig]\nposition_mm = [0.0, 0.0, 5000.0]\n").as_bytes(),
    );
    w(
        "far_reflector.toml",
        (dev("[0.0, 0.0, 0.0]")
            + "[reflector]\npoint_mm = [0.0, 0.0, 1e300]\nnormal = [0.0, 0.0, 1.0]\n")
            .as_bytes(),
    );
    w(
        "far_center.toml",
        ("center_mm = [0.0, 0.0, 1e300]\n".to_owned() + &dev("[0.0, 0.0, 0.0]")).as_bytes(),
    );
    w(
        "facing_away.toml",
        "[[device]]\ncenter_mm = [0.0, 0.0, 0.0]\nrotation_deg = [180.0, 0.0, 0.0]\n".as_bytes(),
    );
    w(
        "edge_on.toml",
        (dev("[0.0, 0.0, 0.0]") + "[lm_plane]\na = [1.0, 0.0, 0.0]\nb = [0.0, 0.0, 1.0]\n")
            .as_bytes(),
    );
    w(
        "tilted_45.toml",
        (dev("[0.0, 0.0, 0.0]")
            + "[lm_plane]\na = [1.0, 0.0, 0.0]\nb = [0.0, 0.7071067811865476, 0.7071067811865476]\n")
            .as_bytes(),
    );
    w(
        "short_dwell.toml",
        ("min_dwell_ms = 0.1\n".to_owned() + &dev("[0.0, 0.0, 0.0]")).as_bytes(),
    );
    w(
        "spinning.toml",
        (dev("[0.0, 0.0, 0.0]") + "rotation_deg = [1e300, 0.0, 0.0]\n").as_bytes(),
    );
    w(
        "slow_dwell.toml",
        ("min_dwell_ms = 1e300\n".to_owned() + &dev("[0.0, 0.0, 0.0]")).as_bytes(),
    );
    // 30 000 devices (1.3 MB) and a 2 MB comment: refused by size before
    // parsing, like the 10^6-device file that would take 46 MB.
    let many: String = (0..30_000)
        .map(|i| dev(&format!("[{}.0, 0.0, 0.0]", i * 200)))
        .collect();
    w("many_devices.toml", many.as_bytes());
    w(
        "huge_comment.toml",
        format!("# {}\n{}", "x".repeat(2 << 20), dev("[0.0, 0.0, 0.0]")).as_bytes(),
    );
    w("bom.csv", b"\xef\xbb\xbf0,0,0,200,1\n0.011,0,0,200,1\n");
    w("crlf.csv", b"0,0,0,200,1\r\n0.011,0,0,200,1\r\n");
    // Depth recordings and intrinsics for `track`.
    let npy = |name: &str, header: &str, data: usize, len_field: Option<u16>| {
        let mut h = header.as_bytes().to_vec();
        while !(10 + h.len() + 1).is_multiple_of(64) {
            h.push(b' ');
        }
        h.push(b'\n');
        let mut b = b"\x93NUMPY\x01\x00".to_vec();
        b.extend(len_field.unwrap_or(h.len() as u16).to_le_bytes());
        b.extend(&h);
        b.extend(std::iter::repeat_n(0u8, data));
        w(name, &b);
    };
    let hdr = |descr: &str, fortran: &str, shape: &str| {
        format!("{{'descr': '{descr}', 'fortran_order': {fortran}, 'shape': {shape}, }}")
    };
    let u2 = |shape: &str| hdr("<u2", "False", shape);
    let twice = "{'descr': '<u2', 'descr': '<f8', 'fortran_order': False, 'shape': (2, 4, 4), }";
    // (file, header, data bytes, header length field if it lies)
    for (name, header, data, len_field) in [
        ("ok.npy", u2("(2, 4, 4)"), 64, None),
        ("empty.npy", u2("(0, 4, 4)"), 0, None),
        ("tb.npy", u2("(1000000000, 8192, 8192)"), 64, None),
        (
            "overflow.npy",
            u2("(18446744073709551615, 8192, 8192)"),
            0,
            None,
        ),
        ("negative.npy", u2("(1, -4, 4)"), 32, None),
        ("float.npy", hdr("<f8", "False", "(2, 4, 4)"), 256, None),
        ("fortran.npy", hdr("<u2", "True", "(2, 4, 4)"), 64, None),
        ("truncated.npy", u2("(2, 4, 4)"), 40, None),
        ("long_tail.npy", u2("(2, 4, 4)"), 100, None),
        ("header_lie.npy", u2("(2, 4, 4)"), 64, Some(60_000)),
        ("twice.npy", twice.to_owned(), 64, None),
    ] {
        npy(name, &header, data, len_field);
    }
    // Time stamps with a wild gap between frame 0 and frame 1.
    for (name, t1) in [("gap_ts.npy", 1e300f64), ("gap100k_ts.npy", 1e5)] {
        let h = hdr("<f8", "False", "(2,)");
        npy(name, &h, 0, None);
        let mut b = std::fs::read(dir.join(name)).unwrap();
        b.extend(0f64.to_le_bytes());
        b.extend(t1.to_le_bytes());
        w(name, &b);
    }
    let cam = |extra: &str| {
        format!(
            "width = 4\nheight = 4\nfx = 2.0\nfy = 2.0\nppx = 1.5\nppy = 1.5\ndepth_scale = 0.001\n{extra}"
        )
    };
    w("cam.toml", cam("").as_bytes());
    for (name, from, to) in [
        ("cam_fx0.toml", "fx = 2.0", "fx = 0.0"),
        ("cam_fxneg.toml", "fx = 2.0", "fx = -2.0"),
        ("cam_fxhuge.toml", "fx = 2.0", "fx = 1e300"),
        ("cam_ppx.toml", "ppx = 1.5", "ppx = 1e300"),
        ("cam_ppy.toml", "ppy = 1.5", "ppy = -3.0"),
        ("cam_nan.toml", "depth_scale = 0.001", "depth_scale = nan"),
        ("cam_wide.toml", "width = 4", "width = 8"),
        ("cam_str.toml", "fy = 2.0", "fy = \"2\""),
    ] {
        w(name, cam("").replace(from, to).as_bytes());
    }
    w("cam_dup.toml", cam("fx = 3.0\n").as_bytes());
    w("cam_unknown.toml", cam("k1 = 0.1\n").as_bytes());
    std::fs::create_dir_all(dir.join("a_directory")).unwrap();
    w("a_file", b"");
    stimulus_fixtures(dir);
    round3_fixtures(dir);
}

/// Stimulus files (`upload --phases`, `--foci-file`) and track lines.
pub(crate) fn stimulus_fixtures(dir: &Path) {
    let w = |name: &str, body: String| std::fs::write(dir.join(name), body).unwrap();
    let rows = |n: usize, t: usize| vec![vec![0u8; t]; n];
    w(
        "ph_short.json",
        serde_json::json!({"phases": rows(4, 10), "dwell_us": 2000}).to_string(),
    );
    w(
        "ph_notime.json",
        serde_json::json!({"phases": rows(4, 996)}).to_string(),
    );
    w(
        "ph_2010.json",
        serde_json::json!({"phases": rows(4, 996), "dwell_us": 2010}).to_string(),
    );
    // Not JSON at all (NaN), so named apart from the .json outputs checked whole.
    w(
        "ph_nan.phases",
        r#"{"phases": [[0]], "dwell_us": NaN}"#.to_owned(),
    );
    w(
        "ph_neg.json",
        serde_json::json!({"phases": rows(4, 996), "dwell_us": -5}).to_string(),
    );
    w(
        "ph_empty.json",
        serde_json::json!({"phases": [], "dwell_us": 2000}).to_string(),
    );
    w(
        "ph_big.json",
        serde_json::json!({"phases": [[300]], "dwell_us": 2000}).to_string(),
    );
    w(
        "fo_behind.json",
        serde_json::json!({"foci_mm": [[[0, 0, -50]]], "dwell_us": 2000}).to_string(),
    );
    w(
        "fo_far.json",
        serde_json::json!({"foci_mm": [[[0, 0, 1e300]]], "dwell_us": 2000}).to_string(),
    );
    w(
        "fo_many.json",
        serde_json::json!({"foci_mm": [vec![[0, 0, 200]; 33]], "dwell_us": 2000}).to_string(),
    );
    w(
        "fo_short.json",
        serde_json::json!({"foci_mm": [[[0, 0, 200]]], "dwell_us": 10}).to_string(),
    );
    // An .npy of phases for 10 transducers, and one shorter than its shape.
    let npy = |shape: &str, data: usize| {
        let h = format!("{{'descr': '|u1', 'fortran_order': False, 'shape': {shape}, }}");
        let mut b = b"\x93NUMPY\x01\x00".to_vec();
        b.extend_from_slice(&((h.len() + 1) as u16).to_le_bytes());
        b.extend_from_slice(h.as_bytes());
        b.push(b'\n');
        b.extend(std::iter::repeat_n(0u8, data));
        b
    };
    std::fs::write(dir.join("ph_10.npy"), npy("(2, 10)", 20)).unwrap();
    std::fs::write(dir.join("ph_ok.npy"), npy("(2, 996)", 2 * 996)).unwrap();
    std::fs::write(dir.join("ph_trunc.npy"), npy("(2, 996)", 996)).unwrap();
    std::fs::write(dir.join("ph_1d.npy"), npy("(996,)", 996)).unwrap();
    w(
        "track_extra.jsonl",
        r#"{"t_s":0,"points":1,"present":false,"centroid_mm":null,"colour":1}"#.to_owned() + "\n",
    );
    w(
        "track_nopos.jsonl",
        r#"{"t_s":0,"points":1,"present":true,"centroid_mm":null}"#.to_owned() + "\n",
    );
}

/// The scene the output-onto-input cases must leave as it was.
pub(crate) const SCENE_COPY: &str = "[[device]]\ncenter_mm = [0.0, 0.0, 0.0]\n";

/// Fixtures of round 3: a FIFO, a scene reached by three names.
pub(crate) fn round3_fixtures(dir: &Path) {
    let st = Command::new("mkfifo")
        .arg(dir.join("fifo"))
        .status()
        .unwrap();
    assert!(st.success(), "mkfifo");
    std::fs::write(dir.join("scene_copy.toml"), SCENE_COPY).unwrap();
    std::os::unix::fs::symlink(dir.join("scene_copy.toml"), dir.join("scene_link.toml")).unwrap();
    std::fs::hard_link(dir.join("scene_copy.toml"), dir.join("scene_hard.toml")).unwrap();
    std::fs::write(
        dir.join("stream_copy.csv"),
        csv(&["0,0,0,200,1", "0.011,0,0,200,1"]),
    )
    .unwrap();
    std::fs::copy(dir.join("ok.npy"), dir.join("in.npy")).unwrap();
    // Valid time stamps named as `--record rec2.npy` would name its own.
    let mut ts = std::fs::read(dir.join("gap100k_ts.npy")).unwrap();
    let n = ts.len();
    ts[n - 8..].copy_from_slice(&0.011f64.to_le_bytes());
    std::fs::write(dir.join("rec2.timestamps.npy"), &ts).unwrap();
    // A camera bridge that sends a bad header and stays alive.
    let bridge = dir.join("stalled_bridge.sh");
    std::fs::write(&bridge, "#!/bin/sh\nprintf BADHEADER\nexec sleep 60\n").unwrap();
    let st = Command::new("chmod")
        .arg("+x")
        .arg(&bridge)
        .status()
        .unwrap();
    assert!(st.success());
    // A D435-sized camera whose depth unit (the finest a camera offers,
    // 1 µm) makes every depth ~0 in the tracking box.
    std::fs::write(
        dir.join("cam_tiny_scale.toml"),
        "width = 848\nheight = 480\nfx = 600.0\nfy = 600.0\nppx = 424.0\nppy = 240.0\ndepth_scale = 1e-6\n",
    )
    .unwrap();
}

/// A small tmpfs at `dir/full` for the disk-full cases, when root may
/// mount one; unmounted on drop. `Err` says why there is none.
pub(crate) struct FullDisk(pub(crate) PathBuf);

impl FullDisk {
    /// 32 KiB, with `keep.bin` (10 bytes) already on it.
    pub(crate) fn mount(dir: &Path) -> Result<FullDisk, String> {
        let at = dir.join("full");
        std::fs::create_dir_all(&at).map_err(|e| e.to_string())?;
        let out = Command::new("mount")
            .args(["-t", "tmpfs", "-o", "size=32k", "tmpfs"])
            .arg(&at)
            .output()
            .map_err(|e| format!("cannot run mount: {e}"))?;
        if !out.status.success() {
            return Err(format!(
                "mount -t tmpfs failed (not root?): {}",
                String::from_utf8_lossy(&out.stderr).trim()
            ));
        }
        std::fs::write(at.join("keep.bin"), b"0123456789").map_err(|e| e.to_string())?;
        Ok(FullDisk(at))
    }
}

impl Drop for FullDisk {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

/// A local TCP port nothing listens on now (the kernel's pick).
pub(crate) fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free local TCP port")
}
