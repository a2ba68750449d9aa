//! Calibrating a rig against measurements, and writing the result into
//! its scene file: [`force`] (`[calibration]`, from a static-focus force
//! measurement) and [`camera`] (`[camera]`, the depth camera's pose from
//! recordings of a ball at known points).
//!
//! A scene is edited as text: the one table is replaced (or appended) and
//! every other line, comments included, is kept; the result must load as a
//! scene before it is written, whole, through [`crate::files`].

pub mod camera;
pub mod force;

use std::path::Path;

use crate::error::InputError;
use crate::plan::scene::Scene;

/// `text` with its `[name]` table's keys replaced by `body` (lines of
/// `key = value`), or the table appended when it has none. Comment and
/// blank lines between the table's last key and the next table stay with
/// the next table.
pub fn with_table(text: &str, name: &str, body: &str) -> String {
    let header = format!("[{name}]");
    let lines: Vec<&str> = text.split_inclusive('\n').collect();
    let is_header = |l: &str| table_header(l).is_some();
    let is_ours = |l: &str| table_header(l) == Some(name);
    let mut table = format!("{header}\n{body}");
    if !table.ends_with('\n') {
        table.push('\n');
    }
    let Some(start) = lines.iter().position(|l| is_ours(l)) else {
        let mut out = text.to_string();
        if !out.is_empty() && !out.ends_with('\n') {
            out.push('\n');
        }
        if !out.is_empty() {
            out.push('\n');
        }
        out.push_str(&table);
        return out;
    };
    let next = lines[start + 1..]
        .iter()
        .position(|l| is_header(l))
        .map_or(lines.len(), |i| start + 1 + i);
    // Keep the comments and blank lines that lead into the next table.
    let mut end = next;
    while end > start + 1 {
        let t = lines[end - 1].trim();
        if t.is_empty() || t.starts_with('#') {
            end -= 1;
        } else {
            break;
        }
    }
    let mut out: String = lines[..start].concat();
    out.push_str(&table);
    if end < next || next < lines.len() {
        let rest: String = lines[end..].concat();
        if !rest.starts_with('\n') && !rest.is_empty() {
            out.push('\n');
        }
        out.push_str(&rest);
    }
    out
}

/// The table a line opens: `[name]` or `[[name]]` (then `[name`), with
/// an optional trailing comment; `None` for anything else, such as the
/// `[1, 0, 0],` line of a multi-line array.
fn table_header(line: &str) -> Option<&str> {
    let t = line.split('#').next()?.trim();
    let inner = t.strip_prefix("[[").and_then(|r| r.strip_suffix("]]"));
    let (key, array) = match inner {
        Some(k) => (k.trim(), true),
        None => (t.strip_prefix('[')?.strip_suffix(']')?.trim(), false),
    };
    let first = key.chars().next()?;
    let bare = |c: char| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.' | ' ' | '"');
    (first.is_ascii_alphabetic() || first == '_' || first == '"')
        .then_some(())
        .filter(|_| key.chars().all(bare))
        .map(|_| if array { &t[1..t.len() - 1] } else { key })
}

/// Where a calibration goes: printed, a new scene file, or the scene
/// replaced in place.
#[derive(Debug, Clone, PartialEq)]
pub enum Dest {
    /// Print the table (stdout).
    Print,
    /// Write the whole scene, updated, to a new file.
    Out(std::path::PathBuf),
    /// Replace the scene file itself (whole or not at all).
    Write,
}

/// The scene text with `[name]` set to `body`, checked to load as a scene
/// (`origin` names it in errors), and written where `dest` says; returns
/// the path written, if any.
pub fn write_scene(
    scene_path: &Path,
    text: &str,
    name: &str,
    body: &str,
    dest: &Dest,
) -> anyhow::Result<Option<std::path::PathBuf>> {
    let updated = with_table(text, name, body);
    Scene::from_toml(&updated, &scene_path.display().to_string()).map_err(|e| {
        InputError::new(format!(
            "the updated scene does not load, nothing written: {}",
            e.0
        ))
    })?;
    match dest {
        Dest::Print => Ok(None),
        Dest::Out(p) => {
            crate::files::write_whole(p, updated.as_bytes())?;
            Ok(Some(p.clone()))
        }
        Dest::Write => {
            crate::files::replace_input(scene_path, updated.as_bytes())?;
            Ok(Some(scene_path.to_path_buf()))
        }
    }
}

/// A float as TOML writes it back exactly.
pub(crate) fn toml_f64(v: f64) -> String {
    let s = format!("{v:?}");
    if s.contains(['.', 'e', 'E']) || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_table_is_replaced_in_place_and_everything_else_kept() {
        let text = "# scene\nname = \"x\"\n\n[calibration]  # old\npressure_scale = 2.0\nmeasured_n = 0.1\n\n# the camera\n[camera]\nposition_mm = [0, 0, 0]\n";
        let out = with_table(text, "calibration", "pressure_scale = 0.5\n");
        assert_eq!(
            out,
            "# scene\nname = \"x\"\n\n[calibration]\npressure_scale = 0.5\n\n# the camera\n[camera]\nposition_mm = [0, 0, 0]\n"
        );
        // Last table in the file.
        let out = with_table("a = 1\n[camera]\nx = 1\ny = 2\n", "camera", "x = 3\n");
        assert_eq!(out, "a = 1\n[camera]\nx = 3\n");
        // Absent: appended after a blank line, also to a file without a
        // final newline.
        assert_eq!(
            with_table("a = 1", "calibration", "k = 1.0"),
            "a = 1\n\n[calibration]\nk = 1.0\n"
        );
        // A multi-line array's rows are not tables.
        let t = "[tracking]\nbox_axes = [\n  [1, 0, 0],\n]\n[camera]\nx = 1\n";
        assert_eq!(
            with_table(t, "tracking", "k = 2\n"),
            "[tracking]\nk = 2\n\n[camera]\nx = 1\n"
        );
        // `[[device]]` and `[calibrationx]` are not the table.
        let t = "[calibrationx]\nk = 1\n[[device]]\nc = 1\n";
        assert_eq!(
            with_table(t, "calibration", "k = 2\n"),
            format!("{t}\n[calibration]\nk = 2\n")
        );
    }

    #[test]
    fn floats_round_trip_through_toml() {
        for v in [0.358_891_2, 1.0, 1e-7, 12_345.678_901_234_5] {
            let s = toml_f64(v);
            let back: toml::Value = toml::from_str(&format!("k = {s}")).unwrap();
            assert_eq!(back["k"].as_float(), Some(v), "{s}");
        }
    }
}
