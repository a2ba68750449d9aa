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
    /// `tracked` or `untracked` (default: the entry's).
    #[serde(default)]
    pub gate: Option<Gate>,
    /// Seconds per on-phase (default: until `stop` or the next `present`).
    #[serde(default)]
    pub on_s: Option<f64>,
    /// Seconds of silence between on-phases (default 0).
    #[serde(default)]
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
                let p: Present = serde_json::from_value(rest).map_err(bad)?;
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
    pub fn named_in(line: &str) -> &'static str {
        let v = crate::json::from_str(line).ok();
        let cmd = v.as_ref().and_then(|v| v.get("cmd")?.as_str());
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
mod tests {
    use super::*;

    #[test]
    fn commands_parse_and_bad_ones_say_what_is_accepted() {
        assert_eq!(
            Command::parse(r#"{"cmd":"present","stimulus":"a","gate":"untracked","on_s":2,"off_s":2,"repeat":3}"#)
                .unwrap(),
            Command::Present(Present {
                stimulus: "a".into(),
                gate: Some(Gate::Untracked),
                on_s: Some(2.0),
                off_s: Some(2.0),
                repeat: Some(3),
            })
        );
        assert_eq!(Command::parse(r#"{"cmd":"stop"}"#).unwrap(), Command::Stop);
        assert_eq!(
            Command::parse(r#"{"cmd":"auth","token":"t"}"#).unwrap(),
            Command::Auth { token: "t".into() }
        );
        for (line, needle) in [
            ("", "bad command"),
            ("{}", "missing field `cmd`"),
            (
                r#"{"cmd":"present","stimulus":"a","on_s":1,"off_s":2}"#,
                "`off_s` is the silence between on-phases: give `repeat` 2 or more",
            ),
            (
                r#"{"cmd":"present","stimulus":"a","on_s":1,"off_s":0,"repeat":1}"#,
                "give `repeat` 2 or more",
            ),
            (r#"{"cmd":"dance"}"#, "unknown command `dance`"),
            (r#"{"cmd":7}"#, "`cmd` is not a string"),
            ("[1,2]", "not a JSON object"),
            (
                r#"{"cmd":"stop","stimulus":"x"}"#,
                "unknown field `stimulus`: `stop` takes no fields",
            ),
            (
                r#"{"cmd":"status","verbose":true}"#,
                "`status` takes no fields",
            ),
            (r#"{"cmd":"quit","now":1}"#, "`quit` takes no fields"),
            (
                r#"{"cmd":"prepare","stimulus":"a","gate":"tracked"}"#,
                "`prepare` takes stimulus",
            ),
            (
                r#"{"cmd":"prepare","stimulus":3}"#,
                "`stimulus` is not a string",
            ),
            (r#"{"cmd":"auth"}"#, "missing field `token`"),
            (r#"{"cmd":"stop","cmd":"quit"}"#, "duplicate key `cmd`"),
            (
                r#"{"cmd":"present","stimulus":"a","on_s":1,"on_s":1000}"#,
                "duplicate key `on_s`",
            ),
            (r#"{"cmd":"present"}"#, "missing field `stimulus`"),
            (
                r#"{"cmd":"present","stimulus":"a","gate":"loose"}"#,
                "unknown variant `loose`",
            ),
            (
                r#"{"cmd":"present","stimulus":"a","colour":1}"#,
                "unknown field `colour`",
            ),
            (
                r#"{"cmd":"present","stimulus":"a","repeat":-1}"#,
                "repeat -1 is out of range: allowed 1..=10000",
            ),
        ] {
            let e = Command::parse(line).unwrap_err().to_string();
            assert!(e.contains(needle), "{line}: {e}");
            assert!(e.starts_with("bad command: ") && !e.contains('\n'), "{e}");
        }
        // The reply says the field's rule, not its Rust type's range.
        let e = Command::parse(r#"{"cmd":"present","stimulus":"a","repeat":-1}"#).unwrap_err();
        let r = Reply::error("present", e.to_string());
        let said = r.0["error"].as_str().unwrap();
        assert!(
            said.ends_with("repeat -1 is out of range: allowed 1..=10000") && !said.contains("u32"),
            "{said}"
        );
        // A refusal names the command it refuses, where the line names one.
        for (line, name) in [
            (r#"{"cmd":"present","stimulus":"a","on_s":"x"}"#, "present"),
            (r#"{"cmd":"stop","now":1}"#, "stop"),
            (r#"{"cmd":"dance"}"#, ""),
            (r#"{"cmd":"stop","cmd":"quit"}"#, ""),
            ("[1]", ""),
        ] {
            assert!(Command::parse(line).is_err(), "{line}");
            assert_eq!(Command::named_in(line), name, "{line}");
        }
        let long = format!(r#"{{"cmd":"present","stimulus":"{}"}}"#, "a".repeat(5000));
        assert!(
            Command::parse(&long)
                .unwrap_err()
                .to_string()
                .contains("longer than")
        );
    }

    #[test]
    fn values_repeated_in_messages_are_bounded() {
        let long = "z".repeat(4000);
        for line in [
            format!(r#"{{"cmd":"{long}"}}"#),
            format!(r#"{{"cmd":"stop","{long}":1}}"#),
            format!(r#"{{"cmd":"present","stimulus":"a","gate":"{long}"}}"#),
            // serde names a string of the wrong type in double quotes.
            format!(r#"{{"cmd":"present","stimulus":"a","on_s":"{long}"}}"#),
        ] {
            let e = Command::parse(&line).unwrap_err().to_string();
            assert!(e.len() < 400, "{} bytes: {e}", e.len());
            assert!(e.contains("(4000 bytes)"), "{e}");
        }
        // A `repeat` is judged by its rule, its value not repeated.
        let e = Command::parse(&format!(
            r#"{{"cmd":"present","stimulus":"a","repeat":"{long}"}}"#
        ))
        .unwrap_err()
        .to_string();
        assert!(
            e.ends_with("`repeat` is a string, not a number: allowed 1..=10000"),
            "{e}"
        );
        assert_eq!(clip("short"), "short");
        assert_eq!(clip("a\nb"), "a\\nb");
        let c = clip(&"é".repeat(100));
        assert!(c.ends_with("(200 bytes)") && c.chars().count() < 70, "{c}");
    }

    #[test]
    fn events_are_flat_json_with_their_name() {
        let e = Event {
            t_host_us: 7,
            kind: EventKind::Switch {
                from: Some("a".into()),
                to: "b".into(),
                latency_ms: 1.5,
                detected_ms: 2.0,
            },
        };
        assert_eq!(
            serde_json::to_string(&e).unwrap(),
            r#"{"t_host_us":7,"event":"switch","from":"a","to":"b","latency_ms":1.5,"detected_ms":2.0}"#
        );
        assert_eq!(
            mute_name(MuteReason::CentroidOutOfRange),
            "centroid_out_of_range"
        );
        assert!(Reply::ok("x").is_ok());
        assert!(!Reply::error("x", "no").is_ok());
    }
}
