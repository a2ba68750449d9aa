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
    /// re-plan to the device. A refusal names the part that is wrong
    /// (the radius or the steps) and what that part allows; a part with
    /// spaces at its ends is refused as a lone flag's value with them.
    pub fn parse(spec: &str, replan_mm: f64, replan: bool) -> Result<Self, InputError> {
        let said = |m: String| InputError::new(format!("--z-profile `{spec}`: {m}"));
        let radius_range = "allowed above 0 and at most 20 mm";
        let steps_range = "allowed 1..=1000";
        let (r, n) = spec
            .split_once(',')
            .filter(|(_, n)| !n.contains(','))
            .ok_or_else(|| {
                said("give RADIUS_MM,STEPS: a radius and a step count, one comma between".into())
            })?;
        let radius_mm =
            crate::limits::exact_number(r).map_err(|m| said(format!("the radius {m}")))?;
        if !(radius_mm > 0.0 && radius_mm <= 20.0) {
            return Err(said(format!(
                "the radius {} mm is out of range: {radius_range}",
                show(radius_mm)
            )));
        }
        let steps: i128 = n.parse().map_err(|_| {
            said(format!(
                "the steps `{n}` are not a whole number: {steps_range}"
            ))
        })?;
        if !(1..=1000).contains(&steps) {
            return Err(said(format!(
                "the steps {steps} are out of range: {steps_range}"
            )));
        }
        let steps = steps as usize;
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
            "--z-profile `3.5, 8`: the steps ` 8` are not a whole number: allowed 1..=1000"
        );
        assert!(err(ZProfile::parse(" 3.5,8", 0.3, false)).contains("(white space around it)"));
        let form = "give RADIUS_MM,STEPS: a radius and a step count, one comma between";
        let radius = "allowed above 0 and at most 20 mm";
        let steps = "allowed 1..=1000";
        let give = "give one such as 2.5, -1 or 1e-3";
        for (spec, why) in [
            ("3", form.to_owned()),
            ("3,8,9", form.to_owned()),
            (
                "3,",
                format!("the steps `` are not a whole number: {steps}"),
            ),
            (
                ",8",
                format!("the radius an empty value is not a number: {give}"),
            ),
            ("x,8", format!("the radius x is not a number: {give}")),
            ("0,8", format!("the radius 0 mm is out of range: {radius}")),
            (
                "-1,8",
                format!("the radius -1 mm is out of range: {radius}"),
            ),
            (
                "20.5,8",
                format!("the radius 20.5 mm is out of range: {radius}"),
            ),
            (
                "inf,8",
                format!("the radius inf mm is out of range: {radius}"),
            ),
            (
                "nan,8",
                format!("the radius NaN mm is out of range: {radius}"),
            ),
            (
                "3,x",
                format!("the steps `x` are not a whole number: {steps}"),
            ),
            (
                "3,2.5",
                format!("the steps `2.5` are not a whole number: {steps}"),
            ),
            ("3,0", format!("the steps 0 are out of range: {steps}")),
            (
                "3,1001",
                format!("the steps 1001 are out of range: {steps}"),
            ),
            ("3,-1", format!("the steps -1 are out of range: {steps}")),
            (
                "3,100000000",
                format!("the steps 100000000 are out of range: {steps}"),
            ),
        ] {
            let e = err(ZProfile::parse(spec, 0.3, false));
            assert_eq!(e, format!("--z-profile `{spec}`: {why}"));
        }
        let e = err(ZProfile::parse("1e999,8", 0.3, false));
        assert!(
            e.starts_with("--z-profile `1e999,8`: the radius 1e999 is too large"),
            "{e}"
        );
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
