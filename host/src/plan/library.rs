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
//! ```
//!
//! Every field but `id` defaults to the plan flags' default
//! ([`Stimulus::default`]). [`Library::plan_for`] plans every entry for one
//! device (AUTD3's 25 µs grid included) before anything is presented, so a
//! bad entry is an error at start, not in the middle of a study.

use std::path::Path;

use serde::Deserialize;

use crate::error::InputError;
use crate::plan::scene::Scene;
use crate::plan::stimulus::{Stimulus, TargetPlan};
use crate::plan::target::Target;
use crate::plan::trajectory::Steps;

/// Most entries in one library.
pub const MAX_ENTRIES: usize = 256;

/// Longest stimulus id, bytes.
pub const MAX_ID_LEN: usize = 64;

/// One named stimulus.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// Its name in `present` commands, protocols and logs.
    pub id: String,
    /// What to play.
    pub stimulus: Stimulus,
    /// Play without tracking unless a `present` says otherwise.
    pub untracked: bool,
}

/// The entries of a library file, in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct Library {
    /// Entries in file order (a device's slot `i` holds entry `i` when the
    /// whole library is resident).
    pub entries: Vec<Entry>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct LibraryFile {
    #[serde(default)]
    stimulus: Vec<EntryFile>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct EntryFile {
    id: String,
    radius: Option<f64>,
    foci: Option<usize>,
    spacing: Option<f64>,
    freq: Option<f64>,
    step: Option<f64>,
    steps: Option<usize>,
    center: Option<[f64; 3]>,
    intensity: Option<f64>,
    #[serde(default)]
    untracked: bool,
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
    fn resolve(self) -> Result<Entry, String> {
        check_id(&self.id)?;
        let d = Stimulus::default();
        let steps = match (self.step, self.steps) {
            (Some(_), Some(_)) => return Err("give `step` or `steps`, not both".into()),
            (_, Some(n)) => Steps::Count(n),
            (Some(w), None) => Steps::Width(w),
            (None, None) => d.steps,
        };
        if let Some(i) = self.intensity {
            crate::limits::in_range("intensity", i, 0.0, 1.0, "").map_err(|e| e.to_string())?;
        }
        let center_mm = self
            .center
            .map(|c| crate::limits::position_mm("center", c).map_err(|e| e.to_string()))
            .transpose()?;
        Ok(Entry {
            id: self.id,
            stimulus: Stimulus {
                radius_mm: self.radius.unwrap_or(d.radius_mm),
                foci: self.foci.unwrap_or(d.foci),
                spacing_mm: self.spacing.unwrap_or(d.spacing_mm),
                freq_hz: self.freq.unwrap_or(d.freq_hz),
                steps,
                center_mm,
                intensity: self.intensity.unwrap_or(d.intensity),
                ..d
            },
            untracked: self.untracked,
        })
    }
}

impl Library {
    /// Reads and checks a library file (one-line errors naming the file,
    /// the entry and the field).
    pub fn load(path: &Path) -> Result<Self, InputError> {
        let text = crate::limits::read_text_file("stimulus library", path)?;
        Self::from_toml(&text, &path.display().to_string())
    }

    /// Parses a library from TOML text; `origin` names it in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, InputError> {
        let bad = |msg: String| InputError::new(format!("stimulus library {origin}: {msg}"));
        let file: LibraryFile =
            toml::from_str(text).map_err(|e| bad(crate::plan::scene::toml_error_line(text, &e)))?;
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
        Ok(Self { entries })
    }

    /// The entry named `id`, with its index.
    pub fn find(&self, id: &str) -> Option<(usize, &Entry)> {
        self.entries.iter().enumerate().find(|(_, e)| e.id == id)
    }

    /// Plans every entry for `target` in `scene` (AUTD3's dwell grid
    /// included); the first entry that cannot be planned is the error,
    /// named.
    pub fn plan_for(&self, target: &Target, scene: &Scene) -> anyhow::Result<Vec<TargetPlan>> {
        self.entries
            .iter()
            .map(|e| {
                e.stimulus
                    .plan_for(target, scene.clone())
                    .map_err(|err| err.context(format!("stimulus `{}`", e.id)))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_default_to_the_plan_flags_and_keep_file_order() {
        let lib = Library::from_toml(
            "[[stimulus]]\nid = \"b\"\nfoci = 4\nintensity = 0.5\n\n[[stimulus]]\nid = \"a\"\nsteps = 64\nfreq = 25\nuntracked = true\n",
            "t",
        )
        .unwrap();
        assert_eq!(lib.entries.len(), 2);
        assert_eq!(lib.entries[0].id, "b");
        assert_eq!(lib.entries[0].stimulus.foci, 4);
        assert_eq!(lib.entries[0].stimulus.radius_mm, 3.0);
        assert_eq!(lib.entries[0].stimulus.intensity, 0.5);
        assert_eq!(lib.entries[1].stimulus.intensity, 1.0);
        assert!(!lib.entries[0].untracked);
        assert_eq!(lib.entries[1].stimulus.steps, Steps::Count(64));
        assert_eq!(lib.entries[1].stimulus.freq_hz, 25.0);
        assert!(lib.entries[1].untracked);
        assert_eq!(lib.find("a").map(|(i, _)| i), Some(1));
        assert!(lib.find("c").is_none());
    }

    #[test]
    fn bad_libraries_are_one_line_errors_naming_the_entry() {
        for (text, needle) in [
            ("", "no stimuli"),
            ("[[stimulus]]\nradius = 3\n", "missing field `id`"),
            ("[[stimulus]]\nid = \"a b\"\n", "use letters"),
            (
                "[[stimulus]]\nid = \"a\"\n[[stimulus]]\nid = \"a\"\n",
                "used twice",
            ),
            (
                "[[stimulus]]\nid = \"a\"\nstep = 0.2\nsteps = 3\n",
                "not both",
            ),
            ("[[stimulus]]\nid = \"a\"\nradius = \"3\"\n", "line 3"),
            ("[[stimulus]]\nid = \"a\"\ncolour = 1\n", "unknown field"),
            ("[[stimulus]]\nid = \"a\"\nintensity = 2\n", "0..=1"),
            ("[[stimulus]]\nid = \"a\"\nintensity = -0.5\n", "0..=1"),
            ("[[stimulus]]\nid = \"a\"\ncenter = [0, 0, 1e9]\n", "±2000"),
        ] {
            let e = Library::from_toml(text, "lib.toml")
                .unwrap_err()
                .to_string();
            assert!(e.contains(needle), "{text:?}: {e}");
            assert!(e.starts_with("stimulus library lib.toml: "), "{e}");
            assert!(!e.contains('\n'), "{e}");
        }
    }

    #[test]
    fn every_entry_is_planned_for_the_target_and_a_bad_one_is_named() {
        let lib = Library::from_toml(
            "[[stimulus]]\nid = \"ok\"\n[[stimulus]]\nid = \"huge\"\nradius = 1000\n",
            "t",
        )
        .unwrap();
        let e = lib.plan_for(&Target::Lm, &Scene::default()).unwrap_err();
        assert!(format!("{e:#}").contains("stimulus `huge`"), "{e:#}");
        let lib = Library::from_toml("[[stimulus]]\nid = \"x\"\nradius = 5\n", "t").unwrap();
        let lm = lib.plan_for(&Target::Lm, &Scene::default()).unwrap();
        let autd = lib.plan_for(&Target::Autd3, &Scene::default()).unwrap();
        // A = 5 mm at 0.23 mm: 137 steps as asked, 136 on AUTD3's grid.
        assert_eq!(lm[0].timing.steps, 137);
        assert_eq!(autd[0].timing.steps, 136);
    }
}
