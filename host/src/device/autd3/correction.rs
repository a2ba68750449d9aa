//! Centroid correction through autd3's per-transducer `PhaseCorrection`.
//!
//! The offsets are computed by the firmware's own function,
//! [`lm_fw_core::correction::compute_offsets`], on the same packed µm
//! positions the LM firmware receives, so both backends steer identically.

use lm_fw_core::correction::{POSITION_BYTES, compute_offsets, sound_speed_m_s};

use crate::error::InputError;
use crate::plan::scene::Scene;
use crate::units::vec_mm_to_um;

/// Transducer positions as the firmware takes them: `[i32; 3]` µm LE, packed.
pub fn packed_positions_um(scene: &Scene) -> Result<Vec<u8>, InputError> {
    let tr = scene.transducers();
    let mut out = Vec::with_capacity(tr.len() * POSITION_BYTES);
    for t in &tr {
        for v in vec_mm_to_um(t.pos_mm)? {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    Ok(out)
}

/// Per-transducer offsets (u8 phase LSB) moving a sequence planned at
/// `center_um` to `centroid_um`, written into `out`.
pub fn offsets_into(
    positions: &[u8],
    center_um: [i32; 3],
    centroid_um: [i32; 3],
    sound_speed_mm_s: u32,
    out: &mut [u8],
) {
    compute_offsets(
        positions,
        center_um,
        centroid_um,
        sound_speed_m_s(sound_speed_mm_s),
        out,
    );
}
