//! The one error type of the instruments: what went wrong, on which port,
//! in one line.

use crate::error::InputError;

/// Why a stage or gauge request failed. Every message starts with the
/// port (`/dev/ttyUSB0: …`, `sim-stage: …`) so a rig with two serial
/// instruments says which one.
#[derive(Debug, thiserror::Error)]
pub enum InstrumentError {
    /// No (complete) reply, or a move not finished, within the time allowed.
    #[error("{port}: {detail}")]
    Timeout {
        /// The instrument's port.
        port: String,
        /// What timed out, and after how long.
        detail: String,
    },
    /// Refused before anything was sent: a position outside the soft
    /// limits, a speed or sampling rate out of range. Carries an
    /// [`InputError`], so a command line given such a value exits 2.
    #[error("{port}: {source}")]
    Limit {
        /// The instrument's port.
        port: String,
        /// What was asked and what is allowed.
        source: InputError,
    },
    /// A reply that does not follow the instrument's protocol (garbage, a
    /// unit we do not know, a reply too long).
    #[error("{port}: {detail}")]
    Protocol {
        /// The instrument's port.
        port: String,
        /// What arrived and what was expected.
        detail: String,
    },
    /// The instrument answered with an error of its own (a controller
    /// error code, a limit switch, an overload) or did something other
    /// than asked (a move that stopped short).
    #[error("{port}: {detail}")]
    Refused {
        /// The instrument's port.
        port: String,
        /// The instrument's error, in words.
        detail: String,
    },
    /// A stop was requested (Ctrl-C, SIGTERM) while a move ran or a series
    /// was taken; a move was stopped first.
    #[error("{port}: {detail}")]
    Interrupted {
        /// The instrument's port.
        port: String,
        /// What was interrupted.
        detail: String,
    },
    /// The port itself failed (unplugged adapter, closed pty).
    #[error("{port}: {}", crate::files::reason(error))]
    Io {
        /// The instrument's port.
        port: String,
        /// The I/O error (said in the message, so not a separate cause).
        error: std::io::Error,
    },
}

impl InstrumentError {
    /// A [`InstrumentError::Limit`] from a message.
    pub fn limit(port: &str, msg: impl Into<String>) -> Self {
        Self::Limit {
            port: port.to_owned(),
            source: InputError::new(msg),
        }
    }

    /// A [`InstrumentError::Protocol`] from a message.
    pub fn protocol(port: &str, detail: impl Into<String>) -> Self {
        Self::Protocol {
            port: port.to_owned(),
            detail: detail.into(),
        }
    }

    /// A [`InstrumentError::Refused`] from a message.
    pub fn refused(port: &str, detail: impl Into<String>) -> Self {
        Self::Refused {
            port: port.to_owned(),
            detail: detail.into(),
        }
    }

    /// A [`InstrumentError::Timeout`] from a message.
    pub fn timeout(port: &str, detail: impl Into<String>) -> Self {
        Self::Timeout {
            port: port.to_owned(),
            detail: detail.into(),
        }
    }

    /// Whether the instrument stopped answering (a timeout or a failed
    /// port), as opposed to answering wrongly.
    pub fn is_silence(&self) -> bool {
        matches!(self, Self::Timeout { .. } | Self::Io { .. })
    }
}

/// A reply as it may appear in a message: printable ASCII kept, anything
/// else escaped, at most 40 characters.
pub(crate) fn quote(reply: &[u8]) -> String {
    let mut s = String::from("'");
    for &b in reply.iter().take(40) {
        match b {
            b' '..=b'~' => s.push(b as char),
            b'\r' => s.push_str("\\r"),
            b'\n' => s.push_str("\\n"),
            _ => s.push_str(&format!("\\x{b:02x}")),
        }
    }
    if reply.len() > 40 {
        s.push('…');
    }
    s.push('\'');
    s
}
