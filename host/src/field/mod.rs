//! Acoustic field simulation: pressure and radiation-pressure maps of a
//! phase sequence on an observation plane.
//!
//! # Model
//!
//! Every transducer is a point source. At distance `r` (mm) and angle `θ`
//! from its normal, a transducer driven with phase `φ` contributes
//!
//! ```text
//! p = P0 · D(θ) · exp(−α r) · exp(j (k r + φ)) / r        [Pa, peak amplitude]
//! ```
//!
//! with the phase sign of [`crate::units`], `k = 2π · 40 kHz / c`, the
//! [`Directivity`] `D`, the medium's amplitude attenuation `α` (Np/m; 0 by
//! default, as AUTD3 uses) and [`T4010A1_P0_PA_MM`] for `P0`. Drive phases
//! are the quantised `u8` values themselves (`φ = 2π · u / 256`); every
//! transducer runs at full amplitude, as in the paper.
//!
//! A reflector (a plane, reflection coefficient 1) is modelled by image
//! sources, and only when the caller passes one: each transducer gets a
//! mirror twin (position and normal mirrored through the plane) driven with
//! the same phase. Points on the far side of the reflector from the array
//! are behind an opaque wall and get zero pressure.
//!
//! # Outputs
//!
//! For a sequence of `N` steps (one LM cycle) on a grid of points,
//! [`FieldMaps`] holds the pressure amplitude and radiation pressure of
//! step 0, the radiation pressure averaged over the cycle, its maximum over
//! the cycle, and the power of its component at the LM frequency (DFT bin 1
//! over the cycle's steps). Radiation pressure is `α_rp |p|² / (2 ρ c²)`
//! (`α_rp` = 2 by default: a perfectly reflecting surface; `ρ` = 1.2 kg/m³).
//!
//! [`simulate`] is the fast path (f32, batched as a propagation block times
//! the drive matrix, 2 threads); [`simulate_reference`] is the plain f64
//! loop it is checked against.

mod kernel;
pub mod npy;
pub mod plot;

use std::f64::consts::PI;

use crate::array::Transducer;
pub use crate::directivity::Directivity;
use crate::units::wavenumber_rad_per_mm;

pub use kernel::isa as fast_path_isa;

/// Source amplitude `P0` of one T4010A1 at full drive (Pa·mm, peak).
///
/// AUTD3 publishes `T4010A1_AMPLITUDE = 275.574246625 Pa × 200 mm` and
/// propagates `p = T4010A1_AMPLITUDE / (4π) · D(θ) / r · exp(j k r)` (autd3
/// `acoustics::propagate`); this constant is that `T4010A1_AMPLITUDE / (4π)`
/// ≈ 4385.9 Pa·mm, i.e. ≈ 21.9 Pa peak on axis at 200 mm.
pub const T4010A1_P0_PA_MM: f64 = 275.574246625 * 200.0 / (4.0 * PI);

/// Default air density (kg/m³) for radiation pressure.
pub const DEFAULT_DENSITY_KG_M3: f64 = 1.2;

/// Default radiation-pressure coefficient α (2: a perfect reflector).
pub const DEFAULT_RADIATION_ALPHA: f64 = 2.0;

/// Largest observation grid accepted (points), to keep memory bounded.
pub const MAX_GRID_POINTS: usize = 4_000_000;

/// A complex number (f64) for pressures and drives.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct C64 {
    /// Real part.
    pub re: f64,
    /// Imaginary part.
    pub im: f64,
}

impl C64 {
    /// `r · exp(j θ)`.
    pub fn from_polar(r: f64, theta: f64) -> Self {
        let (s, c) = theta.sin_cos();
        Self {
            re: r * c,
            im: r * s,
        }
    }
    /// Modulus.
    pub fn abs(self) -> f64 {
        self.re.hypot(self.im)
    }
    /// Squared modulus.
    pub fn norm_sqr(self) -> f64 {
        self.re * self.re + self.im * self.im
    }
    fn mul(self, o: Self) -> Self {
        Self {
            re: self.re * o.re - self.im * o.im,
            im: self.re * o.im + self.im * o.re,
        }
    }
}

/// The medium the sound travels through.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Medium {
    /// Speed of sound (m/s).
    pub sound_speed_m_s: f64,
    /// Amplitude attenuation (Np/m); 0 disables it.
    pub attenuation_np_per_m: f64,
    /// Density (kg/m³), for radiation pressure.
    pub density_kg_m3: f64,
}

impl Default for Medium {
    fn default() -> Self {
        Self {
            sound_speed_m_s: crate::units::DEFAULT_SOUND_SPEED_M_S,
            attenuation_np_per_m: 0.0,
            density_kg_m3: DEFAULT_DENSITY_KG_M3,
        }
    }
}

/// A flat reflector: a point on it and its normal (any length > 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reflector {
    /// A point on the plane (mm).
    pub point_mm: [f64; 3],
    /// Normal of the plane (need not be unit length).
    pub normal: [f64; 3],
}

/// Invalid inputs to the field model.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FieldError {
    /// No transducers.
    #[error("the scene has no transducers; add at least one device")]
    NoTransducers,
    /// A transducer position or normal is not finite, or a normal is zero.
    #[error("transducer {0} has a non-finite position or a zero/non-finite normal")]
    BadTransducer(usize),
    /// The medium is unphysical.
    #[error("bad medium: {0}")]
    BadMedium(&'static str),
    /// The reflector is degenerate.
    #[error("bad reflector: the point must be finite and the normal finite and non-zero")]
    BadReflector,
    /// Every transducer is on the reflector plane or behind it.
    #[error("no transducer is in front of the reflector; check the reflector's point and normal")]
    ReflectorHidesArray,
    /// The observation plane is invalid.
    #[error("bad observation plane: {0}")]
    BadPlane(String),
    /// The phase buffer does not hold steps × transducers bytes.
    #[error("phase sequence has {got} bytes, expected {steps} steps × {transducers} transducers")]
    BadSequence {
        /// Bytes given.
        got: usize,
        /// Steps asked for.
        steps: usize,
        /// Transducers in the model.
        transducers: usize,
    },
    /// A radiation-pressure parameter is invalid.
    #[error("radiation-pressure coefficient must be finite and positive, got {0}")]
    BadAlpha(f64),
}

/// A source of the model: a transducer or its mirror image.
#[derive(Debug, Clone, Copy)]
struct Source {
    pos_mm: [f64; 3],
    normal: [f64; 3],
}

/// The field model: sources, medium and directivity. Cheap to build.
#[derive(Debug, Clone)]
pub struct FieldModel {
    direct: Vec<Source>,
    /// Mirror twins, same order as `direct`; empty without a reflector.
    images: Vec<Source>,
    /// Reflector plane with the normal pointing towards the array.
    wall: Option<([f64; 3], [f64; 3])>,
    directivity: Directivity,
    medium: Medium,
    p0_pa_mm: f64,
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn finite3(a: [f64; 3]) -> bool {
    a.iter().all(|x| x.is_finite())
}
fn unit(a: [f64; 3]) -> Option<[f64; 3]> {
    let n = dot(a, a).sqrt();
    (n.is_finite() && n > 0.0).then(|| [a[0] / n, a[1] / n, a[2] / n])
}

impl FieldModel {
    /// Model of `transducers` in `medium`, with an optional reflector.
    ///
    /// Normals are normalised. With a reflector, the side the array is on
    /// (by the majority of transducers) is the open side.
    pub fn new(
        transducers: &[Transducer],
        directivity: Directivity,
        medium: Medium,
        reflector: Option<Reflector>,
    ) -> Result<Self, FieldError> {
        if transducers.is_empty() {
            return Err(FieldError::NoTransducers);
        }
        let c = medium.sound_speed_m_s;
        if !(c.is_finite() && c > 0.0) {
            return Err(FieldError::BadMedium(
                "sound speed must be finite and positive",
            ));
        }
        let a = medium.attenuation_np_per_m;
        if !(a.is_finite() && a >= 0.0) {
            return Err(FieldError::BadMedium("attenuation must be finite and ≥ 0"));
        }
        let rho = medium.density_kg_m3;
        if !(rho.is_finite() && rho > 0.0) {
            return Err(FieldError::BadMedium("density must be finite and positive"));
        }
        let mut direct = Vec::with_capacity(transducers.len());
        for (i, t) in transducers.iter().enumerate() {
            let normal = unit(t.normal).ok_or(FieldError::BadTransducer(i))?;
            if !finite3(t.pos_mm) {
                return Err(FieldError::BadTransducer(i));
            }
            direct.push(Source {
                pos_mm: t.pos_mm,
                normal,
            });
        }
        let (images, wall) = match reflector {
            None => (Vec::new(), None),
            Some(r) => {
                let n = unit(r.normal).filter(|_| finite3(r.point_mm));
                let mut n = n.ok_or(FieldError::BadReflector)?;
                let side: f64 = direct
                    .iter()
                    .map(|s| dot(sub(s.pos_mm, r.point_mm), n).signum())
                    .sum();
                if side < 0.0 {
                    n = [-n[0], -n[1], -n[2]];
                }
                if direct
                    .iter()
                    .all(|s| dot(sub(s.pos_mm, r.point_mm), n) <= 0.0)
                {
                    return Err(FieldError::ReflectorHidesArray);
                }
                let images = direct
                    .iter()
                    .map(|s| {
                        let h = dot(sub(s.pos_mm, r.point_mm), n);
                        let m = dot(s.normal, n);
                        Source {
                            pos_mm: axpy(-2.0 * h, n, s.pos_mm),
                            normal: axpy(-2.0 * m, n, s.normal),
                        }
                    })
                    .collect();
                (images, Some((r.point_mm, n)))
            }
        };
        Ok(Self {
            direct,
            images,
            wall,
            directivity,
            medium,
            p0_pa_mm: T4010A1_P0_PA_MM,
        })
    }

    /// Replace the source amplitude `P0` (Pa·mm); the default is
    /// [`T4010A1_P0_PA_MM`]. Pressures scale linearly with it.
    pub fn with_p0(mut self, p0_pa_mm: f64) -> Self {
        self.p0_pa_mm = p0_pa_mm;
        self
    }

    /// Number of driven transducers (image sources not counted).
    pub fn transducers(&self) -> usize {
        self.direct.len()
    }

    /// The medium.
    pub fn medium(&self) -> Medium {
        self.medium
    }

    /// Wavenumber (rad/mm).
    pub fn wavenumber_rad_per_mm(&self) -> f64 {
        wavenumber_rad_per_mm(self.medium.sound_speed_m_s)
    }

    /// Whether `point_mm` is behind the reflector (and so silent).
    fn hidden(&self, point_mm: [f64; 3]) -> bool {
        match self.wall {
            Some((p, n)) => dot(sub(point_mm, p), n) < 0.0,
            None => false,
        }
    }

    /// Transfer of one source to a point at offset `d` (point − source).
    fn green(&self, s: &Source, point_mm: [f64; 3], k: f64) -> C64 {
        let d = sub(point_mm, s.pos_mm);
        let r = dot(d, d).sqrt();
        if r == 0.0 {
            // On the source: the 1/r model has no value there. Report zero
            // rather than infinity so maps stay finite.
            return C64::default();
        }
        let gain = self.directivity.gain_towards(s.normal, d);
        let att = (-self.medium.attenuation_np_per_m * r * 1e-3).exp();
        C64::from_polar(self.p0_pa_mm * gain * att / r, k * r)
    }

    /// Column `j` of the transfer row at a point: the complex pressure
    /// transducer `j` (with its image) makes there when driven with φ = 0.
    pub fn transfer_row(&self, point_mm: [f64; 3], row: &mut [C64]) {
        let k = self.wavenumber_rad_per_mm();
        let hidden = self.hidden(point_mm);
        for (j, out) in row.iter_mut().enumerate().take(self.direct.len()) {
            if hidden {
                *out = C64::default();
                continue;
            }
            let mut g = self.green(&self.direct[j], point_mm, k);
            if let Some(im) = self.images.get(j) {
                let h = self.green(im, point_mm, k);
                g.re += h.re;
                g.im += h.im;
            }
            *out = g;
        }
    }

    /// Complex pressure (Pa) at a point for arbitrary complex drives
    /// (`drive[j] = a · exp(jφ)`, `a` = 1 at full amplitude). f64 reference.
    pub fn pressure(&self, point_mm: [f64; 3], drive: &[C64]) -> C64 {
        let mut row = vec![C64::default(); self.direct.len()];
        self.transfer_row(point_mm, &mut row);
        row.iter().zip(drive).fold(C64::default(), |acc, (g, w)| {
            let p = g.mul(*w);
            C64 {
                re: acc.re + p.re,
                im: acc.im + p.im,
            }
        })
    }

    /// Radiation-pressure factor `α / (2 ρ c²)` (1/Pa).
    pub fn radiation_factor(&self, alpha: f64) -> f64 {
        let c = self.medium.sound_speed_m_s;
        alpha / (2.0 * self.medium.density_kg_m3 * c * c)
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn axpy(a: f64, x: [f64; 3], y: [f64; 3]) -> [f64; 3] {
    [a * x[0] + y[0], a * x[1] + y[1], a * x[2] + y[2]]
}

/// Drives for quantised phases: `exp(j 2π u / 256)`.
pub fn drive_from_u8(phases: &[u8]) -> Vec<C64> {
    phases
        .iter()
        .map(|&u| C64::from_polar(1.0, 2.0 * PI * u as f64 / 256.0))
        .collect()
}

/// Drives for exact phases (rad): `exp(j φ)`.
pub fn drive_from_rad(phases_rad: &[f64]) -> Vec<C64> {
    phases_rad
        .iter()
        .map(|&p| C64::from_polar(1.0, p))
        .collect()
}

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
        if !finite3(self.center_mm) {
            return bad("the centre must be finite");
        }
        let (Some(u), Some(v)) = (unit(self.u), unit(self.v)) else {
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
        self.u = u;
        self.v = v;
        let n = self.nu().saturating_mul(self.nv());
        if n > MAX_GRID_POINTS {
            return Err(FieldError::BadPlane(format!(
                "{} × {} = {n} points is more than {MAX_GRID_POINTS}; use a coarser step",
                self.nu(),
                self.nv()
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

/// Maps of one LM cycle on an [`ObservationPlane`], row-major by `v`.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldMaps {
    /// Columns.
    pub nu: usize,
    /// Rows.
    pub nv: usize,
    /// Steps in the cycle.
    pub steps: usize,
    /// Pressure amplitude at step 0 (Pa, peak).
    pub amplitude_pa: Vec<f64>,
    /// Radiation pressure at step 0 (Pa).
    pub pressure_pa: Vec<f64>,
    /// Radiation pressure averaged over the cycle (Pa).
    pub mean_pressure_pa: Vec<f64>,
    /// Maximum radiation pressure over the cycle (Pa).
    pub max_pressure_pa: Vec<f64>,
    /// Power of the radiation pressure at the LM frequency (Pa²): the mean
    /// square `A₁²/2` of its bin-1 sinusoid, `A₁ = 2 |X₁| / N` with
    /// `X₁ = Σₛ P(s) e^{−j2πs/N}` (`A₁ = |X₁| / N` for N = 2; 0 for N = 1).
    pub lm_power_pa2: Vec<f64>,
}

/// Per-point statistics of the radiation pressure over the cycle.
#[derive(Debug, Clone, Copy, Default)]
struct Stats {
    amp0: f64,
    p0: f64,
    sum: f64,
    max: f64,
    x1_re: f64,
    x1_im: f64,
}

/// Radiation-pressure settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Radiation {
    /// Coefficient α of `α |p|² / (2 ρ c²)`.
    pub alpha: f64,
}

impl Default for Radiation {
    fn default() -> Self {
        Self {
            alpha: DEFAULT_RADIATION_ALPHA,
        }
    }
}

fn check_inputs(
    model: &FieldModel,
    plane: &ObservationPlane,
    phases: &[u8],
    steps: usize,
    rad: Radiation,
) -> Result<ObservationPlane, FieldError> {
    let t = model.transducers();
    if steps == 0 || phases.len() != steps.saturating_mul(t) {
        return Err(FieldError::BadSequence {
            got: phases.len(),
            steps,
            transducers: t,
        });
    }
    if !(rad.alpha.is_finite() && rad.alpha > 0.0) {
        return Err(FieldError::BadAlpha(rad.alpha));
    }
    plane.validated()
}

/// DFT twiddles `e^{−j2πs/N}` for bin 1.
fn twiddles(steps: usize) -> Vec<(f64, f64)> {
    (0..steps)
        .map(|s| {
            let a = -2.0 * PI * s as f64 / steps as f64;
            (a.cos(), a.sin())
        })
        .collect()
}

fn finish(plane: &ObservationPlane, steps: usize, stats: &[Stats]) -> FieldMaps {
    let n = steps as f64;
    let scale = match steps {
        1 => 0.0,
        2 => 1.0 / n,
        _ => 2.0 / n,
    };
    FieldMaps {
        nu: plane.nu(),
        nv: plane.nv(),
        steps,
        amplitude_pa: stats.iter().map(|s| s.amp0).collect(),
        pressure_pa: stats.iter().map(|s| s.p0).collect(),
        mean_pressure_pa: stats.iter().map(|s| s.sum / n).collect(),
        max_pressure_pa: stats.iter().map(|s| s.max).collect(),
        lm_power_pa2: stats
            .iter()
            .map(|s| {
                let a1 = scale * s.x1_re.hypot(s.x1_im);
                a1 * a1 / 2.0
            })
            .collect(),
    }
}

/// Maps of a phase sequence (step-major, `steps × transducers` bytes) by
/// the plain f64 loop: one transfer row per point, then one dot product
/// per step. The reference the fast path is checked against.
pub fn simulate_reference(
    model: &FieldModel,
    plane: &ObservationPlane,
    phases: &[u8],
    steps: usize,
    rad: Radiation,
) -> Result<FieldMaps, FieldError> {
    let plane = check_inputs(model, plane, phases, steps, rad)?;
    let t = model.transducers();
    let table: Vec<C64> = drive_from_u8(&(0..=255).collect::<Vec<u8>>());
    let tw = twiddles(steps);
    let f = model.radiation_factor(rad.alpha);
    let mut row = vec![C64::default(); t];
    let mut stats = Vec::with_capacity(plane.nu() * plane.nv());
    for iv in 0..plane.nv() {
        for iu in 0..plane.nu() {
            model.transfer_row(plane.point(iu, iv), &mut row);
            let mut st = Stats::default();
            for s in 0..steps {
                let ph = &phases[s * t..(s + 1) * t];
                let (mut re, mut im) = (0.0, 0.0);
                for (g, &u) in row.iter().zip(ph) {
                    let p = g.mul(table[u as usize]);
                    re += p.re;
                    im += p.im;
                }
                let a2 = re * re + im * im;
                let prad = f * a2;
                if s == 0 {
                    st.amp0 = a2.sqrt();
                    st.p0 = prad;
                }
                st.sum += prad;
                st.max = st.max.max(prad);
                st.x1_re += prad * tw[s].0;
                st.x1_im += prad * tw[s].1;
            }
            stats.push(st);
        }
    }
    Ok(finish(&plane, steps, &stats))
}

/// Maps of a phase sequence (step-major, `steps × transducers` bytes): the
/// fast path. Propagation terms are computed once per point block in f32
/// (phase reduced to turns in f64 first), multiplied by the drive matrix of
/// all steps, and reduced to statistics on the fly; the grid is split over
/// two threads. Agrees with [`simulate_reference`] to ~1e-5 relative at the
/// peak (checked in tests and in `lmhost bench`).
pub fn simulate(
    model: &FieldModel,
    plane: &ObservationPlane,
    phases: &[u8],
    steps: usize,
    rad: Radiation,
) -> Result<FieldMaps, FieldError> {
    let plane = check_inputs(model, plane, phases, steps, rad)?;
    let stats = kernel::run(
        model,
        &plane,
        phases,
        steps,
        model.radiation_factor(rad.alpha),
    );
    Ok(finish(&plane, steps, &stats))
}

/// The field model of a planner [`Scene`](crate::scene::Scene): its
/// transducers, directivity, medium and (only if it has one) reflector.
pub fn model_for_scene(
    scene: &crate::scene::Scene,
    density_kg_m3: f64,
) -> Result<FieldModel, crate::InputError> {
    let medium = Medium {
        sound_speed_m_s: scene.sound_speed_m_s,
        attenuation_np_per_m: scene.attenuation_np_per_m,
        density_kg_m3,
    };
    let reflector = scene.reflector.map(|r| Reflector {
        point_mm: r.point_mm,
        normal: r.normal,
    });
    FieldModel::new(&scene.transducers(), scene.directivity, medium, reflector)
        .map_err(|e| crate::InputError::new(e.to_string()))
}

/// Index and value of a map's maximum (first one on ties; NaN ignored).
pub fn peak(map: &[f64]) -> Option<(usize, f64)> {
    map.iter()
        .copied()
        .enumerate()
        .filter(|(_, v)| !v.is_nan())
        .fold(None, |best: Option<(usize, f64)>, (i, v)| match best {
            Some((_, b)) if b >= v => best,
            _ => Some((i, v)),
        })
}

/// Force (N) of a radiation-pressure map (Pa) over a disk in the plane.
///
/// The disk has diameter `diameter_mm` and centre `center_uv_mm` in plane
/// coordinates; each grid point inside counts with area `step²`. Returns
/// the force and whether the disk reaches beyond the grid (then the force
/// is underestimated).
pub fn disk_force_n(
    plane: &ObservationPlane,
    map_pa: &[f64],
    center_uv_mm: [f64; 2],
    diameter_mm: f64,
) -> (f64, bool) {
    let r = diameter_mm / 2.0;
    let (nu, nv) = (plane.nu(), plane.nv());
    let mut sum = 0.0;
    for iv in 0..nv {
        let dv = plane.v_mm(iv) - center_uv_mm[1];
        for iu in 0..nu {
            let du = plane.u_mm(iu) - center_uv_mm[0];
            if du * du + dv * dv <= r * r {
                sum += map_pa[iv * nu + iu];
            }
        }
    }
    let area_m2 = plane.step_mm * plane.step_mm * 1e-6;
    let half_w = plane.u_mm(nu - 1) + plane.step_mm / 2.0;
    let half_h = plane.v_mm(nv - 1) + plane.step_mm / 2.0;
    let clipped = center_uv_mm[0].abs() + r > half_w || center_uv_mm[1].abs() + r > half_h;
    (sum * area_m2, clipped)
}

#[cfg(test)]
mod tests;
