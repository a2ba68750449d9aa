//! The paper's rig and stimuli, for tests that need realistic phases: four
//! AUTD3 boards and LM circles planned on them. The protocol's codec tests
//! and the firmware core's library tests (which include this file by path)
//! share it, so both measure the same sequences.

use lm_proto::UploadHeader;

/// The paper's LM-S upload header, shared with the protocol's unit tests.
#[path = "lm_s_header.rs"]
pub mod lm_s;

/// AUTD3: 18 × 14 grid minus three screw holes, 10.16 mm pitch; four
/// boards 2 × 2 (192 × 151.4 mm apart), centred on the origin, z = 0 (µm).
pub fn autd3_2x2_um() -> Vec<[i32; 3]> {
    let mut pos = Vec::new();
    for by in 0..2 {
        for bx in 0..2 {
            for iy in 0..14 {
                for ix in 0..18 {
                    if iy == 1 && [1, 2, 16].contains(&ix) {
                        continue;
                    }
                    pos.push([
                        bx as f64 * 192.0 + ix as f64 * 10.16,
                        by as f64 * 151.4 + iy as f64 * 10.16,
                    ]);
                }
            }
        }
    }
    let n = pos.len() as f64;
    let mx = pos.iter().map(|p| p[0]).sum::<f64>() / n;
    let my = pos.iter().map(|p| p[1]).sum::<f64>() / n;
    pos.iter()
        .map(|p| {
            [
                ((p[0] - mx) * 1000.0).round() as i32,
                ((p[1] - my) * 1000.0).round() as i32,
                0,
            ]
        })
        .collect()
}

/// LM with `foci` foci (3 mm apart on the circle) of radius `r_mm`, steps
/// of about `step_mm`, focus plane at `z_mm`, on transducers at `pos_um`:
/// φ = arg Σ exp(−j k d), quantised to u8 (host/src/units.rs). Returns the
/// phases (step-major) and the number of steps.
pub fn lm_phases(
    pos_um: &[[i32; 3]],
    foci: usize,
    r_mm: f64,
    step_mm: f64,
    z_mm: f64,
) -> (Vec<u8>, usize) {
    let tau = std::f64::consts::TAU;
    let k = tau / (340.0 / 40.0);
    let steps = (tau * r_mm / step_mm).round() as usize;
    let mut phases = Vec::with_capacity(steps * pos_um.len());
    for s in 0..steps {
        let fp: Vec<[f64; 3]> = (0..foci)
            .map(|f| {
                let a = tau * s as f64 / steps as f64 + f as f64 * 3.0 / r_mm;
                [r_mm * a.cos(), r_mm * a.sin(), z_mm]
            })
            .collect();
        for t in pos_um {
            let t = [t[0] as f64 / 1000.0, t[1] as f64 / 1000.0, 0.0];
            let (mut re, mut im) = (0.0, 0.0);
            for p in &fp {
                let d =
                    ((t[0] - p[0]).powi(2) + (t[1] - p[1]).powi(2) + (t[2] - p[2]).powi(2)).sqrt();
                re += (k * d).cos();
                im -= (k * d).sin();
            }
            phases.push((im.atan2(re) / tau * 256.0).round().rem_euclid(256.0) as u8);
        }
    }
    (phases, steps)
}
