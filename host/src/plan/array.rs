//! Transducer arrays: the AUTD3 device layout and placed devices.
//!
//! Geometry follows AUTD3's published layout: an 18 × 14 grid at 10.16 mm
//! pitch with three positions left out for the mounting holes (grid
//! (1, 1), (2, 1) and (16, 1)), 249 transducers per device. A device's local
//! origin is the centre of its transducer 0, x runs along the long side,
//! y along the short side, and the transducers face local +z.
//! All lengths are millimetres (see [`crate::units`]).

/// Columns of the AUTD3 grid (along local x).
pub const AUTD3_COLUMNS: usize = 18;
/// Rows of the AUTD3 grid (along local y).
pub const AUTD3_ROWS: usize = 14;
/// Transducer pitch of the AUTD3 grid (mm).
pub const AUTD3_PITCH_MM: f64 = 10.16;
/// Transducers per AUTD3 device.
pub const AUTD3_TRANSDUCERS: usize = 249;
/// Board width of an AUTD3 (mm): the pitch of devices placed side by side along x.
pub const AUTD3_DEVICE_WIDTH_MM: f64 = 192.0;
/// Board height of an AUTD3 (mm): the pitch of devices placed side by side along y.
pub const AUTD3_DEVICE_HEIGHT_MM: f64 = 151.4;

/// One transducer: its centre and the unit normal it emits along.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transducer {
    /// Centre of the emitting face (mm).
    pub pos_mm: [f64; 3],
    /// Unit vector along which the transducer emits.
    pub normal: [f64; 3],
}

/// Whether AUTD3 leaves grid position (`x`, `y`) empty.
pub fn autd3_is_missing(x: usize, y: usize) -> bool {
    y == 1 && (x == 1 || x == 2 || x == 16)
}

/// The 249 transducer centres of one AUTD3 in device-local coordinates
/// (mm), in AUTD3's index order (x fastest).
pub fn autd3_local_positions_mm() -> impl Iterator<Item = [f64; 3]> {
    (0..AUTD3_ROWS).flat_map(|y| {
        (0..AUTD3_COLUMNS)
            .filter(move |&x| !autd3_is_missing(x, y))
            .map(move |x| [x as f64 * AUTD3_PITCH_MM, y as f64 * AUTD3_PITCH_MM, 0.0])
    })
}

/// Centre of the AUTD3 transducer grid in device-local coordinates (mm).
pub fn autd3_local_center_mm() -> [f64; 3] {
    [
        (AUTD3_COLUMNS - 1) as f64 * AUTD3_PITCH_MM / 2.0,
        (AUTD3_ROWS - 1) as f64 * AUTD3_PITCH_MM / 2.0,
        0.0,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn autd3_has_249_transducers_on_the_grid() {
        let p: Vec<_> = autd3_local_positions_mm().collect();
        assert_eq!(p.len(), AUTD3_TRANSDUCERS);
        assert_eq!(p[0], [0.0, 0.0, 0.0]);
        // Row 1 starts at x = 0, then skips x = 1 and 2.
        assert_eq!(p[18], [0.0, AUTD3_PITCH_MM, 0.0]);
        assert_eq!(p[19], [3.0 * AUTD3_PITCH_MM, AUTD3_PITCH_MM, 0.0]);
        let last = p[p.len() - 1];
        assert!((last[0] - 17.0 * AUTD3_PITCH_MM).abs() < 1e-12);
        assert!((last[1] - 13.0 * AUTD3_PITCH_MM).abs() < 1e-12);
    }
}
