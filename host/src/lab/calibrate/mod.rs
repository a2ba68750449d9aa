//! Calibrating a rig against measurements, and writing the result into
//! its scene file: [`force`] (`[calibration]`, from a static-focus force
//! measurement) and [`camera`] (`[camera]`, the depth camera's pose from
//! recordings of a ball at known points).
//!
//! A scene is edited with `toml_edit`: the one table is replaced (or
//! appended), whatever form it had (a `[table]`, dotted keys, an inline
//! table), and every other line, comments included, is kept; the result
//! must load as a scene before it is written, whole, through
//! [`crate::files`].

pub mod camera;
pub mod force;

use std::path::Path;

use toml_edit::{DocumentMut, Item};

use crate::error::InputError;
use crate::plan::scene::Scene;

/// `text` with its `[name]` table replaced by one holding `body` (lines of
/// `key = value`, comments allowed), at the old table's place, or
/// appended when it has none. `origin` names the scene in errors.
pub fn with_table(text: &str, name: &str, body: &str, origin: &str) -> Result<String, InputError> {
    let mut doc: DocumentMut = text.parse().map_err(|e: toml_edit::TomlError| {
        InputError::new(format!(
            "scene file {origin}: {}",
            e.message().lines().next().unwrap_or("invalid TOML")
        ))
    })?;
    let new: DocumentMut =
        format!("[{name}]\n{body}")
            .parse()
            .map_err(|e: toml_edit::TomlError| {
                InputError::new(format!(
                    "the [{name}] table to write is not TOML: {}",
                    e.message()
                ))
            })?;
    let Some(Item::Table(mut table)) = new.as_table().get(name).cloned() else {
        return Err(InputError::new(format!(
            "the [{name}] table to write is empty"
        )));
    };
    let root = doc.as_table_mut();
    match root.get(name) {
        Some(Item::Table(old)) if !old.is_dotted() && old.position().is_some() => {
            // Its place, and the comments above its header.
            table.set_position(old.position());
            let above = old.decor().prefix().cloned().unwrap_or_default();
            table.decor_mut().set_prefix(above);
        }
        // Dotted keys, an inline table or none: a table after the others.
        _ => {
            root.remove(name);
            table.set_position(Some(last_position(root) + 1));
            if !text.trim().is_empty() {
                table.decor_mut().set_prefix("\n");
            }
        }
    }
    root.insert(name, Item::Table(table));
    Ok(doc.to_string())
}

/// The largest document position of any table under `t`.
fn last_position(t: &toml_edit::Table) -> isize {
    t.iter()
        .map(|(_, v)| match v {
            Item::Table(t) => t.position().unwrap_or(0).max(last_position(t)),
            Item::ArrayOfTables(a) => a
                .iter()
                .map(|t| t.position().unwrap_or(0).max(last_position(t)))
                .max()
                .unwrap_or(0),
            _ => 0,
        })
        .max()
        .unwrap_or(0)
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
    let origin = scene_path.display().to_string();
    let updated = with_table(text, name, body, &origin)?;
    Scene::from_toml(&updated, &origin).map_err(|e| {
        InputError::new(format!(
            "the updated scene does not load, nothing written: {}",
            e.0
        ))
    })?;
    if *dest == Dest::Print {
        return Ok(None);
    }
    // Written as the scene's editor saved it (a byte-order mark, CRLF),
    // which reading it read away: the other lines stay byte for byte.
    let raw =
        crate::files::read_input("scene file", scene_path, crate::limits::MAX_TEXT_FILE_BYTES)?;
    let bytes = crate::files::text::Layout::of(&raw).encode(&updated);
    match dest {
        Dest::Print => Ok(None),
        Dest::Out(p) => {
            crate::files::write_whole(p, &bytes)?;
            Ok(Some(p.clone()))
        }
        Dest::Write => {
            crate::files::replace_input(scene_path, &bytes)?;
            Ok(Some(scene_path.to_path_buf()))
        }
    }
}

/// A float as TOML reads it back exactly (toml_edit's own form).
pub(crate) fn toml_f64(v: f64) -> String {
    toml_edit::Value::from(v).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn w(text: &str, name: &str, body: &str) -> String {
        with_table(text, name, body, "s.toml").unwrap()
    }

    #[test]
    fn a_table_is_replaced_in_place_and_everything_else_kept() {
        let text = "# scene\nname = \"x\"\n\n[calibration]  # old\npressure_scale = 2.0\nmeasured_n = 0.1\n\n# the camera\n[camera]\nposition_mm = [0, 0, 0]\n";
        let out = w(text, "calibration", "# why\npressure_scale = 0.5\n");
        assert_eq!(
            out,
            "# scene\nname = \"x\"\n\n[calibration]\n# why\npressure_scale = 0.5\n\n# the camera\n[camera]\nposition_mm = [0, 0, 0]\n"
        );
        // Last table in the file.
        let out = w("a = 1\n[camera]\nx = 1\ny = 2\n", "camera", "x = 3\n");
        assert_eq!(out, "a = 1\n[camera]\nx = 3\n");
        // Absent: appended after a blank line, also to a file without a
        // final newline, and after an array of tables.
        assert_eq!(
            w("a = 1", "calibration", "k = 1.0"),
            "a = 1\n\n[calibration]\nk = 1.0\n"
        );
        let t = "[calibrationx]\nk = 1\n[[device]]\nc = 1\n";
        assert_eq!(
            w(t, "calibration", "k = 2\n"),
            format!("{t}\n[calibration]\nk = 2\n")
        );
        // A multi-line array's rows are not tables.
        let t = "[tracking]\nbox_axes = [\n  [1, 0, 0],\n]\n[camera]\nx = 1\n";
        assert_eq!(
            w(t, "tracking", "k = 2\n"),
            "[tracking]\nk = 2\n[camera]\nx = 1\n"
        );
    }

    #[test]
    fn a_dotted_or_inline_calibration_is_replaced_too() {
        let dotted = "name = \"x\"\ncalibration.pressure_scale = 2.0\n[[device]]\nc = 1\n";
        assert_eq!(
            w(dotted, "calibration", "pressure_scale = 0.5\n"),
            "name = \"x\"\n[[device]]\nc = 1\n\n[calibration]\npressure_scale = 0.5\n"
        );
        let inline = "calibration = { pressure_scale = 2.0 }  # old\n[camera]\nx = 1\n";
        assert_eq!(
            w(inline, "calibration", "pressure_scale = 0.5\n"),
            "[camera]\nx = 1\n\n[calibration]\npressure_scale = 0.5\n"
        );
        // Not TOML: one line naming the scene.
        let e = with_table("a = [", "calibration", "k = 1\n", "s.toml").unwrap_err();
        assert!(
            e.0.starts_with("scene file s.toml:") && !e.0.contains('\n'),
            "{e}"
        );
    }

    #[test]
    fn floats_round_trip_through_toml() {
        for v in [0.358_891_2, 1.0, 1e-7, 12_345.678_901_234_5, 1e300] {
            let s = toml_f64(v);
            let back: toml::Value = toml::from_str(&format!("k = {s}")).unwrap();
            assert_eq!(back["k"].as_float(), Some(v), "{s}");
        }
    }
}
