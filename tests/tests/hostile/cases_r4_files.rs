//! Round 4, files (issues 30.4, 30.12, 30.16): where outputs land (a
//! symlink's target, a device node in place, a FIFO or a socket refused, a
//! file's mode kept, a broken hard link said), event logs that cannot
//! block, one reason per write error, fields named in number and TOML
//! errors, physically meaningless calibrations refused, and scenes
//! calibrated whatever form their table has.

use std::os::unix::fs::{FileTypeExt as _, PermissionsExt as _};

use super::*;

/// The files these cases write over or read.
pub(crate) fn round4_files_fixtures(dir: &Path) {
    let w = |name: &str, body: &[u8]| std::fs::write(dir.join(name), body).unwrap();
    let link =
        |target: &str, name: &str| std::os::unix::fs::symlink(target, dir.join(name)).unwrap();
    // Old contents that are whole JSON, as the other rounds' checks want.
    w("r4_target.json", b"\"old\"");
    link("r4_target.json", "r4_link.json");
    link("r4_made.json", "r4_dangling.json");
    w("r4_private.json", b"\"old\"");
    std::fs::set_permissions(
        dir.join("r4_private.json"),
        std::fs::Permissions::from_mode(0o600),
    )
    .unwrap();
    w("r4_hard_a.json", b"\"old\"");
    std::fs::hard_link(dir.join("r4_hard_a.json"), dir.join("r4_hard_b.json")).unwrap();
    let st = Command::new("mkfifo").arg(dir.join("r4_fifo")).status();
    assert!(st.is_ok_and(|s| s.success()), "mkfifo");
    // A socket file stays after its listener is gone.
    drop(std::os::unix::net::UnixListener::bind(dir.join("r4_sock")).unwrap());
    let paper =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/paper.toml"))
            .unwrap();
    w("r4_scene.toml", paper.as_bytes());
    link("r4_scene.toml", "r4_scene_link.toml");
    w(
        "r4_dotted.toml",
        format!("calibration.pressure_scale = 2.0\n{paper}").as_bytes(),
    );
    w(
        "r4_inline.toml",
        format!("calibration = {{ pressure_scale = 2.0 }}\n{paper}").as_bytes(),
    );
    let dev = "[[device]]\ncenter_mm = [0, 0, 0]\n";
    w(
        "r4_bad_array.toml",
        format!("{dev}[[device]]\ncenter_mm = [0,\n  \"x\", 0]\n").as_bytes(),
    );
    w(
        "r4_tiny_scale.toml",
        format!("{dev}[calibration]\npressure_scale = 1e-300\n").as_bytes(),
    );
}

fn read(ctx: &Ctx, name: &str) -> Result<Vec<u8>, String> {
    std::fs::read(ctx.dir.join(name)).map_err(|e| format!("{name}: {e}"))
}

fn is_link(ctx: &Ctx, name: &str) -> Result<(), String> {
    let m = std::fs::symlink_metadata(ctx.dir.join(name)).map_err(|e| e.to_string())?;
    if m.file_type().is_symlink() {
        Ok(())
    } else {
        Err(format!("{name} is no longer a symlink"))
    }
}

/// `name` holds the plan (a JSON object), not the old contents.
fn plan(ctx: &Ctx, name: &str) -> Result<(), String> {
    if read(ctx, name)?.starts_with(b"{") {
        Ok(())
    } else {
        Err(format!("{name} is not the plan"))
    }
}

fn link_target_written(ctx: &Ctx, _: &Run) -> Result<(), String> {
    is_link(ctx, "r4_link.json")?;
    plan(ctx, "r4_target.json")
}

fn dangling_target_made(ctx: &Ctx, _: &Run) -> Result<(), String> {
    is_link(ctx, "r4_dangling.json")?;
    plan(ctx, "r4_made.json")
}

fn mode_kept(ctx: &Ctx, _: &Run) -> Result<(), String> {
    plan(ctx, "r4_private.json")?;
    let m = std::fs::metadata(ctx.dir.join("r4_private.json")).map_err(|e| e.to_string())?;
    match m.permissions().mode() & 0o777 {
        0o600 => Ok(()),
        other => Err(format!("mode {other:o}, want 600")),
    }
}

fn other_name_kept(ctx: &Ctx, _: &Run) -> Result<(), String> {
    plan(ctx, "r4_hard_a.json")?;
    match read(ctx, "r4_hard_b.json")?.as_slice() {
        b"\"old\"" => Ok(()),
        _ => Err("the other name changed".into()),
    }
}

fn still_char_device(path: &str) -> Result<(), String> {
    let m = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if m.file_type().is_char_device() {
        Ok(())
    } else {
        Err(format!("{path} is no longer a character device"))
    }
}

fn dev_null_kept(_: &Ctx, _: &Run) -> Result<(), String> {
    still_char_device("/dev/null")
}

fn dev_full_kept(_: &Ctx, _: &Run) -> Result<(), String> {
    still_char_device("/dev/full")
}

fn fifo_and_socket_kept(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let t = |n: &str| std::fs::metadata(ctx.dir.join(n)).map(|m| m.file_type());
    match (t("r4_fifo"), t("r4_sock")) {
        (Ok(f), Ok(s)) if f.is_fifo() && s.is_socket() => Ok(()),
        _ => Err("the FIFO or the socket was replaced".into()),
    }
}

/// The OS's wording never follows lmhost's: the reason is said once
/// (which folder is missing, r16a-7, or that no such file is there).
fn reason_once(_: &Ctx, r: &Run) -> Result<(), String> {
    let said =
        r.stderr.matches("no such file").count() + r.stderr.matches("does not exist").count();
    if r.stderr.contains("os error") || said != 1 {
        return Err(format!("reason not said exactly once: {}", r.stderr));
    }
    Ok(())
}

fn scene_behind_link_calibrated(ctx: &Ctx, _: &Run) -> Result<(), String> {
    is_link(ctx, "r4_scene_link.toml")?;
    let text = String::from_utf8_lossy(&read(ctx, "r4_scene.toml")?).into_owned();
    if text.contains("[calibration]") && text.contains("measured_n = 0.022") {
        Ok(())
    } else {
        Err("the scene behind the link was not calibrated".into())
    }
}

fn one_calibration_table(name: &'static str) -> impl Fn(&Ctx) -> Result<(), String> {
    move |ctx| {
        let text = String::from_utf8_lossy(&read(ctx, name)?).into_owned();
        let tables = text.matches("[calibration]").count();
        if tables == 1 && !text.contains("pressure_scale = 2.0") {
            Ok(())
        } else {
            Err(format!(
                "{name}: {tables} [calibration] tables, or the old scale left"
            ))
        }
    }
}

fn dotted_replaced(ctx: &Ctx, _: &Run) -> Result<(), String> {
    one_calibration_table("r4_dotted_out.toml")(ctx)
}

fn inline_replaced(ctx: &Ctx, _: &Run) -> Result<(), String> {
    one_calibration_table("r4_inline.toml")(ctx)
}

/// Round 4's file classes.
pub(crate) fn round4_files_cases() -> Vec<Case> {
    table! {
        // 30.4: the destination is looked at first.
        OUT_DEST "plan --out {dir}/r4_link.json" .ok().check(link_target_written);
        OUT_DEST "plan --out {dir}/r4_dangling.json" .ok().check(dangling_target_made);
        OUT_DEST "plan --out {dir}/r4_private.json" .ok().check(mode_kept);
        OUT_DEST "plan --out {dir}/r4_hard_a.json" .ok().err("hard links").check(other_name_kept);
        OUT_DEST "plan --out /dev/null" .ok().check(dev_null_kept);
        OUT_DEST "plan --json --out /dev/null" .ok().check(dev_null_kept);
        OUT_DEST "plan --out /dev/full" .code(1).err("/dev/full: no space left on device")
                 .check(dev_full_kept);
        OUT_DEST "plan --out {dir}/r4_fifo" .code(1).err("r4_fifo").err("no reader")
                 .check(fifo_and_socket_kept);
        OUT_DEST "plan --out {dir}/r4_sock" .err("r4_sock").err("socket")
                 .check(fifo_and_socket_kept);
        OUT_DEST "simulate --plane-size 2 --plane-step 1 --out {dir}/r4_fifo" .code(1)
                 .err("r4_fifo");
        // ... and an event log never blocks on a FIFO nobody reads.
        EVENT_LOGS "session --library {scenes}/../studies/paper-library.toml --port {port} --control - --events {dir}/r4_fifo"
                   .code(1).err("r4_fifo").err("no reader").check(fifo_and_socket_kept);
        EVENT_LOGS "session --library {scenes}/../studies/paper-library.toml --port {port} --control - --events {dir}/r4_sock"
                   .err("socket").check(fifo_and_socket_kept);
        // 30.16: a write error's reason once; fields named; numbers sane.
        MESSAGES "plan --out {dir}/r4_no_dir/p.npy" .code(1).err("r4_no_dir/p.npy")
                 .check(reason_once);
        MESSAGES "plan --freq 1e400" .err("--freq");
        MESSAGES "plan --radius=-1e400" .err("--radius");
        MESSAGES "plan --scene {dir}/r4_bad_array.toml" .err("line 5, field `device[1].center_mm`");
        MESSAGES "plan --scene {dir}/r4_tiny_scale.toml" .err("calibration.pressure_scale")
                 .err("1e-300");
        // 30.12: physically meaningless calibrations are refused.
        MESSAGES "calibrate force --scene {scenes}/paper.toml --measured 1e-300"
                 .err("--measured").err("0.0001..=100 N").err("1e-300");
        MESSAGES "calibrate force --scene {scenes}/paper.toml --measured 1e300" .err("1e300");
        MESSAGES "simulate --calibration 1e-300 --plane-size 2 --plane-step 1 --out {dir}/r4_cal"
                 .err("--calibration");
        // 30.16, 30.4: a scene is calibrated whatever its table's form,
        // and through a symlink the scene itself.
        SCENE_EDITS "calibrate force --scene {dir}/r4_scene_link.toml --measured 0.022 --write"
                    .ok().check(scene_behind_link_calibrated);
        SCENE_EDITS "calibrate force --scene {dir}/r4_dotted.toml --measured 0.022 --out {dir}/r4_dotted_out.toml"
                    .ok().check(dotted_replaced);
        SCENE_EDITS "calibrate force --scene {dir}/r4_inline.toml --measured 0.022 --write"
                    .ok().check(inline_replaced);
    }
}
