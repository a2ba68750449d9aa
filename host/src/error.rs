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
