//! Centroid correction through autd3's per-transducer `PhaseCorrection`.
//!
//! The offsets are computed by the firmware's own function,
//! [`lm_fw_core::correction::compute_offsets`], on the packed µm positions
//! built here, the same the LM firmware receives, so both backends steer
//! identically.

use lm_fw_core::correction::POSITION_BYTES;

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
