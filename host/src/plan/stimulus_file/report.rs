//! The report `lmhost plan --out F.json` writes (and Python's
//! `Planned.save`), read back by `lmhost upload --phases F.json`: every key
//! plan writes and no other, checked against itself (its `crc32` against
//! its phases, its shape against its header) before the device sees it.

use serde::de::IgnoredAny;

use crate::error::InputError;

/// A first look at a phases JSON object: whether it names a key only a
/// plan report has (then it is read as one). Named as the phases object,
/// so a file that is no JSON object is refused in the same words.
#[derive(serde::Deserialize)]
#[serde(rename = "PhasesJson")]
pub(super) struct Keys {
    #[serde(default)]
    crc32: Option<IgnoredAny>,
    #[serde(default)]
    target: Option<IgnoredAny>,
    #[serde(default)]
    header: Option<IgnoredAny>,
    #[serde(default)]
    phases: Option<IgnoredAny>,
}

impl Keys {
    /// It names `crc32`, `target` or `header`.
    pub fn is_report(&self) -> bool {
        self.crc32.is_some() || self.target.is_some() || self.header.is_some()
    }

    /// It is a report without its phases (`lmhost plan --json`'s summary).
    pub fn is_summary(&self) -> bool {
        self.is_report() && self.phases.is_none()
    }
}

/// `plan --out F.json`, as [`TargetPlan::summary_json`](crate::plan::stimulus::TargetPlan::summary_json)
/// writes it with its phases. Keys upload does not use are still required
/// (their values unread), so a file with a key plan never writes is refused.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PlanReport {
    pub scene: String,
    transducers: usize,
    steps: usize,
    foci_per_step: usize,
    #[serde(rename = "index_offset")]
    _index_offset: IgnoredAny,
    #[serde(rename = "step_mm")]
    _step_mm: IgnoredAny,
    #[serde(rename = "dwell_s")]
    _dwell_s: IgnoredAny,
    #[serde(rename = "period_s")]
    _period_s: IgnoredAny,
    /// The header plan made, read as the protocol declares it (unknown
    /// keys refused).
    pub header: lm_proto::UploadHeader,
    pub center_mm: [f64; 3],
    #[serde(rename = "mirrored")]
    _mirrored: IgnoredAny,
    pub foci_mm: Vec<Vec<[f64; 3]>>,
    #[serde(rename = "encoding")]
    _encoding: IgnoredAny,
    crc32: u32,
    #[serde(default)]
    intensity_table: Option<Vec<u8>>,
    #[serde(default, rename = "drive_foci_mm")]
    _drive_foci_mm: Option<IgnoredAny>,
    pub phases: Vec<Vec<u8>>,
    pub target: String,
    pub timing: TimingReport,
}

/// The report's `timing`: the realised dwell is what upload plays.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct TimingReport {
    steps: usize,
    pub dwell_us: f64,
    #[serde(rename = "requested_dwell_us")]
    _requested_dwell_us: IgnoredAny,
    #[serde(rename = "dwell_error_us")]
    _dwell_error_us: IgnoredAny,
    #[serde(rename = "freq_hz")]
    _freq_hz: IgnoredAny,
    #[serde(rename = "requested_freq_hz")]
    _requested_freq_hz: IgnoredAny,
    #[serde(rename = "freq_error_hz")]
    _freq_error_hz: IgnoredAny,
    #[serde(rename = "step_mm")]
    _step_mm: IgnoredAny,
    #[serde(rename = "requested_step_mm")]
    _requested_step_mm: IgnoredAny,
    #[serde(rename = "step_error_mm")]
    _step_error_mm: IgnoredAny,
    #[serde(rename = "divide")]
    _divide: Option<u16>,
    am_freq_hz: Option<f64>,
}

impl PlanReport {
    /// Checks the report against itself: its shape against its header and
    /// `steps`/`transducers`, its `crc32` against its phases; a plan with
    /// amplitude modulation is refused (the phases alone do not replay it).
    pub fn check(&self) -> Result<(), InputError> {
        let bad = |m: String| Err(InputError::new(m));
        let h = &self.header;
        let steps = self.phases.len();
        if steps == 0 {
            return bad("has no steps".into());
        }
        for (what, n) in [
            ("steps", self.steps),
            ("header.steps", usize::from(h.steps)),
            ("timing.steps", self.timing.steps),
            ("foci_mm", self.foci_mm.len()),
        ] {
            if n != steps {
                return bad(format!("{what} says {n} steps, its phases have {steps}"));
            }
        }
        for (what, n) in [
            ("transducers", self.transducers),
            ("header.transducers", usize::from(h.transducers)),
        ] {
            if let Some((i, r)) = self.phases.iter().enumerate().find(|(_, r)| r.len() != n) {
                return bad(format!(
                    "step {i} has {} phases, its {what} says {n}",
                    r.len()
                ));
            }
        }
        let foci = self.foci_per_step;
        if foci != usize::from(h.foci_per_step) || self.foci_mm.iter().any(|r| r.len() != foci) {
            return bad(format!(
                "foci_mm does not have foci_per_step = {foci} foci in every step"
            ));
        }
        let mut c = lm_proto::Crc32::new();
        self.phases.iter().for_each(|r| c.update(r));
        if let Some(t) = &self.intensity_table {
            c.update(t);
        }
        let crc = c.finish();
        if crc != self.crc32 {
            return bad(format!(
                "its crc32 {:08x} is not its phases' ({crc:08x}): the file changed after plan wrote it",
                self.crc32
            ));
        }
        if self.intensity_table.is_some() || self.timing.am_freq_hz.is_some() {
            return bad(
                "was planned with amplitude modulation (--am), which upload --phases does not \
                 replay: upload with the plan's flags"
                    .into(),
            );
        }
        Ok(())
    }
}
