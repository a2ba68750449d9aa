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
    /// An input error with the given one-line message.
    pub fn new(msg: impl Into<String>) -> Self {
        Self(msg.into())
    }
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
}
