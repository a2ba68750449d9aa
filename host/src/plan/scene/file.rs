//! The scene file's TOML schema and its parse errors (one line each).

use serde::Deserialize;

use crate::geom::Vec3;
use crate::plan::directivity::Directivity;

/// One line from a TOML error: `line N, field `path`: message`, the line
/// and the field found from the error's byte span (the field is the
/// innermost key whose key or value holds it: `device[1].center_mm`, also
/// for dotted keys, inline tables and arrays over several lines).
fn toml_error_line(text: &str, e: &toml::de::Error) -> String {
    let msg = first_line(e.message());
    let msg = if msg.is_empty() { "invalid TOML" } else { msg };
    let Some(span) = e.span() else {
        return msg.to_string();
    };
    if msg.starts_with("missing field `") {
        return missing(text, span.start, msg);
    }
    match quoted_number(msg) {
        Some(m) => placed(text, span.start, &m),
        None => placed(text, span.start, msg),
    }
}

/// A number written in quotes, in the words of a number flag's refusal
/// ([`crate::files::text::number_hint`]): `invalid type: string "2,5",
/// expected a number` said neither that the quotes were the trouble nor
/// what the text looks like (`"2,5" is text, not a number (a decimal
/// comma? write `2.5`)`), as `--radius 2,5` and a CSV field do.
fn quoted_number(msg: &str) -> Option<String> {
    let rest = msg.strip_prefix("invalid type: string \"")?;
    let (value, expected) = rest.rsplit_once("\", expected ")?;
    let number = [
        "f64", "f32", "number", "integer", "u8", "u16", "u32", "u64", "usize", "i32", "i64",
    ]
    .iter()
    .any(|w| expected.contains(w));
    if !number {
        return None;
    }
    let hint = crate::files::text::number_hint(value);
    let give = match hint.is_empty() && value.trim().parse::<f64>().is_ok() {
        true => format!(": write `{}` without quotes", value.trim()),
        false => String::new(),
    };
    // What was expected, in words (a whole number's range kept).
    let what = match expected.starts_with("a ") {
        true => expected,
        false => "a number",
    };
    Some(format!("\"{value}\" is text, not {what}{hint}{give}"))
}

/// Where a missing field was wanted: the error's span is the table that
/// lacks it, a `[header]` or `{ inline }` table named by its path (`line
/// N, table `device[1]`: missing field `x``), else the file's top level,
/// which has no line of its own (the first key of the file is not the
/// one missing: "field `width`: missing field `fx`" named the wrong one).
fn missing(text: &str, at: usize, msg: &str) -> String {
    let at = at.min(text.len());
    let table = text[at..].starts_with(['[', '{']);
    match field_at(text, at).filter(|_| table) {
        Some(path) => format!("line {}, table `{path}`: {msg}", line_of(text, at)),
        None => format!("{msg} at the top level"),
    }
}

/// The first line of a TOML error's message (the lines after it list
/// what was expected), but through to the end of a value it quotes that
/// holds a line break (an unknown variant written with `\n`), which the
/// one line of an [`crate::InputError`] shows escaped; cut at the break,
/// the value would be repeated to its break, its quote left open.
fn first_line(msg: &str) -> &str {
    let mut end = 0;
    let mut open = false;
    for (i, c) in msg.char_indices() {
        match c {
            '`' => open = !open,
            '\n' if !open => break,
            _ => {}
        }
        end = i + c.len_utf8();
    }
    // An unclosed quote: the first line only.
    let whole = if open {
        msg.lines().next().unwrap_or("")
    } else {
        &msg[..end]
    };
    whole.trim()
}

/// `line N, field `path`: msg` for byte `at` of `text` (without the field
/// where no key holds it).
fn placed(text: &str, at: usize, msg: &str) -> String {
    let at = at.min(text.len());
    let line_no = line_of(text, at);
    match field_at(text, at) {
        Some(field) => format!("line {line_no}, field `{field}`: {msg}"),
        None => format!("line {line_no}: {msg}"),
    }
}

/// The line (from 1) that holds byte `at` of `text`.
pub(crate) fn line_of(text: &str, at: usize) -> usize {
    text.as_bytes()[..at]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// Every TOML file lmhost reads goes through here: `T` from `text`, or
/// one line naming the line and field ([`toml_error_line`]). A float
/// literal that underflows (`1e-400` reads as 0) is refused as well
/// ([`crate::limits::exact_literal`]): the parse has lost the literal, so
/// its spans are read back from the text.
///
/// A file of another kind than `expected` (a library given as a scene)
/// says what it is and what takes it instead ([`crate::files::kind`]). A
/// table is read from a table only, never from an array by position
/// ([`super::tables`]).
pub(crate) fn from_toml<T: serde::de::DeserializeOwned>(
    text: &str,
    expected: &crate::files::kind::Kind,
) -> Result<T, String> {
    use crate::files::kind;
    let read =
        toml::Deserializer::parse(text).and_then(|d| T::deserialize(super::tables::Tables(d)));
    let v = read.map_err(|e| {
        kind::other_kind(expected, &kind::TOML, &kind::toml_keys(text))
            .unwrap_or_else(|| toml_error_line(text, &e))
    })?;
    let Ok(doc) = toml_edit::Document::parse(text) else {
        return Ok(v);
    };
    let mut floats = Vec::new();
    floats_in_table(doc.as_table(), &mut floats);
    for (span, v) in floats {
        let Some(lit) = text.get(span.clone()) else {
            continue;
        };
        if let Err(m) = crate::limits::exact_literal(lit.trim().replace('_', "").as_str(), v) {
            return Err(placed(text, span.start, &m));
        }
    }
    Ok(v)
}

fn floats_in_table(t: &toml_edit::Table, out: &mut Vec<(std::ops::Range<usize>, f64)>) {
    for (_, item) in t.iter() {
        match item {
            toml_edit::Item::Table(t) => floats_in_table(t, out),
            toml_edit::Item::ArrayOfTables(a) => a.iter().for_each(|t| floats_in_table(t, out)),
            toml_edit::Item::Value(v) => floats_in_value(v, out),
            toml_edit::Item::None => {}
        }
    }
}

fn floats_in_value(v: &toml_edit::Value, out: &mut Vec<(std::ops::Range<usize>, f64)>) {
    match v {
        toml_edit::Value::Float(f) => out.extend(f.span().map(|s| (s, *f.value()))),
        toml_edit::Value::Array(a) => a.iter().for_each(|v| floats_in_value(v, out)),
        toml_edit::Value::InlineTable(t) => t.iter().for_each(|(_, v)| floats_in_value(v, out)),
        _ => {}
    }
}

/// The dotted path of the innermost key at byte `at` of `text`, by the
/// spans of its parse (none when the text does not parse, as when the
/// error is in its syntax).
pub(crate) fn field_at(text: &str, at: usize) -> Option<String> {
    let Ok(doc) = toml_edit::Document::parse(text) else {
        // A value toml_edit cannot hold (an integer past i64, say): the
        // key on the error's line, under the table header above it.
        return field_on_line(text, at);
    };
    let mut path = Vec::new();
    walk_table(doc.as_table(), at, &mut path).then(|| path.join("."))
}

/// `key = …` on the line holding byte `at`, prefixed by the last table
/// header above it (`[[name]]` numbered as the spans walk numbers it).
fn field_on_line(text: &str, at: usize) -> Option<String> {
    let start = text[..at].rfind('\n').map_or(0, |i| i + 1);
    let line = text[start..].lines().next()?;
    let (key, _) = line.split_once('=')?;
    let key = key.trim();
    let bare = |k: &str| {
        !k.is_empty()
            && k.chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'))
    };
    if !bare(key) {
        return None;
    }
    let mut header: Option<String> = None;
    let mut counts = std::collections::HashMap::<String, usize>::new();
    for l in text[..start].lines() {
        let l = l.trim();
        if let Some(name) = l.strip_prefix("[[").and_then(|r| r.strip_suffix("]]")) {
            let n = counts.entry(name.trim().to_owned()).or_default();
            header = Some(format!("{}[{}]", name.trim(), *n));
            *n += 1;
        } else if let Some(name) = l.strip_prefix('[').and_then(|r| r.strip_suffix(']')) {
            header = Some(name.trim().to_owned());
        }
    }
    Some(match header {
        Some(h) => format!("{h}.{key}"),
        None => key.to_owned(),
    })
}

fn holds(span: Option<std::ops::Range<usize>>, at: usize) -> bool {
    span.is_some_and(|s| s.start <= at && at < s.end.max(s.start + 1))
}

/// Pushes onto `path` the keys down to the one at `at`; whether found.
fn walk_table(t: &toml_edit::Table, at: usize, path: &mut Vec<String>) -> bool {
    for (k, item) in t.iter() {
        let key = t.key(k).and_then(toml_edit::Key::span);
        path.push(k.to_owned());
        if walk_item(item, at, path) || holds(key, at) {
            return true;
        }
        path.pop();
    }
    false
}

fn walk_item(item: &toml_edit::Item, at: usize, path: &mut Vec<String>) -> bool {
    use toml_edit::Item;
    match item {
        Item::Table(t) => walk_table(t, at, path) || holds(t.span(), at),
        Item::ArrayOfTables(a) => a.iter().enumerate().any(|(i, t)| {
            let last = path.len() - 1;
            let name = std::mem::take(&mut path[last]);
            path[last] = format!("{name}[{i}]");
            let found = walk_table(t, at, path) || holds(t.span(), at);
            if !found {
                path[last] = name;
            }
            found
        }),
        Item::Value(v) => walk_value(v, at, path),
        Item::None => false,
    }
}

fn walk_value(v: &toml_edit::Value, at: usize, path: &mut Vec<String>) -> bool {
    let toml_edit::Value::InlineTable(t) = v else {
        return holds(v.span(), at);
    };
    let inner = t.iter().any(|(k, v)| {
        path.push(k.to_owned());
        let key = t.key(k).and_then(toml_edit::Key::span);
        let found = walk_value(v, at, path) || holds(key, at);
        if !found {
            path.pop();
        }
        found
    });
    inner || holds(t.span(), at)
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SceneFile {
    pub(super) name: Option<String>,
    pub(super) directivity: Option<Directivity>,
    #[serde(default, deserialize_with = "crate::geom::exact::opt_vec3")]
    pub(super) center_mm: Option<Vec3>,
    pub(super) min_dwell_ms: Option<f64>,
    pub(super) medium: Option<MediumFile>,
    pub(super) reflector: Option<ReflectorFile>,
    pub(super) lm_plane: Option<PlaneFile>,
    pub(super) rig: Option<PoseFile>,
    #[serde(default)]
    pub(super) device: Vec<DeviceFile>,
    pub(super) camera: Option<super::camera::CameraFile>,
    pub(super) tracking: Option<super::camera::TrackingFile>,
    pub(super) calibration: Option<CalibrationFile>,
}

/// `[calibration]`: the force calibration `lmhost calibrate force` writes.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CalibrationFile {
    pub(super) pressure_scale: f64,
    pub(super) measured_n: Option<f64>,
    pub(super) simulated_n: Option<f64>,
    pub(super) disk_mm: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct MediumFile {
    pub(super) sound_speed_m_s: Option<f64>,
    pub(super) temperature_c: Option<f64>,
    pub(super) attenuation_np_per_m: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ReflectorFile {
    #[serde(deserialize_with = "crate::geom::exact::vec3")]
    pub(super) point_mm: Vec3,
    #[serde(deserialize_with = "crate::geom::exact::vec3")]
    pub(super) normal: Vec3,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PlaneFile {
    #[serde(deserialize_with = "crate::geom::exact::vec3")]
    pub(super) a: Vec3,
    #[serde(deserialize_with = "crate::geom::exact::vec3")]
    pub(super) b: Vec3,
    #[serde(default, deserialize_with = "crate::geom::exact::opt_vec3")]
    pub(super) c: Option<Vec3>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PoseFile {
    #[serde(default, deserialize_with = "crate::geom::exact::vec3")]
    pub(super) position_mm: Vec3,
    #[serde(default, deserialize_with = "crate::geom::exact::vec3")]
    pub(super) rotation_deg: Vec3,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct DeviceFile {
    #[serde(deserialize_with = "crate::geom::exact::vec3")]
    pub(super) center_mm: Vec3,
    #[serde(default, deserialize_with = "crate::geom::exact::vec3")]
    pub(super) rotation_deg: Vec3,
}
