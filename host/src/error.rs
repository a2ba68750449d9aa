//! Error kinds that decide the exit code.
//!
//! `main` is the only place that maps errors to exit codes: an error chain
//! that contains an [`InputError`] exits 2 (bad input), any other error
//! exits 1 (the operation failed).

/// The user's input (a flag, a scene file, a tracker stream) is invalid.
///
/// The message is one line that says what was wrong and what is accepted.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct InputError(pub String);

impl InputError {
    /// An input error with the given message, made one line of bounded
    /// length whatever values it repeats ([`one_line_echo`]).
    pub fn new(msg: impl Into<String>) -> Self {
        Self(one_line_echo(msg.into()))
    }
}

/// Longest value (characters) an [`InputError`] repeats in quotes: a
/// key, a name or a label as the input gave it, whole when it is one a
/// person typed (a number is left to `limits::tidy_numbers`).
pub const MAX_ECHO_CHARS: usize = 100;
/// Characters of a cut echo kept before and after its length.
const ECHO_HEAD: usize = 60;
const ECHO_TAIL: usize = 20;

/// `msg` as one line, its echoes bounded: a line break inside it (a value
/// holding one, as a JSON or TOML escape gives it: an id, a key, a level)
/// written as its escape (`\n`, `\r`), not a second line or a blank the
/// value does not have; and a quoted value (in backquotes, as serde, the
/// toml crate and lmhost quote one, or in double quotes, serde's wrong
/// string; a backquote left open runs to the end) longer than
/// [`MAX_ECHO_CHARS`] cut around its length, so a pasted or generated
/// value of thousands of characters (with spaces, which no cut of long
/// words catches) is not repeated whole; a message still over 400
/// characters whose backquotes do not pair (a value holding one, which
/// closed its quote early) has every stretch between two backquotes cut
/// so.
pub fn one_line_echo(msg: String) -> String {
    let msg = if msg.contains(['\n', '\r']) {
        msg.replace('\r', "\\r").replace('\n', "\\n")
    } else {
        msg
    };
    if msg.chars().count() <= MAX_ECHO_CHARS {
        return msg;
    }
    let mut out = String::with_capacity(msg.len().min(4 * MAX_ECHO_CHARS));
    let mut rest = msg.as_str();
    while let Some(i) = rest.find(['`', '"']) {
        let q = rest.as_bytes()[i];
        out.push_str(&rest[..=i]);
        rest = &rest[i + 1..];
        // The closing quote (a double-quoted value's own `\"` does not
        // close it).
        let mut end = None;
        let mut escaped = false;
        for (j, c) in rest.char_indices() {
            match c {
                '\\' if q == b'"' && !escaped => escaped = true,
                c if c as u32 == u32::from(q) && !escaped => {
                    end = Some(j);
                    break;
                }
                _ => escaped = false,
            }
        }
        // An unclosed backquote runs to the end: the value, cut short
        // before it closed (a first line of several), is the rest. A lone
        // double quote is a character of the text (a path's).
        let j = match end {
            Some(j) => j,
            None if q == b'`' => rest.len(),
            None => break,
        };
        let inner = &rest[..j];
        let n = inner.chars().count();
        // A number is left whole for the one shortening of numbers
        // (`limits::tidy_numbers`, as every message is shown), which a cut
        // through its digits would defeat.
        match n > MAX_ECHO_CHARS && !is_number(inner) {
            true => cut(inner, n, &mut out),
            false => out.push_str(inner),
        }
        if end.is_none() {
            rest = "";
            break;
        }
        out.push(char::from(q));
        rest = &rest[j + 1..];
    }
    out.push_str(rest);
    let odd = out.matches('`').count() % 2 == 1;
    if !odd || out.chars().count() <= MAX_MESSAGE_CHARS {
        return out;
    }
    // Still long, its backquotes unpaired: a value holding a backquote of
    // its own closed its quote early, its rest read as the message's
    // text. Every stretch between two backquotes is then cut like a value
    // (the message's own words between its quotes are short).
    let mut cut_out = String::with_capacity(out.len().min(4 * MAX_MESSAGE_CHARS));
    for (k, part) in out.split('`').enumerate() {
        if k > 0 {
            cut_out.push('`');
        }
        let n = part.chars().count();
        match n > MAX_ECHO_CHARS && !is_number(part) {
            true => cut(part, n, &mut cut_out),
            false => cut_out.push_str(part),
        }
    }
    cut_out
}

/// Longest message [`one_line_echo`] leaves as it is once its quoted
/// values are cut (characters).
const MAX_MESSAGE_CHARS: usize = 400;

/// Whether `s` is a number as a message writes one.
fn is_number(s: &str) -> bool {
    s.bytes()
        .all(|b| b.is_ascii_digit() || b"+-.eE".contains(&b))
}

/// The refusal of environment variable `var` whose value `raw` is not
/// UTF-8, saying what to `give`: named, where a flag's parser said only
/// "invalid UTF-8 was detected in one or more arguments".
pub fn env_not_utf8(var: &str, raw: &std::ffi::OsStr, give: &str) -> InputError {
    InputError::new(format!(
        "${var} `{}` is not UTF-8: give {give} in UTF-8, or unset it",
        short_echo(&raw.to_string_lossy())
    ))
}

/// `s` as an [`InputError`] echoes a quoted value: cut around its length
/// when longer than [`MAX_ECHO_CHARS`]. For a value whose own backquotes
/// would split its echo into pieces each short enough to stay whole.
pub fn short_echo(s: &str) -> String {
    let n = s.chars().count();
    let mut out = String::new();
    match n > MAX_ECHO_CHARS {
        true => cut(s, n, &mut out),
        false => out.push_str(s),
    }
    out
}

/// `s` (of `n` characters) cut around its length, as a long word on
/// stderr is.
fn cut(s: &str, n: usize, out: &mut String) {
    out.extend(s.chars().take(ECHO_HEAD));
    out.push_str(&format!("…({n} characters)…"));
    out.extend(s.chars().skip(n - ECHO_TAIL));
}

/// The value `name` stands for among `choices` (name, value), or one line
/// naming them all: "`{name}` is not {what}: give a, b or c" (`what` with
/// its article, "a shape"). The names are matched exactly.
pub fn choose<T: Copy>(what: &str, name: &str, choices: &[(&str, T)]) -> Result<T, String> {
    find(what, name, choices, |a, b| a == b)
}

/// [`choose`], the names matched in any ASCII case.
pub fn choose_any_case<T: Copy>(
    what: &str,
    name: &str,
    choices: &[(&str, T)],
) -> Result<T, String> {
    find(what, name, choices, str::eq_ignore_ascii_case)
}

fn find<T: Copy>(
    what: &str,
    name: &str,
    choices: &[(&str, T)],
    same: impl Fn(&str, &str) -> bool,
) -> Result<T, String> {
    if let Some((_, v)) = choices.iter().find(|(n, _)| same(n, name)) {
        return Ok(*v);
    }
    let names: Vec<&str> = choices.iter().map(|(n, _)| *n).collect();
    let list = match names.split_last() {
        Some((last, [])) => (*last).to_owned(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        None => "nothing".to_owned(),
    };
    Err(format!("`{name}` is not {what}: give {list}"))
}

/// Most items a message lists ([`some_of`]).
pub const MAX_LISTED: usize = 8;

/// `items` for a message, joined with `sep`: the first [`MAX_LISTED`],
/// then how many more there are (`a, b, c, … and 192 more`). A message
/// naming what a file, a folder or a system holds (every level of a
/// factor, every folder skipped, every serial port) stays one readable
/// line however much it holds.
pub fn some_of<S: std::fmt::Display>(items: impl IntoIterator<Item = S>, sep: &str) -> String {
    let mut out = String::new();
    let mut more = 0usize;
    for (i, item) in items.into_iter().enumerate() {
        if i >= MAX_LISTED {
            more += 1;
            continue;
        }
        if i > 0 {
            out.push_str(sep);
        }
        out.push_str(&item.to_string());
    }
    if more > 0 {
        out.push_str(&format!("{sep}… and {more} more"));
    }
    out
}

/// An error chain as one line: the messages joined with ": ", a cause
/// said once even when its parent's text already includes it.
pub fn one_line(err: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in err.chain() {
        let text = cause.to_string().replace('\n', " ");
        if line.ends_with(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

/// Rust's type names, as serde and the toml crate end a message with
/// them (`expected u32`), in the words of someone who writes the file:
/// what each type holds.
const TYPE_WORDS: [(&str, &str); 15] = [
    ("u8", "a whole number from 0 to 255"),
    ("u16", "a whole number from 0 to 65535"),
    ("u32", "a whole number from 0 to 4294967295"),
    ("u64", "a whole number ≥ 0"),
    ("u128", "a whole number ≥ 0"),
    ("usize", "a whole number ≥ 0"),
    ("i8", "a whole number from -128 to 127"),
    ("i16", "a whole number from -32768 to 32767"),
    ("i32", "a whole number"),
    ("i64", "a whole number"),
    ("i128", "a whole number"),
    ("isize", "a whole number"),
    ("f32", "a number"),
    ("f64", "a number"),
    ("bool", "true or false"),
];

/// `msg` with serde's words for a value of the wrong type in plain ones:
/// `expected usize` says `expected a whole number ≥ 0`, `expected f64`
/// `expected a number`, and the toml crate's `` `1e20` as i128 `` drops
/// its ` as i128`. A scene, a library, a protocol or a control line is
/// written by a researcher, who should not need Rust's names for
/// numbers. Only a whole word after `expected ` (or `as `) is replaced;
/// the rest of the message is left as it is.
pub fn plain_types(msg: &str) -> std::borrow::Cow<'_, str> {
    if !msg.contains("expected ") && !msg.contains("` as ") {
        return msg.into();
    }
    let mut out = String::with_capacity(msg.len() + 32);
    let mut rest = msg;
    while let Some(i) = rest.find(['e', '`']) {
        out.push_str(&rest[..i]);
        rest = &rest[i..];
        let word_start = out
            .chars()
            .next_back()
            .is_none_or(|c| !c.is_alphanumeric() && c != '_');
        let (lead, replace) = if word_start && rest.starts_with("expected ") {
            ("expected ", true)
        } else if rest.starts_with("` as ") {
            ("` as ", false)
        } else {
            let c = rest.chars().next().unwrap_or_default();
            out.push(c);
            rest = &rest[c.len_utf8()..];
            continue;
        };
        let after = &rest[lead.len()..];
        let end = after
            .find(|c: char| !c.is_alphanumeric() && c != '_')
            .unwrap_or(after.len());
        match TYPE_WORDS.iter().find(|(t, _)| *t == &after[..end]) {
            Some((_, words)) if replace => {
                out.push_str(lead);
                out.push_str(words);
            }
            // `1e20` as i128: the quoted value alone.
            Some(_) => out.push('`'),
            None => out.push_str(&rest[..lead.len() + end]),
        }
        rest = &after[end..];
    }
    out.push_str(rest);
    out.into()
}

/// Return early with an [`InputError`] built from a format string.
#[macro_export]
macro_rules! bad_input {
    ($($arg:tt)*) => {
        return Err($crate::error::InputError::new(format!($($arg)*)).into())
    };
}

/// Standard output was closed by the reader (`lmhost … | head`): `main`
/// ends quietly with exit 0. Only output to stdout maps to it; a closed
/// socket to the device stays a failed operation.
#[derive(Debug, thiserror::Error)]
#[error("standard output closed")]
pub struct StdoutClosed;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_list_in_a_message_names_a_few_and_counts_the_rest() {
        assert_eq!(some_of(["a", "b"], ", "), "a, b");
        assert_eq!(some_of(Vec::<String>::new(), ", "), "");
        let many: Vec<String> = (1..=200).map(|i| format!("l{i}")).collect();
        assert_eq!(
            some_of(&many, ", "),
            "l1, l2, l3, l4, l5, l6, l7, l8, … and 192 more"
        );
        assert_eq!(
            some_of(&many[..9], "; "),
            "l1; l2; l3; l4; l5; l6; l7; l8; … and 1 more"
        );
    }

    #[test]
    fn an_input_error_is_one_line_whatever_value_it_repeats() {
        // A value holding a line break (a JSON or TOML escape) is shown
        // escaped, on the line.
        let e = InputError::new("stimulus 2 (`a\nb\r\n`): bad").to_string();
        assert_eq!(e, "stimulus 2 (`a\\nb\\r\\n`): bad");
        // A long quoted value is cut, saying its length; the rest of the
        // message stays whole.
        let long = "a b ".repeat(300);
        let e = InputError::new(format!(
            "field `model`: unknown variant `{long}`, expected `none` or `brown_conrady`"
        ))
        .to_string();
        assert!(
            e.contains(
                "a b …(1200 characters)…a b a b a b a b a b `, expected `none` or `brown_conrady`"
            ),
            "{e}"
        );
        assert!(e.len() < 200, "{e}");
        // Double quotes (serde's wrong string), their own escaped quotes
        // inside.
        let s = format!("\\\"{}", "y".repeat(150));
        let e = InputError::new(format!("invalid type: string \"{s}\", expected f64")).to_string();
        let tail = format!("…(152 characters)…{}\", expected f64", "y".repeat(20));
        assert!(
            e.starts_with("invalid type: string \"\\\"yyy") && e.ends_with(&tail),
            "{e}"
        );
        // A number, for `limits::tidy_numbers` to shorten as it is shown.
        let m = format!("invalid type: floating point `{}`, expected u32", 5e-324);
        assert_eq!(InputError::new(m.clone()).to_string(), m);
        assert_eq!(
            crate::out::tidy(&InputError::new(m).to_string()),
            "invalid type: floating point `5e-324`, expected a whole number from 0 to 4294967295"
        );
        // A value holding a backquote of its own, its rest then read as
        // text between two quotes: cut as well.
        let v = format!("{} ` {}", "a b ".repeat(30), "c d ".repeat(200));
        let e = InputError::new(format!("field `name`: `{v}` must be 1 to 64 letters, `-`"))
            .to_string();
        assert!(
            e.len() < 400 && e.ends_with("` must be 1 to 64 letters, `-`"),
            "{e}"
        );
        assert!(e.starts_with("field `name`: `a b a b"), "{e}");
        // Short values kept as given; an unclosed quote runs to the end.
        let m = format!("`{}` and `{}", "x".repeat(100), "z".repeat(300));
        let e = InputError::new(m).to_string();
        assert!(
            e.starts_with(&format!("`{}` and `zzz", "x".repeat(100))),
            "{e}"
        );
        assert!(
            e.contains("z…(300 characters)…z") && !e.ends_with('`'),
            "{e}"
        );
        let m = format!("`{}` and `{}", "x".repeat(100), "z".repeat(99));
        assert_eq!(InputError::new(m.clone()).to_string(), m);
        let m = format!("scene file /tmp/a\"b.toml: {}", "w ".repeat(100));
        assert_eq!(InputError::new(m.clone()).to_string(), m);
    }

    #[test]
    fn a_name_gives_its_value_and_anything_else_names_every_choice() {
        let c = [("lm", 1), ("autd3", 2), ("sim", 3)];
        assert_eq!(choose("a target", "autd3", &c), Ok(2));
        assert_eq!(
            choose("a target", "AUTD3", &c).unwrap_err(),
            "`AUTD3` is not a target: give lm, autd3 or sim"
        );
        assert_eq!(choose_any_case("a target", "AUTD3", &c), Ok(2));
        assert_eq!(
            choose("a shape", "probit", &[("logistic", 'l'), ("weibull", 'w')]).unwrap_err(),
            "`probit` is not a shape: give logistic or weibull"
        );
        assert_eq!(
            choose("a mode", "x", &[("only", ())]).unwrap_err(),
            "`x` is not a mode: give only"
        );
    }

    #[test]
    fn serdes_type_names_are_said_in_words() {
        for (msg, said) in [
            (
                "line 10, field `stimulus[0].foci`: invalid value: integer `-1`, expected usize",
                "line 10, field `stimulus[0].foci`: invalid value: integer `-1`, expected a whole number ≥ 0",
            ),
            (
                "field `foci`: invalid type: integer `1e20` as i128, expected usize",
                "field `foci`: invalid type: integer `1e20`, expected a whole number ≥ 0",
            ),
            (
                "invalid type: string \"a\", expected f64",
                "invalid type: string \"a\", expected a number",
            ),
            (
                "invalid type: floating point `1.5`, expected u8 at line 1 column 9",
                "invalid type: floating point `1.5`, expected a whole number from 0 to 255 at line 1 column 9",
            ),
            (
                "invalid type: integer `2`, expected bool",
                "invalid type: integer `2`, expected true or false",
            ),
        ] {
            assert_eq!(plain_types(msg), said);
            assert_eq!(crate::out::tidy(msg), said);
        }
        // Other words after `expected`, a type name inside a word or a
        // quoted value, and a value's own ` as ` are left as they are.
        for msg in [
            "unknown variant `x`, expected `none` or `brown_conrady`",
            "invalid length 2, expected an array of length 3",
            "unexpected u8 in `expected u32x`",
            "`usize` as written",
            "field `unexpected`: 1 as i8",
            "",
        ] {
            assert_eq!(plain_types(msg), msg);
        }
    }
}
