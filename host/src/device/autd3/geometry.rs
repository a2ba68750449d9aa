//! Scene devices → autd3 devices, in the same order.
//!
//! lmhost places a device by the centre of its transducer grid and a
//! rotation matrix; autd3 places it by its transducer 0 and a unit
//! quaternion (f32). [`devices`] converts, [`check_positions`] asserts that
//! the transducer positions autd3 computes equal lmhost's within 1 µm.

use autd3::core::geometry::{Geometry, Point3, Quaternion, UnitQuaternion};
use autd3::prelude::AUTD3;

use crate::error::InputError;
use crate::geom::{Vec3, add, norm, sub};
use crate::plan::array;
use crate::plan::scene::{Device, Scene};

/// Largest transducer position difference accepted between lmhost and autd3 (mm).
pub const POSITION_TOLERANCE_MM: f64 = 1e-3;

/// Two transducers of different devices closer than this (mm) means the
/// boards overlap: the T4010A1 case is 10 mm across.
pub const MIN_TRANSDUCER_GAP_MM: f64 = 10.0;

/// Unit quaternion `(w, x, y, z)` of a rotation matrix (Shepperd's method).
pub fn quaternion(m: &[[f64; 3]; 3]) -> [f64; 4] {
    let tr = m[0][0] + m[1][1] + m[2][2];
    let q = if tr > 0.0 {
        let s = (tr + 1.0).sqrt() * 2.0;
        [
            0.25 * s,
            (m[2][1] - m[1][2]) / s,
            (m[0][2] - m[2][0]) / s,
            (m[1][0] - m[0][1]) / s,
        ]
    } else if m[0][0] > m[1][1] && m[0][0] > m[2][2] {
        let s = (1.0 + m[0][0] - m[1][1] - m[2][2]).sqrt() * 2.0;
        [
            (m[2][1] - m[1][2]) / s,
            0.25 * s,
            (m[0][1] + m[1][0]) / s,
            (m[0][2] + m[2][0]) / s,
        ]
    } else if m[1][1] > m[2][2] {
        let s = (1.0 + m[1][1] - m[0][0] - m[2][2]).sqrt() * 2.0;
        [
            (m[0][2] - m[2][0]) / s,
            (m[0][1] + m[1][0]) / s,
            0.25 * s,
            (m[1][2] + m[2][1]) / s,
        ]
    } else {
        let s = (1.0 + m[2][2] - m[0][0] - m[1][1]).sqrt() * 2.0;
        [
            (m[1][0] - m[0][1]) / s,
            (m[0][2] + m[2][0]) / s,
            (m[1][2] + m[2][1]) / s,
            0.25 * s,
        ]
    };
    let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
    q.map(|x| x / n)
}

/// Scene position of a device's transducer 0 (autd3's device origin).
fn origin_mm(d: &Device) -> Vec3 {
    let c = array::autd3_local_center_mm();
    let r = &d.rotation;
    let local = sub([0.0; 3], c);
    let rotated = [0, 1, 2].map(|i| r[i][0] * local[0] + r[i][1] * local[1] + r[i][2] * local[2]);
    add(rotated, d.center_mm)
}

/// The scene's devices as autd3 devices, same order.
pub fn devices(scene: &Scene) -> Vec<AUTD3<UnitQuaternion>> {
    scene
        .devices
        .iter()
        .map(|d| {
            let o = origin_mm(d);
            let [w, x, y, z] = quaternion(&d.rotation);
            AUTD3::new(
                Point3::new(o[0] as f32, o[1] as f32, o[2] as f32),
                UnitQuaternion::new_normalize(Quaternion::new(
                    w as f32, x as f32, y as f32, z as f32,
                )),
            )
        })
        .collect()
}

/// Refuses a scene whose devices overlap (transducers of two devices
/// closer than [`MIN_TRANSDUCER_GAP_MM`]).
pub fn check_no_overlap(scene: &Scene) -> Result<(), InputError> {
    let per: Vec<Vec<Vec3>> = scene
        .devices
        .iter()
        .map(|d| d.transducers().map(|t| t.pos_mm).collect())
        .collect();
    for a in 0..per.len() {
        for b in a + 1..per.len() {
            // Cheap reject: grid centres farther apart than two grid diagonals.
            if norm(sub(scene.devices[a].center_mm, scene.devices[b].center_mm)) > 2.0 * 230.0 {
                continue;
            }
            let gap = per[a]
                .iter()
                .flat_map(|p| per[b].iter().map(move |q| norm(sub(*p, *q))))
                .fold(f64::INFINITY, f64::min);
            if gap < MIN_TRANSDUCER_GAP_MM {
                return Err(InputError::new(format!(
                    "scene `{}`: devices {a} and {b} overlap (transducers {gap:.2} mm apart, a T4010A1 is {MIN_TRANSDUCER_GAP_MM} mm across)",
                    scene.name
                )));
            }
        }
    }
    Ok(())
}

/// Largest distance (mm) between lmhost's and autd3's position of the same transducer.
pub fn max_position_error_mm(scene: &Scene, geometry: &Geometry) -> f64 {
    let ours = scene.transducers();
    let theirs = geometry.iter().flat_map(|d| d.iter().map(|t| t.position()));
    let mut n = 0;
    let mut worst = 0.0f64;
    for (a, p) in ours.iter().zip(theirs) {
        n += 1;
        let b = [f64::from(p.x), f64::from(p.y), f64::from(p.z)];
        worst = worst.max(norm(sub(a.pos_mm, b)));
    }
    if n != ours.len() || n != geometry.num_transducers() {
        return f64::INFINITY;
    }
    worst
}

/// Fails (not an input error: a bug or an unsupported autd3 change) when
/// autd3's transducers are not where lmhost planned them.
pub fn check_positions(scene: &Scene, geometry: &Geometry) -> anyhow::Result<()> {
    let e = max_position_error_mm(scene, geometry);
    if e > POSITION_TOLERANCE_MM {
        anyhow::bail!(
            "autd3 places the transducers up to {:.3} µm from lmhost's plan (limit 1 µm)",
            e * 1e3
        );
    }
    Ok(())
}
