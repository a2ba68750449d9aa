//! Where scene geometry lands in the colour image: the LM circle (its
//! centre the corrected centre the device plays, its radius the stimulus's
//! A, in the scene's LM plane), the foci and the finger's centroid, each
//! through the calibrated camera pose (scene → depth camera), the depth →
//! colour extrinsics and the colour intrinsics with their distortion
//! ([`ColourCamera::project_from_depth`]).

use super::camera::CameraPose;
use super::colour::ColourCamera;
use crate::geom::{Vec3, add, scale};
use crate::plan::scene::LmPlane;

/// The colour camera placed in the scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColourView {
    /// The depth camera's pose (the scene's `[camera]`).
    pub pose: CameraPose,
    /// The colour camera beside it.
    pub cam: ColourCamera,
}

impl ColourView {
    /// Pixel (column, row) of a scene point, `None` behind the camera.
    pub fn pixel(&self, p_mm: Vec3) -> Option<[f64; 2]> {
        self.cam.project_from_depth(self.pose.to_camera(p_mm))
    }

    /// `n` points of the circle of `radius_mm` about `centre_mm` in the
    /// a-b plane of `plane`, in the image (points behind the camera left
    /// out): a closed polyline, θ = 0 along a, as the trajectory's.
    pub fn circle(
        &self,
        centre_mm: Vec3,
        plane: &LmPlane,
        radius_mm: f64,
        n: usize,
    ) -> Vec<[f64; 2]> {
        (0..n)
            .filter_map(|i| {
                let th = std::f64::consts::TAU * i as f64 / n as f64;
                let p = add(
                    centre_mm,
                    add(
                        scale(plane.a, radius_mm * th.cos()),
                        scale(plane.b, radius_mm * th.sin()),
                    ),
                );
                self.pixel(p)
            })
            .collect()
    }

    /// The square of the image around `centre_mm` that shows
    /// ±`half_mm` of the LM plane about it: `[x0, y0, side]` in pixels,
    /// kept inside the image where it fits (the participant's crop).
    pub fn crop(&self, centre_mm: Vec3, plane: &LmPlane, half_mm: f64) -> [f64; 3] {
        let pts = self.circle(centre_mm, plane, half_mm * std::f64::consts::SQRT_2, 16);
        let (w, h) = (
            f64::from(self.cam.pinhole.width),
            f64::from(self.cam.pinhole.height),
        );
        let Some(c) = self.pixel(centre_mm) else {
            return [0.0, 0.0, w.min(h)];
        };
        let half = pts
            .iter()
            .map(|p| (p[0] - c[0]).abs().max((p[1] - c[1]).abs()))
            .fold(1.0, f64::max)
            .min(w.min(h) / 2.0);
        let x0 = (c[0] - half).clamp(0.0, w - 2.0 * half);
        let y0 = (c[1] - half).clamp(0.0, h - 2.0 * half);
        [x0, y0, 2.0 * half]
    }
}
