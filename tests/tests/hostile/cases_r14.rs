//! Round 14: classes no earlier round had.
//!
//! - r14-1: the outputs of one run never share a path, a folder a run
//!   writes into among them. `track --record R.npy --plot R.npy` made the
//!   plot folder at the recording's path, tracked the whole run, then
//!   failed (exit 1, "cannot write R.npy: it is a directory") and left
//!   the recording's intrinsics and time stamps beside no recording;
//!   `session --events P --control P` made the event log, then refused
//!   its own log as a socket path that "exists and is not a socket" (and
//!   `--events` at the TCP token file's path was not checked at all).
//!   Every output of a run, the files beside a recording, the control
//!   socket and its token file included, is now checked against every
//!   other before any is made.
//! - r14-2: a port name of a form no port has is refused as such, not
//!   opened: `--port " /dev/ttyACM0"` or a name with its line end (and the
//!   same in `$LMHOST_PORT`, a stage's or a gauge's port) was opened as it
//!   was and failed as "no such file or directory" (exit 1, the space or
//!   line break unseen in the message); `stage --port "sim "` asked for a
//!   real stage's limits; `gauge --port ""` said ": no such file or
//!   directory"; a `$LMHOST_PORT` that is not UTF-8 was taken for an
//!   unset one, and discovery picked whatever board it found.
//!
//! Fixtures in `{dir}/r14`.

use super::*;

pub(crate) fn round14_fixtures(dir: &Path) {
    std::fs::create_dir_all(dir.join("r14")).unwrap();
}

/// Nothing of the refused run is left in `{dir}/r14` (the folder was made
/// empty by the fixtures and every case here is refused).
fn nothing_made(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let left: Vec<String> = std::fs::read_dir(ctx.dir.join("r14"))
        .map_err(|e| e.to_string())?
        .filter_map(Result::ok)
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    match left.is_empty() {
        true => Ok(()),
        false => Err(format!("left in r14: {left:?}")),
    }
}

/// A `$LMHOST_PORT` that is not UTF-8 is refused, naming the variable.
fn env_not_utf8(_: &Ctx, _: &Run) -> Result<(), String> {
    use std::os::unix::ffi::OsStrExt as _;
    let out = Command::new(lmhost())
        .arg("status")
        .env("LMHOST_PORT", std::ffi::OsStr::from_bytes(b"/dev/tty\xff"))
        .output()
        .map_err(|e| e.to_string())?;
    let err = String::from_utf8_lossy(&out.stderr);
    let want = "error: $LMHOST_PORT `/dev/tty\u{fffd}` is not UTF-8: give a port name in UTF-8, or unset it\n";
    match (out.status.code(), err == want) {
        (Some(2), true) => Ok(()),
        (code, _) => Err(format!("non-UTF-8 $LMHOST_PORT: exit {code:?}, {err}")),
    }
}

/// `case(class, args)` with `more` appended as single arguments (values
/// with spaces or control characters).
fn with(class: &'static str, args: &str, more: &[&str]) -> Case {
    let mut c = case(class, args);
    c.args.extend(more.iter().map(|s| (*s).to_owned()));
    c
}

pub(crate) fn round14_cases() -> Vec<Case> {
    let session = "session --library {scenes}/../studies/paper-library.toml --port autd3:emulator --synthetic";
    let mut v = table! {
        R14_OUTPUTS "track --synthetic --fast --seconds 0.2 --record {dir}/r14/rec.npy --plot {dir}/r14/rec.npy"
            .err("error: --plot {dir}/r14/rec.npy and --record {dir}/r14/rec.npy are the same path; give each output its own")
            .check(nothing_made);
        R14_OUTPUTS "track --synthetic --fast --seconds 0.2 --record {dir}/r14/b.npy --plot {dir}/r14/./b.timestamps.npy"
            .err("error: --plot {dir}/r14/./b.timestamps.npy and --record's time stamps {dir}/r14/b.timestamps.npy are the same path; give each output its own")
            .check(nothing_made);
    };
    v.extend([
        case(
            R14_OUTPUTS,
            &format!("{session} --control {{dir}}/r14/ctl.sock --events {{dir}}/r14/ctl.sock"),
        )
        .err("error: --events {dir}/r14/ctl.sock and --control {dir}/r14/ctl.sock are the same path; give each output its own")
        .check(nothing_made),
        case(
            R14_OUTPUTS,
            &format!(
                "{session} --control {{dir}}/r14/c.sock --tcp {{tcp}} --events {{dir}}/r14/c.sock.token"
            ),
        )
        .err("error: --events {dir}/r14/c.sock.token and the TCP token file {dir}/r14/c.sock.token are the same path; give each output its own")
        .check(nothing_made),
    ]);
    let spaces = "has spaces at an end: give the port's name without them";
    let control = "holds a line break or control character: give the port's name alone";
    v.extend([
        with(R14_PORT_FORM, "status --port", &[" {port}"])
            .err(&format!("error: --port ` {{port}}` {spaces}"))
            .check(env_not_utf8),
        with(R14_PORT_FORM, "upload --hold 0.1 --port", &["{port}\n"])
            .err(&format!("error: --port `{{port}}\\n` {control}")),
        with(R14_PORT_FORM, "info --port", &["autd3:emulator "])
            .err(&format!("error: --port `autd3:emulator ` {spaces}")),
        case(R14_PORT_FORM, "status")
            .env("LMHOST_PORT", "{port} ")
            .err(&format!("error: $LMHOST_PORT `{{port}} ` {spaces}")),
        with(R14_PORT_FORM, "stage position --port", &["sim "])
            .err(&format!("error: stage `sim ` {spaces}")),
        with(R14_PORT_FORM, "gauge read --port", &[" sim"])
            .err(&format!("error: gauge ` sim` {spaces}")),
        with(R14_PORT_FORM, "gauge read --port", &[""])
            .err("error: gauge: give sim or a serial port, not an empty name"),
        with(
            R14_PORT_FORM,
            "study run {scenes}/../studies/paper-exp3.toml --port autd3:emulator \
             --out {dir}/r14/study --participant P1 --finger synthetic --stage sim --gauge",
            &["sim\t"],
        )
        .err(&format!("error: gauge `sim\\t` {control}"))
        .check(nothing_made),
    ]);
    v
}
