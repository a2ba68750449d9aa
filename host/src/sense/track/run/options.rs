//! What `lmhost track` tracks and how, as types: one [`Source`] of four,
//! the synthetic finger's settings checked when made, the plot, the gate
//! and the surface's depth profile parsed once. A combination the flags
//! cannot mean (two sources, `--replan` without `--z-profile`) has no
//! value here; a value out of range is refused by its constructor with an
//! [`InputError`] naming its flag.

use std::path::PathBuf;

use crate::error::InputError;
use crate::limits::show;
use crate::sense::stream::filter::FilterKind;
use crate::sense::track::presence::Hysteresis;
use crate::sense::track::synth;

/// What a session tracks and how (the error messages name the `lmhost
/// track` flags).
#[derive(Debug, Clone)]
pub struct Options {
    /// Scene with `[camera]` and `[tracking]` (needed but for the
    /// synthetic finger, which falls back to a setup about its centre).
    pub scene: Option<PathBuf>,
    /// Where the depth frames come from.
    pub source: Source,
    /// Save the frames as this `.npy`, intrinsics and time stamps beside.
    pub record: Option<PathBuf>,
    /// Write a PNG of one frame.
    pub plot: Option<Plot>,
    /// Replay as fast as possible instead of at the recorded speed.
    pub fast: bool,
    /// One JSON object per frame instead of a summary line per second.
    pub json: bool,
    /// The presence gate ([`Hysteresis::new`] for the flags' range).
    pub gate: Hysteresis,
    /// Centroid filter [default: gaussian with `device`, else none].
    pub filter: Option<FilterKind>,
    /// Measure the finger surface's depth along a circle about the
    /// centroid (and re-plan on it).
    pub z_profile: Option<ZProfile>,
    /// The centres go to a device given to
    /// [`TrackRun::run`](super::TrackRun::run): the default filter is
    /// gaussian, frames are not paced and every line shows the gated,
    /// filtered centre.
    pub device: bool,
}

impl Options {
    /// `source` tracked with the defaults: no scene, no recording, no plot,
    /// paced, summary lines, the default gate, the default filter, no depth
    /// profile, no device.
    pub fn new(source: Source) -> Self {
        Self {
            scene: None,
            source,
            record: None,
            plot: None,
            fast: false,
            json: false,
            gate: Hysteresis::default(),
            filter: None,
            z_profile: None,
            device: false,
        }
    }
}

/// Where a session's depth frames come from: exactly one source.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// Recorded depth frames (`.npy`, uint16, frames × height × width).
    Recorded {
        /// The recording.
        depth: PathBuf,
        /// Its time stamps [default: beside it, else 90 fps].
        timestamps: Option<PathBuf>,
        /// Its camera intrinsics TOML [default: beside it].
        intrinsics: Option<PathBuf>,
    },
    /// The synthetic finger, with ground truth.
    Synthetic {
        /// How long and how noisy.
        finger: SyntheticFinger,
        /// The camera it is rendered for [default: a D435 at 848 × 480].
        intrinsics: Option<PathBuf>,
    },
    /// A live RealSense camera.
    Camera {
        /// Intrinsics the camera's own are checked against.
        intrinsics: Option<PathBuf>,
    },
    /// An LMDEPTH1 stream.
    Stream {
        /// The file (`-` = stdin).
        path: PathBuf,
        /// Intrinsics the stream's own are checked against.
        intrinsics: Option<PathBuf>,
    },
}

/// The synthetic finger's run: its length, depth noise and holes, each
/// checked when made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SyntheticFinger {
    seconds: f64,
    noise_mm: f64,
    holes: f64,
}

impl Default for SyntheticFinger {
    /// One motion cycle with the finger's default noise and holes.
    fn default() -> Self {
        Self {
            seconds: synth::PERIOD_S,
            noise_mm: synth::NOISE_MM,
            holes: synth::HOLES,
        }
    }
}

impl SyntheticFinger {
    /// `seconds` (`--seconds`) in (0, 3600] and at least one frame,
    /// `noise_mm` (`--noise-mm`, 1 σ) in [0, 50], `holes` (`--holes`, the
    /// fraction of pixels with no data) in [0, 1]; each `None` takes
    /// its [`Default`].
    pub fn new(
        seconds: Option<f64>,
        noise_mm: Option<f64>,
        holes: Option<f64>,
    ) -> Result<Self, InputError> {
        let d = Self::default();
        let (seconds, noise_mm, holes) = (
            seconds.unwrap_or(d.seconds),
            noise_mm.unwrap_or(d.noise_mm),
            holes.unwrap_or(d.holes),
        );
        if !(seconds.is_finite() && seconds > 0.0 && seconds <= 3600.0) {
            crate::bad_input!("--seconds {} must be in (0, 3600]", show(seconds));
        }
        if (seconds * synth::RATE_HZ).round() < 1.0 {
            crate::bad_input!(
                "--seconds {} renders no frame at {} fps; give at least {} s",
                show(seconds),
                synth::RATE_HZ,
                show(0.5 / synth::RATE_HZ)
            );
        }
        if !(noise_mm.is_finite() && (0.0..=50.0).contains(&noise_mm)) {
            crate::bad_input!("--noise-mm {} must be in [0, 50]", show(noise_mm));
        }
        if !(holes.is_finite() && (0.0..=1.0).contains(&holes)) {
            crate::bad_input!("--holes {} must be in [0, 1]", show(holes));
        }
        Ok(Self {
            seconds,
            noise_mm,
            holes,
        })
    }

    /// Seconds to render.
    pub fn seconds(&self) -> f64 {
        self.seconds
    }

    /// Depth noise (mm, 1 σ).
    pub fn noise_mm(&self) -> f64 {
        self.noise_mm
    }

    /// Fraction of pixels with no data.
    pub fn holes(&self) -> f64 {
        self.holes
    }
}

/// A PNG of one frame (box, contact area, centroid).
#[derive(Debug, Clone, PartialEq)]
pub struct Plot {
    /// The directory it is written into.
    pub dir: PathBuf,
    /// The frame [default: the first with a contact area].
    pub frame: Option<u64>,
}

/// `--z-profile RADIUS_MM,STEPS`: the finger surface's depth along that
/// circle about the centroid, a re-plan due when it moves more than
/// `--replan-mm`, and (`--replan`) each re-plan uploaded to the device.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZProfile {
    radius_mm: f64,
    steps: usize,
    replan_mm: f64,
    replan: bool,
}

impl ZProfile {
    /// `--replan-mm`'s default (mm).
    pub const DEFAULT_REPLAN_MM: f64 = 0.3;

    /// Parses `spec` (`RADIUS_MM,STEPS`, 0 < RADIUS_MM <= 20, 1 <= STEPS
    /// <= 1000) and checks `replan_mm`
    /// (0..=[`crate::limits::MAX_REPLAN_MM`]); `replan`: upload each
    /// re-plan to the device.
    pub fn parse(spec: &str, replan_mm: f64, replan: bool) -> Result<Self, InputError> {
        let bad = || {
            InputError::new(format!(
                "--z-profile `{spec}` must be RADIUS_MM,STEPS with 0 < RADIUS_MM <= 20 and 1 <= STEPS <= 1000"
            ))
        };
        let (r, n) = spec.split_once(',').ok_or_else(bad)?;
        let radius_mm = crate::limits::exact_number(r).map_err(|e| match e {
            Some(m) => InputError::new(format!("--z-profile `{spec}`: {m}")),
            None => bad(),
        })?;
        if n.trim() != n {
            // As a lone whole-number flag refuses ` 8`.
            crate::bad_input!(
                "--z-profile `{spec}`: `{n}` is not a whole number: allowed 1..=1000"
            );
        }
        let steps: usize = n.parse().map_err(|_| bad())?;
        if !(radius_mm > 0.0 && radius_mm <= 20.0 && (1..=1000).contains(&steps)) {
            return Err(bad());
        }
        // Bounded: a threshold no depth change can pass re-plans never,
        // which `--replan-mm 1e9` did without a word.
        crate::limits::in_range(
            "--replan-mm",
            replan_mm,
            0.0,
            crate::limits::MAX_REPLAN_MM,
            "mm",
        )?;
        Ok(Self {
            radius_mm,
            steps,
            replan_mm,
            replan,
        })
    }

    /// The circle's radius (mm).
    pub fn radius_mm(&self) -> f64 {
        self.radius_mm
    }

    /// Depth samples along the circle (a re-plan's step count).
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// How far the profile moves before a re-plan is due (mm).
    pub fn replan_mm(&self) -> f64 {
        self.replan_mm
    }

    /// Whether each re-plan is uploaded to the device and played.
    pub fn replan(&self) -> bool {
        self.replan
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err<T: std::fmt::Debug>(r: Result<T, InputError>) -> String {
        r.unwrap_err().to_string()
    }

    #[test]
    fn the_synthetic_finger_defaults_to_one_cycle_and_checks_each_flag() {
        let d = SyntheticFinger::new(None, None, None).unwrap();
        assert_eq!((d.seconds(), d.noise_mm(), d.holes()), (6.0, 0.5, 0.02));
        let f = SyntheticFinger::new(Some(3600.0), Some(50.0), Some(1.0)).unwrap();
        assert_eq!((f.seconds(), f.noise_mm(), f.holes()), (3600.0, 50.0, 1.0));
        let f = SyntheticFinger::new(Some(1.0 / 90.0), Some(0.0), Some(0.0)).unwrap();
        assert_eq!((f.noise_mm(), f.holes()), (0.0, 0.0));
        for (s, e) in [
            (0.0, "--seconds 0 must be in (0, 3600]"),
            (-1.0, "--seconds -1 must be in (0, 3600]"),
            (3600.5, "--seconds 3600.5 must be in (0, 3600]"),
            (f64::NAN, "--seconds NaN must be in (0, 3600]"),
            (f64::INFINITY, "--seconds inf must be in (0, 3600]"),
        ] {
            assert_eq!(err(SyntheticFinger::new(Some(s), None, None)), e);
        }
        let e = err(SyntheticFinger::new(Some(1e-300), None, None));
        assert!(e.contains("renders no frame at 90 fps"), "{e}");
        for n in [-0.1, 50.1, f64::NAN] {
            let e = err(SyntheticFinger::new(None, Some(n), None));
            assert!(e.starts_with("--noise-mm ") && e.ends_with("must be in [0, 50]"));
        }
        for h in [-0.01, 1.5, f64::INFINITY] {
            let e = err(SyntheticFinger::new(None, None, Some(h)));
            assert!(e.starts_with("--holes ") && e.ends_with("must be in [0, 1]"));
        }
    }

    #[test]
    fn the_z_profile_is_parsed_once_with_its_threshold() {
        let z = ZProfile::parse("3.5,8", 0.3, true).unwrap();
        assert_eq!((z.radius_mm(), z.steps(), z.replan_mm()), (3.5, 8, 0.3));
        assert!(z.replan());
        assert!(!ZProfile::parse("20,1000", 0.0, false).unwrap().replan());
        // Spaces at an item's end refused, as a lone flag's value.
        assert_eq!(
            err(ZProfile::parse("3.5, 8", 0.3, false)),
            "--z-profile `3.5, 8`: ` 8` is not a whole number: allowed 1..=1000"
        );
        assert!(err(ZProfile::parse(" 3.5,8", 0.3, false)).contains("(white space around it)"));
        for spec in [
            "3",
            "3,",
            ",8",
            "x,8",
            "3,x",
            "0,8",
            "-1,8",
            "20.5,8",
            "inf,8",
            "nan,8",
            "3,0",
            "3,1001",
            "3,-1",
            "3,8,9",
            "3,100000000",
        ] {
            let e = err(ZProfile::parse(spec, 0.3, false));
            assert_eq!(
                e,
                format!(
                    "--z-profile `{spec}` must be RADIUS_MM,STEPS with 0 < RADIUS_MM <= 20 and 1 <= STEPS <= 1000"
                )
            );
        }
        for mm in [-0.1, f64::NAN, f64::INFINITY, 100.5, 1e9] {
            let e = err(ZProfile::parse("3,8", mm, false));
            assert!(
                e.starts_with("--replan-mm ") && e.ends_with("is out of range: allowed 0..=100 mm"),
                "{e}"
            );
        }
        assert!(ZProfile::parse("3,8", 100.0, false).is_ok());
    }
}
