//! Round 12: hostile input to the Python package, streamed inputs and
//! device replies; the classes the command line shares.
//!
//! - A whole number of a control line names its rule's range, whatever
//!   number came: `{"repeat":-1}` said "expected a whole number from 0 to
//!   4294967295" (its Rust type's range, not 1..=10000), `2.5` and
//!   `1e21` "invalid type: floating point", while `0` and `10001` named
//!   the rule. Python's `Session.present(repeat=2**70)` named the range of
//!   an i64 it was checked against on the way.
//! - A port name longer than any (a device path's `PATH_MAX`) is refused
//!   when the port is read, naming its length: a `--port` (or
//!   `$LMHOST_PORT`) of 40 000 characters with spaces in it was echoed
//!   whole by "opening serial port …" and "connecting to …" (40 kB on one
//!   line; no cut of long words catches a value with spaces).
//!
//! The Python classes (a name or path of the wrong kind made text with
//! `str()`, an empty path taken as the working directory) are in
//! `python/tests/test_hostile_r12.py`: the command line has no such
//! values.

use super::*;

/// `session --control -` fed `lines`, ended by its input.
fn session(lines: &str) -> Case {
    case(
        R12_CONTROL_WHOLE,
        "session --library {scenes}/../studies/paper-library.toml --port autd3:emulator --control -",
    )
    .stdin(lines)
    .ok()
}

/// A `present` of the library's first entry with `field` as given.
fn present(field: &str) -> String {
    format!("{{\"cmd\":\"present\",\"stimulus\":\"lms-5hz-a2\",\"on_s\":0.5,{field}}}\n")
}

pub(crate) fn round12_cases() -> Vec<Case> {
    let rule = "allowed 1..=10000";
    let mut v = Vec::new();
    for (field, said) in [
        ("\"repeat\":-1", "repeat -1 is out of range"),
        ("\"repeat\":0", "repeat 0 is out of range"),
        ("\"repeat\":10001", "repeat 10001 is out of range"),
        ("\"repeat\":4294967296", "repeat 4294967296 is out of range"),
        (
            "\"repeat\":1180591620717411303424",
            "repeat 1.18059e21 is out of range",
        ),
        ("\"repeat\":2.5", "repeat 2.5 is not a whole number"),
        ("\"repeat\":\"3\"", "`repeat` is a string, not a number"),
    ] {
        v.push(
            session(&present(field))
                .out(&format!("{said}: {rule}\""))
                // Refused: nothing was presented.
                .check(nothing_presented),
        );
    }
    // The rule's own values still play.
    v.push(
        session(
            &(present("\"repeat\":2,\"off_s\":0.1,\"gate\":\"untracked\"")
                + "{\"cmd\":\"stop\"}\n"),
        )
        .out("{\"cmd\":\"present\",\"ok\":true}"),
    );
    let long = "a b ".repeat(10_000);
    let tcp = format!("tcp:{}:80", "h".repeat(5000));
    for (args, env) in [
        (vec!["status", "--port", long.as_str()], None),
        (vec!["upload", "--port", tcp.as_str()], None),
        (vec!["status"], Some(long.as_str())),
    ] {
        let mut c = case(R12_PORT_LONG, "");
        c.args = args.into_iter().map(str::to_owned).collect();
        if let Some(e) = env {
            c = c.env("LMHOST_PORT", e);
        }
        v.push(
            c.err("bytes is longer than any port name (at most 4095)")
                .check(short_stderr),
        );
    }
    v
}

/// The error is short: the port was not echoed whole.
fn short_stderr(_: &Ctx, r: &Run) -> Result<(), String> {
    match r.stderr.len() {
        n if n < 400 => Ok(()),
        n => Err(format!("stderr has {n} bytes")),
    }
}

/// No `present` was accepted.
fn nothing_presented(_: &Ctx, r: &Run) -> Result<(), String> {
    match r.stdout.contains("{\"cmd\":\"present\",\"ok\":true") {
        true => Err("a present was accepted".into()),
        false => Ok(()),
    }
}
