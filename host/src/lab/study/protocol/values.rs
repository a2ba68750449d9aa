//! The protocol file's values checked on their own as they are parsed
//! (a name, a label, seconds, a count in range), each with the JSON
//! Schema built from the same limit: the types [`super::file`]'s tables
//! are made of.

use std::borrow::Cow;

use schemars::{JsonSchema, Schema, SchemaGenerator, json_schema};
use serde::{Deserialize, Serialize};

use super::{
    MAX_ADJUSTMENTS, MAX_DEPTH_MM, MAX_NUMBER, MAX_RUN, MAX_SECONDS, MAX_SETS, MAX_STAIRCASE,
};
use crate::lab::study::columns::{LIST_SEPARATOR, MAX_LABEL_BYTES};
use crate::limits::show;

/// Longest text a participant reads (characters).
pub(super) const MAX_TEXT_CHARS: usize = 2000;

/// Longest name (a column, an item), bytes.
pub(super) const MAX_NAME_BYTES: usize = 64;
/// Largest adjustment step, mm.
pub(super) const MAX_STEP_MM: f64 = 100.0;

/// A value checked on its own as it is parsed: `check` says why not, and
/// `schema` is its JSON Schema, built from the same limits. Serialized
/// only to show a default in the schema.
macro_rules! checked {
    ($(#[$m:meta])* $name:ident($t:ty as $ts:literal), $default:expr, |$v:ident| $check:expr,
     schema $schema:tt) => {
        checked!(
            @made $(#[$m])* $name($t) from $t as $ts, $default,
            |$v| {
                let r: Result<(), String> = $check;
                r.map(|()| Self($v))
            },
            schema $schema
        );
    };
    // Made from what the file holds (`$src`, which serde reads as `$ts`)
    // by `$make`, which refuses it in one line.
    (@made $(#[$m:meta])* $name:ident($t:ty) from $src:ty as $ts:literal, $default:expr,
     |$v:ident| $make:expr, schema $schema:tt) => {
        $(#[$m])*
        #[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
        #[serde(try_from = $ts)]
        pub(super) struct $name(pub $t);

        impl TryFrom<$src> for $name {
            type Error = String;
            fn try_from($v: $src) -> Result<Self, String> {
                $make
            }
        }

        impl Default for $name {
            fn default() -> Self {
                Self($default)
            }
        }

        impl JsonSchema for $name {
            fn inline_schema() -> bool {
                true
            }
            fn schema_name() -> Cow<'static, str> {
                stringify!($name).into()
            }
            fn json_schema(_: &mut SchemaGenerator) -> Schema {
                json_schema!($schema)
            }
        }
    };
    // A whole number or a number in `$lo..=$hi`, `$unit` after the message.
    ($(#[$m:meta])* $name:ident($t:ty as $ts:literal), $default:expr, $json:literal $lo:tt..=$hi:expr,
     $unit:literal) => {
        checked!(
            $(#[$m])* $name($t as $ts), $default,
            |v| in_range(v as f64, $lo as f64, $hi as f64).map_err(|m| format!("{m}{}", $unit)),
            schema { "type": $json, "minimum": $lo, "maximum": $hi }
        );
    };
}

checked!(
    /// A name: 1 to 64 letters, digits, `-`, `_` or `.` (a column, an item).
    Name(String as "String"), String::new(), |v| check_name(&v),
    schema {
        "type": "string",
        "minLength": 1,
        "maxLength": MAX_NAME_BYTES,
        "pattern": "^[A-Za-z0-9._-]+$"
    }
);
checked!(
    /// A label shown or recorded: 1 to 200 bytes on one line.
    Label(String as "String"), String::new(), |v| check_label(&v),
    schema {
        "type": "string",
        "minLength": 1,
        "maxLength": MAX_LABEL_BYTES,
        "pattern": label_pattern(false)
    }
);
checked!(
    /// An answer's label: a [`Label`] a participant can type back and that
    /// trials.csv's lists can hold.
    AnswerLabel(String as "String"), String::new(), |v| check_answer_label(&v),
    schema {
        "type": "string",
        "minLength": 1,
        "maxLength": MAX_LABEL_BYTES,
        "pattern": label_pattern(true)
    }
);
/// A whole number in `$lo..=$hi` read as any number the file wrote
/// ([`crate::whole`]): `-1`, `2.5` or `1e30` are refused naming the
/// field's range, not the range of `$t`.
macro_rules! whole {
    ($(#[$m:meta])* $name:ident($t:ty), $default:expr, $lo:literal..=$hi:expr) => {
        checked!(
            @made $(#[$m])* $name($t) from crate::whole::FileNumber
                as "crate::whole::FileNumber", $default,
            |n| {
                let v = n.whole_in($lo, $hi as u64)?;
                <$t>::try_from(v).map(Self).map_err(|_| format!("{v} is out of range"))
            },
            schema { "type": "integer", "minimum": $lo, "maximum": $hi }
        );
    };
}

checked!(
    /// Text the participant reads (a question's, an adjustment's): at most
    /// [`MAX_TEXT_CHARS`], its lines broken with line breaks and tabs and
    /// no other control character (an escape sequence in it drove the
    /// participant's terminal: `\u001b[2J` cleared the screen).
    Text(String as "String"), String::new(), |v| check_text(&v),
    schema {
        "type": "string",
        "maxLength": MAX_TEXT_CHARS,
        "pattern": r"^[^\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f]*$"
    }
);

whole!(
    /// Sets: each a fresh permutation of every condition.
    Sets(usize), 1, 1..=MAX_SETS
);
whole!(
    /// Most adjustments per trial.
    Adjustments(u32), 20, 1..=MAX_ADJUSTMENTS
);
whole!(
    /// Answers in a row that move a staircase (its `up` and `down`).
    Run(u32), 1, 1..=MAX_RUN
);
whole!(
    /// Reversals that end a staircase.
    Reversals(u32), 8, 1..=MAX_STAIRCASE
);
whole!(
    /// Presentations that end a staircase.
    Presentations(u32), 50, 1..=MAX_STAIRCASE
);
checked!(
    /// A depth, mm.
    Depth(f64 as "f64"), 0.0, "number" (-MAX_DEPTH_MM)..=MAX_DEPTH_MM, " mm"
);
checked!(
    /// An adjustment step, mm.
    Step(f64 as "f64"), 0.25, |v| step(v),
    schema { "type": "number", "exclusiveMinimum": 0.0, "maximum": MAX_STEP_MM }
);
checked!(
    /// A number question's limit.
    Number(f64 as "f64"), 0.0, "number" (-MAX_NUMBER)..=MAX_NUMBER, ""
);

/// Seconds, from 0 when `ZERO_OK`, else above 0, at most [`MAX_SECONDS`].
#[derive(Debug, Clone, Copy, PartialEq, Default, Deserialize, Serialize)]
#[serde(try_from = "f64")]
pub(super) struct Seconds<const ZERO_OK: bool>(pub f64);

impl<const ZERO_OK: bool> TryFrom<f64> for Seconds<ZERO_OK> {
    type Error = String;
    fn try_from(s: f64) -> Result<Self, String> {
        if !s.is_finite() || !(0.0..=MAX_SECONDS).contains(&s) || (!ZERO_OK && s == 0.0) {
            return Err(format!(
                "{} is out of range: give seconds {} and at most {MAX_SECONDS}",
                show(s),
                if ZERO_OK { "from 0" } else { "above 0" }
            ));
        }
        Ok(Self(s))
    }
}

impl<const ZERO_OK: bool> JsonSchema for Seconds<ZERO_OK> {
    fn inline_schema() -> bool {
        true
    }
    fn schema_name() -> Cow<'static, str> {
        if ZERO_OK {
            "Seconds"
        } else {
            "PositiveSeconds"
        }
        .into()
    }
    fn json_schema(_: &mut SchemaGenerator) -> Schema {
        let lower = if ZERO_OK {
            "minimum"
        } else {
            "exclusiveMinimum"
        };
        json_schema!({ "type": "number", lower: 0.0, "maximum": MAX_SECONDS })
    }
}

/// The `pattern` of a label: not blank, no control characters; an
/// answer's label also has no spaces at its ends, is not a whole number
/// and does not hold [`LIST_SEPARATOR`] (as [`check_answer_label`]).
fn label_pattern(answer: bool) -> String {
    // `char::is_control`: the C0 and C1 controls and DEL.
    const CONTROL: &str = r"\x00-\x1f\x7f-\x9f";
    if answer {
        let sep = format!("\\{LIST_SEPARATOR}");
        format!(r"^(?!\+?[0-9]+$)[^\s{sep}{CONTROL}](?:[^{sep}{CONTROL}]*[^\s{sep}{CONTROL}])?$")
    } else {
        format!(r"^[^{CONTROL}]*\S[^{CONTROL}]*$")
    }
}

fn in_range(v: f64, lo: f64, hi: f64) -> Result<(), String> {
    if v.is_finite() && lo <= v && v <= hi {
        Ok(())
    } else {
        Err(format!(
            "{} is out of range: allowed {}..={}",
            show(v),
            show(lo),
            show(hi)
        ))
    }
}

fn step(v: f64) -> Result<(), String> {
    if v.is_finite() && v > 0.0 && v <= MAX_STEP_MM {
        Ok(())
    } else {
        Err(format!(
            "{} is out of range: give millimetres above 0 and at most {}",
            show(v),
            show(MAX_STEP_MM)
        ))
    }
}

/// 1 to [`MAX_NAME_BYTES`] letters, digits, `-`, `_` or `.`.
pub(super) fn check_name(s: &str) -> Result<(), String> {
    if s.is_empty()
        || s.len() > MAX_NAME_BYTES
        || !s
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
    {
        return Err(format!(
            "`{}` must be 1 to {MAX_NAME_BYTES} letters, digits, `-`, `_` or `.`",
            s.escape_debug()
        ));
    }
    Ok(())
}

/// 1 to [`MAX_LABEL_BYTES`] bytes on one line, not blank.
fn check_text(s: &str) -> Result<(), String> {
    let n = s.chars().count();
    if n > MAX_TEXT_CHARS {
        return Err(format!(
            "{n} characters, more than {MAX_TEXT_CHARS}: a participant reads it"
        ));
    }
    if let Some(c) = s
        .chars()
        .find(|c| c.is_control() && !matches!(c, '\n' | '\r' | '\t'))
    {
        return Err(format!(
            "holds the control character {}: give text, line breaks and tabs only",
            c.escape_unicode()
        ));
    }
    Ok(())
}

pub(super) fn check_label(s: &str) -> Result<(), String> {
    if s.trim().is_empty() || s.len() > MAX_LABEL_BYTES || s.chars().any(char::is_control) {
        return Err(format!(
            "`{}` must be 1 to {MAX_LABEL_BYTES} characters on one line",
            s.escape_debug()
        ));
    }
    Ok(())
}

/// A label that answers are matched to: an answer is trimmed and a number
/// picks an option by its place, so a label may not have spaces at its
/// ends nor be a whole number; trials.csv joins answers with `|`.
pub(super) fn check_answer_label(s: &str) -> Result<(), String> {
    check_label(s)?;
    if s.trim() != s {
        return Err(format!(
            "`{}` has spaces at an end; answers are trimmed, so it could not be given",
            s.escape_debug()
        ));
    }
    if s.parse::<usize>().is_ok() {
        return Err(format!(
            "`{s}` is a number; answers by number are 1-based indices"
        ));
    }
    if s.contains(LIST_SEPARATOR) {
        return Err(format!(
            "`{s}` holds `{LIST_SEPARATOR}`, which separates answers in trials.csv"
        ));
    }
    Ok(())
}

/// The first label of `v` that repeats an earlier one, ignoring ASCII case
/// as answers are matched.
pub(super) fn repeated(v: &[&str]) -> Option<(usize, usize)> {
    (0..v.len()).find_map(|j| {
        (0..j)
            .find(|&i| v[i].eq_ignore_ascii_case(v[j]))
            .map(|i| (i, j))
    })
}
