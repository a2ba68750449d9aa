//! `lmhost calibrate camera`: the depth camera's pose in the scene from
//! recordings of a ball held at known scene points.
//!
//! A ball's centre is found without bias from its visible cap: the points
//! in front of the background are fitted with a sphere of the ball's known
//! radius (Gauss–Newton, then refitted on the points within a band of the
//! surface, so a stick or a hand drops out). A fingertip would not do: the
//! centroid of its visible surface moves with the viewing angle. Three or
//! more centres at known, non-collinear scene points then give the rigid
//! transform camera → scene in closed form (Horn's quaternion method),
//! with the residual at every point reported.
//!
//! The points file (TOML; paths relative to it):
//!
//! ```toml
//! ball_diameter_mm = 40.0
//! background = "empty.npy"       # optional: the view without the ball
//! [[point]]
//! at_mm = [0, 30, 30]            # ball centre in the scene
//! depth = "p1.npy"               # (frames, height, width) uint16
//! ```

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::InputError;
use nalgebra::{Matrix3, Matrix4, Quaternion, SymmetricEigen, UnitQuaternion, Vector3};

use crate::geom::{Vec3, add, cross, dot, norm, scale, sub};
use crate::npy::DepthNpy;
use crate::plan::scene::camera::CameraPose;
use crate::sense::track::intrinsics::Intrinsics;

/// A pixel is in front of the background when it is this much nearer (mm).
pub const FOREGROUND_MM: f64 = 15.0;
/// Fewest points on a ball that make a fit.
pub const MIN_BALL_POINTS: usize = 50;
/// Largest RMS distance of a ball's points from its fitted surface (mm).
pub const MAX_FIT_RMS_MM: f64 = 3.0;
/// Default largest residual at a known point (mm) before the calibration
/// is refused.
pub const MAX_RESIDUAL_MM: f64 = 3.0;
/// Frames used per recording (the first ones).
pub const MAX_FRAMES: u64 = 30;
/// Most points a points file may list.
pub const MAX_POINTS: usize = 64;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PointsFile {
    ball_diameter_mm: f64,
    background: Option<PathBuf>,
    #[serde(default)]
    point: Vec<PointFile>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PointFile {
    #[serde(deserialize_with = "crate::geom::exact::vec3")]
    at_mm: Vec3,
    depth: PathBuf,
}

/// The calibration target: a ball recorded at known points.
#[derive(Debug, Clone)]
pub struct Target {
    /// The points file it was read from (named in every error about it).
    pub file: PathBuf,
    /// Ball diameter (mm).
    pub ball_diameter_mm: f64,
    /// Recording of the view without the ball, if any.
    pub background: Option<PathBuf>,
    /// Known ball centres (scene, mm) and their recordings.
    pub points: Vec<(Vec3, PathBuf)>,
}

impl Target {
    /// Reads and checks a points file; recordings are relative to it.
    pub fn load(path: &Path) -> Result<Self, InputError> {
        let text = crate::limits::read_text_file("points file", path)?;
        let origin = path.display();
        let bad = |m: String| InputError::new(format!("points file {origin}: {m}"));
        let f: PointsFile =
            crate::plan::scene::from_toml(&text, &crate::files::kind::POINTS).map_err(bad)?;
        let d = f.ball_diameter_mm;
        if !(d.is_finite() && (5.0..=500.0).contains(&d)) {
            return Err(bad(format!(
                "`ball_diameter_mm` must be 5..=500 mm, got {d}"
            )));
        }
        if f.point.len() < 3 || f.point.len() > MAX_POINTS {
            return Err(InputError::new(format!(
                "points file {origin}: needs 3..={MAX_POINTS} [[point]] entries (ball positions), got {}",
                f.point.len()
            )));
        }
        let dir = path.parent().unwrap_or(Path::new("."));
        let mut points = Vec::with_capacity(f.point.len());
        for (i, p) in f.point.into_iter().enumerate() {
            crate::limits::position_mm(
                &format!("points file {origin}: point[{i}].at_mm"),
                p.at_mm,
            )?;
            let at = crate::files::in_folder(dir, &format!("point[{i}].depth"), &p.depth);
            points.push((p.at_mm, at.map_err(bad)?));
        }
        // The positions' geometry is the file's: refused, naming it,
        // before a recording is read.
        let known: Vec<Vec3> = points.iter().map(|p| p.0).collect();
        check_spread(&known).map_err(|e| InputError::new(format!("points file {origin}: {e}")))?;
        Ok(Self {
            file: path.to_path_buf(),
            ball_diameter_mm: d,
            background: (f.background.as_deref())
                .map(|b| crate::files::in_folder(dir, "background", b).map_err(bad))
                .transpose()?,
            points,
        })
    }
}

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

/// The pose found and how well it fits.
#[derive(Debug, Clone, Serialize)]
pub struct CameraCalibration {
    /// Camera → scene.
    pub pose: CameraPose,
    /// The balls, in the points file's order.
    pub balls: Vec<Ball>,
    /// |pose(ball) − known point| per point (mm).
    pub residuals_mm: Vec<f64>,
    /// RMS of the residuals (mm).
    pub rms_mm: f64,
}

impl CameraCalibration {
    /// The `[camera]` table's keys, with a comment on the fit.
    pub fn table(&self) -> String {
        let v = |a: Vec3| {
            format!(
                "[{}, {}, {}]",
                super::toml_f64(a[0]),
                super::toml_f64(a[1]),
                super::toml_f64(a[2])
            )
        };
        let max = self.residuals_mm.iter().copied().fold(0.0, f64::max);
        format!(
            "# lmhost calibrate camera: {} ball positions, residual RMS {:.3} mm (max {:.3} mm).\n\
             # Axes in scene coordinates: x image right, y image down, z forward.\n\
             position_mm = {}\nx_axis = {}\ny_axis = {}\nz_axis = {}\n",
            self.balls.len(),
            self.rms_mm,
            max,
            v(self.pose.position_mm),
            v(self.pose.axes[0]),
            v(self.pose.axes[1]),
            v(self.pose.axes[2]),
        )
    }
}

/// Camera points (mm) of a recording's first frames, or of the pixels in
/// front of `background` (per-pixel depth, mm; 0 = none).
fn foreground(
    path: &Path,
    intr: &Intrinsics,
    background: Option<&[f64]>,
) -> Result<Vec<Vec3>, InputError> {
    let mut npy = DepthNpy::open(path)?;
    intr.check_frames(npy.width, npy.height, &path.display().to_string())?;
    let mut buf = Vec::new();
    let mut pts = Vec::new();
    let mm = intr.mm_per_unit();
    let mut n = 0;
    while n < MAX_FRAMES && npy.read_into(&mut buf)? {
        n += 1;
        for (i, &d) in buf.iter().enumerate() {
            if d == 0 {
                continue;
            }
            let z = f64::from(d) * mm;
            if let Some(bg) = background
                && bg[i] > 0.0
                && z > bg[i] - FOREGROUND_MM
            {
                continue;
            }
            let (col, row) = (i as u32 % npy.width, i as u32 / npy.width);
            pts.push(intr.deproject(col, row, z));
        }
    }
    if n == 0 {
        return Err(InputError::new(format!(
            "{}: the recording holds no frames",
            path.display()
        )));
    }
    Ok(pts)
}

/// Per-pixel median depth (mm) of a background recording (0: no return).
fn background_depth(path: &Path, intr: &Intrinsics) -> Result<Vec<f64>, InputError> {
    let mut npy = DepthNpy::open(path)?;
    intr.check_frames(npy.width, npy.height, &path.display().to_string())?;
    let mut frames: Vec<Vec<u16>> = Vec::new();
    let mut buf = Vec::new();
    while (frames.len() as u64) < MAX_FRAMES && npy.read_into(&mut buf)? {
        frames.push(buf.clone());
    }
    if frames.is_empty() {
        return Err(InputError::new(format!(
            "{}: the recording holds no frames",
            path.display()
        )));
    }
    let mm = intr.mm_per_unit();
    let mut col = Vec::with_capacity(frames.len());
    Ok((0..frames[0].len())
        .map(|i| {
            col.clear();
            col.extend(
                frames
                    .iter()
                    .map(|f| f[i])
                    .filter(|&d| d > 0)
                    .map(f64::from),
            );
            if col.is_empty() {
                return 0.0;
            }
            col.sort_by(f64::total_cmp);
            crate::clock::quantile(&col, 0.5) * mm
        })
        .collect())
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
fn check_spread(points: &[Vec3]) -> Result<(), InputError> {
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

/// The camera pose from `target`'s recordings seen through `intr`;
/// refused (one line) when a residual exceeds `max_residual_mm`.
pub fn calibrate(
    target: &Target,
    intr: &Intrinsics,
    max_residual_mm: f64,
) -> anyhow::Result<CameraCalibration> {
    let known: Vec<Vec3> = target.points.iter().map(|p| p.0).collect();
    let origin = target.file.display();
    check_spread(&known).map_err(|e| InputError::new(format!("points file {origin}: {e}")))?;
    let bg = target
        .background
        .as_deref()
        .map(|b| background_depth(b, intr))
        .transpose()?;
    let mut balls = Vec::with_capacity(known.len());
    for (i, (_, rec)) in target.points.iter().enumerate() {
        let pts = foreground(rec, intr, bg.as_deref())?;
        let what = format!("points file {origin}: point[{i}] ({})", rec.display());
        balls.push(find_ball(&pts, target.ball_diameter_mm, &what)?);
    }
    let seen: Vec<Vec3> = balls.iter().map(|b| b.center_mm).collect();
    let (r, t) = rigid_fit(&seen, &known);
    let pose = CameraPose {
        position_mm: t,
        axes: [0, 1, 2].map(|k| [r[0][k], r[1][k], r[2][k]]),
    };
    let residuals_mm: Vec<f64> = seen
        .iter()
        .zip(&known)
        .map(|(c, s)| norm(sub(pose.to_scene(*c), *s)))
        .collect();
    let rms_mm =
        (residuals_mm.iter().map(|e| e * e).sum::<f64>() / residuals_mm.len() as f64).sqrt();
    if let Some((i, e)) = residuals_mm
        .iter()
        .enumerate()
        .find(|(_, e)| **e > max_residual_mm)
    {
        return Err(InputError::new(format!(
            "points file {origin}: the ball at point[{i}] lands {e:.2} mm from its known position (limit {max_residual_mm} mm): check at_mm and the recording"
        ))
        .into());
    }
    Ok(CameraCalibration {
        pose,
        balls,
        residuals_mm,
        rms_mm,
    })
}

/// A synthetic depth frame of a ball of `diameter` at `center` (scene)
/// seen by a camera at `pose`, in front of a wall `wall_mm` away, with
/// Gaussian depth noise of `noise_mm` from `rng`: test and demo data.
pub fn render_ball(
    intr: &Intrinsics,
    pose: &CameraPose,
    center: Vec3,
    diameter: f64,
    wall_mm: f64,
    noise_mm: f64,
    rng: &mut crate::rng::SplitMix64,
) -> Vec<u16> {
    let c = pose.to_camera(center);
    let r = diameter / 2.0;
    let mm = intr.mm_per_unit();
    let mut out = Vec::with_capacity((intr.pinhole.width * intr.pinhole.height) as usize);
    for row in 0..intr.pinhole.height {
        for col in 0..intr.pinhole.width {
            // Ray (x, y, 1) · z: the first hit of |z d − c| = r.
            let [x, y] = intr.pinhole.normalised(f64::from(col), f64::from(row));
            let d = [x, y, 1.0];
            let (a, b, cc) = (dot(d, d), -2.0 * dot(d, c), dot(c, c) - r * r);
            let disc = b * b - 4.0 * a * cc;
            let z = if disc >= 0.0 {
                (-b - disc.sqrt()) / (2.0 * a)
            } else {
                wall_mm
            };
            // Box–Muller.
            let (u1, u2) = (rng.next_f64().max(1e-300), rng.next_f64());
            let n = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
            let v = ((z + noise_mm * n) / mm).round();
            out.push(if v >= 1.0 && v <= f64::from(u16::MAX) {
                v as u16
            } else {
                0
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::euler_xyz_deg;

    fn pose_from(rot_deg: Vec3, position: Vec3) -> CameraPose {
        let r = euler_xyz_deg(rot_deg);
        CameraPose {
            position_mm: position,
            axes: [0, 1, 2].map(|k| [r[0][k], r[1][k], r[2][k]]),
        }
    }

    fn angle_deg(a: &CameraPose, b: &CameraPose) -> f64 {
        // Angle of the rotation a⁻¹ b: trace = 1 + 2 cos θ.
        let tr: f64 = (0..3).map(|k| dot(a.axes[k], b.axes[k])).sum();
        ((tr - 1.0) / 2.0).clamp(-1.0, 1.0).acos().to_degrees()
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

    /// The synthetic rig: a camera 250 mm from the marker, a 40 mm ball at
    /// six known points, depth noise of 0.5 mm and 0.1 mm units; the pose
    /// comes back within 0.5 mm and 0.2°.
    #[test]
    fn a_synthetic_pose_is_recovered_within_half_a_millimetre_and_a_fifth_of_a_degree() {
        let dir = crate::files::scratch("calcam");
        let intr = Intrinsics::D435_848X480;
        let truth = pose_from([-100.0, 3.0, 177.0], [4.0, 276.0, 73.0]);
        let marker = [0.0, 30.0, 30.0];
        let offsets = [
            [0.0, 0.0, 0.0],
            [40.0, 0.0, 10.0],
            [-40.0, 10.0, 0.0],
            [0.0, 35.0, -20.0],
            [20.0, -30.0, 20.0],
            [-25.0, -20.0, -25.0],
        ];
        let mut rng = crate::rng::SplitMix64::new(7);
        let mut text = String::from("ball_diameter_mm = 40.0\nbackground = \"bg.npy\"\n");
        let write = |name: &str, frames: &[Vec<u16>]| {
            let mut w = crate::npy::DepthNpyWriter::create(
                &dir.join(name),
                intr.pinhole.width,
                intr.pinhole.height,
            )
            .unwrap();
            for f in frames {
                w.push(f).unwrap();
            }
            w.finish().unwrap();
        };
        let far = [0.0, -2000.0, 30.0];
        let bg: Vec<Vec<u16>> = (0..3)
            .map(|_| render_ball(&intr, &truth, far, 1.0, 600.0, 0.5, &mut rng))
            .collect();
        write("bg.npy", &bg);
        for (i, o) in offsets.iter().enumerate() {
            let at = add(marker, *o);
            let frames: Vec<Vec<u16>> = (0..3)
                .map(|_| render_ball(&intr, &truth, at, 40.0, 600.0, 0.5, &mut rng))
                .collect();
            write(&format!("p{i}.npy"), &frames);
            text.push_str(&format!(
                "[[point]]\nat_mm = [{}, {}, {}]\ndepth = \"p{i}.npy\"\n",
                at[0], at[1], at[2]
            ));
        }
        std::fs::write(dir.join("points.toml"), &text).unwrap();
        let target = Target::load(&dir.join("points.toml")).unwrap();
        let cal = calibrate(&target, &intr, MAX_RESIDUAL_MM).unwrap();
        let dp = norm(sub(cal.pose.position_mm, truth.position_mm));
        let da = angle_deg(&cal.pose, &truth);
        assert!(
            dp <= 0.5 && da <= 0.2,
            "position off by {dp} mm, rotation by {da}°"
        );
        assert!(cal.rms_mm < 0.5, "{cal:?}");
        // The written table loads as a scene's [camera], and the scene's
        // axis checks (unit, orthogonal, right-handed) pass.
        let base = "[[device]]\ncenter_mm = [0, 0, 0]\n";
        let scene = crate::plan::scene::Scene::from_toml(
            &super::super::with_table(base, "camera", &cal.table(), "s.toml").unwrap(),
            "s.toml",
        )
        .unwrap();
        let cam = scene.camera.unwrap();
        assert!(norm(sub(cam.position_mm, cal.pose.position_mm)) < 1e-9);

        // Collinear positions: refused, one line.
        let line: String = (0..3)
            .map(|i| {
                format!(
                    "[[point]]\nat_mm = [{}, 30, 30]\ndepth = \"p{i}.npy\"\n",
                    20 * i
                )
            })
            .collect();
        // A targets file's error, refused as one line.
        let refused = |name: &str, body: String| {
            std::fs::write(dir.join(name), body).unwrap();
            let e = match Target::load(&dir.join(name)) {
                Err(e) => e.to_string(),
                Ok(t) => calibrate(&t, &intr, 3.0).unwrap_err().to_string(),
            };
            assert!(
                e.contains(&format!("points file {}", dir.join(name).display())),
                "{e}"
            );
            assert!(!e.contains('\n'), "{e}");
            e
        };
        let e = refused("line.toml", format!("ball_diameter_mm = 40.0\n{line}"));
        assert!(e.contains("one line"), "{e}");
        // A wrong ball size does not fit.
        let wrong = text.replace("ball_diameter_mm = 40.0", "ball_diameter_mm = 20.0");
        let e = refused("wrong.toml", wrong);
        assert!(e.contains("point[0]"), "{e}");
        // A swapped position: its residual is named.
        let swapped = text.replacen("depth = \"p0.npy\"", "depth = \"p1.npy\"", 1);
        let e = refused("swapped.toml", swapped);
        assert!(e.contains("from its known position"), "{e}");
        // An empty view (the background only) has no ball.
        let e = refused("empty.toml", text.replace("p3.npy", "bg.npy"));
        assert!(e.contains("point[3]"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn bad_points_files_are_one_line_errors() {
        let dir = crate::files::scratch("calpts");
        for (body, needle) in [
            ("ball_diameter_mm = 40.0\n", "needs 3"),
            ("ball_diameter_mm = 0.0\n", "ball_diameter_mm"),
            (
                "ball_diameter_mm = 40.0\n[[point]]\nat_mm = [0, 0]\ndepth = \"a.npy\"\n",
                "line",
            ),
            ("ball_diameter_mm = 40.0\nfoo = 1\n", "foo"),
            // Three positions on one line: the file's geometry, named
            // as the file's other errors are.
            (
                "ball_diameter_mm = 40.0\n[[point]]\nat_mm = [0, 0, 100]\ndepth = \"a.npy\"\n\
                 [[point]]\nat_mm = [10, 0, 100]\ndepth = \"b.npy\"\n\
                 [[point]]\nat_mm = [20, 0, 100]\ndepth = \"c.npy\"\n",
                "on one line",
            ),
        ] {
            std::fs::write(dir.join("p.toml"), body).unwrap();
            let e = Target::load(&dir.join("p.toml")).unwrap_err().0;
            assert!(e.contains(needle) && !e.contains('\n'), "{body}: {e}");
            assert!(
                e.starts_with("points file ") && e.contains("p.toml: "),
                "{e}"
            );
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
