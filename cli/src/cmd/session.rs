//! `lmhost session`: hold the device and the finger source, preload a
//! stimulus library, take commands on a control socket, log events.

use std::path::PathBuf;

use clap::ValueEnum;
use lmhost::clock::{Clock, Spread};
use lmhost::lab::session::serve::{self, Control, Endpoint, Finger, OnDisconnect, Options};
use lmhost::lab::session::{EventLog, PendingEventLog, Session};
use lmhost::plan::library::Library;
use lmhost::plan::scene::Scene;

use super::args::{FingerArgs, FingerFeed, PortArgs};

/// What to do when the controlling client goes away.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Disconnect {
    /// Stop the presentation (the array goes silent) and keep serving.
    Stop,
    /// Carry on playing.
    Continue,
    /// End the session.
    Quit,
}

/// Arguments of `lmhost session`.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
    lmhost session --library studies/paper-library.toml --port autd3:emulator --control /tmp/lm.sock --synthetic\n  \
    echo '{\"cmd\":\"present\",\"stimulus\":\"lms-5hz-a3\",\"gate\":\"untracked\",\"on_s\":2}' | \\\n    \
    lmhost session --library studies/paper-library.toml --port autd3:emulator --control -\n\n\
    The control protocol (JSON lines) is in host/src/lab/session/PROTOCOL.md.")]
pub struct Args {
    /// Stimulus library (TOML, one [[stimulus]] table per entry).
    #[arg(long, value_name = "FILE")]
    library: PathBuf,
    #[command(flatten)]
    port: PortArgs,
    /// Scene file (TOML) [default: four AUTD3 in a flat 2×2 facing +z].
    #[arg(long, value_name = "FILE")]
    scene: Option<PathBuf>,
    /// Control socket: a Unix socket path (created mode 0600), or `-` for
    /// commands on stdin and replies and events on stdout
    /// [default: $XDG_RUNTIME_DIR/lmhost.sock (an absolute path), else
    /// /tmp/lmhost-$USER.sock ($USER a file name), else /tmp/lmhost-UID.sock].
    #[arg(long, value_name = "PATH")]
    control: Option<PathBuf>,
    /// Also listen on 127.0.0.1:PORT (TCP, local only).
    #[arg(long, value_name = "PORT", value_parser = super::whole::whole::<u16>(1, u16::MAX.into()))]
    tcp: Option<u16>,
    /// Event log (JSON lines; every line whole), started afresh once the
    /// session has (one refused in its set-up leaves it as it was).
    #[arg(long, value_name = "FILE")]
    events: Option<PathBuf>,
    #[command(flatten)]
    finger: FingerArgs,
    /// When the client that sent `present`, `prepare` or `stop` disconnects
    /// from the control socket [default: stop].
    #[arg(long, value_enum)]
    on_disconnect: Option<Disconnect>,
    /// End the session (the array silent) when stdin reaches its end: for
    /// a program that starts the session with a pipe on its stdin and
    /// never writes to it, so the session ends with that program however
    /// it ends, `kill -9` included (Python's `lmhost.Session` does this).
    /// What arrives on stdin is ignored.
    #[arg(long)]
    exit_with_stdin: bool,
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        // Graceful from the start: a signal during the set-up (planning,
        // connecting, uploading the library) ends it with its end lines
        // and the array silent, as one during the run does.
        lmhost::stop::graceful();
        let control = match &self.control {
            Some(p) if p.as_os_str() == "-" => Control::Stdio,
            Some(p) => Control::Socket {
                unix: p.clone(),
                tcp: self.tcp,
                named: "--control".into(),
            },
            None => {
                let (unix, named) = serve::default_socket()?;
                Control::Socket {
                    unix,
                    tcp: self.tcp,
                    named,
                }
            }
        };
        if control == Control::Stdio && self.tcp.is_some() {
            lmhost::bad_input!("--tcp needs a socket --control, not `-`");
        }
        // With commands on stdin no client connects, so none disconnects:
        // the end of stdin is the session's own rule (see --control).
        if control == Control::Stdio && self.on_disconnect.is_some() {
            lmhost::bad_input!("--on-disconnect needs a socket --control, not `-`");
        }
        let stream_stdin = self.finger.reads_stdin();
        if control == Control::Stdio && stream_stdin {
            lmhost::bad_input!("--control - and a finger source on `-` cannot both read stdin");
        }
        if self.exit_with_stdin && (control == Control::Stdio || stream_stdin) {
            lmhost::bad_input!(
                "--exit-with-stdin watches stdin for its end: it cannot also carry --control - or a finger source on `-`"
            );
        }
        // First of all: an owner that is already gone ends the session at
        // the first look at the flag (the set-up's, or the loop's).
        if self.exit_with_stdin {
            lmhost::stop::when_ends(std::io::stdin())
                .map_err(|e| anyhow::anyhow!("watching stdin: {e}"))?;
        }
        let library = Library::load(&self.library)?;
        let scene = Scene::load_or_default(self.scene.as_deref())?;
        // Every input, defaults and sidecars included, is known (and
        // remembered as an input) before any output is created.
        self.finger.check(self.scene.as_deref())?;
        control.check_outputs(self.events.as_deref())?;
        // The log is opened before the device: a path it cannot be written
        // at fails here, before the session says it started. It is started
        // (an earlier session's log emptied) once the session has: a
        // session refused or failed in its set-up leaves it as it was.
        let events = self.events.as_deref().map(EventLog::prepare).transpose()?;
        let spec = self.port.spec();
        let target = spec.device()?.target();
        let plans = library.plan_for(&target, &scene)?;
        if let Err(e) = lmhost::stop::check_set_up("planning the stimulus library") {
            return set_up_interrupted(&e, events, "the device was not opened");
        }
        let mut warned = std::collections::BTreeSet::new();
        for w in plans.iter().flat_map(|p| &p.warnings) {
            if warned.insert(w.clone()) {
                lmhost::errln!("warning: {w}");
            }
        }
        let endpoint = Endpoint::bind(&control)?;
        let dev = lmhost::device::connect::open(&spec, &scene)?;
        let where_ = dev.describe();
        let session = match Session::new(dev, &library, plans, scene, Clock::real()) {
            Ok(s) => s,
            Err(e) => {
                if let Some(i) = e.downcast_ref::<lmhost::stop::SetUpInterrupted>() {
                    return set_up_interrupted(i, events, "the array is silent");
                }
                return Err(lmhost::device::backend::port_context(
                    e,
                    &where_,
                    "starting the session",
                    || format!("starting the session on {where_}"),
                ));
            }
        };
        // The finger source starts once the device is ready, so a replay
        // runs from its first frame while the session takes commands.
        let finger = match self.finger.start(self.scene.as_deref())? {
            FingerFeed::Samples(feed, intake, _) => Finger::Samples(Box::new(feed), *intake),
            FingerFeed::Synthetic => Finger::Synthetic,
            FingerFeed::None => Finger::None,
        };
        let events = events.map(PendingEventLog::start).transpose()?;
        if let Control::Socket { unix, tcp, .. } = &control {
            lmhost::errln!(
                "lmhost: session on {where_}: {} stimuli; control socket {}{}",
                library.entries.len(),
                unix.display(),
                tcp.map(|p| format!(
                    " and 127.0.0.1:{p} (clients send the token in {} first)",
                    serve::token_path(unix).display()
                ))
                .unwrap_or_default()
            );
        }
        let report = serve::serve(
            session,
            Options {
                control: endpoint,
                on_disconnect: match self.on_disconnect.unwrap_or(Disconnect::Stop) {
                    Disconnect::Stop => OnDisconnect::Stop,
                    Disconnect::Continue => OnDisconnect::Continue,
                    Disconnect::Quit => OnDisconnect::Quit,
                },
                events,
                finger,
                filter: self.finger.filter().build(),
            },
        );
        // The source's counts are end lines whatever ended the session.
        self.finger.print_end_lines(&report);
        let report = report?;
        if report.dropped_clients > 0 {
            lmhost::errln!(
                "lmhost: {} clients were disconnected for not reading their replies and events",
                report.dropped_clients
            );
        }
        lmhost::errln!(
            "lmhost: session ended ({}); {} commands, {} events; the array is silent",
            report
                .reason
                .map(|r| serde_json::to_string(&r)
                    .unwrap_or_default()
                    .replace('"', ""))
                .unwrap_or_default(),
            report.commands,
            report.events
        );
        let f = &report.figures;
        let ms = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.1} ms"));
        if f.switches > 0 || f.timed_on_phases > 0 {
            lmhost::errln!(
                "lmhost: {} switches (latency {}); {} timed on-phases (|device − on_s| max {})",
                f.switches,
                Spread::describe_or(f.switch_ms.as_ref(), |v| format!("{v:.1} ms")),
                f.timed_on_phases,
                ms(f.on_error_max_abs_ms)
            );
        }
        Ok(())
    }
}

/// The end of a session stopped during its set-up: the `closed` event
/// (the log's last line, as at any end), then the end line saying what the
/// set-up was doing and `then` (what holds of the device). Exit 0, as a
/// session a signal ends mid-run.
fn set_up_interrupted(
    e: &lmhost::stop::SetUpInterrupted,
    events: Option<PendingEventLog>,
    then: &str,
) -> anyhow::Result<()> {
    use lmhost::lab::session::{Event, EventKind, OffsetReason};
    if let Some(mut log) = events.map(PendingEventLog::start).transpose()? {
        let closed = Event {
            t_host_us: lmhost::clock::monotonic_us(),
            kind: EventKind::Closed {
                reason: OffsetReason::stopped(),
                finger: None,
            },
        };
        log.line(serde_json::to_string(&closed)?.into())?;
        log.finish()?;
    }
    lmhost::errln!("lmhost: session {e}; {then}");
    Ok(())
}
