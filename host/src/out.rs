//! The one path to standard output and standard error.
//!
//! Every line lmhost prints goes through [`outln!`](crate::outln) /
//! [`out!`](macro@crate::out) (stdout) or [`errln!`](crate::errln) (stderr);
//! `print!`-style macros, which panic on a write error, are not used
//! (clippy's `print_stdout` and `print_stderr` are denied).
//!
//! - stdout closed by its reader (`| head`): [`StdoutClosed`], which `main`
//!   turns into a quiet exit 0;
//! - any other stdout error (`> /dev/full`): [`StdoutError`], one line and
//!   exit 1;
//! - a stderr error: ignored (there is nowhere left to say it); the exit
//!   code says what happened.

use std::io::Write as _;

pub use crate::error::StdoutClosed;

/// Writing to standard output failed for a reason other than a closed
/// pipe.
#[derive(Debug, thiserror::Error)]
#[error("cannot write to standard output: {}", crate::files::reason(.0))]
pub struct StdoutError(pub std::io::Error);

/// Maps a stdout write result: broken pipe → [`StdoutClosed`], other
/// errors → [`StdoutError`].
pub fn stdout_result(r: std::io::Result<()>) -> anyhow::Result<()> {
    match r {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Err(StdoutClosed.into()),
        Err(e) => Err(StdoutError(e).into()),
    }
}

/// Writes `args` to stdout (line-buffered: a full line is written at once).
/// On a terminal, what a terminal would act on (a scene's name, a path
/// or a prompt holding an escape sequence) is shown escaped
/// ([`for_stdout`]), as `ls` shows such file names; into a pipe or a file
/// the text is kept byte for byte.
pub fn stdout_fmt(args: std::fmt::Arguments<'_>) -> anyhow::Result<()> {
    use std::io::IsTerminal as _;
    static TERMINAL: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let terminal = *TERMINAL.get_or_init(|| std::io::stdout().is_terminal());
    let mut out = std::io::stdout().lock();
    if terminal {
        stdout_result(out.write_all(for_stdout(&args.to_string(), true).as_bytes()))
    } else {
        stdout_result(out.write_fmt(args))
    }
}

/// `text` as stdout shows it: kept as it is unless `terminal`; on a
/// terminal, JSON (the whole text, else each line that is JSON) with its
/// hidden characters as JSON escapes ([`json_visible`]), so it stays JSON
/// a program can read, and other text through [`visible`].
pub fn for_stdout(text: &str, terminal: bool) -> std::borrow::Cow<'_, str> {
    use std::borrow::Cow;
    if !terminal || !text.chars().any(hidden) {
        return Cow::Borrowed(text);
    }
    if is_json(text) {
        return Cow::Owned(json_visible(text));
    }
    Cow::Owned(
        text.split_inclusive('\n')
            .map(|line| {
                if is_json(line) {
                    json_visible(line)
                } else {
                    visible(line)
                }
            })
            .collect(),
    )
}

/// Whether `text` is one JSON value (white space around it allowed).
fn is_json(text: &str) -> bool {
    serde_json::from_str::<serde::de::IgnoredAny>(text).is_ok()
}

/// JSON text `json` with every hidden character ([`visible`]'s) written
/// as a JSON escape, `\u202e` (a surrogate pair beyond the BMP): in JSON
/// they stand only inside strings, where the escape means the same
/// character. Tab, CR and LF are left as they are: in JSON text they can
/// only be the white space between values (serde_json escapes them in
/// strings).
pub fn json_visible(json: &str) -> String {
    let mut out = String::with_capacity(json.len() + 16);
    for c in json.chars() {
        if hidden(c) && !matches!(c, '\t' | '\r' | '\n') {
            out.push_str(&json_escape(c));
        } else {
            out.push(c);
        }
    }
    out
}

/// `c` as a JSON escape: `\u` and four hex digits per UTF-16 unit (a
/// surrogate pair beyond the BMP).
fn json_escape(c: char) -> String {
    c.encode_utf16(&mut [0; 2])
        .iter()
        .map(|unit| format!("\\u{unit:04x}"))
        .collect()
}

/// Flushes stdout (what `main` does last).
pub fn flush_stdout() -> anyhow::Result<()> {
    stdout_result(std::io::stdout().lock().flush())
}

/// Writes `args` to stderr, every number through
/// [`crate::limits::tidy_numbers`] and every overlong word through
/// [`shorten_long_words`]; a failure is ignored, never a panic.
pub fn stderr_fmt(args: std::fmt::Arguments<'_>) {
    let text = tidy(&args.to_string());
    let _ = std::io::stderr().lock().write_all(text.as_bytes());
}

/// `n` and the noun, plural unless `n` is 1 (`1 sample`, `2 samples`):
/// for nouns whose plural adds an `s`.
pub fn count(n: u64, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

/// `msg` as every message leaves lmhost (stderr, Python's exceptions):
/// numbers through [`crate::limits::tidy_numbers`], overlong words through
/// [`shorten_long_words`], Rust's type names through
/// [`crate::error::plain_types`], hidden characters through [`visible`].
pub fn tidy(msg: &str) -> String {
    let msg = crate::error::plain_types(msg);
    visible(&crate::limits::tidy_numbers(&shorten_long_words(&msg)))
}

/// `msg` with every character a terminal acts on instead of showing
/// written as its escape: control characters but the line end (`\r`,
/// `\t`, `\u{1b}`), and the ones that reorder or hide text
/// (bidirectional overrides and isolates, zero-width marks, line and
/// paragraph separators, the byte-order mark) as `\u{…}`. A message
/// echoes paths, ports and values as they were given; an escape sequence
/// in one would recolour the line, move the cursor or overwrite what the
/// message says.
pub fn visible(msg: &str) -> String {
    if !msg.chars().any(hidden) {
        return msg.to_owned();
    }
    let mut out = String::with_capacity(msg.len() + 16);
    for c in msg.chars() {
        match c {
            '\t' => out.push_str("\\t"),
            '\r' => out.push_str("\\r"),
            c if hidden(c) => out.push_str(&format!("\\u{{{:x}}}", c as u32)),
            c => out.push(c),
        }
    }
    out
}

/// Whether a terminal acts on `c` instead of showing it (see [`visible`]).
fn hidden(c: char) -> bool {
    (c.is_control() && c != '\n')
        || matches!(
            c,
            '\u{061c}'
                | '\u{200b}'..='\u{200f}'
                | '\u{2028}'..='\u{202e}'
                | '\u{2060}'..='\u{2069}'
                | '\u{feff}'
        )
}

/// `msg` with every word (a run without white space) longer than
/// [`crate::limits::MAX_MESSAGE_WORD_CHARS`] cut to its start and end
/// around its length: a flag value or path of 100 000 characters is
/// echoed by many messages (clap's, the OS's `File name too long`), and
/// an error is one readable line.
pub fn shorten_long_words(msg: &str) -> String {
    const HEAD: usize = 200;
    const TAIL: usize = 100;
    let max = crate::limits::MAX_MESSAGE_WORD_CHARS;
    let mut out = String::with_capacity(msg.len().min(4 * max));
    let mut word = String::new();
    let flush = |word: &mut String, out: &mut String| {
        let n = word.chars().count();
        if n > max {
            out.extend(word.chars().take(HEAD));
            out.push_str(&format!("…({n} characters)…"));
            out.extend(word.chars().skip(n - TAIL));
        } else {
            out.push_str(word);
        }
        word.clear();
    };
    for c in msg.chars() {
        if c.is_whitespace() {
            flush(&mut word, &mut out);
            out.push(c);
        } else {
            word.push(c);
        }
    }
    flush(&mut word, &mut out);
    out
}

/// `println!` that returns `anyhow::Result<()>` instead of panicking.
#[macro_export]
macro_rules! outln {
    () => {
        $crate::out::stdout_fmt(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::out::stdout_fmt(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// `print!` that returns `anyhow::Result<()>` instead of panicking.
#[macro_export]
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::out::stdout_fmt(format_args!($($arg)*))
    };
}

/// `eprintln!` that never panics (a lost stderr is ignored).
#[macro_export]
macro_rules! errln {
    () => {
        $crate::out::stderr_fmt(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::out::stderr_fmt(format_args!("{}\n", format_args!($($arg)*)))
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_closed_pipe_is_quiet_and_a_full_disk_is_an_error() {
        let e = stdout_result(Err(std::io::ErrorKind::BrokenPipe.into())).unwrap_err();
        assert!(e.is::<StdoutClosed>());
        let e = stdout_result(Err(std::io::Error::from_raw_os_error(libc::ENOSPC))).unwrap_err();
        assert!(e.is::<StdoutError>());
        assert_eq!(
            e.to_string(),
            "cannot write to standard output: no space left on device"
        );
        assert!(stdout_result(Ok(())).is_ok());
    }

    #[test]
    fn an_overlong_word_is_cut_around_its_length() {
        let long = "x".repeat(100_000);
        let msg = format!("error: cannot read scene file /tmp/{long}: File name too long\n");
        let short = shorten_long_words(&msg);
        assert!(short.len() < 500, "{}", short.len());
        assert!(
            short.starts_with("error: cannot read scene file /tmp/xxx"),
            "{short}"
        );
        assert!(short.contains("…(100006 characters)…"), "{short}");
        assert!(short.ends_with("xx: File name too long\n"), "{short}");
        // Words up to the limit, and every other character, are kept.
        let path = format!(
            "/tmp/{}",
            "é".repeat(crate::limits::MAX_MESSAGE_WORD_CHARS - 6)
        );
        let msg = format!("cannot write {path}:\tno\n");
        assert_eq!(shorten_long_words(&msg), msg);
    }

    #[test]
    fn what_a_terminal_would_act_on_is_shown_escaped() {
        assert_eq!(
            tidy("cannot read scene file a\u{1b}[31mred\rb\tc: gone\n"),
            "cannot read scene file a\\u{1b}[31mred\\rb\\tc: gone\n"
        );
        // Right-to-left override, zero-width space, line separator, BOM,
        // C1 control, DEL.
        assert_eq!(
            visible("x\u{202e}y\u{200b}z\u{2028}w\u{feff}v\u{85}u\u{7f}"),
            "x\\u{202e}y\\u{200b}z\\u{2028}w\\u{feff}v\\u{85}u\\u{7f}"
        );
        // Text, accents, symbols and the line end are kept as they are.
        let plain = "spacing 3 mm ≥ d_LM: étape 0.23 mm, 5 µs → 2πA\n";
        assert_eq!(visible(plain), plain);
    }

    #[test]
    fn json_on_a_terminal_stays_json_with_its_hidden_characters_escaped() {
        let obj = serde_json::json!({
            "name": "x\u{202e}y\u{200b}z\u{2028}w\u{feff}v\u{85}u\u{7f}",
            "ok": "µs → 2πA",
        });
        let line = format!("{obj}\n");
        let cases: [(&str, String, String); 6] = [
            (
                "a JSON line: JSON escapes, the line end kept",
                line.clone(),
                "{\"name\":\"x\\u202ey\\u200bz\\u2028w\\ufeffv\\u0085u\\u007f\",\"ok\":\"µs → 2πA\"}\n".into(),
            ),
            (
                "JSON lines (JSONL), each escaped",
                format!("{line}{line}"),
                format!(
                    "{0}{0}",
                    "{\"name\":\"x\\u202ey\\u200bz\\u2028w\\ufeffv\\u0085u\\u007f\",\"ok\":\"µs → 2πA\"}\n"
                ),
            ),
            (
                "text then a JSON line: each in its own form",
                "scene a\u{202e}b\n[\"a\u{202e}b\"]\n".into(),
                "scene a\\u{202e}b\n[\"a\\u202eb\"]\n".into(),
            ),
            (
                "pretty JSON over many lines, one value",
                "{\n  \"a\": \"\u{2066}x\u{9b}\"\n}\n".into(),
                "{\n  \"a\": \"\\u2066x\\u009b\"\n}\n".into(),
            ),
            (
                "plain text keeps the visible form",
                "cannot read x\u{202e}y\tz\n".into(),
                "cannot read x\\u{202e}y\\tz\n".into(),
            ),
            (
                "text that only looks like JSON",
                "{\"a\": \u{202e}}\n".into(),
                "{\"a\": \\u{202e}}\n".into(),
            ),
        ];
        for (name, text, want) in cases {
            assert_eq!(for_stdout(&text, true), want, "{name}");
            // Into a pipe or a file: byte for byte.
            assert_eq!(for_stdout(&text, false), text, "{name}");
        }
        // What a program reads back is the value printed.
        let shown = for_stdout(&line, true);
        let back: serde_json::Value = serde_json::from_str(&shown).unwrap();
        assert_eq!(back, obj);
        assert!(!shown.trim_end().chars().any(hidden), "{shown}");
        // Beyond the BMP an escape is a surrogate pair.
        assert_eq!(json_escape('\u{1f600}'), "\\ud83d\\ude00");
        assert_eq!(
            serde_json::from_str::<String>(&format!("\"{}\"", json_escape('\u{1f600}'))).unwrap(),
            "\u{1f600}"
        );
        // Nothing hidden: nothing changes, nothing copied.
        let plain = "{\"a\":1}\n";
        assert!(matches!(
            for_stdout(plain, true),
            std::borrow::Cow::Borrowed(_)
        ));
    }
}
