//! The report `lmhost plan --out F.json` writes (and Python's
//! `Planned.save`), read back by `lmhost upload --phases F.json`: every key
//! plan writes and no other, checked against itself (its `crc32` against
//! its phases, its shape against its header) before the device sees it.

use serde::de::IgnoredAny;

use crate::error::InputError;
use crate::plan::trajectory::{MAX_FOCI, MAX_STEPS};
use crate::whole::{Byte, Signed, Whole};

/// A count of steps or transducers: one at least, at most a `u16`'s.
type Count = Whole<1, { MAX_STEPS as u64 }>;

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
    transducers: Count,
    steps: Count,
    foci_per_step: Whole<1, { MAX_FOCI as u64 }>,
    #[serde(rename = "index_offset")]
    _index_offset: IgnoredAny,
    #[serde(rename = "step_mm")]
    _step_mm: IgnoredAny,
    #[serde(rename = "dwell_s")]
    _dwell_s: IgnoredAny,
    #[serde(rename = "period_s")]
    _period_s: IgnoredAny,
    /// The header plan made, read as the protocol declares it (unknown
    /// keys refused), each number in its field's range.
    #[serde(deserialize_with = "header")]
    pub header: lm_proto::UploadHeader,
    pub center_mm: [f64; 3],
    #[serde(rename = "mirrored")]
    _mirrored: IgnoredAny,
    pub foci_mm: Vec<Vec<[f64; 3]>>,
    #[serde(rename = "encoding")]
    _encoding: IgnoredAny,
    crc32: Whole<0, { u32::MAX as u64 }>,
    /// Left out without AM; `null` refused ([`crate::json::no_null`]).
    #[serde(default, deserialize_with = "opt_bytes")]
    intensity_table: Option<Vec<u8>>,
    #[serde(
        default,
        rename = "drive_foci_mm",
        deserialize_with = "crate::json::no_null"
    )]
    _drive_foci_mm: Option<IgnoredAny>,
    #[serde(deserialize_with = "byte_rows")]
    pub phases: Vec<Vec<u8>>,
    pub target: String,
    pub timing: TimingReport,
}

/// The report's `timing`: the realised dwell is what upload plays.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct TimingReport {
    steps: Count,
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
    /// `null` off AUTD3's grid (as plan writes it).
    #[serde(rename = "divide")]
    _divide: Option<Whole<1, { u16::MAX as u64 }>>,
    /// `null` without AM (as plan writes it).
    am_freq_hz: Option<f64>,
}

/// The report's `header`, each number read in its field's range (the
/// protocol's, as the device checks it), not its Rust type's.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct HeaderJson {
    steps: Count,
    transducers: Count,
    period_us: Whole<1, { u32::MAX as u64 }>,
    center_um: [Signed<{ i32::MIN as i64 }, { i32::MAX as i64 }>; 3],
    foci_per_step: Whole<1, { MAX_FOCI as u64 }>,
    sound_speed_mm_s: Whole<
        { *lm_proto::SOUND_SPEED_MM_S.start() as u64 },
        { *lm_proto::SOUND_SPEED_MM_S.end() as u64 },
    >,
    max_offset_um: Whole<
        { *lm_proto::MAX_OFFSET_UM.start() as u64 },
        { *lm_proto::MAX_OFFSET_UM.end() as u64 },
    >,
    intensity: Byte,
}

fn header<'de, D: serde::Deserializer<'de>>(d: D) -> Result<lm_proto::UploadHeader, D::Error> {
    let h = <HeaderJson as serde::Deserialize>::deserialize(d)?;
    let narrow = |v: u64| u16::try_from(v).unwrap_or(u16::MAX);
    Ok(lm_proto::UploadHeader {
        steps: narrow(h.steps.0),
        transducers: narrow(h.transducers.0),
        period_us: h.period_us.get(),
        center_um: h.center_um.map(|c| i32::try_from(c.0).unwrap_or(0)),
        foci_per_step: u8::try_from(h.foci_per_step.0).unwrap_or(u8::MAX),
        sound_speed_mm_s: h.sound_speed_mm_s.get(),
        max_offset_um: h.max_offset_um.get(),
        intensity: h.intensity.0,
    })
}

/// `text` read as a `T`, the whole of it; an error names the field it is
/// in (`header.steps: -1 is out of range: allowed 1..=65535 at line 1
/// column 9`).
pub(super) fn from_json<T: serde::de::DeserializeOwned>(text: &str) -> Result<T, String> {
    let mut de = serde_json::Deserializer::from_str(text);
    let v = value_of(&mut de)?;
    // One value: what follows it (a second object, a stray word) was
    // ignored without a word.
    de.end().map_err(|e| e.to_string())?;
    Ok(v)
}

fn value_of<T: serde::de::DeserializeOwned>(
    de: &mut serde_json::Deserializer<serde_json::de::StrRead<'_>>,
) -> Result<T, String> {
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        // A syntax error is where it is, not in a field.
        if path == "." || !e.inner().is_data() {
            e.inner().to_string()
        } else {
            // The path and serde's quoted values hold the file's own
            // keys, which may be as long as the file and hold anything.
            let inner = e.inner().to_string();
            let quoted = inner.split('`').enumerate();
            let inner: Vec<String> = quoted
                .map(|(i, s)| if i % 2 == 1 { shown(s) } else { s.to_owned() })
                .collect();
            format!("{}: {}", shown(&path), inner.join("`"))
        }
    })
}

/// Most characters of a key or a field's path a message repeats.
const MAX_SHOWN_CHARS: usize = 80;

/// `s` as a message repeats it: escaped, cut after [`MAX_SHOWN_CHARS`]
/// saying how long it was.
fn shown(s: &str) -> String {
    let n = s.chars().count();
    let head: String = s.chars().take(MAX_SHOWN_CHARS).collect();
    let head = head.escape_debug();
    match n > MAX_SHOWN_CHARS {
        true => format!("{head}… ({n} characters)"),
        false => head.to_string(),
    }
}

/// A report's `phases` or a phases file's: rows of whole numbers 0..=255.
pub(super) fn byte_rows<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<Vec<u8>>, D::Error> {
    <Vec<Vec<Byte>> as serde::Deserialize>::deserialize(d).map(crate::whole::bytes)
}

fn opt_bytes<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<Vec<u8>>, D::Error> {
    let v = crate::json::no_null::<_, Vec<Byte>>(d)?;
    Ok(v.map(|r| r.into_iter().map(|b| b.0).collect()))
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
            ("steps", self.steps.get_usize()),
            ("header.steps", usize::from(h.steps)),
            ("timing.steps", self.timing.steps.get_usize()),
            ("foci_mm", self.foci_mm.len()),
        ] {
            if n != steps {
                return bad(format!("{what} says {n} steps, its phases have {steps}"));
            }
        }
        for (what, n) in [
            ("transducers", self.transducers.get_usize()),
            ("header.transducers", usize::from(h.transducers)),
        ] {
            if let Some((i, r)) = self.phases.iter().enumerate().find(|(_, r)| r.len() != n) {
                return bad(format!(
                    "step {i} has {} phases, its {what} says {n}",
                    r.len()
                ));
            }
        }
        let foci = self.foci_per_step.get_usize();
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
        if crc != self.crc32.get() {
            return bad(format!(
                "its crc32 {:08x} is not its phases' ({crc:08x}): the file changed after plan wrote it",
                self.crc32.get()
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
