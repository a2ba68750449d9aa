//! The upload header of the paper's LM-S, for the protocol's unit tests
//! (`src/header.rs`, by path) and its integration tests (`paper.rs`): the
//! includer has `UploadHeader` in scope.

use super::UploadHeader;

/// The paper's LM-S (one focus, 5 Hz, 82 steps of about 0.23 mm round
/// A = 3 mm) on the four boards, 200 mm up, within a 20 mm work volume, at
/// `intensity`.
pub fn lm_s_header(intensity: u8) -> UploadHeader {
    UploadHeader {
        steps: 82,
        transducers: 996,
        period_us: 200_000,
        center_um: [0, 0, 200_000],
        foci_per_step: 1,
        sound_speed_mm_s: 340_000,
        max_offset_um: 20_000,
        intensity,
    }
}
