//! Every documented maximum on user input, in one place, and the checked
//! conversions that enforce them.
//!
//! A value beyond its range is an [`InputError`] (exit 2) whose one-line
//! message names the flag and the allowed range; nothing is clamped
//! silently. The `--help` texts quote these numbers.

use std::time::Duration;

use crate::error::InputError;

/// Longest accepted line of a centroid stream (stdin, file, one UDP line),
/// bytes. A longer line is an error, so `/dev/zero` cannot grow a buffer.
pub const MAX_LINE_BYTES: usize = 4096;
/// Largest time-stamp gap between two consecutive samples of a replayed
/// file (s). A larger gap is an error naming the line, not a long sleep.
pub const MAX_REPLAY_GAP_S: f64 = 60.0;
/// Latest time stamp (s) a centroid sample may carry (stream lines, files,
/// datagrams); the earliest is 0. Room for a tracker's Unix-epoch seconds
/// (`time.time()`, 1.8e9 in 2027) until the year 2286: a larger or negative
/// one is a broken tracker, refused where it is parsed (a file's line, a
/// datagram counted bad), never let past the gate to drop what follows.
pub const MAX_TIME_STAMP_S: f64 = 1.0e10;
/// How much further (s) a centroid's time stamp may run ahead of the last
/// accepted one than their arrivals are apart: beyond, it is a wild stamp,
/// dropped and counted as a time jump unless [`JUMPS_TO_ACCEPT`] in a row
/// agree (the
/// rule: `sense::stream::plausible`). Room for a tracker's output held up
/// in a pipe or a socket and delivered at once.
pub const MAX_TIME_SKEW_S: f64 = 1.0;
/// Longest `--seconds` (s) for `stream` and `sim`: one day.
pub const MAX_SECONDS: f64 = 86_400.0;
/// Longest `--seconds` for `stream --synthetic --fast` (s): one hour of
/// 90 fps samples (324 000 updates).
pub const MAX_FAST_SYNTHETIC_S: f64 = 3_600.0;
/// Most GS-PAT iterations (`--iterations`).
pub const MAX_ITERATIONS: usize = 1_000;
/// Longest response timeout per attempt (`--timeout-ms`), ms.
pub const MAX_TIMEOUT_MS: u64 = 60_000;
/// Most attempts per request (`--tries`).
pub const MAX_TRIES: u32 = 100;
/// Most steps per slot of the simulated device (`sim --slot-steps`): the
/// wire's u16 step count.
pub const MAX_SLOT_STEPS: u32 = u16::MAX as u32;
/// Longest centroid timeout of the simulated device (`sim
/// --centroid-timeout-ms`), ms: it travels as µs in a u32.
pub const MAX_CENTROID_TIMEOUT_MS: u32 = 3_600_000;
/// Largest |coordinate| of any position the planner accepts (scene
/// devices, reflector, LM centre, foci), mm: inside the wire's i32 µm
/// (±2147 mm) with room for the LM circle.
pub const MAX_COORD_MM: f64 = 2_000.0;
/// Largest LM circle radius A (`--radius`), mm.
pub const MAX_RADIUS_MM: f64 = 100.0;
/// Largest |per-step depth| (`--z`), mm.
pub const MAX_Z_MM: f64 = 100.0;
/// Largest re-plan threshold (`track --replan-mm`), mm: a re-plan is due
/// when a step's depth moves more than it, and a planned depth lies within
/// ±[`MAX_Z_MM`], so a step moving further than that is beyond any plan.
pub const MAX_REPLAN_MM: f64 = MAX_Z_MM;
/// Largest focus spacing d (`--spacing`) and step width (`--step`), mm.
pub const MAX_SPACING_MM: f64 = 1_000.0;
/// Highest LM frequency (`--freq`), Hz.
pub const MAX_FREQ_HZ: f64 = 1_000.0;
/// Lowest LM frequency (`--freq`), Hz: its period, 1 / f, fills the
/// wire's u32 microseconds. Checked as the frequency given, so a lower
/// one is refused by its own value, never by a period derived from it
/// (`1e-320` Hz said "period inf s").
pub const MIN_FREQ_HZ: f64 = 1e6 / u32::MAX as f64;
/// Largest weight (`--weights`, each within 0..=this: the synthesis
/// refuses a negative one).
pub const MAX_WEIGHT: f64 = 1.0e6;
/// Closest two transducers of different devices may be (mm): the T4010A1's
/// diameter. Closer means the devices overlap.
pub const MIN_TRANSDUCER_GAP_MM: f64 = 10.0;
/// Largest accepted tracker coordinate (mm) of a streamed centroid.
pub const MAX_CENTROID_MM: f64 = MAX_COORD_MM;
/// A present centroid further than this from the last accepted one (mm) is
/// a jump and is dropped ...
pub const MAX_JUMP_MM: f64 = 50.0;
/// ... unless this many jumps in a row agree that the finger moved.
pub const JUMPS_TO_ACCEPT: u32 = 3;
/// Consecutive bad UDP datagrams that end a `stream --udp` session (a
/// flood); fewer are skipped and counted.
pub const MAX_BAD_DATAGRAMS_IN_A_ROW: u64 = 1_000;

/// A number for a message, the one formatter every message uses: exactly
/// as given when short (`100.0004`, `0.23`), else six significant digits
/// (`2439.02`, `0.000232831`); scientific when huge or tiny (`1e300`, not
/// three hundred digits); `NaN`, `inf`.
pub fn show(v: f64) -> String {
    let a = v.abs();
    let moderate = v == 0.0 || !v.is_finite() || (1e-4..1e9).contains(&a);
    let exact = if moderate {
        format!("{v}")
    } else {
        format!("{v:e}")
    };
    let sig = exact
        .split('e')
        .next()
        .unwrap_or("")
        .trim_start_matches(['-', '0', '.'])
        .bytes()
        .filter(u8::is_ascii_digit)
        .count();
    if sig <= 10 {
        return exact;
    }
    let trim = |t: String| {
        if t.contains('.') {
            t.trim_end_matches('0').trim_end_matches('.').to_owned()
        } else {
            t
        }
    };
    if moderate {
        let decimals = (5 - a.log10().floor() as i32).max(0) as usize;
        trim(format!("{v:.decimals$}"))
    } else {
        let t = format!("{v:.5e}");
        match t.split_once('e') {
            Some((m, e)) => format!("{}e{e}", trim(m.to_owned())),
            None => t,
        }
    }
}

/// `v` for the message refusing it against the bounds `lo` and `hi`:
/// [`show`], or every digit where six would read as a bound
/// (`3600.0000001` is not "3600 s ... at most 3600 s"), in scientific
/// form when huge or tiny as [`show`] writes it (`1.0000000000000002e-310`,
/// not three hundred zeros before it).
pub fn show_beside(v: f64, lo: f64, hi: f64) -> String {
    let shown = show(v);
    if v != lo && v != hi && (shown == show(lo) || shown == show(hi)) {
        let moderate = v == 0.0 || !v.is_finite() || (1e-4..1e9).contains(&v.abs());
        match moderate {
            true => format!("{v}"),
            false => format!("{v:e}"),
        }
    } else {
        shown
    }
}

/// A number for a message with an optional precision (`{:.3}`): fixed
/// point when moderate, scientific when huge or tiny, like [`show`].
#[derive(Debug, Clone, Copy)]
pub struct Num(pub f64);

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let v = self.0;
        let a = v.abs();
        let moderate = v == 0.0 || !v.is_finite() || (1e-4..1e9).contains(&a);
        match (f.precision(), moderate) {
            (Some(p), true) => write!(f, "{v:.p$}"),
            (Some(p), false) => write!(f, "{v:.p$e}"),
            (None, _) => f.write_str(&show(v)),
        }
    }
}

/// Longest word (a run without white space) a message on stderr keeps
/// whole: longer than any path a user types, far shorter than a pasted
/// 100 000-character value ([`crate::out::shorten_long_words`]).
pub const MAX_MESSAGE_WORD_CHARS: usize = 512;

/// Every number in a message through [`show`]: a numeric token with more
/// than 15 digits (a huge or tiny value printed in full, or a saturated
/// integer) is rewritten in scientific form, so no message carries a
/// 300-digit number whatever formatted it, quoted (`` `1000…0.0` ``, as
/// serde and the toml crate quote a value) or not; one beyond `f64` keeps
/// its first digits and says how many it had. Paths and words are left
/// alone.
pub fn tidy_numbers(msg: &str) -> String {
    let b = msg.as_bytes();
    let mut out = String::with_capacity(msg.len());
    let mut i = 0;
    let boundary_before = |i: usize| {
        i == 0
            || matches!(
                b[i - 1],
                b' ' | b'(' | b'[' | b'=' | b',' | b':' | b'-' | b'+' | b'\t' | b'`' | b'"' | b'\''
            )
    };
    while i < b.len() {
        if b[i].is_ascii_digit() && boundary_before(i) {
            let start = i;
            while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.') {
                i += 1;
            }
            if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
                let mut j = i + 1;
                if j < b.len() && (b[j] == b'-' || b[j] == b'+') {
                    j += 1;
                }
                if j < b.len() && b[j].is_ascii_digit() {
                    i = j;
                    while i < b.len() && b[i].is_ascii_digit() {
                        i += 1;
                    }
                }
            }
            let tok = &msg[start..i];
            let digits = tok.bytes().filter(u8::is_ascii_digit).count();
            let next_ok =
                i == b.len() || !(b[i].is_ascii_alphanumeric() || b[i] == b'/' || b[i] == b'_');
            match tok.parse::<f64>() {
                Ok(v) if digits > 15 && next_ok && v.is_finite() => out.push_str(&show(v)),
                // Beyond f64 (400 nines): not `inf`, which it does not say.
                Ok(_) if digits > 15 && next_ok => {
                    out.push_str(&tok[..6]);
                    out.push_str(&format!("…({digits} digits)"));
                }
                _ => out.push_str(tok),
            }
        } else {
            let c = msg[i..].chars().next().unwrap_or(' ');
            out.push(c);
            i += c.len_utf8();
        }
    }
    out
}

/// Most field work `lmhost simulate` accepts: grid points × transducers
/// (× 2 with a reflector's image sources) × steps. About 10 s on the fast
/// path (the bench's 101 × 101 × 996 × 82 case, 8.3·10⁸, takes 0.17 s).
pub const MAX_SIM_WORK: f64 = 5.0e10;
/// The same for `simulate --reference` (the f64 loop is ~10× slower).
pub const MAX_SIM_WORK_REFERENCE: f64 = 5.0e9;

/// Why `s` is no number, for a number flag's refusal and a number in a
/// flag's list: one wording for both ([`no_number`], then what to give).
pub fn not_a_number(s: &str) -> String {
    format!("{}: give one such as 2.5, -1 or 1e-3", no_number(s))
}

/// `s` is no number, and what it looks like
/// ([`crate::files::text::number_hint`]): `0x10 is not a number (a
/// hexadecimal number? write it in decimal)`. The words of every number
/// refused as text, a flag's, a list item's, a CSV field's, before what
/// its reader asks for instead.
pub fn no_number(s: &str) -> String {
    if s.is_empty() {
        "an empty value is not a number".into()
    } else if s.trim() != s {
        format!(
            "`{}` is not a number (white space around it)",
            crate::error::short_echo(s)
        )
    } else {
        format!(
            "{} is not a number{}",
            crate::error::short_echo(s),
            crate::files::text::number_hint(s)
        )
    }
}

/// `literal` read as a number, exactly ([`exact_literal`]): for a number
/// inside a flag's value (`--center X,Y,Z`, `--away START,END`,
/// `--faults ber=P`), which a lone number flag's parser never sees. `Err`:
/// the message, for the caller to prefix with the flag and the part; one
/// that is no number in a lone number flag's words ([`not_a_number`]:
/// each list had words of its own, `` `` is not a number (got …)``).
pub fn exact_number(literal: &str) -> Result<f64, String> {
    // Spaces at an end refused as a lone number flag refuses them: a list
    // trimmed its items (`--center " 0,0,150"` taken) where `--radius " 5"`
    // was refused.
    let v: f64 = match literal.parse() {
        Ok(v) if literal.trim() == literal => v,
        _ => return Err(not_a_number(literal)),
    };
    exact_literal(literal, v)?;
    Ok(v)
}

/// Checks that the decimal `literal` was read as itself: one whose digits
/// are not all zero but which parses to 0 or to a subnormal (`1e-400`,
/// `1e-310`) underflowed and would be taken as another value without a
/// word; one past the largest number (`1e400`) overflowed to infinity.
/// `Err` is the message, for the caller to prefix with the field. Every
/// number read from text (a centroid or control line, a JSON value, a
/// TOML file) passes here.
pub fn exact_literal(literal: &str, v: f64) -> Result<(), String> {
    let mantissa = literal.split(['e', 'E']).next().unwrap_or(literal);
    let nonzero = mantissa.bytes().any(|b| (b'1'..=b'9').contains(&b));
    let least = show(f64::MIN_POSITIVE);
    if nonzero && v == 0.0 {
        return Err(format!(
            "{literal} is too small to represent (it would be read as 0): give 0 or a magnitude of at least {least}"
        ));
    }
    // A literal past the largest number reads as infinity: refused as
    // itself (a flag's `1e309` was "got inf", a value never typed).
    let spelled_inf = literal
        .trim_start_matches(['+', '-'])
        .get(..3)
        .is_some_and(|h| h.eq_ignore_ascii_case("inf"));
    if v.is_infinite() && !spelled_inf {
        return Err(format!(
            "{literal} is too large to represent (it would be read as {}): give a magnitude of at most {}",
            show(v),
            show(f64::MAX)
        ));
    }
    if nonzero && v.is_subnormal() {
        return Err(format!(
            "{literal} is too small to represent: below {least} it cannot be held exactly (it would be read as {}); give 0 or a magnitude of at least {least}",
            // Its digits as held: the shortest form that reads back
            // (`1e-320`) is the literal itself, and said nothing.
            held_digits(v)
        ));
    }
    Ok(())
}

/// A subnormal `v` in 8 significant digits (few enough that
/// [`tidy_numbers`] leaves them), trailing zeros dropped: `1e-320` is held
/// as `9.9998867e-321`.
fn held_digits(v: f64) -> String {
    let s = format!("{v:.7e}");
    match s.split_once('e') {
        Some((m, e)) if m.contains('.') => {
            format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.'))
        }
        _ => s,
    }
}

/// Seconds to a [`Duration`], checked: finite, `0 < s ≤ max_s`. `what`
/// names the flag or field in the error.
pub fn duration_s(what: &str, s: f64, max_s: f64) -> Result<Duration, InputError> {
    if !(s.is_finite() && s > 0.0 && s <= max_s) {
        return Err(InputError::new(format!(
            "{what} {} s is out of range: give a number above 0 and at most {max_s} s",
            show_beside(s, 0.0, max_s)
        )));
    }
    let d = Duration::try_from_secs_f64(s)
        .map_err(|e| InputError::new(format!("{what} {s} s is not a duration ({e})")))?;
    if let Some(m) = rounds_to_no_time(&format!("{what} {} s", show(s)), s) {
        return Err(InputError::new(format!("{m}: give at least 1e-9 s")));
    }
    Ok(d)
}

/// Why `s` seconds, above 0, is no duration, or `None`: below a
/// nanosecond, the least a duration holds, it is none (`--hold 1e-300`
/// held for 0 s, a UDP idle time of it failed the socket, an `off_s` of it
/// paused not at all). The one rule of [`duration_s`], [`pause_s`] and a
/// study protocol's scaled `off_s`; `said` is the value as the caller
/// names it (`off_s 1e-300 s`, or the protocol's field × its time scale),
/// and the caller says what to give.
pub fn rounds_to_no_time(said: &str, s: f64) -> Option<String> {
    (s > 0.0 && Duration::try_from_secs_f64(s).is_ok_and(|d| d.is_zero()))
        .then(|| format!("{said} rounds to no time (a duration holds whole nanoseconds)"))
}

/// A pause (a control line's `off_s`), checked: 0 (no pause) or a
/// duration as [`duration_s`] takes it, and said so when refused: "give at
/// least 1e-9 s" of a field that takes 0 hid the 0.
pub fn pause_s(what: &str, s: f64, max_s: f64) -> Result<Duration, InputError> {
    if s == 0.0 {
        return Ok(Duration::ZERO);
    }
    if !(s.is_finite() && s > 0.0 && s <= max_s) {
        return Err(InputError::new(format!(
            "{what} {} s is out of range: give 0 (no pause) or a number from 1e-9 to {max_s} s",
            show_beside(s, 0.0, max_s)
        )));
    }
    if let Some(m) = rounds_to_no_time(&format!("{what} {} s", show(s)), s) {
        return Err(InputError::new(format!(
            "{m}: give 0 (no pause) or at least 1e-9 s"
        )));
    }
    duration_s(what, s, max_s)
}

/// Refuses a value given twice to a repeatable flag (`flag`, e.g.
/// `--section`; `what`, e.g. `section`): it was merged without a word
/// (`bench --section planner --section planner` ran it once).
pub fn each_once(flag: &str, what: &str, values: &[String]) -> Result<(), InputError> {
    for (i, v) in values.iter().enumerate() {
        if values[..i].contains(v) {
            return Err(InputError::new(format!(
                "{flag} `{}` is given twice: give each {what} once",
                crate::error::short_echo(v)
            )));
        }
    }
    Ok(())
}

/// Checks `lo ≤ v ≤ hi` for a finite `v`; the error names `what`, the
/// unit and the range.
pub fn in_range(what: &str, v: f64, lo: f64, hi: f64, unit: &str) -> Result<f64, InputError> {
    let allowed = |unit: &str| format!("{}..={}{unit}", show(lo), show(hi));
    range_check(what, v, (lo..=hi).contains(&v), (lo, hi), unit, allowed)
}

/// Checks `lo < v ≤ hi` for a finite `v`, as [`in_range`] does with `lo`
/// left out: a range with an open end is said so. `allowed 0..=1000 mm`
/// for a spacing of 1e9 named a 0 the check refuses.
pub fn in_range_above(what: &str, v: f64, lo: f64, hi: f64, unit: &str) -> Result<f64, InputError> {
    let allowed = |unit: &str| format!("above {} and at most {}{unit}", show(lo), show(hi));
    range_check(what, v, v > lo && v <= hi, (lo, hi), unit, allowed)
}

/// `v` when finite and `inside`, else `WHAT V UNIT is out of range:
/// allowed …` with `allowed(" UNIT")` (the unit with its space, or none).
fn range_check(
    what: &str,
    v: f64,
    inside: bool,
    (lo, hi): (f64, f64),
    unit: &str,
    allowed: impl Fn(&str) -> String,
) -> Result<f64, InputError> {
    if v.is_finite() && inside {
        return Ok(v);
    }
    let unit = match unit {
        "" => String::new(),
        u => format!(" {u}"),
    };
    Err(InputError::new(format!(
        "{what} {}{unit} is out of range: allowed {}",
        show_beside(v, lo, hi),
        allowed(&unit)
    )))
}

/// Checks every coordinate of a position against [`MAX_COORD_MM`].
pub fn position_mm(what: &str, v: [f64; 3]) -> Result<[f64; 3], InputError> {
    if v.iter().all(|x| x.is_finite() && x.abs() <= MAX_COORD_MM) {
        Ok(v)
    } else {
        Err(InputError::new(format!(
            "{what} [{}] mm is out of range: every coordinate must be within ±{MAX_COORD_MM} mm",
            v.map(show).join(", ")
        )))
    }
}

/// Largest accepted text input file (scene, intrinsics), bytes. A scene
/// with the most devices a sequence can address is a few tens of kB.
pub const MAX_TEXT_FILE_BYTES: u64 = 1 << 20;

/// Reads the UTF-8 text file `path` (`what` names it in errors), refusing
/// one longer than [`MAX_TEXT_FILE_BYTES`] before reading it whole, and
/// anything but a regular file before opening it
/// ([`crate::files::read_input`]); read as [`crate::files::text::decode`]
/// reads text (a byte-order mark skipped, CRLF as LF, UTF-16 refused).
pub fn read_text_file(what: &str, path: &std::path::Path) -> Result<String, InputError> {
    read_text_file_up_to(what, path, MAX_TEXT_FILE_BYTES)
}

/// [`read_text_file`] with its own limit, `max` bytes (a stimulus file).
pub fn read_text_file_up_to(
    what: &str,
    path: &std::path::Path,
    max: u64,
) -> Result<String, InputError> {
    let bytes = crate::files::read_input(what, path, max)?;
    crate::files::text::decode(bytes)
        .map_err(|why| InputError::new(format!("cannot read {what} {}: {why}", path.display())))
}

/// The names of the options given, in order: `(name, given)` pairs (for
/// "give only …" and "has no …" messages).
pub fn given<'a>(options: &[(&'a str, bool)]) -> Vec<&'a str> {
    options
        .iter()
        .filter(|(_, g)| *g)
        .map(|(n, _)| *n)
        .collect()
}

/// Makes `property` required in a file's JSON Schema and drops the default
/// serde gives it: the loader takes a file without it only to say what to
/// add, so the file needs it.
pub fn require_in_schema(schema: &mut schemars::Schema, property: &str) {
    match schema.get_mut("required") {
        Some(serde_json::Value::Array(r)) => r.push(property.into()),
        _ => {
            schema.insert("required".into(), serde_json::json!([property]));
        }
    }
    if let Some(p) = schema
        .get_mut("properties")
        .and_then(|p| p.get_mut(property))
        .and_then(|p| p.as_object_mut())
    {
        p.remove("default");
    }
}
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_number_inside_a_value_is_read_exactly() {
        assert_eq!(exact_number("2.5"), Ok(2.5));
        assert_eq!(exact_number("-0"), Ok(-0.0));
        assert_eq!(exact_number("0e-400"), Ok(0.0));
        // In a lone number flag's words, spaces at an end too.
        for (v, why) in [
            ("x", "x is not a number"),
            ("", "an empty value is not a number"),
            ("` 1`", "` 1` is not a number (white space around it)"),
            (
                "3mm",
                "3mm is not a number (a unit after it? give the number alone: `3`)",
            ),
        ] {
            let v = v.trim_matches('`');
            assert_eq!(
                exact_number(v),
                Err(format!("{why}: give one such as 2.5, -1 or 1e-3")),
                "{v}"
            );
        }
        for tiny in ["1e-400", "-5e-330"] {
            let m = exact_number(tiny).unwrap_err();
            assert!(
                m.starts_with(&format!("{tiny} is too small to represent")),
                "{m}"
            );
        }
    }

    #[test]
    fn a_pause_takes_0_and_says_so() {
        assert_eq!(pause_s("off_s", 0.0, 3600.0).unwrap(), Duration::ZERO);
        assert_eq!(
            pause_s("off_s", 1e-9, 3600.0).unwrap(),
            Duration::from_nanos(1)
        );
        assert_eq!(
            pause_s("off_s", -1.0, 3600.0).unwrap_err().0,
            "off_s -1 s is out of range: give 0 (no pause) or a number from 1e-9 to 3600 s"
        );
        assert!(
            pause_s("off_s", 1e-300, 3600.0)
                .unwrap_err()
                .0
                .ends_with("give 0 (no pause) or at least 1e-9 s")
        );
    }

    #[test]
    fn a_repeated_value_is_named() {
        let v = |s: &[&str]| s.iter().map(|x| (*x).to_owned()).collect::<Vec<_>>();
        assert!(each_once("--section", "section", &v(&["a", "b"])).is_ok());
        assert_eq!(
            each_once("--section", "section", &v(&["a", "b", "a"]))
                .unwrap_err()
                .0,
            "--section `a` is given twice: give each section once"
        );
    }

    #[test]
    fn durations_are_checked_not_panicking() {
        assert_eq!(
            duration_s("--seconds", 1.5, MAX_SECONDS).unwrap(),
            Duration::from_millis(1500)
        );
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e30, MAX_SECONDS * 2.0] {
            let e = duration_s("--seconds", bad, MAX_SECONDS).unwrap_err();
            assert!(e.0.contains("--seconds") && e.0.contains("at most"), "{e}");
        }
        assert!(duration_s("x", MAX_SECONDS, MAX_SECONDS).is_ok());
        // Refused beside a bound, it is not shown as the bound.
        let e = duration_s("--hold", 1e-300, MAX_SECONDS).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("--hold 1e-300 s rounds to no time"),
            "{e}"
        );
        assert_eq!(duration_s("x", 1e-9, 1.0).unwrap(), Duration::from_nanos(1));
        let e = duration_s("on_s", 3600.0000001, 3600.0).unwrap_err();
        assert!(
            e.0.starts_with("on_s 3600.0000001 s is out of range"),
            "{e}"
        );
        let e = in_range("x", 1.0000000001, 0.0, 1.0, "").unwrap_err();
        assert!(e.0.starts_with("x 1.0000000001 is out of range"), "{e}");
        assert_eq!(show_beside(1e300, 0.0, 1.0), "1e300");
    }

    #[test]
    fn a_tiny_or_huge_number_beside_its_bound_keeps_every_digit_in_scientific_form() {
        // Two neighbouring subnormals (a stream's time stamps): six digits
        // read alike, every digit tells them apart, no zeros spelt out.
        let t = 1.0e-310f64;
        let next = f64::from_bits(t.to_bits() + 1);
        assert_eq!(show_beside(t, next, next), "1e-310");
        let shown = show_beside(next, t, t);
        assert!(shown.len() < 30 && shown.ends_with("e-310"), "{shown}");
        assert_ne!(shown, show(t));
        assert_eq!(shown.parse::<f64>().unwrap(), next);
        let big = f64::from_bits(1e300f64.to_bits() + 1);
        let shown = show_beside(big, 1e300, 1e300);
        assert!(
            shown.len() < 30 && shown.parse::<f64>().unwrap() == big,
            "{shown}"
        );
        // A moderate one as before.
        assert_eq!(show_beside(3600.0000001, 0.0, 3600.0), "3600.0000001");
    }

    #[test]
    fn numbers_in_messages_stay_short() {
        let tiny = format!("step {} mm", 1e-300);
        assert_eq!(tidy_numbers(&tiny), "step 1e-300 mm");
        let huge = format!("period {} s, N = {}", 1e300, u64::MAX);
        assert_eq!(tidy_numbers(&huge), "period 1e300 s, N = 1.84467e19");
        let fine = "dwell 2.439 ms at /tmp/12345678901234567890/x, 0.30000000000000004";
        assert_eq!(
            tidy_numbers(fine),
            fine.replace("0.30000000000000004", "0.3")
        );
        assert_eq!(show(100.0004), "100.0004");
        assert_eq!(show(9.999999999999999e299), "1e300");
        assert_eq!(show(1e6 / f64::from(u32::MAX)), "0.000232831");
        assert_eq!(show(2439.0243902439024), "2439.02");
        assert_eq!(show(f64::NAN), "NaN");
        assert_eq!(show(-5e-324), "-5e-324");
        assert_eq!(tidy_numbers("µs ±1e-300 é"), "µs ±1e-300 é");
        // Quoted as serde and the toml crate quote a value.
        let quoted = format!("invalid type: floating point `{:.1}`, expected u32", 1e300);
        assert_eq!(
            tidy_numbers(&quoted),
            "invalid type: floating point `1e300`, expected u32"
        );
        let nines = format!("`{}` is not a `present` value", "9".repeat(400));
        assert_eq!(
            tidy_numbers(&nines),
            "`999999…(400 digits)` is not a `present` value"
        );
        assert_eq!(tidy_numbers("\"18446744073709551616\""), "\"1.84467e19\"");
        assert_eq!(format!("{:.3}", Num(1e-300)), "1.000e-300");
        assert_eq!(format!("{:.3}", Num(2.5)), "2.500");
        assert_eq!(format!("{}", Num(1e300)), "1e300");
    }

    #[test]
    fn ranges_name_the_limits() {
        assert_eq!(in_range("--radius", 3.0, 0.0, 100.0, "mm").unwrap(), 3.0);
        let e = in_range("--radius", 1e30, 0.0, 100.0, "mm").unwrap_err();
        assert!(e.0.contains("0..=100 mm"), "{e}");
        assert!(in_range("x", f64::NAN, 0.0, 1.0, "").is_err());
        let e = in_range_above("spacing", 1e9, 0.0, 1000.0, "mm").unwrap_err();
        assert_eq!(
            e.to_string(),
            "spacing 1e9 mm is out of range: allowed above 0 and at most 1000 mm"
        );
        assert!(in_range_above("spacing", 0.0, 0.0, 1000.0, "mm").is_err());
        assert_eq!(
            in_range_above("spacing", 1000.0, 0.0, 1000.0, "mm").unwrap(),
            1000.0
        );
        assert!(position_mm("c", [0.0, 0.0, 2000.0]).is_ok());
        let e = position_mm("c", [0.0, 0.0, 1e300]).unwrap_err();
        assert!(e.0.contains("±2000 mm"), "{e}");
    }
}
