//! Minimal NPY (NumPy format 1.0) writer for 2-D little-endian f64 maps.

/// Bytes of a C-order `rows × cols` f64 array in NPY 1.0 format.
///
/// Panics never; `data.len()` must equal `rows * cols` (checked: a
/// mismatch gives an `InvalidInput` I/O error when written).
pub fn encode_f64(rows: usize, cols: usize, data: &[f64]) -> std::io::Result<Vec<u8>> {
    if data.len() != rows.saturating_mul(cols) {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("map has {} values, not {rows} × {cols}", data.len()),
        ));
    }
    let mut header =
        format!("{{'descr': '<f8', 'fortran_order': False, 'shape': ({rows}, {cols}), }}");
    // Magic (6) + version (2) + header length (2) + header + '\n' is a
    // multiple of 64 bytes.
    let unpadded = 10 + header.len() + 1;
    header.push_str(&" ".repeat(unpadded.next_multiple_of(64) - unpadded));
    header.push('\n');
    let mut out = Vec::with_capacity(10 + header.len() + data.len() * 8);
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for v in data {
        out.extend_from_slice(&v.to_le_bytes());
    }
    Ok(out)
}

/// Write a `rows × cols` f64 map to `path` as `.npy`, whole or not at all.
pub fn write_f64(
    path: &std::path::Path,
    rows: usize,
    cols: usize,
    data: &[f64],
) -> anyhow::Result<()> {
    let bytes = encode_f64(rows, cols, data).map_err(|e| crate::files::WriteError::new(path, e))?;
    crate::files::write_whole(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
