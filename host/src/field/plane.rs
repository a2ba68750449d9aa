//! The observation plane: a rectangular grid of points in space, the
//! coordinates of every map.

use super::FieldError;
use crate::geom::{axpy, dot, is_finite, normalized, sub};

/// Largest observation grid accepted (points), to keep memory bounded.
pub const MAX_GRID_POINTS: usize = 4_000_000;

/// A rectangular grid on a plane in space.
///
/// Point `(iu, iv)` is at `center + (iu·step − width/2)·u + (iv·step −
/// height/2)·v`, `iu < nu`, `iv < nv`. Maps are stored row-major by `iv`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObservationPlane {
    /// Centre of the grid (mm).
    pub center_mm: [f64; 3],
    /// First in-plane axis (unit vector; map columns).
    pub u: [f64; 3],
    /// Second in-plane axis (unit vector; map rows).
    pub v: [f64; 3],
    /// Extent along `u` (mm).
    pub width_mm: f64,
    /// Extent along `v` (mm).
    pub height_mm: f64,
    /// Grid spacing (mm).
    pub step_mm: f64,
}

impl ObservationPlane {
    /// The default LM plane: 20 × 20 mm at 0.2 mm around `center_mm`
    /// spanned by `u` and `v` (101 × 101 points).
    pub fn lm_default(center_mm: [f64; 3], u: [f64; 3], v: [f64; 3]) -> Self {
        Self {
            center_mm,
            u,
            v,
            width_mm: 20.0,
            height_mm: 20.0,
            step_mm: 0.2,
        }
    }

    /// Check the plane and return it with `u`, `v` normalised.
    pub fn validated(mut self) -> Result<Self, FieldError> {
        let bad = |m: &str| Err(FieldError::BadPlane(m.to_string()));
        if !is_finite(self.center_mm) {
            return bad("the centre must be finite");
        }
        let (Some(u), Some(v)) = (normalized(self.u), normalized(self.v)) else {
            return bad("the axes must be finite and non-zero");
        };
        if dot(u, v).abs() > 1e-6 {
            return bad("the axes must be perpendicular");
        }
        if !(self.step_mm.is_finite() && self.step_mm > 0.0) {
            return bad("the step must be finite and positive");
        }
        for (name, w) in [("width", self.width_mm), ("height", self.height_mm)] {
            if !(w.is_finite() && w >= 0.0) {
                return Err(FieldError::BadPlane(format!(
                    "the {name} must be finite and ≥ 0"
                )));
            }
        }
        // A step wider than a side of the plane gave that side one point,
        // the width or height asked for dropped without a word (a 20 mm
        // plane at a 50 mm step was one pixel).
        for (name, w) in [("width", self.width_mm), ("height", self.height_mm)] {
            if w > 0.0 && self.step_mm > w * (1.0 + 1e-9) {
                return Err(FieldError::BadPlane(format!(
                    "a step of {} mm is wider than the plane's {name} of {} mm, which it would leave one point across; give a step of at most {} mm",
                    crate::limits::show(self.step_mm),
                    crate::limits::show(w),
                    crate::limits::show(w),
                )));
            }
        }
        self.u = u;
        self.v = v;
        // Counted in f64 before any integer conversion, so a tiny step is
        // refused with its real size, not with saturated integers.
        let count = |w: f64| (w / self.step_mm + 1e-9).floor() + 1.0;
        let (nu, nv) = (count(self.width_mm), count(self.height_mm));
        let points = nu * nv;
        if points.is_nan() || points > MAX_GRID_POINTS as f64 {
            // The step's own bound, and the counts only where they are
            // numbers (a step of 1e-320 mm said "inf × inf = inf points").
            let counts = match points.is_finite() {
                true => format!(
                    "{} × {} = {} points",
                    crate::limits::show(nu),
                    crate::limits::show(nv),
                    crate::limits::show(points)
                ),
                false => "too many points to count".to_owned(),
            };
            return Err(FieldError::BadPlane(format!(
                "a step of {} mm over {} × {} mm gives {counts}, more than {MAX_GRID_POINTS}; give a step of at least {} mm",
                crate::limits::show(self.step_mm),
                crate::limits::show(self.width_mm),
                crate::limits::show(self.height_mm),
                crate::limits::Num(finest_step(self.width_mm, self.height_mm)),
            )));
        }
        Ok(self)
    }

    fn count(extent: f64, step: f64) -> usize {
        // Tolerate rounding of e.g. 20 / 0.2.
        ((extent / step + 1e-9).floor() as usize).saturating_add(1)
    }
    /// Columns (points along `u`).
    pub fn nu(&self) -> usize {
        Self::count(self.width_mm, self.step_mm)
    }
    /// Rows (points along `v`).
    pub fn nv(&self) -> usize {
        Self::count(self.height_mm, self.step_mm)
    }
    /// In-plane coordinates (mm, relative to the centre) of column `iu`.
    pub fn u_mm(&self, iu: usize) -> f64 {
        iu as f64 * self.step_mm - (self.nu() - 1) as f64 * self.step_mm / 2.0
    }
    /// In-plane coordinates (mm, relative to the centre) of row `iv`.
    pub fn v_mm(&self, iv: usize) -> f64 {
        iv as f64 * self.step_mm - (self.nv() - 1) as f64 * self.step_mm / 2.0
    }
    /// Point `(iu, iv)` in space (mm).
    pub fn point(&self, iu: usize, iv: usize) -> [f64; 3] {
        let (a, b) = (self.u_mm(iu), self.v_mm(iv));
        axpy(b, self.v, axpy(a, self.u, self.center_mm))
    }
    /// In-plane coordinates (mm) of a point in space (its projection).
    pub fn project(&self, p_mm: [f64; 3]) -> [f64; 2] {
        let d = sub(p_mm, self.center_mm);
        [dot(d, self.u), dot(d, self.v)]
    }
}

#[cfg(test)]
impl ObservationPlane {
    /// A plane parallel to the array (`u` = x, `v` = y) around
    /// `center_mm`: the tests' usual plane.
    pub(crate) fn xy(center_mm: [f64; 3], width_mm: f64, height_mm: f64, step_mm: f64) -> Self {
        Self {
            center_mm,
            u: [1.0, 0.0, 0.0],
            v: [0.0, 1.0, 0.0],
            width_mm,
            height_mm,
            step_mm,
        }
    }
}

/// The finest step (mm) whose grid over `w` × `h` mm holds at most
/// [`MAX_GRID_POINTS`]: `(w/s + 1)(h/s + 1) = M` solved for `1/s`,
/// nudged up so it rounds onto the safe side.
fn finest_step(w: f64, h: f64) -> f64 {
    let m = MAX_GRID_POINTS as f64;
    let t = if w * h > 0.0 {
        let (a, b, c) = (w * h, w + h, 1.0 - m);
        (-b + (b * b - 4.0 * a * c).sqrt()) / (2.0 * a)
    } else if w + h > 0.0 {
        (m - 1.0) / (w + h)
    } else {
        return 0.0;
    };
    (1.0 / t) * (1.0 + 1e-9)
}
