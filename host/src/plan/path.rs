//! The shape a focus runs along in one LM cycle, in the LM plane's (a, b)
//! coordinates about the centre: the paper's circle, and the line, ellipse
//! and Lissajous figure of Ultraleap's sensations.
//!
//! Every shape is a closed curve over a parameter `θ ∈ [0, 2π)`; step `j`
//! of `N` sits at `θ_j = 2π j / N`, as on the circle. The line runs back
//! and forth at constant speed; the ellipse and the Lissajous figure are
//! sampled evenly in `θ` (not in arc length), as their usual definitions
//! are, so a step's width varies along them and the step width the planner
//! reports is the mean, `length / N`.

use crate::error::InputError;
use crate::limits;

/// Samples over which a path's length is summed (a chord sum: within
/// 1e-6 relative of the arc length for the figures the limits allow).
const LENGTH_SAMPLES: usize = 1 << 14;

/// Largest frequency ratio term of a Lissajous figure.
pub const MAX_LISSAJOUS_RATIO: u32 = 32;

/// The shape of an LM path.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Path {
    /// The paper's circle of the stimulus's radius `A`.
    #[default]
    Circle,
    /// A segment along the plane's a axis, centred, run there and back.
    Line {
        /// Its length (mm).
        length_mm: f64,
    },
    /// `(a cos θ, b sin θ)`.
    Ellipse {
        /// Semi-axis along a (mm).
        a_mm: f64,
        /// Semi-axis along b (mm).
        b_mm: f64,
    },
    /// A Lissajous figure.
    Lissajous(Lissajous),
}

/// `(a sin(n_a θ + φ), b sin(n_b θ))`: one cycle is the whole figure.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lissajous {
    /// Half-width along a (mm).
    pub a_mm: f64,
    /// Half-height along b (mm).
    pub b_mm: f64,
    /// Frequency ratio term along a.
    pub n_a: u32,
    /// Frequency ratio term along b.
    pub n_b: u32,
    /// Phase φ of the a term (degrees).
    pub phase_deg: f64,
}

impl Lissajous {
    /// Checks its numbers, `size` its half-extents.
    fn check(&self, size: impl Fn(&str, f64) -> Result<(), InputError>) -> Result<(), InputError> {
        size("lissajous half-width a", self.a_mm)?;
        size("lissajous half-height b", self.b_mm)?;
        for (what, n) in [("a", self.n_a), ("b", self.n_b)] {
            if !(1..=MAX_LISSAJOUS_RATIO).contains(&n) {
                return Err(InputError::new(format!(
                    "lissajous ratio term {what} must be 1..={MAX_LISSAJOUS_RATIO}, got {n}"
                )));
            }
        }
        let phase = self.phase_deg;
        if !phase.is_finite() {
            return Err(InputError::new(format!(
                "lissajous phase must be finite, got {phase}"
            )));
        }
        limits::in_range("lissajous phase", phase, -360.0, 360.0, "°").map(|_| ())
    }

    /// The offset `(u, v)` at `θ`.
    fn at(&self, theta: f64) -> (f64, f64) {
        let a = f64::from(self.n_a) * theta + self.phase_deg.to_radians();
        let b = f64::from(self.n_b) * theta;
        (self.a_mm * a.sin(), self.b_mm * b.sin())
    }
}

impl Path {
    /// Its name in summaries and the library file.
    pub fn name(&self) -> &'static str {
        match self {
            Path::Circle => "circle",
            Path::Line { .. } => "line",
            Path::Ellipse { .. } => "ellipse",
            Path::Lissajous(_) => "lissajous",
        }
    }

    /// Checks the shape's numbers (one-line [`InputError`]s naming them).
    pub fn check(&self) -> Result<(), InputError> {
        let size = |what: &str, v: f64| {
            if !v.is_finite() || v < 0.0 {
                return Err(InputError::new(format!(
                    "{what} must be a finite number ≥ 0 mm, got {}",
                    limits::show(v)
                )));
            }
            limits::in_range(what, v, 0.0, limits::MAX_RADIUS_MM, "mm").map(|_| ())
        };
        match *self {
            Path::Circle => Ok(()),
            Path::Line { length_mm } => size("line length", length_mm),
            Path::Ellipse { a_mm, b_mm } => {
                size("ellipse semi-axis a", a_mm)?;
                size("ellipse semi-axis b", b_mm)
            }
            Path::Lissajous(l) => l.check(size),
        }
    }

    /// The offset `(u, v)` along the plane's (a, b) at `θ`, for a circle of
    /// `radius_mm`.
    pub fn at(&self, theta: f64, radius_mm: f64) -> (f64, f64) {
        use std::f64::consts::PI;
        match *self {
            Path::Circle => (radius_mm * theta.cos(), radius_mm * theta.sin()),
            Path::Line { length_mm } => {
                // 1 at θ = 0, -1 at π, 1 again at 2π: constant speed.
                let x = (theta / PI).rem_euclid(2.0);
                (length_mm / 2.0 * (2.0 * (x - 1.0).abs() - 1.0), 0.0)
            }
            Path::Ellipse { a_mm, b_mm } => (a_mm * theta.cos(), b_mm * theta.sin()),
            Path::Lissajous(l) => l.at(theta),
        }
    }

    /// The length of one cycle (mm): `2πA` for the circle, twice the line.
    pub fn length_mm(&self, radius_mm: f64) -> f64 {
        match *self {
            Path::Circle => 2.0 * std::f64::consts::PI * radius_mm,
            Path::Line { length_mm } => 2.0 * length_mm,
            _ => {
                let tau = 2.0 * std::f64::consts::PI;
                let mut prev = self.at(0.0, radius_mm);
                let mut sum = 0.0;
                for k in 1..=LENGTH_SAMPLES {
                    let p = self.at(tau * k as f64 / LENGTH_SAMPLES as f64, radius_mm);
                    sum += (p.0 - prev.0).hypot(p.1 - prev.1);
                    prev = p;
                }
                sum
            }
        }
    }

    /// What its length is called in errors.
    pub fn length_name(&self) -> &'static str {
        match self {
            Path::Circle => "circumference 2πA",
            _ => "path length",
        }
    }

    /// The half-extents of the figure along a and b (mm).
    pub fn half_extent_mm(&self, radius_mm: f64) -> (f64, f64) {
        match *self {
            Path::Circle => (radius_mm, radius_mm),
            Path::Line { length_mm } => (length_mm / 2.0, 0.0),
            Path::Ellipse { a_mm, b_mm } | Path::Lissajous(Lissajous { a_mm, b_mm, .. }) => {
                (a_mm, b_mm)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn lengths_match_their_closed_forms() {
        assert!((Path::Circle.length_mm(3.0) - 6.0 * PI).abs() < 1e-12);
        assert_eq!(Path::Line { length_mm: 8.0 }.length_mm(0.0), 16.0);
        // A circle as an ellipse is summed to the closed form.
        let e = Path::Ellipse {
            a_mm: 3.0,
            b_mm: 3.0,
        }
        .length_mm(0.0);
        assert!((e - 6.0 * PI).abs() < 1e-6, "{e}");
        // Ramanujan's approximation for a 4 × 2 ellipse: 19.3769.
        let e = Path::Ellipse {
            a_mm: 4.0,
            b_mm: 2.0,
        }
        .length_mm(0.0);
        assert!((e - 19.3769).abs() < 1e-3, "{e}");
        // A 1:1 Lissajous at 90° is the circle.
        let l = Path::Lissajous(Lissajous {
            a_mm: 3.0,
            b_mm: 3.0,
            n_a: 1,
            n_b: 1,
            phase_deg: 90.0,
        });
        assert!((l.length_mm(0.0) - 6.0 * PI).abs() < 1e-6);
    }

    #[test]
    fn the_line_runs_there_and_back_at_constant_speed() {
        let p = Path::Line { length_mm: 10.0 };
        let u: Vec<f64> = (0..8)
            .map(|j| p.at(2.0 * PI * j as f64 / 8.0, 0.0).0)
            .collect();
        let want = [5.0, 2.5, 0.0, -2.5, -5.0, -2.5, 0.0, 2.5];
        for (a, b) in u.iter().zip(want) {
            assert!((a - b).abs() < 1e-12, "{u:?}");
        }
    }

    #[test]
    fn lissajous_spans_its_half_extents() {
        let p = Path::Lissajous(Lissajous {
            a_mm: 5.0,
            b_mm: 2.0,
            n_a: 3,
            n_b: 2,
            phase_deg: 90.0,
        });
        let pts: Vec<(f64, f64)> = (0..1000)
            .map(|j| p.at(2.0 * PI * j as f64 / 1000.0, 0.0))
            .collect();
        let max_u = pts.iter().map(|p| p.0.abs()).fold(0.0, f64::max);
        let max_v = pts.iter().map(|p| p.1.abs()).fold(0.0, f64::max);
        assert!((max_u - 5.0).abs() < 1e-3 && (max_v - 2.0).abs() < 1e-3);
        assert_eq!(p.half_extent_mm(0.0), (5.0, 2.0));
    }

    #[test]
    fn bad_shapes_are_one_line_input_errors() {
        for (p, says) in [
            (Path::Line { length_mm: -1.0 }, "line length"),
            (
                Path::Ellipse {
                    a_mm: f64::NAN,
                    b_mm: 1.0,
                },
                "semi-axis a",
            ),
            (
                Path::Ellipse {
                    a_mm: 1.0,
                    b_mm: 1e9,
                },
                "range",
            ),
            (
                Path::Lissajous(Lissajous {
                    a_mm: 1.0,
                    b_mm: 1.0,
                    n_a: 0,
                    n_b: 1,
                    phase_deg: 0.0,
                }),
                "1..=32",
            ),
            (
                Path::Lissajous(Lissajous {
                    a_mm: 1.0,
                    b_mm: 1.0,
                    n_a: 1,
                    n_b: 1,
                    phase_deg: f64::INFINITY,
                }),
                "phase",
            ),
        ] {
            let e = p.check().unwrap_err().to_string();
            assert!(e.contains(says) && !e.contains('\n'), "{e}");
        }
    }
}
