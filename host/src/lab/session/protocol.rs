//! The session's control protocol: commands in, replies and events out,
//! one JSON object per line (`host/src/lab/session/PROTOCOL.md`).

use lm_proto::MuteReason;
use serde::{Deserialize, Serialize};

use crate::error::InputError;

pub mod repeat;

/// Longest command line, bytes (longer lines are refused, not buffered).
pub const MAX_COMMAND_BYTES: usize = crate::limits::MAX_LINE_BYTES;

/// The safety gate a presentation plays under.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Gate {
    /// Muted until a finger is tracked, steered to it (the default).
    Tracked,
    /// Plays where planned whatever the finger does.
    Untracked,
}

/// `present`: what to play and for how long.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Present {
    /// The library entry's id.
    pub stimulus: String,
    /// `tracked` or `untracked` (default: the entry's). Each optional
    /// field is left out for its default; `null` is refused
    /// ([`crate::json::no_null`]).
    #[serde(default, deserialize_with = "crate::json::no_null")]
    pub gate: Option<Gate>,
    /// Seconds per on-phase (default: until `stop` or the next `present`).
    #[serde(default, deserialize_with = "crate::json::no_null")]
    pub on_s: Option<f64>,
    /// Seconds of silence between on-phases (default 0).
    #[serde(default, deserialize_with = "crate::json::no_null")]
    pub off_s: Option<f64>,
    /// On-phases (default 1; more need `on_s`), 1..=`MAX_REPEAT`.
    #[serde(default, deserialize_with = "repeat::opt")]
    pub repeat: Option<u32>,
}

/// A command, as sent on the control socket.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Present a stimulus.
    Present(Present),
    /// Load a stimulus into a slot that does not play, ahead of `present`.
    Prepare {
        /// The library entry's id.
        stimulus: String,
    },
    /// Stop what plays: the array goes silent.
    Stop,
    /// The session's and the device's state.
    Status,
    /// The library as planned for this device.
    Library,
    /// Receive events on this connection.
    Subscribe,
    /// End the session (the array goes silent).
    Quit,
    /// Authenticate a TCP connection (its first line there).
    Auth {
        /// The session's token, from its token file.
        token: String,
    },
}

/// Every command's name and the fields it takes: a field not listed is
/// refused, a command without fields takes none.
const FIELDS: [(&str, &[&str]); 8] = [
    ("present", &["stimulus", "gate", "on_s", "off_s", "repeat"]),
    ("prepare", &["stimulus"]),
    ("stop", &[]),
    ("status", &[]),
    ("library", &[]),
    ("subscribe", &[]),
    ("quit", &[]),
    ("auth", &["token"]),
];

/// Most characters of a value from a command line that a reply or an event
/// repeats (a longer one is cut, with its length said).
pub const MAX_ECHO_CHARS: usize = 64;

/// `s` as a message may repeat it: at most [`MAX_ECHO_CHARS`] characters,
/// escaped; a longer one is cut and says how long it was.
pub fn clip(s: &str) -> String {
    let n = s.chars().count();
    if n <= MAX_ECHO_CHARS {
        return s.escape_debug().to_string();
    }
    let head: String = s.chars().take(MAX_ECHO_CHARS - 16).collect();
    format!("{}... ({} bytes)", head.escape_debug(), s.len())
}

/// Cuts every quoted fragment of `msg` with [`clip`]: serde names a
/// value in backquotes (`` `x` ``) or, for a string of the wrong type, in
/// escaped double quotes (`string "x"`), whose own `\"` and `\\` do not
/// end it.
fn clip_quoted(msg: &str) -> String {
    let mut out = String::new();
    let mut chars = msg.chars();
    while let Some(c) = chars.next() {
        out.push(c);
        if c != '`' && c != '"' {
            continue;
        }
        let mut inner = String::new();
        let mut closed = false;
        while let Some(d) = chars.next() {
            if d == c {
                closed = true;
                break;
            }
            inner.push(d);
            if c == '"' && d == '\\' {
                inner.extend(chars.next());
            }
        }
        out.push_str(&if c == '`' {
            clip(&inner)
        } else if inner.chars().count() <= MAX_ECHO_CHARS {
            // Escaped already (serde's `{:?}`): kept as it is.
            inner
        } else {
            let head: String = inner.chars().take(MAX_ECHO_CHARS - 16).collect();
            format!("{head}... ({} bytes)", inner.len())
        });
        if closed {
            out.push(c);
        }
    }
    out
}

fn bad(msg: impl std::fmt::Display) -> InputError {
    InputError::new(format!("bad command: {}", clip_quoted(&msg.to_string())))
}

const HINT: &str = " (a command is a JSON object such as {\"cmd\":\"present\",\"stimulus\":\"ID\"}; commands: present, prepare, stop, status, library, subscribe, quit, auth)";

impl Command {
    /// Parses one command line; a bad line is an [`InputError`] of one
    /// line, repeating at most [`MAX_ECHO_CHARS`] of any value in it.
    pub fn parse(line: &str) -> Result<Self, InputError> {
        if line.len() > MAX_COMMAND_BYTES {
            return Err(InputError::new(format!(
                "bad command: {} bytes is longer than {MAX_COMMAND_BYTES}",
                line.len()
            )));
        }
        // A number no float holds (`1e999`, `1e-320`) is refused naming
        // its key; the line is JSON, so without the hint on what JSON a
        // command is.
        crate::json::exact_numbers(line).map_err(bad)?;
        let v: serde_json::Value = crate::json::from_str(line).map_err(|e| {
            let msg = e.to_string();
            bad(format!(
                "{}{HINT}",
                msg.split(" at line ").next().unwrap_or(&msg)
            ))
        })?;
        let serde_json::Value::Object(map) = v else {
            return Err(bad(format!("not a JSON object{HINT}")));
        };
        let name = match map.get("cmd") {
            Some(serde_json::Value::String(c)) => c.as_str(),
            Some(_) => return Err(bad("`cmd` is not a string")),
            None => return Err(bad(format!("missing field `cmd`{HINT}"))),
        };
        let Some((name, fields)) = FIELDS.iter().find(|(n, _)| *n == name) else {
            let names: Vec<&str> = FIELDS.iter().map(|(n, _)| *n).collect();
            return Err(bad(format!(
                "unknown command `{name}`, expected one of {}",
                names.join(", ")
            )));
        };
        if let Some(k) = map
            .keys()
            .find(|k| *k != "cmd" && !fields.contains(&k.as_str()))
        {
            return Err(bad(if fields.is_empty() {
                format!("unknown field `{k}`: `{name}` takes no fields")
            } else {
                format!("unknown field `{k}`: `{name}` takes {}", fields.join(", "))
            }));
        }
        let mut rest = map.clone();
        rest.remove("cmd");
        let rest = serde_json::Value::Object(rest);
        let field = |key: &str| -> Result<String, InputError> {
            match rest.get(key) {
                Some(serde_json::Value::String(s)) => Ok(s.clone()),
                Some(_) => Err(bad(format!("`{key}` is not a string"))),
                None => Err(bad(format!("missing field `{key}`"))),
            }
        };
        Ok(match *name {
            "present" => {
                let p: Present = crate::json::from_value(rest).map_err(bad)?;
                super::check_off_s(p.off_s.is_some(), p.repeat.unwrap_or(1), false).map_err(bad)?;
                Self::Present(p)
            }
            "prepare" => Self::Prepare {
                stimulus: field("stimulus")?,
            },
            "auth" => Self::Auth {
                token: field("token")?,
            },
            "stop" => Self::Stop,
            "status" => Self::Status,
            "library" => Self::Library,
            "subscribe" => Self::Subscribe,
            // The last name of `FIELDS`.
            _ => Self::Quit,
        })
    }

    /// The known command a line names, `""` when none: the `cmd` of its
    /// refusal, so a `present` with a bad field is answered as a `present`.
    /// Its other values are skipped unread, so one that no float holds
    /// (`"on_s":1e999`) still leaves the command named; a `cmd` given
    /// twice names none.
    pub fn named_in(line: &str) -> &'static str {
        #[derive(Deserialize)]
        struct Named {
            cmd: String,
        }
        // An object only: serde would read a struct from an array too.
        let named = line
            .trim_start()
            .starts_with('{')
            .then(|| serde_json::from_str::<Named>(line).ok())
            .flatten();
        let cmd = named.as_ref().map(|n| n.cmd.as_str());
        FIELDS
            .iter()
            .find(|(n, _)| Some(*n) == cmd)
            .map_or("", |(n, _)| n)
    }

    /// Its `cmd` name.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Present(_) => "present",
            Self::Prepare { .. } => "prepare",
            Self::Stop => "stop",
            Self::Status => "status",
            Self::Library => "library",
            Self::Subscribe => "subscribe",
            Self::Quit => "quit",
            Self::Auth { .. } => "auth",
        }
    }
}

/// Why an on-phase ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum OffsetReason {
    /// Its `on_s` elapsed.
    Timer,
    /// The device silenced itself: the host's lease lapsed (it stalled).
    LeaseExpired,
    /// A `stop` command.
    Stop,
    /// Another stimulus took over at the cycle end.
    Switch,
    /// The same stimulus was presented again.
    Replaced,
    /// The `quit` command.
    Quit,
    /// The control input ended (`--control -`: stdin closed).
    EndOfInput,
    /// A study ran its last trial.
    Finished,
    /// SIGINT (Ctrl-C).
    Sigint,
    /// SIGTERM.
    Sigterm,
    /// SIGHUP (the terminal closed).
    Sighup,
    /// SIGQUIT (Ctrl-\\).
    Sigquit,
    /// SIGUSR1.
    Sigusr1,
    /// The owner's end of stdin closed (`--exit-with-stdin`).
    OwnerGone,
    /// The program asked to stop (the Python package, after a
    /// `KeyboardInterrupt`).
    Interrupted,
    /// The controlling client went away (`--on-disconnect stop`), or
    /// standard output was closed by its reader.
    Disconnect,
    /// The session failed (a device error, say).
    Error,
}

impl OffsetReason {
    /// What asked the command to stop ([`crate::stop::cause`]), as an end
    /// reason; [`Self::Interrupted`] when nothing did.
    pub fn stopped() -> Self {
        use crate::stop::Cause;
        use nix::sys::signal::Signal;
        match crate::stop::cause() {
            Some(Cause::Signal(Signal::SIGINT)) => Self::Sigint,
            Some(Cause::Signal(Signal::SIGTERM)) => Self::Sigterm,
            Some(Cause::Signal(Signal::SIGHUP)) => Self::Sighup,
            Some(Cause::Signal(Signal::SIGQUIT)) => Self::Sigquit,
            Some(Cause::Signal(Signal::SIGUSR1)) => Self::Sigusr1,
            Some(Cause::OwnerGone) => Self::OwnerGone,
            Some(Cause::Signal(_) | Cause::Requested) | None => Self::Interrupted,
        }
    }
}

/// One event: what happened and when (host monotonic µs).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Event {
    /// Host monotonic clock (µs).
    pub t_host_us: u64,
    /// What happened.
    #[serde(flatten)]
    pub kind: EventKind,
}

/// What an [`Event`] reports.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum EventKind {
    /// A stimulus was uploaded to the device.
    Preloaded {
        /// Its id.
        stimulus: String,
        /// The slot it went to.
        slot: u8,
        /// Upload time (s).
        seconds: f64,
        /// Bytes sent on a framed link.
        wire_bytes: Option<u64>,
        /// Phases read back that differ (AUTD3 emulator).
        readback_mismatches: Option<u64>,
        /// The entries whose place it took (the slot held one; the
        /// device's library memory was full), now on the host only.
        evicted: Vec<String>,
    },
    /// The session took commands from here on.
    Ready {
        /// Backend kind.
        backend: String,
        /// The port.
        port: String,
        /// Library entries.
        stimuli: usize,
        /// Entries resident on the device.
        resident: usize,
        /// The device's slots.
        slots: u8,
    },
    /// An on-phase began (the device plays it).
    Onset {
        /// The stimulus.
        stimulus: String,
        /// Its slot.
        slot: u8,
        /// Its gate.
        gate: Gate,
        /// On-phase number, 1-based.
        rep: u32,
    },
    /// An on-phase ended.
    Offset {
        /// The stimulus.
        stimulus: String,
        /// Its slot.
        slot: u8,
        /// On-phase number.
        rep: u32,
        /// Why.
        reason: OffsetReason,
        /// Host time from onset to offset (s).
        presented_s: f64,
        /// Time the device played, from its own step and cycle counters
        /// (s; `null` where the device played on, at a switch).
        device_presented_s: Option<f64>,
        /// Time muted within it (host, s).
        muted_s: f64,
        /// `1 - muted_s / presented_s`.
        present_fraction: f64,
    },
    /// The device switched from one stimulus to the next at a cycle end.
    Switch {
        /// The stimulus that played.
        from: Option<String>,
        /// The one that plays now.
        to: String,
        /// From the request to the device playing it (ms): the status that
        /// showed the switch, less what the device's counters say it had
        /// played of the new stimulus by then.
        latency_ms: f64,
        /// From the request to the status that showed the switch (ms): an
        /// upper bound by the host's clock alone.
        detected_ms: f64,
    },
    /// A presentation ended (all its on-phases, or stopped).
    Done {
        /// The stimulus.
        stimulus: String,
        /// On-phases played.
        reps: u32,
    },
    /// A presentation waiting for its switch was replaced or stopped
    /// before it played.
    Cancelled {
        /// The stimulus.
        stimulus: String,
    },
    /// The finger appeared or left.
    Finger {
        /// Whether it is there.
        present: bool,
    },
    /// The output muted during an on-phase.
    Mute {
        /// Why (`waiting_for_tracking`, `finger_absent`, `tracking_stale`,
        /// `centroid_out_of_range`).
        reason: String,
    },
    /// The output sounds again.
    Unmute,
    /// A command was refused.
    Refused {
        /// The command.
        command: String,
        /// Why, one line.
        error: String,
    },
    /// The session ended; the array is silent.
    Closed {
        /// Why.
        reason: OffsetReason,
        /// What the finger source's plausibility gate read and dropped
        /// (the end line's counts); absent without a source of samples.
        #[serde(skip_serializing_if = "Option::is_none")]
        finger: Option<crate::sense::stream::intake::GateCounts>,
    },
}

/// A mute reason's name in events (snake case of the wire's name).
pub fn mute_name(r: MuteReason) -> String {
    let s = format!("{r:?}");
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if c.is_ascii_uppercase() {
            if i > 0 {
                out.push('_');
            }
            out.push(c.to_ascii_lowercase());
        } else {
            out.push(c);
        }
    }
    out
}

/// A library entry as the `library` command lists it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LibraryItem {
    /// Its id.
    pub id: String,
    /// The slot holding it (`null`: on the host only).
    pub slot: Option<u8>,
    /// Its default gate.
    pub gate: Gate,
    /// Realised timing on this device.
    #[serde(flatten)]
    pub timing: crate::plan::stimulus::Timing,
    /// Foci per step.
    pub foci: usize,
    /// Circle radius (mm).
    pub radius_mm: f64,
    /// CRC-32 of its phases.
    pub crc32: u32,
}

/// The `status` command's answer.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StatusReply {
    /// The stimulus presented (or waiting to switch in).
    pub stimulus: Option<String>,
    /// `on`, `off` (between on-phases) or `switching`.
    pub phase: Option<&'static str>,
    /// On-phase number.
    pub rep: Option<u32>,
    /// On-phases asked for.
    pub repeat: Option<u32>,
    /// Its gate.
    pub gate: Option<Gate>,
    /// Whether a finger is there (`null`: no sample yet).
    pub finger_present: Option<bool>,
    /// The device's state (`idle`, `playing`, `muted`, `stopped`).
    pub state: String,
    /// Slot playing or last played.
    pub slot: Option<u8>,
    /// Slot queued to take over.
    pub queued_slot: Option<u8>,
    /// Why it is muted.
    pub mute_reason: Option<String>,
    /// Step within the cycle.
    pub step: u16,
    /// Cycles since the play.
    pub cycles: u32,
}

/// A reply to one command: `{"ok":true,"cmd":...}` plus data, or
/// `{"ok":false,"cmd":...,"error":"..."}`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Reply(pub serde_json::Map<String, serde_json::Value>);

impl Reply {
    /// Success for `cmd`.
    pub fn ok(cmd: &str) -> Self {
        let mut m = serde_json::Map::new();
        m.insert("ok".into(), true.into());
        m.insert("cmd".into(), cmd.into());
        Self(m)
    }

    /// Failure for `cmd` (`""` when the line was not a command), Rust's
    /// type names in words ([`crate::error::plain_types`]).
    pub fn error(cmd: &str, msg: impl Into<String>) -> Self {
        let msg: String = msg.into();
        let mut m = serde_json::Map::new();
        m.insert("ok".into(), false.into());
        m.insert("cmd".into(), cmd.into());
        m.insert("error".into(), crate::error::plain_types(&msg).into());
        Self(m)
    }

    /// Adds `key`.
    pub fn with(mut self, key: &str, v: impl Serialize) -> Self {
        self.0.insert(
            key.into(),
            serde_json::to_value(v).unwrap_or(serde_json::Value::Null),
        );
        self
    }

    /// Whether it reports success.
    pub fn is_ok(&self) -> bool {
        self.0.get("ok") == Some(&serde_json::Value::Bool(true))
    }
}

#[cfg(test)]
mod tests;
