//! A stimulus from a file (`lmhost upload --phases FILE`, `--foci-file
//! FILE`), through the checks a planned stimulus gets, for one device.
//!
//! Formats:
//! - phases: `.npy` `uint8` of shape `(steps, transducers)` (what `lmhost
//!   plan --out F.npy` writes), `.bin` raw bytes, step-major (`plan --out
//!   F.bin`; steps = length / transducers), JSON `{"phases": [[u8, ...],
//!   ...], "dwell_us": D}` (`dwell_us` optional), or the JSON report `plan
//!   --out F.json` writes (`report.rs`: its phases, its dwell, its centre,
//!   foci and intensity; checked against its `crc32` and its header, and
//!   refused for another target or scene);
//! - foci: `.npy` `float64` of shape `(steps, foci, 3)` in mm, finger space
//!   (mirrored through the scene's reflector like a planned stimulus), or
//!   JSON `{"foci_mm": [[[x, y, z], ...], ...], "dwell_us": D}`; the phases
//!   are synthesised with the planner's linear synthesis.
//!
//! In the JSON forms a key left out takes its default and `null` is
//! refused naming it (`dwell_us`, a report's `intensity_table`;
//! [`crate::json`]'s rule), except where `plan` writes `null` itself: a
//! report's `timing.am_freq_hz` (no AM) and `timing.divide` (off AUTD3's
//! grid).
//!
//! Timing: exactly one of a dwell in the file (µs per step) and an LM
//! frequency (`--freq`: the dwell is `1 / (N f)`). On an AUTD3 a frequency
//! lands on the 25 µs grid (the realised timing is reported) and a dwell in
//! the file must lie on it. Every file is checked before it is read whole:
//! its size (an `.npy` exactly as long as its shape says, JSON at most
//! [`MAX_JSON_BYTES`]), its shape against the scene's transducers, the step
//! limits of the device, finite values, the dwell limits and, for foci, the
//! work volume (±2000 mm, in front of the array). A bad file is one
//! [`InputError`] naming the file.

mod report;

use std::io::Read as _;
use std::path::Path;

use crate::error::InputError;
use crate::files::kind;
use crate::geom::Vec3;
use crate::limits;
use crate::plan::grid::{self as grid, MAX_PATTERNS, MIN_PATTERNS};
use crate::plan::scene::Scene;
use crate::plan::sequence::{Plan, Sequence};
use crate::plan::stimulus::{TargetPlan, Timing};
use crate::plan::synth::fast::SynthPlan;
use crate::plan::target::Target;
use crate::plan::trajectory::{MAX_FOCI, MAX_STEPS, Steps, Trajectory};

/// Largest JSON stimulus file (bytes), checked before it is read.
pub const MAX_JSON_BYTES: u64 = 64 << 20;

/// What the file holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Content {
    /// Phases, `(steps, transducers)` u8.
    Phases,
    /// Foci, `(steps, foci, 3)` mm.
    Foci,
}

impl Content {
    fn what(self) -> &'static str {
        match self {
            Self::Phases => "--phases file",
            Self::Foci => "--foci-file",
        }
    }
}

/// The file's array and its dwell, if it gives one.
enum Loaded {
    Phases {
        steps: usize,
        phases: Vec<u8>,
    },
    Foci {
        steps: usize,
        foci: usize,
        mm: Vec<f64>,
    },
    /// A `plan --out F.json` report, checked against itself; its phases
    /// moved out into `phases`.
    Planned {
        steps: usize,
        phases: Vec<u8>,
        report: Box<report::PlanReport>,
    },
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct PhasesJson {
    #[serde(deserialize_with = "report::byte_rows")]
    phases: Vec<Vec<u8>>,
    #[serde(default, deserialize_with = "crate::json::no_null")]
    dwell_us: Option<f64>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct FociJson {
    foci_mm: Vec<Vec<[f64; 3]>>,
    #[serde(default, deserialize_with = "crate::json::no_null")]
    dwell_us: Option<f64>,
}

/// What the JSON `text` holds when it is not an object (`an array`, `a
/// string`, …), by its first character once it reads as JSON (skimmed, no
/// tree built); `None` for an object or text that is no JSON (a TOML
/// file's `name = …` is not `null`: refused by its parse, with the place).
fn not_an_object(text: &str) -> Option<&'static str> {
    serde_json::from_str::<serde::de::IgnoredAny>(text).ok()?;
    match text.trim_start().chars().next()? {
        '[' => Some("an array"),
        '"' => Some("a string"),
        '-' | '0'..='9' => Some("a number"),
        't' => Some("`true`"),
        'f' => Some("`false`"),
        'n' => Some("`null`"),
        _ => None,
    }
}

/// `text` read as the JSON object of `expected` (`what` in errors). When it
/// does not read, the error names the other kind lmhost reads that it is
/// (foci given as phases), if any.
fn json_object<T: serde::de::DeserializeOwned>(
    expected: &kind::Kind,
    what: &str,
    text: &str,
) -> Result<T, String> {
    report::from_json(text).map_err(|e| {
        kind::other_kind(expected, &kind::JSON, &kind::json_keys(text))
            .unwrap_or_else(|| format!("not a {what} JSON object ({e})"))
    })
}

/// Loads `path` and makes the plan `target` plays, in `scene`: `freq_hz`
/// is `--freq` when given, `center_mm` `--center` (the work volume's
/// centre; default: the foci's mean, or the scene's centre for phases).
pub fn plan_for(
    content: Content,
    path: &Path,
    target: &Target,
    scene: Scene,
    freq_hz: Option<f64>,
    center_mm: Option<Vec3>,
) -> Result<TargetPlan, InputError> {
    let what = content.what();
    let bad = |msg: String| InputError::new(format!("{what} {}: {msg}", path.display()));
    let transducers = scene.transducers().len();
    let (loaded, dwell_us) = read(content, path, transducers).map_err(|e| {
        // Errors of the npy reader already name the path.
        if e.to_string().starts_with(&path.display().to_string()) {
            InputError::new(format!("{what} {e}"))
        } else {
            e
        }
    })?;
    let steps = match &loaded {
        Loaded::Phases { steps, .. }
        | Loaded::Foci { steps, .. }
        | Loaded::Planned { steps, .. } => *steps,
    };
    if let Loaded::Planned { report: r, .. } = &loaded {
        if r.target != target.name() {
            return Err(bad(format!(
                "was planned for target {} (its timing and step limits); this port is {}: \
                 plan it with --target {}",
                r.target,
                target.name(),
                target.name()
            )));
        }
        if r.scene != scene.name {
            return Err(bad(format!(
                "was planned for scene '{}', this upload's scene is '{}': give the plan's --scene",
                r.scene, scene.name
            )));
        }
    }
    let (lo, hi) = match target {
        Target::Lm => (1, MAX_STEPS),
        Target::Autd3 => (MIN_PATTERNS, MAX_PATTERNS),
    };
    if !(lo..=hi).contains(&steps) {
        return Err(bad(format!(
            "{steps} steps; the device takes {lo}..={hi} steps"
        )));
    }
    let (dwell_s, requested_dwell_us, divide) =
        timing(target, &scene, steps, freq_hz, dwell_us).map_err(|e| bad(e.to_string()))?;
    let (foci_mm, foci) = match &loaded {
        Loaded::Phases { .. } => (Vec::new(), 1),
        Loaded::Foci { foci, mm, .. } => (
            mm.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
            *foci,
        ),
        Loaded::Planned { report: r, .. } => (
            r.foci_mm.iter().flatten().copied().collect(),
            r.foci_mm[0].len(),
        ),
    };
    for (i, f) in foci_mm.iter().enumerate() {
        let (j, k) = (i / foci, i % foci);
        limits::position_mm("focus", *f).map_err(|e| bad(format!("step {j} focus {k}: {e}")))?;
        if !scene.faces(scene.drive_point(*f)) {
            return Err(bad(format!(
                "step {j} focus {k} [{:.1}, {:.1}, {:.1}] mm is behind or in the plane of every device",
                f[0], f[1], f[2]
            )));
        }
    }
    let planned_center = match &loaded {
        Loaded::Planned { report: r, .. } => Some(r.center_mm),
        _ => None,
    };
    let center_mm = match (center_mm.or(planned_center), foci_mm.is_empty()) {
        (Some(c), _) => c,
        (None, true) => scene.center_mm,
        (None, false) => {
            let n = foci_mm.len() as f64;
            let s = foci_mm
                .iter()
                .fold([0.0; 3], |a, f| crate::geom::add(a, *f));
            crate::geom::scale(s, 1.0 / n)
        }
    };
    limits::position_mm("center", center_mm)?;
    if !scene.faces(scene.drive_point(center_mm)) {
        return Err(InputError::new(format!(
            "center [{:.1}, {:.1}, {:.1}] mm is behind or in the plane of every device",
            center_mm[0], center_mm[1], center_mm[2]
        )));
    }
    // A phases file has no foci: its trajectory is the centre, still.
    let foci_mm = if foci_mm.is_empty() {
        vec![center_mm; steps]
    } else {
        foci_mm
    };
    let drive_mm: Vec<Vec3> = foci_mm.iter().map(|&f| scene.drive_point(f)).collect();
    let step_mm = (0..steps)
        .map(|j| {
            crate::geom::norm(crate::geom::sub(
                foci_mm[((j + 1) % steps) * foci],
                foci_mm[j * foci],
            ))
        })
        .sum::<f64>()
        / steps as f64;
    let trajectory = Trajectory {
        steps,
        foci,
        index_offset: 0,
        step_mm,
        dwell_s,
        period_s: dwell_s * steps as f64,
        center_mm,
        foci_mm,
        drive_mm,
        path: None,
    };
    let mut header = Sequence::header_for(&scene, &trajectory, transducers)?;
    let phases = match loaded {
        Loaded::Phases { phases, .. } => phases,
        Loaded::Planned {
            phases, report: r, ..
        } => {
            // What plan made, made again here: the same header but for the
            // work volume (--max-offset) and, given --center, the centre.
            header.intensity = r.header.intensity;
            let h = &r.header;
            let differs = [
                ("period_us", header.period_us != h.period_us),
                (
                    "center_um",
                    center_mm == r.center_mm && header.center_um != h.center_um,
                ),
                ("foci_per_step", header.foci_per_step != h.foci_per_step),
                (
                    "sound_speed_mm_s",
                    header.sound_speed_mm_s != h.sound_speed_mm_s,
                ),
            ];
            if let Some((k, _)) = differs.iter().find(|(_, d)| *d) {
                return Err(bad(format!(
                    "its header's {k} is not what its timing, centre and this scene make: \
                     the file changed after plan wrote it, or give the plan's --scene"
                )));
            }
            phases
        }
        Loaded::Foci { .. } => {
            let synth = SynthPlan::new(&scene.transducers(), scene.wavenumber_rad_per_mm());
            let mut scratch = synth.scratch();
            let mut phases = vec![0u8; steps * transducers];
            for (j, out) in phases.chunks_exact_mut(transducers).enumerate() {
                synth.foci(trajectory.drive_step(j), None, &mut scratch, out);
            }
            phases
        }
    };
    let plan = Plan {
        scene,
        trajectory,
        sequence: Sequence {
            header,
            phases,
            intensity_table: None,
        },
        am: None,
    };
    let period_us = f64::from(plan.sequence.header.period_us);
    let dwell_us = plan.sequence.dwell_us();
    let requested_freq_hz = freq_hz.unwrap_or(1e6 / (requested_dwell_us * steps as f64));
    let freq = 1e6 / period_us;
    let timing = Timing {
        steps,
        dwell_us,
        requested_dwell_us,
        dwell_error_us: dwell_us - requested_dwell_us,
        freq_hz: freq,
        requested_freq_hz,
        freq_error_hz: freq - requested_freq_hz,
        step_mm,
        requested_step_mm: step_mm,
        step_error_mm: 0.0,
        divide,
        am_freq_hz: None,
    };
    Ok(TargetPlan {
        plan,
        timing,
        warnings: Vec::new(),
    })
}

/// The dwell (s), the dwell asked (µs) and the AUTD3 divide.
fn timing(
    target: &Target,
    scene: &Scene,
    steps: usize,
    freq_hz: Option<f64>,
    dwell_us: Option<f64>,
) -> Result<(f64, f64, Option<u16>), InputError> {
    let asked_us = match (freq_hz, dwell_us) {
        (Some(_), Some(_)) => {
            return Err(InputError::new(
                "gives a dwell_us and --freq gives another timing: give one",
            ));
        }
        (None, None) => {
            return Err(InputError::new(
                "has no timing: give --freq HZ or a dwell_us in a JSON file",
            ));
        }
        (Some(f), None) => {
            limits::in_range("--freq", f, limits::MIN_FREQ_HZ, limits::MAX_FREQ_HZ, "Hz")?;
            if f <= 0.0 {
                return Err(InputError::new(format!("--freq {f} must be above 0 Hz")));
            }
            1e6 / (f * steps as f64)
        }
        (None, Some(d)) => {
            if !(d.is_finite() && d > 0.0) {
                return Err(InputError::new(format!(
                    "dwell_us {} must be a finite number above 0",
                    limits::show(d)
                )));
            }
            // The dwell's own range over these steps (a frequency derived
            // from 1e-320 µs was inf Hz, from 1e300 µs a period the wire
            // cannot hold).
            let per = |f: f64| 1e6 / (f * steps as f64);
            let (lo, hi) = (per(limits::MAX_FREQ_HZ), per(limits::MIN_FREQ_HZ));
            if !(lo..=hi).contains(&d) {
                return Err(InputError::new(format!(
                    "dwell_us {} over {} is out of range: allowed {}..={} µs (an LM frequency of {}..={} Hz)",
                    limits::show(d),
                    crate::out::count(steps as u64, "step"),
                    limits::Num(lo),
                    limits::Num(hi),
                    limits::Num(limits::MIN_FREQ_HZ),
                    limits::MAX_FREQ_HZ
                )));
            }
            d
        }
    };
    let (dwell_s, divide) = match (target, freq_hz) {
        (Target::Lm, _) => (asked_us * 1e-6, None),
        (Target::Autd3, Some(f)) => {
            let g = grid::grid_timing(0.0, f, Steps::Count(steps), scene.min_dwell_s)?;
            (f64::from(g.dwell_us) * 1e-6, Some(g.divide))
        }
        (Target::Autd3, None) => {
            let d = grid::divide_for_dwell(asked_us * 1e-6)
                .filter(|&d| u32::from(d) >= grid::SILENCER_MIN_DIVIDE)
                .ok_or_else(|| {
                    InputError::new(format!(
                        "dwell_us {} is not on AUTD3's 25 µs grid from {} to {} µs",
                        limits::show(asked_us),
                        grid::dwell_us(grid::SILENCER_MIN_DIVIDE),
                        grid::dwell_us(grid::MAX_DIVIDE)
                    ))
                })?;
            (f64::from(grid::dwell_us(u32::from(d))) * 1e-6, Some(d))
        }
    };
    if dwell_s < scene.min_dwell_s * (1.0 - 1e-12) {
        return Err(InputError::new(format!(
            "dwell {:.4} ms is below the device minimum {:.4} ms",
            limits::Num(dwell_s * 1e3),
            limits::Num(scene.min_dwell_s * 1e3)
        )));
    }
    crate::units::period_us(dwell_s * steps as f64)?;
    Ok((dwell_s, asked_us, divide))
}

/// Reads the file by its extension (`.npy`, `.bin` for phases, else JSON),
/// checked against `transducers` before the data is read.
fn read(
    content: Content,
    path: &Path,
    transducers: usize,
) -> Result<(Loaded, Option<f64>), InputError> {
    let what = content.what();
    let bad = |msg: String| InputError::new(format!("{what} {}: {msg}", path.display()));
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    if content == Content::Phases && ext.as_deref() == Some("bin") {
        return read_bin(path, transducers);
    }
    if ext.as_deref() != Some("npy") {
        // `plan --out` writes raw bytes for any extension but .json and
        // .npy; read back, such a file is taken for JSON: say how to name it.
        let unnamed = |e: InputError| match (content, ext.as_deref()) {
            (Content::Phases, Some("json")) => e,
            (Content::Phases, _) => InputError::new(format!(
                "{e} (read as JSON by its extension; name raw phase bytes .bin, as plan --out F.bin writes them)"
            )),
            _ => e,
        };
        // (A missing file or a folder is named right; only a file's
        // content gets the hint.)
        let text = limits::read_text_file_up_to(what, path, MAX_JSON_BYTES)
            .map_err(|e| if path.is_file() { unnamed(e) } else { e })?;
        // A number that underflows is refused, as in every JSON we read.
        crate::json::exact_numbers(&text).map_err(bad)?;
        // An object, before any key is looked at: serde reads a struct
        // from an array too, so `[[]]` was "a plan summary" (its first
        // item taken for `crc32`) and `"x"` "expected struct Keys".
        if let Some(it) = not_an_object(&text) {
            let form = match content {
                Content::Phases => "{\"phases\": [[P, ...], ...], \"dwell_us\": D}",
                Content::Foci => "{\"foci_mm\": [[[x, y, z], ...], ...], \"dwell_us\": D}",
            };
            return Err(unnamed(bad(format!(
                "is {it}, not a JSON object: give {form}"
            ))));
        }
        // Duplicate keys are refused, at any depth.
        // Typed straight from the text (a byte a phase, not a tree of
        // values); serde refuses a field given twice.
        let keys = match content {
            Content::Phases => Some(
                serde_json::from_str::<report::Keys>(&text)
                    .map_err(|e| unnamed(bad(format!("not a phases JSON object ({e})"))))?,
            ),
            // A file that is no object is refused below, as a foci file.
            Content::Foci => serde_json::from_str::<report::Keys>(&text).ok(),
        };
        let is_report = keys.as_ref().is_some_and(report::Keys::is_report);
        if keys.as_ref().is_some_and(report::Keys::is_summary) {
            return Err(bad(
                "is a plan summary without its phases (`lmhost plan --json`): a plan replays \
                 from the report `lmhost plan --out F.json` writes (or `plan --json --phases`), \
                 given as --phases"
                    .into(),
            ));
        }
        return match content {
            Content::Phases if is_report => {
                let mut r: report::PlanReport = report::from_json(&text)
                    .map_err(|e| bad(format!("not a `lmhost plan --out` JSON report ({e})")))?;
                r.check().map_err(|e| bad(e.to_string()))?;
                whole_steps(&r.phases, transducers).map_err(bad)?;
                let phases = std::mem::take(&mut r.phases).concat();
                let dwell_us = r.timing.dwell_us;
                Ok((
                    Loaded::Planned {
                        steps: phases.len() / transducers,
                        phases,
                        report: Box::new(r),
                    },
                    Some(dwell_us),
                ))
            }
            Content::Phases => {
                let j: PhasesJson = json_object(&kind::PHASES, "phases", &text).map_err(bad)?;
                let steps = j.phases.len();
                if steps == 0 {
                    return Err(bad("has no steps".into()));
                }
                whole_steps(&j.phases, transducers).map_err(bad)?;
                Ok((
                    Loaded::Phases {
                        steps,
                        phases: j.phases.concat(),
                    },
                    j.dwell_us,
                ))
            }
            // A plan report's foci alone would not replay it: its
            // synthesis, weights and intensity are not in them.
            Content::Foci if is_report => Err(bad(format!(
                "is a `lmhost plan --out` report, not a foci file: replay the plan with --phases {} \
                 (its phases as planned); --foci-file takes {{\"foci_mm\": [[[x, y, z], ...], ...], \
                 \"dwell_us\": D}} and synthesises them anew",
                path.display()
            ))),
            Content::Foci => {
                let j: FociJson = json_object(&kind::FOCI, "foci", &text).map_err(bad)?;
                let steps = j.foci_mm.len();
                let foci = j.foci_mm.first().map_or(0, Vec::len);
                if steps == 0 || foci == 0 {
                    return Err(bad("has no steps or no foci".into()));
                }
                if foci > MAX_FOCI {
                    return Err(bad(format!("{foci} foci per step; at most {MAX_FOCI}")));
                }
                if let Some((i, r)) = j.foci_mm.iter().enumerate().find(|(_, r)| r.len() != foci) {
                    return Err(bad(format!(
                        "step {i} has {} foci, step 0 has {foci}: every step needs as many",
                        r.len()
                    )));
                }
                let mm: Vec<f64> = j.foci_mm.iter().flatten().flatten().copied().collect();
                Ok((Loaded::Foci { steps, foci, mm }, j.dwell_us))
            }
        };
    }
    let mut f = crate::files::open_input(what, path)?;
    let len = f
        .metadata()
        .map_err(|e| bad(crate::files::reason(&e)))?
        .len();
    let mut r = std::io::BufReader::new(&mut f);
    let h = crate::npy::read_header(&mut r, len, path)?;
    let (descr, elem, want_rank) = match content {
        Content::Phases => ("|u1", 1u64, 2),
        Content::Foci => ("<f8", 8u64, 3),
    };
    let descr_ok = h.descr == descr || (content == Content::Phases && h.descr == "u1");
    if !descr_ok {
        return Err(bad(format!(
            ".npy dtype '{}' is not '{descr}' ({})",
            h.descr,
            match content {
                Content::Phases => "uint8 phases",
                Content::Foci => "float64 mm",
            }
        )));
    }
    if h.shape.len() != want_rank {
        return Err(bad(format!(
            ".npy shape {:?} is not {}",
            h.shape,
            match content {
                Content::Phases => "(steps, transducers)",
                Content::Foci => "(steps, foci, 3)",
            }
        )));
    }
    let steps = h.shape[0];
    if steps == 0 || steps > MAX_STEPS as u64 {
        return Err(bad(format!("{steps} steps; at most {MAX_STEPS}")));
    }
    let (per_step, foci) = match content {
        Content::Phases => {
            if h.shape[1] != transducers as u64 {
                return Err(bad(format!(
                    "{} phases per step; the scene has {transducers} transducers",
                    h.shape[1]
                )));
            }
            (h.shape[1], 0)
        }
        Content::Foci => {
            let foci = h.shape[1];
            if foci == 0 || foci > MAX_FOCI as u64 || h.shape[2] != 3 {
                return Err(bad(format!(
                    ".npy shape {:?} is not (steps, foci, 3) with 1..={MAX_FOCI} foci",
                    h.shape
                )));
            }
            (foci * 3, foci as usize)
        }
    };
    let data = steps * per_step * elem;
    if len != h.data_offset + data {
        return Err(bad(format!(
            "{len} bytes, but its shape {:?} needs {} (header and data)",
            h.shape,
            h.data_offset + data
        )));
    }
    let mut bytes = Vec::with_capacity(data as usize);
    r.read_to_end(&mut bytes)
        .map_err(|e| bad(crate::files::reason(&e)))?;
    if bytes.len() as u64 != data {
        return Err(bad("changed while it was read".into()));
    }
    let steps = steps as usize;
    Ok(match content {
        Content::Phases => (
            Loaded::Phases {
                steps,
                phases: bytes,
            },
            None,
        ),
        Content::Foci => {
            let mm: Vec<f64> = bytes
                .chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
                .collect();
            (Loaded::Foci { steps, foci, mm }, None)
        }
    })
}

/// Every step of a JSON file's `phases` has one phase per transducer.
fn whole_steps(phases: &[Vec<u8>], transducers: usize) -> Result<(), String> {
    match phases
        .iter()
        .enumerate()
        .find(|(_, row)| row.len() != transducers)
    {
        Some((i, row)) => Err(format!(
            "step {i} has {} phases; the scene has {transducers} transducers",
            row.len()
        )),
        None => Ok(()),
    }
}

/// Reads a `.bin` of raw phases, step-major (what `plan --out F.bin`
/// writes): `transducers` bytes a step, its length checked before it is
/// read; no timing (`--freq` gives it).
fn read_bin(path: &Path, transducers: usize) -> Result<(Loaded, Option<f64>), InputError> {
    let what = Content::Phases.what();
    let bad = |msg: String| InputError::new(format!("{what} {}: {msg}", path.display()));
    let mut f = crate::files::open_input(what, path)?;
    let len = f
        .metadata()
        .map_err(|e| bad(crate::files::reason(&e)))?
        .len();
    let per_step = transducers as u64;
    if len == 0 || len % per_step != 0 || len / per_step > MAX_STEPS as u64 {
        return Err(bad(format!(
            "{len} bytes is not 1..={MAX_STEPS} steps of {transducers} phases (raw .bin, \
             a byte per transducer, step-major)"
        )));
    }
    let mut phases = Vec::with_capacity(len as usize);
    (&mut f)
        .take(len + 1)
        .read_to_end(&mut phases)
        .map_err(|e| bad(crate::files::reason(&e)))?;
    if phases.len() as u64 != len {
        return Err(bad("changed while it was read".into()));
    }
    let steps = phases.len() / transducers;
    Ok((Loaded::Phases { steps, phases }, None))
}

#[cfg(test)]
mod tests;
