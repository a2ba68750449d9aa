//! Checks a case runs on its outputs beyond the exit code and stderr.

use super::*;

pub(crate) fn no_warning(_: &Ctx, r: &Run) -> Result<(), String> {
    if r.stderr.contains("warning") {
        return Err(format!("unexpected warning: {}", r.stderr));
    }
    Ok(())
}

/// Every `.npy`/`.png`/`.svg` named in summary.json exists.
pub(crate) fn named_files_exist(dir: &Path) -> Result<serde_json::Value, String> {
    let text = std::fs::read_to_string(dir.join("summary.json")).map_err(|e| e.to_string())?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| e.to_string())?;
    fn walk(v: &serde_json::Value, dir: &Path, missing: &mut Vec<String>) {
        match v {
            serde_json::Value::String(s)
                if [".npy", ".png", ".svg"].iter().any(|e| s.ends_with(e))
                    && !dir.join(s).exists() =>
            {
                missing.push(s.clone());
            }
            serde_json::Value::Array(a) => a.iter().for_each(|x| walk(x, dir, missing)),
            serde_json::Value::Object(o) => o.values().for_each(|x| walk(x, dir, missing)),
            _ => {}
        }
    }
    let mut missing = Vec::new();
    walk(&v, dir, &mut missing);
    if missing.is_empty() {
        Ok(v)
    } else {
        Err(format!("summary.json names missing files: {missing:?}"))
    }
}

pub(crate) fn compare_summary_is_true(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let v = named_files_exist(&ctx.dir.join("compare"))?;
    let panels = v["compare"].as_array().ok_or("no compare array")?;
    // The paper's 3 × 5 grid.
    if panels.len() != 15 {
        return Err(format!("{} panels", panels.len()));
    }
    for p in panels {
        let m = &p["maps"]["mean_pressure"];
        if !(m["normalisation_pa"].as_f64().is_some_and(|x| x > 0.0)
            && m["png_normalised"].is_string()
            && m["svg_normalised"].is_string()
            && p["radial"]["profile_pa"].is_array()
            && p["radial"]["peak_radius_mm"].is_number())
        {
            return Err(format!("panel lacks normalisation or radial profile: {p}"));
        }
    }
    Ok(())
}

pub(crate) fn single_summary_is_true(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let v = named_files_exist(&ctx.dir.join("single"))?;
    if !v["radial"]["profile_pa"].is_array() {
        return Err("no radial profile".into());
    }
    Ok(())
}

/// The scene reached by three names is as the fixtures wrote it.
pub(crate) fn scene_copy_intact(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let text =
        std::fs::read_to_string(ctx.dir.join("scene_copy.toml")).map_err(|e| e.to_string())?;
    if text != SCENE_COPY {
        return Err(format!("scene_copy.toml was changed: {text:?}"));
    }
    Ok(())
}

/// Every file under `{dir}` is whole (see [`every_file_whole`]).
pub(crate) fn dir_whole(ctx: &Ctx, _: &Run) -> Result<(), String> {
    every_file_whole(&ctx.dir)
}

/// Every file on the full tmpfs is whole and `keep.bin` is as it was.
pub(crate) fn full_whole(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let Some(full) = &ctx.full else {
        return Ok(());
    };
    every_file_whole(full)?;
    let keep = std::fs::read(full.join("keep.bin")).map_err(|e| e.to_string())?;
    if keep != b"0123456789" {
        return Err("keep.bin was changed by a failed overwrite".into());
    }
    Ok(())
}

/// No temporary file is left, every `.npy`'s header agrees with its size,
/// every `.json` parses and every `.png` ends with its IEND chunk.
pub(crate) fn every_file_whole(dir: &Path) -> Result<(), String> {
    let entries = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    for e in entries {
        let e = e.map_err(|e| e.to_string())?;
        let path = e.path();
        let name = e.file_name().to_string_lossy().into_owned();
        let ft = e.file_type().map_err(|e| e.to_string())?;
        if ft.is_dir() {
            // Round 14's broken JSON fixtures are broken on purpose.
            if !path.ends_with(super::cases_r14::BROKEN) {
                every_file_whole(&path)?;
            }
            continue;
        }
        if !ft.is_file() {
            continue;
        }
        if name.contains(".lmhost-") {
            return Err(format!("temporary file left behind: {}", path.display()));
        }
        let bytes = std::fs::read(&path).map_err(|e| e.to_string())?;
        let bad = |why: &str| Err(format!("{} is not whole: {why}", path.display()));
        if name.ends_with(".npy") {
            if let Err(why) = npy_whole(&bytes) {
                // The hostile fixtures are broken on purpose.
                if !FIXTURE_NPY.contains(&name.as_str()) {
                    return bad(&why);
                }
            }
        } else if name.ends_with(".json") {
            // Round 10's are written as other tools write JSON on purpose.
            let fixture = super::cases_r10::FIXTURE_JSON.contains(&name.as_str());
            if !fixture && serde_json::from_slice::<serde_json::Value>(&bytes).is_err() {
                return bad("not JSON");
            }
        } else if name.ends_with(".png") && !bytes.ends_with(&[0xAE, 0x42, 0x60, 0x82]) {
            return bad("no IEND chunk at the end");
        }
    }
    Ok(())
}

/// The broken `.npy` fixtures of [`fixtures`].
pub(crate) const FIXTURE_NPY: [&str; 9] = [
    "ph_trunc.npy",
    "tb.npy",
    "overflow.npy",
    "negative.npy",
    "truncated.npy",
    "long_tail.npy",
    "header_lie.npy",
    "twice.npy",
    "float.npy",
];

/// Whether an `.npy`'s header (shape, dtype) agrees with its length.
pub(crate) fn npy_whole(b: &[u8]) -> Result<(), String> {
    if b.len() < 10 || &b[..6] != b"\x93NUMPY" {
        return Err("no npy magic".into());
    }
    let hlen = u16::from_le_bytes([b[8], b[9]]) as usize;
    let header = std::str::from_utf8(b.get(10..10 + hlen).ok_or("short header")?)
        .map_err(|_| "header not text")?;
    let item: usize = if header.contains("<f8") {
        8
    } else if header.contains("<u2") {
        2
    } else if header.contains("|u1") || header.contains("<u1") {
        1
    } else {
        return Err(format!("unknown dtype in {header}"));
    };
    let shape = header
        .split("'shape': (")
        .nth(1)
        .and_then(|t| t.split(')').next())
        .ok_or("no shape")?;
    let mut n = 1usize;
    for d in shape.split(',').map(str::trim).filter(|d| !d.is_empty()) {
        n = n
            .checked_mul(d.parse::<usize>().map_err(|_| "bad shape")?)
            .ok_or("shape overflows")?;
    }
    if b.len() != 10 + hlen + n * item {
        return Err(format!(
            "header says {n} items of {item} bytes, the file has {} data bytes",
            b.len() - 10 - hlen
        ));
    }
    Ok(())
}

/// No line of the run carries a number of 20 digits or more, and no
/// stderr line is longer than 300 characters.
pub(crate) fn short_numbers(_: &Ctx, r: &Run) -> Result<(), String> {
    for line in r.stdout.lines().chain(r.stderr.lines()) {
        let mut run = 0;
        for c in line.chars() {
            run = if c.is_ascii_digit() { run + 1 } else { 0 };
            if run >= 20 {
                return Err(format!("a 20-digit number: {line}"));
            }
        }
    }
    if let Some(l) = r.stderr.lines().find(|l| l.chars().count() > 300) {
        return Err(format!("a {}-character message: {l}", l.chars().count()));
    }
    Ok(())
}

/// No part of the one error line is said twice in a row.
pub(crate) fn cause_once(_: &Ctx, r: &Run) -> Result<(), String> {
    let parts: Vec<&str> = r.stderr.trim().split(": ").collect();
    if parts.windows(2).any(|w| w[0] == w[1]) {
        return Err(format!("a cause said twice: {}", r.stderr.trim()));
    }
    Ok(())
}

/// `in.npy` is still the fixture it was (a copy of `ok.npy`).
pub(crate) fn in_npy_intact(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let a = std::fs::read(ctx.dir.join("in.npy")).map_err(|e| e.to_string())?;
    let b = std::fs::read(ctx.dir.join("ok.npy")).map_err(|e| e.to_string())?;
    if a != b {
        return Err("in.npy was changed".into());
    }
    Ok(())
}

/// A recording stopped by a signal: whole, with time stamps and intrinsics
/// beside it, and it replays with as many frames as it holds.
pub(crate) fn recording_replays(ctx: &Ctx, name: &str) -> Result<(), String> {
    let npy = ctx.dir.join(format!("{name}.npy"));
    let ts = ctx.dir.join(format!("{name}.timestamps.npy"));
    let cam = ctx.dir.join(format!("{name}.intrinsics.toml"));
    for p in [&npy, &ts, &cam] {
        if !p.exists() {
            return Err(format!("{} is missing", p.display()));
        }
    }
    for p in [&npy, &ts] {
        let b = std::fs::read(p).map_err(|e| e.to_string())?;
        npy_whole(&b).map_err(|e| format!("{}: {e}", p.display()))?;
    }
    let out = Command::new(lmhost())
        .args(["track", "--depth"])
        .arg(&npy)
        .args(["--fast", "--scene"])
        .arg(ctx.scenes.join("paper.toml"))
        .output()
        .map_err(|e| e.to_string())?;
    let text = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() || !text.contains(" frames of 848×480") || text.starts_with("0 frames")
    {
        return Err(format!(
            "the recording does not replay: {text} {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(())
}

pub(crate) fn sig_int_replays(ctx: &Ctx, _: &Run) -> Result<(), String> {
    recording_replays(ctx, "sig_int")
}

pub(crate) fn sig_term_replays(ctx: &Ctx, _: &Run) -> Result<(), String> {
    recording_replays(ctx, "sig_term")
}

/// The time stamps `--record rec2.npy` would have overwritten are intact
/// and no `rec2.npy` was written.
pub(crate) fn rec2_ts_intact(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let b = std::fs::read(ctx.dir.join("rec2.timestamps.npy")).map_err(|e| e.to_string())?;
    if b[b.len() - 8..] != 0.011f64.to_le_bytes() || ctx.dir.join("rec2.npy").exists() {
        return Err("rec2 files were written".into());
    }
    Ok(())
}
