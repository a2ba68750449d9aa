//! The fits behind `lmhost calibrate camera`, plain geometry with no file
//! or camera: a ball's centre from the points of its visible cap (a
//! sphere of known radius, Gauss–Newton, refitted on the points near its
//! surface) and the rigid transform between two sets of points (Horn's
//! closed form), with the check that known points pin a rotation down.

use nalgebra::{Matrix3, Matrix4, Quaternion, SymmetricEigen, UnitQuaternion, Vector3};
use serde::Serialize;

use crate::error::InputError;
use crate::geom::{Vec3, add, cross, dot, norm, scale, sub};

/// Fewest points on a ball that make a fit.
pub const MIN_BALL_POINTS: usize = 50;
/// Largest RMS distance of a ball's points from its fitted surface (mm).
pub const MAX_FIT_RMS_MM: f64 = 3.0;

/// A ball found in a recording.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Ball {
    /// Centre (camera, mm).
    pub center_mm: Vec3,
    /// Points the fit used.
    pub points: usize,
    /// Their RMS distance from the fitted surface (mm).
    pub rms_mm: f64,
}

/// Least-squares centre of a sphere of radius `r` through `pts`, from
/// `c0`: Gauss–Newton on |p − c| − r.
fn sphere_fit(pts: &[Vec3], r: f64, c0: Vec3) -> Vec3 {
    let mut c = c0;
    for _ in 0..50 {
        let mut jtj = [[0.0; 3]; 3];
        let mut jtr = [0.0; 3];
        for p in pts {
            let d = sub(*p, c);
            let l = norm(d);
            if l < 1e-9 {
                continue;
            }
            let res = l - r;
            let j = scale(d, -1.0 / l);
            for a in 0..3 {
                jtr[a] += j[a] * res;
                for b in 0..3 {
                    jtj[a][b] += j[a] * j[b];
                }
            }
        }
        let m = Matrix3::from_fn(|i, j| jtj[i][j]);
        let Some(step) = m.cholesky().map(|c| c.solve(&Vector3::from(jtr))) else {
            break;
        };
        let step = [step[0], step[1], step[2]];
        c = sub(c, step);
        if norm(step) < 1e-7 {
            break;
        }
    }
    c
}

/// Finds a ball of `diameter` among `pts` (camera, mm): seeded at the
/// nearest points, fitted, then refitted on the points near its surface.
pub fn find_ball(pts: &[Vec3], diameter: f64, what: &str) -> Result<Ball, InputError> {
    let r = diameter / 2.0;
    let nearest = pts
        .iter()
        .copied()
        .min_by(|a, b| a[2].total_cmp(&b[2]))
        .ok_or_else(|| InputError::new(format!("{what}: no points in front of the background")))?;
    let mut inliers: Vec<Vec3> = pts
        .iter()
        .copied()
        .filter(|p| norm(sub(*p, nearest)) < 1.5 * diameter)
        .collect();
    let mut c = Vec3::default();
    let mut rms = f64::INFINITY;
    for round in 0..4 {
        if inliers.len() < MIN_BALL_POINTS {
            break;
        }
        let n = inliers.len() as f64;
        let centroid = inliers
            .iter()
            .fold([0.0; 3], |a, p| add(a, scale(*p, 1.0 / n)));
        // The visible cap's centroid lies about r/2 in front of the centre.
        let c0 = if round == 0 {
            add(
                centroid,
                scale(centroid, 0.5 * r / norm(centroid).max(1e-9)),
            )
        } else {
            c
        };
        c = sphere_fit(&inliers, r, c0);
        let res: Vec<f64> = inliers.iter().map(|p| norm(sub(*p, c)) - r).collect();
        rms = (res.iter().map(|e| e * e).sum::<f64>() / n).sqrt();
        let band = (3.0 * rms).max(2.0);
        inliers = pts
            .iter()
            .copied()
            .filter(|p| (norm(sub(*p, c)) - r).abs() < band)
            .collect();
    }
    if inliers.len() < MIN_BALL_POINTS {
        return Err(InputError::new(format!(
            "{what}: only {} points on a {diameter} mm ball (need {MIN_BALL_POINTS}); is it in view and in front of the background?",
            inliers.len()
        )));
    }
    if rms.is_nan() || rms > MAX_FIT_RMS_MM {
        return Err(InputError::new(format!(
            "{what}: the points do not fit a {diameter} mm ball (RMS {rms:.2} mm > {MAX_FIT_RMS_MM} mm); check ball_diameter_mm"
        )));
    }
    Ok(Ball {
        center_mm: c,
        points: inliers.len(),
        rms_mm: rms,
    })
}

/// The rotation and translation with `to ≈ R from + t`, least squares
/// (Horn 1987, unit quaternions: the rotation is the eigenvector of the
/// largest eigenvalue of a symmetric 4 × 4 matrix, nalgebra's solver).
pub fn rigid_fit(from: &[Vec3], to: &[Vec3]) -> ([[f64; 3]; 3], Vec3) {
    let n = from.len() as f64;
    let mean = |v: &[Vec3]| v.iter().fold([0.0; 3], |a, p| add(a, scale(*p, 1.0 / n)));
    let (cf, ct) = (mean(from), mean(to));
    let mut s = [[0.0; 3]; 3];
    for (a, b) in from.iter().zip(to) {
        let (a, b) = (sub(*a, cf), sub(*b, ct));
        for i in 0..3 {
            for j in 0..3 {
                s[i][j] += a[i] * b[j];
            }
        }
    }
    let [[sxx, sxy, sxz], [syx, syy, syz], [szx, szy, szz]] = s;
    let n = Matrix4::new(
        sxx + syy + szz,
        syz - szy,
        szx - sxz,
        sxy - syx,
        syz - szy,
        sxx - syy - szz,
        sxy + syx,
        szx + sxz,
        szx - sxz,
        sxy + syx,
        -sxx + syy - szz,
        syz + szy,
        sxy - syx,
        szx + sxz,
        syz + szy,
        -sxx - syy + szz,
    );
    // The rotation is the unit quaternion of N's largest eigenvalue.
    let eig = SymmetricEigen::new(n);
    let top = eig.eigenvalues.imax();
    let q = eig.eigenvectors.column(top);
    let rot = UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]));
    let m = rot.to_rotation_matrix();
    let r: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]));
    let rc = [dot(r[0], cf), dot(r[1], cf), dot(r[2], cf)];
    (r, sub(ct, rc))
}

/// Refuses points that do not pin a rotation down: fewer than 3, or
/// (nearly) on one line.
pub(super) fn check_spread(points: &[Vec3]) -> Result<(), InputError> {
    let n = points.len() as f64;
    let c = points
        .iter()
        .fold([0.0; 3], |a, p| add(a, scale(*p, 1.0 / n)));
    // Largest distance from the centroid, then from the line through it.
    let far = points
        .iter()
        .map(|p| sub(*p, c))
        .max_by(|a, b| norm(*a).total_cmp(&norm(*b)))
        .unwrap_or_default();
    let len = norm(far);
    let off_line = points
        .iter()
        .map(|p| {
            let d = sub(*p, c);
            if len > 0.0 {
                norm(cross(d, scale(far, 1.0 / len)))
            } else {
                0.0
            }
        })
        .fold(0.0, f64::max);
    if len < 10.0 || off_line < 10.0 {
        return Err(InputError::new(format!(
            "the ball positions are (nearly) on one line ({off_line:.1} mm off it): place at least 3 of them 10 mm or more off any line"
        )));
    }
    Ok(())
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::geom::euler_xyz_deg;
    use crate::plan::scene::camera::CameraPose;

    pub(in crate::lab::calibrate::camera) fn pose_from(
        rot_deg: Vec3,
        position: Vec3,
    ) -> CameraPose {
        let r = euler_xyz_deg(rot_deg);
        CameraPose {
            position_mm: position,
            axes: [0, 1, 2].map(|k| [r[0][k], r[1][k], r[2][k]]),
        }
    }

    #[test]
    fn rigid_fit_recovers_a_rotation_exactly_from_clean_points() {
        let truth = pose_from([23.0, -61.0, 147.0], [12.0, 280.0, 70.0]);
        let cam: Vec<Vec3> = [
            [10.0, 0.0, 250.0],
            [-40.0, 20.0, 230.0],
            [0.0, -35.0, 270.0],
            [30.0, 30.0, 260.0],
        ]
        .to_vec();
        let scene: Vec<Vec3> = cam.iter().map(|c| truth.to_scene(*c)).collect();
        let (r, t) = rigid_fit(&cam, &scene);
        let got = CameraPose {
            position_mm: t,
            axes: [0, 1, 2].map(|k| [r[0][k], r[1][k], r[2][k]]),
        };
        assert!(norm(sub(got.position_mm, truth.position_mm)) < 1e-9);
        for k in 0..3 {
            assert!(norm(sub(got.axes[k], truth.axes[k])) < 1e-12, "axis {k}");
        }
        // A proper rotation: orthonormal, right-handed.
        let z = cross(got.axes[0], got.axes[1]);
        assert!(norm(sub(z, got.axes[2])) < 1e-12);
    }
}
