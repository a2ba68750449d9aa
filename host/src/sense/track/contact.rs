//! The paper's contact area: the depth points inside the detection box, and
//! their centroid.
//!
//! Only pixels whose rays can hit the box are touched: the box's eight
//! corners are projected into the image and the pixel rectangle around
//! them (clipped to the frame) is scanned. A pixel's point is computed in
//! the box's own frame as `o + Z · (d_row + c · d_col)` (camera origin `o`
//! and ray directions precomputed per row), so the inner loop is a few
//! multiply-adds and three comparisons. [`reference()`] is the plain
//! full-frame f64 version it is checked against.

use super::camera::CameraSetup;
use super::intrinsics::Intrinsics;
use crate::geom::{Vec3, add, dot, scale};

/// What one frame's contact area is.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Contact {
    /// Depth points inside the box.
    pub points: u32,
    /// Centroid of those points (mm, scene), `None` when there are none.
    pub centroid_mm: Option<Vec3>,
}

/// A pixel rectangle `[c0, c1) × [r0, r1)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Roi {
    /// First column.
    pub c0: u32,
    /// One past the last column.
    pub c1: u32,
    /// First row.
    pub r0: u32,
    /// One past the last row.
    pub r1: u32,
}

impl Roi {
    /// Number of pixels.
    pub fn pixels(&self) -> usize {
        (self.c1 - self.c0) as usize * (self.r1 - self.r0) as usize
    }
}

/// The contact-area tracker for one camera, box and frame size.
#[derive(Debug, Clone)]
pub struct Tracker {
    intr: Intrinsics,
    setup: CameraSetup,
    roi: Roi,
    /// Camera optical centre in box coordinates (mm).
    origin: Vec3,
    /// Box coordinates of the ray of pixel (0, r) per unit depth: `base + r · step_row`.
    ray0: Vec3,
    step_col: Vec3,
    step_row: Vec3,
    half: Vec3,
    mm_per_unit: f64,
}

impl Tracker {
    /// A tracker for frames described by `intr`, seen by `setup`.
    pub fn new(intr: Intrinsics, setup: CameraSetup) -> Self {
        let cam = setup.camera;
        let b = setup.track_box;
        // Box coordinates of a camera vector v: axes_box · (R_cam v).
        let to_box = |v: Vec3| -> Vec3 {
            let scene = cam
                .axes
                .iter()
                .zip(&v)
                .fold([0.0; 3], |acc, (a, &k)| add(acc, scale(*a, k)));
            b.axes.map(|ax| dot(ax, scene))
        };
        let origin = {
            let d = crate::geom::sub(cam.position_mm, b.center_mm);
            b.axes.map(|ax| dot(ax, d))
        };
        let ray0 = to_box([
            -intr.pinhole.ppx / intr.pinhole.fx,
            -intr.pinhole.ppy / intr.pinhole.fy,
            1.0,
        ]);
        let step_col = to_box([1.0 / intr.pinhole.fx, 0.0, 0.0]);
        let step_row = to_box([0.0, 1.0 / intr.pinhole.fy, 0.0]);
        Self {
            intr,
            setup,
            roi: box_roi(&intr, &setup),
            origin,
            ray0,
            step_col,
            step_row,
            half: b.size_mm.map(|s| s / 2.0),
            mm_per_unit: intr.mm_per_unit(),
        }
    }

    /// The pixel rectangle scanned per frame.
    pub fn roi(&self) -> Roi {
        self.roi
    }

    /// The intrinsics.
    pub fn intrinsics(&self) -> &Intrinsics {
        &self.intr
    }

    /// The setup.
    pub fn setup(&self) -> &CameraSetup {
        &self.setup
    }

    /// Visit every point inside the box: `f(col, row, p_box)` with `p_box`
    /// in box coordinates (mm). `depth` is one row-major frame.
    #[inline]
    pub fn for_each_inside(&self, depth: &[u16], mut f: impl FnMut(u32, u32, Vec3)) {
        let w = self.intr.pinhole.width as usize;
        assert_eq!(
            depth.len(),
            w * self.intr.pinhole.height as usize,
            "frame size"
        );
        let [h0, h1, h2] = self.half;
        for r in self.roi.r0..self.roi.r1 {
            let row = &depth[r as usize * w..(r as usize + 1) * w];
            let base = add(self.ray0, scale(self.step_row, r as f64));
            for c in self.roi.c0..self.roi.c1 {
                let v = row[c as usize];
                if v == 0 {
                    continue;
                }
                let z = v as f64 * self.mm_per_unit;
                let cf = c as f64;
                let p = [
                    self.origin[0] + z * (base[0] + cf * self.step_col[0]),
                    self.origin[1] + z * (base[1] + cf * self.step_col[1]),
                    self.origin[2] + z * (base[2] + cf * self.step_col[2]),
                ];
                if p[0].abs() <= h0 && p[1].abs() <= h1 && p[2].abs() <= h2 {
                    f(c, r, p);
                }
            }
        }
    }

    /// The contact area of one frame.
    pub fn track(&self, depth: &[u16]) -> Contact {
        let mut n = 0u32;
        let mut sum = [0.0; 3];
        self.for_each_inside(depth, |_, _, p| {
            n += 1;
            sum = add(sum, p);
        });
        Contact {
            points: n,
            centroid_mm: (n > 0).then(|| self.box_to_scene(scale(sum, 1.0 / n as f64))),
        }
    }

    /// A box-coordinate point in scene coordinates.
    pub fn box_to_scene(&self, p: Vec3) -> Vec3 {
        let b = &self.setup.track_box;
        b.axes
            .iter()
            .zip(&p)
            .fold(b.center_mm, |acc, (a, &k)| add(acc, scale(*a, k)))
    }
}

/// The pixel rectangle that can see the box: the bounding rectangle of
/// its projected corners, clipped to the frame. A corner at or behind the
/// camera plane makes it the whole frame.
pub fn box_roi(intr: &Intrinsics, setup: &CameraSetup) -> Roi {
    let full = Roi {
        c0: 0,
        c1: intr.pinhole.width,
        r0: 0,
        r1: intr.pinhole.height,
    };
    let (mut umin, mut umax, mut vmin, mut vmax) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for corner in setup.track_box.corners() {
        let q = setup.camera.to_camera(corner);
        if q[2] <= 1e-6 {
            return full;
        }
        let [u, v] = intr.project(q);
        umin = umin.min(u);
        umax = umax.max(u);
        vmin = vmin.min(v);
        vmax = vmax.max(v);
    }
    let clip = |lo: f64, hi: f64, n: u32| -> (u32, u32) {
        let a = lo.floor().max(0.0);
        let b = (hi.ceil() + 1.0).min(n as f64);
        if b <= a { (0, 0) } else { (a as u32, b as u32) }
    };
    let (c0, c1) = clip(umin, umax, intr.pinhole.width);
    let (r0, r1) = clip(vmin, vmax, intr.pinhole.height);
    if c0 == c1 || r0 == r1 {
        return Roi {
            c0: 0,
            c1: 0,
            r0: 0,
            r1: 0,
        };
    }
    Roi { c0, c1, r0, r1 }
}

/// The plain version: every pixel deprojected as the intrinsics say, moved
/// into the scene by the camera pose, tested against the box.
pub fn reference(intr: &Intrinsics, setup: &CameraSetup, depth: &[u16]) -> Contact {
    let mut n = 0u32;
    let mut sum = [0.0; 3];
    for r in 0..intr.pinhole.height {
        for c in 0..intr.pinhole.width {
            let v = depth[(r * intr.pinhole.width + c) as usize];
            if v == 0 {
                continue;
            }
            let p = setup
                .camera
                .to_scene(intr.deproject(c, r, v as f64 * intr.mm_per_unit()));
            if setup.track_box.contains(p) {
                n += 1;
                sum = add(sum, p);
            }
        }
    }
    Contact {
        points: n,
        centroid_mm: (n > 0).then(|| scale(sum, 1.0 / n as f64)),
    }
}
