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

mod fit;
use fit::check_spread;
pub use fit::{Ball, MAX_FIT_RMS_MM, MIN_BALL_POINTS, find_ball, rigid_fit};

use crate::geom::{Vec3, dot, norm, sub};
use crate::npy::DepthNpy;
use crate::plan::scene::camera::CameraPose;
use crate::sense::track::intrinsics::Intrinsics;

/// A pixel is in front of the background when it is this much nearer (mm).
pub const FOREGROUND_MM: f64 = 15.0;
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
    use super::fit::tests::pose_from;
    use super::*;
    use crate::geom::add;

    fn angle_deg(a: &CameraPose, b: &CameraPose) -> f64 {
        // Angle of the rotation a⁻¹ b: trace = 1 + 2 cos θ.
        let tr: f64 = (0..3).map(|k| dot(a.axes[k], b.axes[k])).sum();
        ((tr - 1.0) / 2.0).clamp(-1.0, 1.0).acos().to_degrees()
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
