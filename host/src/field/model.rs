//! The field model: transducers as point sources (with their mirror images
//! when there is a reflector), the medium, and the f64 transfer function
//! every path starts from.

use std::f64::consts::PI;

use super::FieldError;
use crate::geom::{axpy, dot, is_finite, normalized, sub};
use crate::plan::array::Transducer;
use crate::plan::directivity::Directivity;
use crate::units::wavenumber_rad_per_mm;

/// Source amplitude `P0` of one T4010A1 at full drive (Pa·mm, peak).
///
/// AUTD3 publishes `T4010A1_AMPLITUDE = 275.574246625 Pa × 200 mm` and
/// propagates `p = T4010A1_AMPLITUDE / (4π) · D(θ) / r · exp(j k r)` (autd3
/// `acoustics::propagate`); this constant is that `T4010A1_AMPLITUDE / (4π)`
/// ≈ 4385.9 Pa·mm, i.e. ≈ 21.9 Pa peak on axis at 200 mm.
pub const T4010A1_P0_PA_MM: f64 = 275.574246625 * 200.0 / (4.0 * PI);

/// Default air density (kg/m³) for radiation pressure.
pub const DEFAULT_DENSITY_KG_M3: f64 = 1.2;

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
    /// Product.
    pub(super) fn mul(self, o: Self) -> Self {
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

/// A source of the model: a transducer or its mirror image.
#[derive(Debug, Clone, Copy)]
pub(super) struct Source {
    pub(super) pos_mm: [f64; 3],
    pub(super) normal: [f64; 3],
}

/// The field model: sources, medium and directivity. Cheap to build.
#[derive(Debug, Clone)]
pub struct FieldModel {
    pub(super) direct: Vec<Source>,
    /// Mirror twins, same order as `direct`; empty without a reflector.
    pub(super) images: Vec<Source>,
    /// Reflector plane with the normal pointing towards the array.
    pub(super) wall: Option<([f64; 3], [f64; 3])>,
    pub(super) directivity: Directivity,
    pub(super) medium: Medium,
    pub(super) p0_pa_mm: f64,
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
            let normal = normalized(t.normal).ok_or(FieldError::BadTransducer(i))?;
            if !is_finite(t.pos_mm) {
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
                let n = normalized(r.normal).filter(|_| is_finite(r.point_mm));
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

/// The field model of a planner [`Scene`](crate::plan::scene::Scene): its
/// transducers, directivity, medium and (only if it has one) reflector.
pub fn model_for_scene(
    scene: &crate::plan::scene::Scene,
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
