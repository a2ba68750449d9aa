//! `lmhost study run` answered on standard input: lines bounded, read one
//! at a time as each question is asked, checked as they come.

use std::process::Stdio;

mod link_support;
#[allow(dead_code)]
mod study_support;
use study_support::*;

/// Answers piped on stdin (no `--responses`, not a terminal) are lines of
/// at most 4096 bytes: a longer one ends the run as bad input, read no
/// further, the array silent and the session resumable.
#[test]
fn stdin_answers_are_bounded_lines() {
    use std::io::Read;
    let d = scratch("stdin");
    // 64 MiB without a line break: never held whole.
    let o = with_stdin(
        &mut exp1("autd3:emulator", &d.join("out"), "0.02", &["--seed", "1"]),
        std::io::repeat(b'7').take(64 << 20),
    );
    ended_as_bad_input(
        &o,
        &[
            "stdin line 1: a line longer than 4096 bytes",
            "the array is silent",
            "--resume",
        ],
    );
}

/// `--responses -`: each answer is read as its question is asked (a GUI or
/// a button box answering while trials run), `na` included; a run that
/// read stdin to its end first would wait forever here (the watchdog ends
/// it and the test fails).
#[test]
fn responses_from_stdin_are_read_one_at_a_time_as_asked() {
    use std::io::{BufRead, BufReader, Write};
    let d = scratch("live");
    let out = d.join("out");
    let mut child = exp1(
        "autd3:emulator",
        &out,
        "0.02",
        &["--responses", "-", "--seed", "3"],
    )
    .stdin(Stdio::piped())
    .stdout(Stdio::null())
    .stderr(Stdio::piped())
    .spawn()
    .unwrap();
    let watchdog = Watchdog::start(&child);
    let mut stdin = child.stdin.take().unwrap();
    let mut given = Vec::new();
    let mut log = Vec::new();
    for line in BufReader::new(child.stderr.take().unwrap()).lines() {
        let line = line.unwrap();
        if !line.starts_with(' ') && line.ends_with(']') && line.contains("[1 = ") {
            assert!(
                line.contains("[na = could not perceive the stimulus]"),
                "{line}"
            );
            let a = if given.len() % 11 == 3 {
                "na".to_owned()
            } else {
                (given.len() % 7 + 1).to_string()
            };
            writeln!(stdin, "{a}").unwrap();
            given.push(a);
        }
        log.push(line);
    }
    drop(stdin);
    let status = child.wait().unwrap();
    watchdog.stop();
    assert!(status.success(), "{status}: {}", log.join("\n"));
    assert_eq!(given.len(), 150, "one line per question asked");
    check_exp1(&rows(&out.join("P01")), &given);
}

/// `--responses -` lines are checked as they come: a bad one or stdin's
/// end ends the run as bad input, the array silent and the session
/// resumable.
#[test]
fn responses_from_stdin_are_checked_as_they_come() {
    let d = scratch("live-bad");
    for (id, input, want) in [
        (
            "B1",
            "1\n9\n",
            "--responses - line 2: `9` is not an answer to `movement`",
        ),
        (
            "B2",
            "na\n",
            "--responses - ended: an answer to `movement` is needed",
        ),
        // A lone CR ends an answer as LF does (it was refused as a
        // carriage return inside line 1).
        (
            "B3",
            "1\r9\r",
            "--responses - line 2: `9` is not an answer to `movement`",
        ),
        (
            "B4",
            "na\r\n",
            "--responses - ended: an answer to `movement` is needed",
        ),
    ] {
        let o = with_stdin(
            &mut exp1("autd3:emulator", &d.join(id), "0.02", &["--responses", "-"]),
            std::io::Cursor::new(input),
        );
        ended_as_bad_input(&o, &[want, "the array is silent", "--resume"]);
    }
}

/// Answers on stdin are text as every file is: a byte-order mark opening
/// them (PowerShell piping UTF-8 with one) is skipped, UTF-16 (PowerShell
/// 5) is named with what to do, not "a line that is not UTF-8 text".
#[test]
fn stdin_answers_are_read_whatever_wrote_them() {
    let d = scratch("stdin_text");
    let wide: Vec<u8> = "\u{feff}1\n2\n"
        .encode_utf16()
        .flat_map(u16::to_le_bytes)
        .collect();
    for (input, want) in [
        (
            wide,
            "stdin line 1: the line is UTF-16 (little-endian) text, not UTF-8",
        ),
        (
            b"\xef\xbb\xbfx\r\n".to_vec(),
            "stdin line 1: `x` is not an answer",
        ),
    ] {
        let o = with_stdin(
            &mut exp1("autd3:emulator", &d.join("out"), "0.02", &["--seed", "1"]),
            std::io::Cursor::new(input),
        );
        ended_as_bad_input(&o, &[want, "--resume"]);
        std::fs::remove_dir_all(d.join("out")).unwrap();
    }
}
