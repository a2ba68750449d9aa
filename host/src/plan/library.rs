//! A stimulus library: the named stimuli a session or a study presents,
//! read from a TOML file and planned once for the device at hand.
//!
//! ```toml
//! [[stimulus]]
//! id = "lms-5hz-a3"      # letters, digits, `-`, `_`, `.`; unique
//! radius = 3.0           # mm (the plan flags' names and units)
//! foci = 1
//! spacing = 3.0          # mm, LM-M
//! freq = 5.0             # Hz
//! step = 0.23            # mm; or `steps = 82`
//! center = [0, 0, 200]   # mm, finger space; default: the scene's centre
//! intensity = 1.0        # 0..=1 of full output
//! untracked = false      # the default gate when a `present` names none
//!
//! [[stimulus]]
//! id = "liss-am"
//! freq = 2.0             # Hz: one whole figure per cycle
//! path = { shape = "lissajous", a = 5.0, b = 3.0, ratio = [3, 2], phase = 90.0 }
//! am = { shape = "sine", freq = 200.0, depth = 1.0 }   # AUTD3: 200 Hz; LM: see below
//! z = [0.5]              # mm along the plane's c axis: one, or one per step
//! method = "gspat"       # or "linear" (default)
//! iterations = 20        # GS-PAT's
//! ```
//!
//! An entry may instead play phases or foci from a file, relative to the
//! library's folder, as `lmhost upload --phases` / `--foci-file` read it:
//! `phases_file = "circle.npy"` or `foci_file = "path.json"`, with only
//! `freq` (when the file gives no dwell), `center` and `untracked` beside.
//!
//! Every field but `id` defaults to the plan flags' default
//! ([`Stimulus::default`]). `path` is the shape the foci run along
//! ([`Path`]): `circle` (the default, of `radius`), `line` (`length`),
//! `ellipse` (semi-axes `a`, `b`) or `lissajous` (half-extents `a`, `b`,
//! `ratio = [n_a, n_b]`, `phase` in degrees); `radius` belongs to the
//! circle only. `am` is an amplitude modulation ([`Am`]): `sine` or
//! `square`, `freq` in Hz, `depth` 0..=1; an AUTD3 plays it as its
//! modulation (4 kHz samples), the LM firmware as a per-step intensity
//! table (protocol v6), which needs a whole number of AM periods per LM
//! cycle of at least 4 steps each: at the paper's 82 steps and 5 Hz, 5 to
//! 100 Hz in 5 Hz steps; another frequency is refused naming those.
//! [`Library::plan_for`] plans every entry for one device (AUTD3's 25 µs
//! grid included) before anything is presented, so a bad entry is an
//! error at start, not in the middle of a study.
//!
//! The file types below also derive the file's JSON Schema (doc comments,
//! ranges from the limits the checks use, defaults): `lmhost study schema
//! library` prints it, `docs/schema/` holds it and its reference page.

use std::path::{Path as FsPath, PathBuf};

use schemars::JsonSchema;
use serde::Deserialize;

use crate::error::InputError;
use crate::limits::{
    MAX_COORD_MM, MAX_FREQ_HZ, MAX_ITERATIONS, MAX_RADIUS_MM, MAX_SPACING_MM, MAX_Z_MM,
};
use crate::plan::modulation::{self, Am, AmShape};
use crate::plan::path::{Lissajous, MAX_LISSAJOUS_RATIO, Path};
use crate::plan::scene::Scene;
use crate::plan::stimulus::{Stimulus, TargetPlan};
use crate::plan::stimulus_file::Content;
use crate::plan::target::Target;
use crate::plan::trajectory::{Cycle, MAX_FOCI, MAX_STEPS, paper};
use crate::whole::Whole;

/// Most entries in one library.
pub const MAX_ENTRIES: usize = 256;

/// Longest stimulus id, bytes.
pub const MAX_ID_LEN: usize = 64;

/// A Lissajous path's frequency ratio when it gives none.
const RATIO: [u32; 2] = [1, 2];
/// A Lissajous path's phase when it gives none, degrees.
const PHASE_DEG: f64 = 90.0;
/// An amplitude modulation's depth when it gives none.
const AM_DEPTH: f64 = 1.0;

/// One named stimulus.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// Its name in `present` commands, protocols and logs.
    pub id: String,
    /// What to play (of an entry from a file: its `freq` and `center`).
    pub stimulus: Stimulus,
    /// Play without tracking unless a `present` says otherwise.
    pub untracked: bool,
    /// Phases or foci from a file (`phases_file`, `foci_file`), as
    /// `lmhost upload --phases` / `--foci-file` read them.
    pub file: Option<(Content, PathBuf)>,
    /// An entry from a file: its `freq`, if given (else the file's dwell).
    pub file_freq_hz: Option<f64>,
}

impl Entry {
    /// Plans the entry for `target` in `scene`: its stimulus, or its file
    /// through the checks `upload --phases` / `--foci-file` make.
    pub fn plan_for(&self, target: &Target, scene: Scene) -> anyhow::Result<TargetPlan> {
        match &self.file {
            None => self.stimulus.plan_for(target, scene),
            Some((content, path)) => Ok(crate::plan::stimulus_file::plan_for(
                *content,
                path,
                target,
                scene,
                self.file_freq_hz,
                self.stimulus.center_mm,
            )?),
        }
    }
}

/// The entries of a library file, in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct Library {
    /// Entries in file order (a device's slot `i` holds entry `i` when the
    /// whole library is resident).
    pub entries: Vec<Entry>,
    /// The file it was read from, as its errors name it (its path).
    pub origin: String,
}

/// A stimulus library: the named stimuli a session or a study presents,
/// each `[[stimulus]]` table one entry; every field but `id` defaults to
/// the plan flags' default.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(title = "lmhost stimulus library", transform = stimulus_required)]
pub(crate) struct LibraryFile {
    /// The entries, in file order (a device's slot `i` holds entry `i`).
    #[serde(default)]
    #[schemars(length(min = 1, max = MAX_ENTRIES))]
    stimulus: Vec<EntryFile>,
}

/// The schema of [`LibraryFile`]: serde takes a file without stimuli so
/// that the loader can say what to add, but the file needs one.
fn stimulus_required(schema: &mut schemars::Schema) {
    crate::limits::require_in_schema(schema, "stimulus");
}

/// One `[[stimulus]]` table.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
struct EntryFile {
    /// Name in `present` commands: 1..=64 letters, digits, `-`, `_`, `.`.
    #[schemars(length(min = 1, max = MAX_ID_LEN), pattern(r"^[A-Za-z0-9._-]+$"))]
    id: String,
    /// Circle radius A. The circle's only.
    #[schemars(
        range(min = 0.0, max = MAX_RADIUS_MM),
        extend("x-unit" = "mm", "default" = paper::RADIUS_MM),
    )]
    radius: Option<f64>,
    /// Foci per step (1: LM-S).
    #[schemars(
        with = "Option<usize>",
        range(min = 1, max = MAX_FOCI),
        extend("default" = paper::FOCI)
    )]
    foci: Option<Whole<1, { MAX_FOCI as u64 }>>,
    /// Spacing between neighbouring foci along the path.
    #[schemars(
        range(max = MAX_SPACING_MM),
        extend("x-unit" = "mm", "exclusiveMinimum" = 0.0, "default" = paper::SPACING_MM),
    )]
    spacing: Option<f64>,
    /// LM frequency: cycles of the path per second.
    #[schemars(
        range(max = MAX_FREQ_HZ),
        extend("x-unit" = "Hz", "exclusiveMinimum" = 0.0, "default" = paper::FREQ_HZ),
    )]
    freq: Option<f64>,
    /// Step width along the path. Not with `steps`.
    #[schemars(
        range(max = MAX_SPACING_MM),
        extend("x-unit" = "mm", "exclusiveMinimum" = 0.0, "default" = paper::STEP_MM),
    )]
    step: Option<f64>,
    /// Steps per cycle. Not with `step`.
    #[schemars(with = "Option<usize>", range(min = 1, max = MAX_STEPS))]
    steps: Option<Whole<1, { MAX_STEPS as u64 }>>,
    /// Path centre in finger space `[x, y, z]`; default the scene's centre.
    #[schemars(inner(range(min = -MAX_COORD_MM, max = MAX_COORD_MM)), extend("x-unit" = "mm"))]
    center: Option<[f64; 3]>,
    /// Output intensity, of full.
    #[schemars(range(min = 0.0, max = 1.0), extend("default" = Stimulus::default().intensity))]
    intensity: Option<f64>,
    /// Play without tracking unless a `present` says otherwise.
    #[serde(default)]
    untracked: bool,
    /// The path's shape; default the circle of `radius`.
    path: Option<PathFile>,
    /// Amplitude modulation; default none.
    am: Option<AmFile>,
    /// Depth along the LM plane's c axis per step: one value (constant) or
    /// one per step; default 0.
    #[schemars(
        length(max = MAX_STEPS),
        inner(range(min = -MAX_Z_MM, max = MAX_Z_MM)),
        extend("x-unit" = "mm"),
    )]
    z: Option<Vec<f64>>,
    /// Phase synthesis of several foci: `linear` (the paper's) or `gspat`.
    #[schemars(extend("default" = "linear"))]
    method: Option<MethodName>,
    /// Phases from a file, relative to the library's folder: `.npy` uint8
    /// `(steps, transducers)` (what `lmhost plan --out F.npy` writes) or
    /// JSON `{"phases": [[...]], "dwell_us": D}`, as `lmhost upload
    /// --phases` reads it. Takes only `freq` (when the file gives no
    /// dwell), `center` and `untracked` beside it.
    phases_file: Option<String>,
    /// Foci from a file, relative to the library's folder: `.npy` float64
    /// `(steps, foci, 3)` in mm, finger space, or JSON `{"foci_mm":
    /// [[[x, y, z]]], "dwell_us": D}`, as `lmhost upload --foci-file` reads
    /// it (linear synthesis). Takes only `freq`, `center` and `untracked`.
    foci_file: Option<String>,
    /// GS-PAT iterations (`method = "gspat"` only).
    #[schemars(
        with = "Option<usize>",
        range(min = 1, max = MAX_ITERATIONS),
        extend("default" = crate::plan::stimulus::GSPAT_ITERATIONS),
    )]
    iterations: Option<Whole<1, { MAX_ITERATIONS as u64 }>>,
}

/// A synthesis method's name.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
enum MethodName {
    Linear,
    Gspat,
}

/// A path's shape name.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
enum ShapeName {
    Circle,
    Line,
    Ellipse,
    Lissajous,
}

/// `path = { shape = ..., ... }`: only the shape's own fields.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
struct PathFile {
    /// `circle`, `line`, `ellipse` or `lissajous`.
    shape: ShapeName,
    /// Line length; the line's only, required.
    #[schemars(range(min = 0.0, max = MAX_RADIUS_MM), extend("x-unit" = "mm"))]
    length: Option<f64>,
    /// Ellipse semi-axis or Lissajous half-width along the plane's a;
    /// required for both.
    #[schemars(range(min = 0.0, max = MAX_RADIUS_MM), extend("x-unit" = "mm"))]
    a: Option<f64>,
    /// Ellipse semi-axis or Lissajous half-height along b; required for
    /// both.
    #[schemars(range(min = 0.0, max = MAX_RADIUS_MM), extend("x-unit" = "mm"))]
    b: Option<f64>,
    /// Lissajous frequency ratio `[n_a, n_b]`.
    #[schemars(
        with = "Option<[u32; 2]>",
        inner(range(min = 1, max = MAX_LISSAJOUS_RATIO)),
        extend("default" = RATIO)
    )]
    ratio: Option<[Whole<1, { MAX_LISSAJOUS_RATIO as u64 }>; 2]>,
    /// Lissajous phase of the a term.
    #[schemars(range(min = -360.0, max = 360.0), extend("x-unit" = "°", "default" = PHASE_DEG))]
    phase: Option<f64>,
}

/// An AM envelope's shape name.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
enum AmShapeName {
    Sine,
    Square,
}

/// `am = { shape = ..., freq = ..., depth = ... }`.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
struct AmFile {
    /// `sine` or `square`.
    shape: AmShapeName,
    /// Modulation frequency; on AUTD3 4000 Hz / a whole number of samples.
    #[schemars(
        range(min = modulation::MIN_FREQ_HZ, max = modulation::MAX_FREQ_HZ),
        extend("x-unit" = "Hz"),
    )]
    freq: f64,
    /// Depth (1: down to silence).
    #[schemars(range(min = 0.0, max = 1.0), extend("default" = AM_DEPTH))]
    depth: Option<f64>,
}

impl PathFile {
    fn resolve(&self) -> Result<Path, String> {
        let given = crate::limits::given(&[
            ("length", self.length.is_some()),
            ("a", self.a.is_some()),
            ("b", self.b.is_some()),
            ("ratio", self.ratio.is_some()),
            ("phase", self.phase.is_some()),
        ]);
        let (name, own): (&str, &[&str]) = match self.shape {
            ShapeName::Circle => ("circle", &[]),
            ShapeName::Line => ("line", &["length"]),
            ShapeName::Ellipse => ("ellipse", &["a", "b"]),
            ShapeName::Lissajous => ("lissajous", &["a", "b", "ratio", "phase"]),
        };
        if let Some(f) = given.iter().find(|f| !own.contains(f)) {
            return Err(format!(
                "path `{name}` has no `{f}` (its fields: {})",
                if own.is_empty() {
                    "none; the circle's size is `radius`".to_string()
                } else {
                    own.join(", ")
                }
            ));
        }
        let need = |v: Option<f64>, f: &str| v.ok_or_else(|| format!("path `{name}` needs `{f}`"));
        let path = match self.shape {
            ShapeName::Circle => Path::Circle,
            ShapeName::Line => Path::Line {
                length_mm: need(self.length, "length")?,
            },
            ShapeName::Ellipse => Path::Ellipse {
                a_mm: need(self.a, "a")?,
                b_mm: need(self.b, "b")?,
            },
            ShapeName::Lissajous => {
                let [n_a, n_b] = self.ratio.map_or(RATIO, |r| r.map(Whole::get));
                Path::Lissajous(Lissajous {
                    a_mm: need(self.a, "a")?,
                    b_mm: need(self.b, "b")?,
                    n_a,
                    n_b,
                    phase_deg: self.phase.unwrap_or(PHASE_DEG),
                })
            }
        };
        path.check().map_err(|e| e.to_string())?;
        Ok(path)
    }
}

impl AmFile {
    fn resolve(&self) -> Result<Am, String> {
        let am = Am {
            shape: match self.shape {
                AmShapeName::Sine => AmShape::Sine,
                AmShapeName::Square => AmShape::Square,
            },
            freq_hz: self.freq,
            depth: self.depth.unwrap_or(AM_DEPTH),
        };
        am.check().map_err(|e| e.to_string())?;
        Ok(am)
    }
}

/// Checks a stimulus id: non-empty, at most [`MAX_ID_LEN`] bytes of
/// letters, digits, `-`, `_` and `.`.
pub fn check_id(id: &str) -> Result<(), String> {
    if id.is_empty() || id.len() > MAX_ID_LEN {
        return Err(format!(
            "stimulus id `{}` must be 1 to {MAX_ID_LEN} characters",
            id.escape_debug()
        ));
    }
    if let Some(c) = id
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.')))
    {
        return Err(format!(
            "stimulus id `{}` has `{}`: use letters, digits, `-`, `_` and `.`",
            id.escape_debug(),
            c.escape_debug()
        ));
    }
    Ok(())
}

impl EntryFile {
    /// `center`, checked: the work volume's.
    fn center_mm(&self) -> Result<Option<[f64; 3]>, String> {
        self.center
            .map(|c| crate::limits::position_mm("center", c).map_err(|e| e.to_string()))
            .transpose()
    }

    /// An entry whose phases or foci come from a file: only the fields
    /// that file plans take.
    fn into_file_entry(self, content: Content, path: String) -> Result<Entry, String> {
        let given = [
            ("radius", self.radius.is_some()),
            ("foci", self.foci.is_some()),
            ("spacing", self.spacing.is_some()),
            ("step", self.step.is_some()),
            ("steps", self.steps.is_some()),
            ("intensity", self.intensity.is_some()),
            ("path", self.path.is_some()),
            ("am", self.am.is_some()),
            ("z", self.z.is_some()),
            ("method", self.method.is_some()),
            ("iterations", self.iterations.is_some()),
        ];
        let key = match content {
            Content::Phases => "phases_file",
            Content::Foci => "foci_file",
        };
        if let Some((f, _)) = given.iter().find(|(_, g)| *g) {
            return Err(format!(
                "`{f}` does not apply to a stimulus from `{key}` (it takes `freq`, `center` and `untracked`)"
            ));
        }
        if path.trim().is_empty() {
            return Err(format!("`{key}` is empty: give a file"));
        }
        let mut stimulus = Stimulus {
            center_mm: self.center_mm()?,
            ..Stimulus::default()
        };
        if let Some(f) = self.freq {
            stimulus.cycle.freq_hz = f;
        }
        Ok(Entry {
            id: self.id,
            stimulus,
            untracked: self.untracked,
            file: Some((content, PathBuf::from(path))),
            file_freq_hz: self.freq,
        })
    }

    fn resolve(mut self) -> Result<Entry, String> {
        check_id(&self.id)?;
        match (self.phases_file.take(), self.foci_file.take()) {
            (Some(_), Some(_)) => return Err("give `phases_file` or `foci_file`, not both".into()),
            (Some(p), None) => return self.into_file_entry(Content::Phases, p),
            (None, Some(p)) => return self.into_file_entry(Content::Foci, p),
            (None, None) => {}
        }
        let d = Stimulus::default();
        if self.step.is_some() && self.steps.is_some() {
            return Err("give `step` or `steps`, not both".into());
        }
        if let Some(i) = self.intensity {
            crate::limits::in_range("intensity", i, 0.0, 1.0, "").map_err(|e| e.to_string())?;
        }
        let path = self
            .path
            .as_ref()
            .map(PathFile::resolve)
            .transpose()?
            .unwrap_or_default();
        if self.radius.is_some() && path != Path::Circle {
            return Err(format!(
                "`radius` is the circle's; a `{}` path has its size in `path`",
                path.name()
            ));
        }
        let am = self.am.as_ref().map(AmFile::resolve).transpose()?;
        let synthesis = match (self.method, self.iterations) {
            (Some(MethodName::Gspat), n) => crate::plan::stimulus::gspat(
                n.map_or(crate::plan::stimulus::GSPAT_ITERATIONS, Whole::get_usize),
            )
            .map_err(|e| e.to_string().replace("--iterations", "iterations"))?,
            (_, Some(_)) => return Err("`iterations` applies to `method = \"gspat\"` only".into()),
            _ => d.synthesis.clone(),
        };
        let center_mm = self.center_mm()?;
        let cycle = Cycle {
            path,
            z_profile_mm: self.z.unwrap_or_default(),
            ..Cycle::given(
                self.radius,
                self.foci.map(Whole::get_usize),
                self.spacing,
                self.freq,
                self.step,
                self.steps.map(Whole::get_usize),
            )
            // The flags' words, in the file's names.
            .map_err(|e| e.to_string().replace("--", ""))?
        };
        // The plan flags' rule, here where the file is named (`study
        // check` plans nothing); its words name the flags, whose names
        // are the fields'.
        cycle.check().map_err(|e| {
            ["radius", "freq", "spacing", "step"]
                .iter()
                .fold(e.to_string(), |m, f| m.replace(&format!(" (--{f})"), ""))
                .replace("--", "")
        })?;
        Ok(Entry {
            id: self.id,
            stimulus: Stimulus {
                cycle,
                center_mm,
                intensity: self.intensity.unwrap_or(d.intensity),
                am,
                synthesis,
            },
            untracked: self.untracked,
            file: None,
            file_freq_hz: None,
        })
    }
}

impl Library {
    /// Reads and checks a library file (one-line errors naming the file,
    /// the entry and the field).
    pub fn load(path: &FsPath) -> Result<Self, InputError> {
        let text = crate::limits::read_text_file("stimulus library", path)?;
        let mut lib = Self::from_toml(&text, &path.display().to_string())?;
        // Files an entry names are relative to the library's folder.
        let dir = path.parent().unwrap_or(FsPath::new(""));
        for e in &mut lib.entries {
            if let Some((_, f)) = &mut e.file {
                *f = dir.join(&*f);
            }
        }
        Ok(lib)
    }

    /// Parses a library from TOML text; `origin` names it in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, InputError> {
        let bad = |msg: String| InputError::new(format!("stimulus library {origin}: {msg}"));
        let file: LibraryFile =
            crate::plan::scene::from_toml(text, &crate::files::kind::LIBRARY).map_err(bad)?;
        if file.stimulus.is_empty() {
            return Err(bad(
                "no stimuli: add at least one [[stimulus]] table with an `id`".into(),
            ));
        }
        if file.stimulus.len() > MAX_ENTRIES {
            return Err(bad(format!(
                "{} stimuli; at most {MAX_ENTRIES} fit one library",
                file.stimulus.len()
            )));
        }
        let mut entries: Vec<Entry> = Vec::with_capacity(file.stimulus.len());
        for (i, e) in file.stimulus.into_iter().enumerate() {
            let id = e.id.clone();
            let entry = e
                .resolve()
                .map_err(|m| bad(format!("stimulus {} (`{}`): {m}", i + 1, id.escape_debug())))?;
            if entries.iter().any(|x| x.id == entry.id) {
                return Err(bad(format!(
                    "stimulus {}: id `{}` is used twice",
                    i + 1,
                    entry.id
                )));
            }
            entries.push(entry);
        }
        Ok(Self {
            entries,
            origin: origin.to_owned(),
        })
    }

    /// The entry named `id`, with its index.
    pub fn find(&self, id: &str) -> Option<(usize, &Entry)> {
        self.entries.iter().enumerate().find(|(_, e)| e.id == id)
    }

    /// Plans every entry for `target` in `scene` (AUTD3's dwell grid
    /// included); the first entry that cannot be planned is the error,
    /// named as the loader names it: the file, the entry's place and id.
    pub fn plan_for(&self, target: &Target, scene: &Scene) -> anyhow::Result<Vec<TargetPlan>> {
        self.entries
            .iter()
            .enumerate()
            .map(|(i, e)| {
                e.plan_for(target, scene.clone()).map_err(|err| {
                    err.context(format!(
                        "stimulus library {}: stimulus {} (`{}`)",
                        self.origin,
                        i + 1,
                        e.id.escape_debug()
                    ))
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests;
