//! The one stop flag: what the ending signals ([`SIGNALS`]: SIGINT
//! (Ctrl-C), SIGTERM, SIGHUP (the terminal closed), SIGQUIT (Ctrl-\),
//! SIGUSR1, and every other signal whose default action ends the process:
//! SIGUSR2, the timers' SIGALRM, SIGVTALRM and SIGPROF, the limits'
//! SIGXCPU and SIGXFSZ, SIGIO, SIGPWR and SIGSTKFLT) do.
//!
//! `main` calls [`install`] before any command runs. From then on any of
//! them does one of two things:
//!
//! - in a command that polls the flag (it called [`graceful`]: `stream`,
//!   `track`, `demo`, `upload --hold`, `session`, `study`), it sets the
//!   flag; the command's loop ends, the device is muted, recordings are
//!   finished and the report is printed. `session` and `study run` are
//!   graceful from their start: a signal during their set-up (connecting,
//!   uploading the library, which checks the flag between entries) ends
//!   it with [`SetUpInterrupted`] and their end lines;
//! - in any other command, it removes the temporary files of the outputs
//!   still being written ([`crate::files::Output`]), says so in one line
//!   on stderr (`lmhost: interrupted by SIGINT`, and `; unfinished
//!   outputs removed` when it removed one), removes the output directories
//!   it made that are still empty ([`crate::files::output_dir`]) and exits
//!   at once with 128 + the signal number, as the default action would
//!   have, so no half-written file is left behind under any name.

use std::ffi::{CString, c_char};
use std::sync::atomic::{AtomicBool, AtomicI32, AtomicPtr, Ordering};

static STOP: AtomicBool = AtomicBool::new(false);
/// What asked first ([`Cause`]): 0 nothing yet, a signal's number, or one
/// of the negative codes below. Set once by the first asker, so a second
/// signal during the shutdown does not rename what ended the command.
static CAUSE: AtomicI32 = AtomicI32::new(0);
const OWNER_GONE: i32 = -1;
const REQUESTED: i32 = -2;
static GRACEFUL: AtomicBool = AtomicBool::new(false);

/// Temporary files to remove when a signal ends the process. Slots hold
/// leaked C strings (never freed, so the handler never reads freed memory).
const MAX_TEMPS: usize = 256;
static TEMPS: [AtomicPtr<c_char>; MAX_TEMPS] =
    [const { AtomicPtr::new(std::ptr::null_mut()) }; MAX_TEMPS];
/// Output directories made for the running command, deepest first, that
/// the handler removes (while empty, after the temporary files) when a
/// signal ends the process ([`crate::files::output_dir`]).
const MAX_DIRS: usize = 64;
static DIRS: [AtomicPtr<c_char>; MAX_DIRS] =
    [const { AtomicPtr::new(std::ptr::null_mut()) }; MAX_DIRS];

/// The signals that end a command. Each one's default action would end the
/// process at once (SIGQUIT with a core dump), leaving an array that a
/// session or a hold loop plays sounding and an output's temporary file
/// beside its name (SIGUSR2 and SIGALRM did, as only the first five were
/// caught): all of them go through the flag. (SIGPIPE is ignored by Rust's
/// runtime; a closed pipe is a write error.)
/// SIGPWR and SIGSTKFLT are Linux's own.
pub const SIGNALS: &[nix::sys::signal::Signal] = {
    use nix::sys::signal::Signal::*;
    &[
        SIGINT,
        SIGTERM,
        SIGHUP,
        SIGQUIT,
        SIGUSR1,
        SIGUSR2,
        SIGALRM,
        SIGVTALRM,
        SIGPROF,
        SIGXCPU,
        SIGXFSZ,
        SIGIO,
        #[cfg(target_os = "linux")]
        SIGPWR,
        #[cfg(target_os = "linux")]
        SIGSTKFLT,
    ]
};

/// What asked the running command to stop, for its end line and its
/// event log: the first asker when several did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cause {
    /// One of [`SIGNALS`].
    Signal(nix::sys::signal::Signal),
    /// The owner's end of stdin closed ([`when_ends`]: the program that
    /// started `lmhost session --exit-with-stdin` is gone).
    OwnerGone,
    /// The program asked ([`request`]: the Python package after a
    /// `KeyboardInterrupt`).
    Requested,
}

impl std::fmt::Display for Cause {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Signal(s) => f.write_str(s.as_str()),
            Self::OwnerGone => f.write_str("the owner's end of stdin closed"),
            Self::Requested => f.write_str("a stop request"),
        }
    }
}

/// Whether a stop (one of [`SIGNALS`]) was requested.
pub fn requested() -> bool {
    STOP.load(Ordering::SeqCst)
}

/// What asked for the stop, once one was requested.
pub fn cause() -> Option<Cause> {
    if !requested() {
        return None;
    }
    Some(match CAUSE.load(Ordering::SeqCst) {
        OWNER_GONE => Cause::OwnerGone,
        n => nix::sys::signal::Signal::try_from(n).map_or(Cause::Requested, Cause::Signal),
    })
}

/// `interrupted by SIGTERM` (by what [`cause`] says), for an end line.
pub fn interrupted() -> String {
    match cause() {
        Some(c) => format!("interrupted by {c}"),
        None => "interrupted".to_owned(),
    }
}

/// Ask the running command to stop.
pub fn request() {
    ask(REQUESTED);
}

/// Records `cause` if nothing asked before, then sets the flag (what the
/// signal handler does too: atomics only).
fn ask(cause: i32) {
    let _ = CAUSE.compare_exchange(0, cause, Ordering::SeqCst, Ordering::SeqCst);
    STOP.store(true, Ordering::SeqCst);
}

/// Clears a stop request once what it stopped has ended: for a program
/// that runs commands in process one after another (the Python package's
/// `Study` after a `KeyboardInterrupt`), so the next one is not stopped
/// before it starts.
pub fn clear() {
    STOP.store(false, Ordering::SeqCst);
    CAUSE.store(0, Ordering::SeqCst);
}

/// Declare that this command polls [`requested`] and ends cleanly: from
/// now on a signal only sets the flag.
pub fn graceful() {
    GRACEFUL.store(true, Ordering::SeqCst);
}

/// A command stopped during its set-up (connecting, uploading the
/// stimulus library), before its run began: `interrupted by SIGTERM
/// during set-up (uploading stimulus `x`, 3 of 15)`. A command that polls
/// the flag declares [`graceful`] first thing, so a signal in its set-up
/// ends it through its own end lines, not at once.
#[derive(Debug, thiserror::Error)]
#[error("{cause} during set-up ({doing})")]
pub struct SetUpInterrupted {
    /// `interrupted by SIGTERM` ([`interrupted`]).
    cause: String,
    /// What the set-up was doing.
    pub doing: String,
}

impl SetUpInterrupted {
    /// The stop of a set-up that was `doing` (by what [`cause`] says).
    pub fn new(doing: impl Into<String>) -> Self {
        Self {
            cause: interrupted(),
            doing: doing.into(),
        }
    }
}

/// Ends a set-up that was `doing` once a stop was requested.
pub fn check_set_up(doing: &str) -> Result<(), SetUpInterrupted> {
    if requested() {
        return Err(SetUpInterrupted::new(doing));
    }
    Ok(())
}

/// Errors once a stop was requested, for `?` in a loop that holds a device.
pub fn check() -> anyhow::Result<()> {
    if requested() {
        anyhow::bail!("{}; the array was left silent", interrupted());
    }
    Ok(())
}

/// Requests a stop when `input` ends (or fails to read): what `lmhost
/// session --exit-with-stdin` does with its stdin, so a session started
/// by another program ends with that program. The owner keeps the writing
/// end of a pipe on our stdin and never writes; when it dies, however it
/// dies (SIGKILL included), the kernel closes that end and the read here
/// returns 0. Unlike `prctl(PR_SET_PDEATHSIG)` this needs no code between
/// fork and exec, is not Linux-only, and is not fired by the exit of the
/// owner's *thread* that happened to start us. Anything read is ignored;
/// the reading thread is left to end with the process.
pub fn when_ends(input: impl std::io::Read + Send + 'static) -> std::io::Result<()> {
    watch(input, || ask(OWNER_GONE))
}

/// Reads `input` to its end on a thread of its own, then calls `then`.
fn watch(
    mut input: impl std::io::Read + Send + 'static,
    then: impl FnOnce() + Send + 'static,
) -> std::io::Result<()> {
    std::thread::Builder::new()
        .name("lmhost-owner".into())
        .spawn(move || {
            let mut buf = [0u8; 512];
            loop {
                match input.read(&mut buf) {
                    Ok(0) => break,
                    Ok(_) => {}
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                    Err(_) => break,
                }
            }
            then();
        })
        .map(drop)
}

/// The line a non-graceful command's end says, one static string per
/// signal of [`SIGNALS`] (the handler may not format); it adds
/// [`REMOVED`] when it removed an unfinished output.
fn ending_line(sig: libc::c_int) -> &'static [u8] {
    match sig {
        libc::SIGINT => b"lmhost: interrupted by SIGINT",
        libc::SIGTERM => b"lmhost: interrupted by SIGTERM",
        libc::SIGHUP => b"lmhost: interrupted by SIGHUP",
        libc::SIGQUIT => b"lmhost: interrupted by SIGQUIT",
        libc::SIGUSR1 => b"lmhost: interrupted by SIGUSR1",
        libc::SIGUSR2 => b"lmhost: interrupted by SIGUSR2",
        libc::SIGALRM => b"lmhost: interrupted by SIGALRM",
        libc::SIGVTALRM => b"lmhost: interrupted by SIGVTALRM",
        libc::SIGPROF => b"lmhost: interrupted by SIGPROF",
        libc::SIGXCPU => b"lmhost: interrupted by SIGXCPU",
        libc::SIGXFSZ => b"lmhost: interrupted by SIGXFSZ",
        libc::SIGIO => b"lmhost: interrupted by SIGIO",
        #[cfg(target_os = "linux")]
        libc::SIGPWR => b"lmhost: interrupted by SIGPWR",
        #[cfg(target_os = "linux")]
        libc::SIGSTKFLT => b"lmhost: interrupted by SIGSTKFLT",
        _ => b"lmhost: interrupted by a signal",
    }
}

/// What the end line adds when unfinished outputs were removed.
const REMOVED: &[u8] = b"; unfinished outputs removed";

extern "C" fn on_signal(sig: libc::c_int) {
    // Async-signal-safe only: atomics, unlink(2), write(2), _exit(2).
    ask(sig);
    if GRACEFUL.load(Ordering::SeqCst) {
        return;
    }
    let mut removed = false;
    for slot in &TEMPS {
        let p = slot.load(Ordering::SeqCst);
        if !p.is_null() {
            // SAFETY: `p` is a leaked, NUL-terminated C string (never freed).
            removed |= unsafe { libc::unlink(p) } == 0;
        }
    }
    // Until a pass removes none: a parent may sit in a slot before its
    // child's (a slot freed and taken again).
    let mut more = true;
    while more {
        more = false;
        for slot in &DIRS {
            let p = slot.load(Ordering::SeqCst);
            // SAFETY: as above; rmdir(2) is async-signal-safe and removes
            // an empty directory only (one removed fails the next pass).
            if !p.is_null() && unsafe { libc::rmdir(p) } == 0 {
                more = true;
            }
        }
    }
    let parts: [&[u8]; 3] = [ending_line(sig), if removed { REMOVED } else { b"" }, b"\n"];
    for part in parts {
        // SAFETY: write(2) is async-signal-safe; `part` is a static
        // string. A lost stderr changes nothing but what can be said.
        let _ = unsafe { libc::write(libc::STDERR_FILENO, part.as_ptr().cast(), part.len()) };
    }
    // SAFETY: _exit is async-signal-safe; no destructors run, which is
    // what the default action of the signal would have done too.
    unsafe { libc::_exit(128 + sig) };
}

/// Install the handler of [`SIGNALS`] (once, from `main`).
pub fn install() -> anyhow::Result<()> {
    use nix::sys::signal::{SaFlags, SigAction, SigHandler, SigSet, sigaction};
    let act = SigAction::new(
        SigHandler::Handler(on_signal),
        SaFlags::empty(),
        SigSet::empty(),
    );
    for &sig in SIGNALS {
        // SAFETY: the handler does only async-signal-safe work (atomics,
        // unlink, write, _exit); no other handler for these signals exists.
        unsafe { sigaction(sig, &act) }
            .map_err(|e| anyhow::anyhow!("installing the {sig} handler: {e}"))?;
    }
    Ok(())
}

/// A temporary file (or an output directory) the handler removes if a
/// signal ends the process.
#[derive(Debug)]
pub(crate) struct TempGuard(Option<usize>, &'static [AtomicPtr<c_char>]);

impl TempGuard {
    /// Register `path`; `None` inside when all slots are taken (the file is
    /// then only removed by `Drop`).
    pub(crate) fn register(path: &std::path::Path) -> TempGuard {
        Self::register_in(&TEMPS, path)
    }

    /// Register the output directory `path`, removed (when empty) after
    /// the temporary files.
    pub(crate) fn register_dir(path: &std::path::Path) -> TempGuard {
        Self::register_in(&DIRS, path)
    }

    fn register_in(slots: &'static [AtomicPtr<c_char>], path: &std::path::Path) -> TempGuard {
        use std::os::unix::ffi::OsStrExt as _;
        let Ok(c) = CString::new(path.as_os_str().as_bytes()) else {
            return TempGuard(None, slots);
        };
        let p = c.into_raw();
        for (i, slot) in slots.iter().enumerate() {
            if slot
                .compare_exchange(std::ptr::null_mut(), p, Ordering::SeqCst, Ordering::SeqCst)
                .is_ok()
            {
                return TempGuard(Some(i), slots);
            }
        }
        // SAFETY: `p` came from `into_raw` above and was not shared.
        drop(unsafe { CString::from_raw(p) });
        TempGuard(None, slots)
    }
}

impl Drop for TempGuard {
    fn drop(&mut self) {
        if let Some(i) = self.0 {
            // Leaked on purpose: the handler may be reading it right now.
            self.1[i].store(std::ptr::null_mut(), Ordering::SeqCst);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_end_of_the_owners_pipe_is_seen_and_nothing_before() {
        // Through `watch`: the real stop flag is process-wide, and other
        // tests poll it.
        let (r, mut w) = std::io::pipe().expect("a pipe");
        let (tx, rx) = std::sync::mpsc::channel();
        watch(r, move || tx.send(()).expect("the test waits")).expect("the watcher starts");
        std::io::Write::write_all(&mut w, b"anything the owner writes is ignored\n").unwrap();
        assert!(
            rx.recv_timeout(std::time::Duration::from_millis(50))
                .is_err(),
            "ended while the owner still held its end"
        );
        drop(w);
        rx.recv_timeout(std::time::Duration::from_secs(10))
            .expect("no end seen after the owner's end closed");
    }

    #[test]
    fn every_ending_signal_has_its_own_line() {
        for &sig in SIGNALS {
            let line = std::str::from_utf8(ending_line(sig as libc::c_int)).unwrap();
            assert_eq!(line, format!("lmhost: interrupted by {sig}"));
        }
    }

    #[test]
    fn a_temp_file_is_registered_until_dropped() {
        let path = std::env::temp_dir().join("lmhost-stop-test");
        let g = TempGuard::register(&path);
        let i = g.0.expect("a free slot");
        let p = TEMPS[i].load(Ordering::SeqCst);
        // SAFETY: registered slots hold leaked C strings.
        let s = unsafe { std::ffi::CStr::from_ptr(p) };
        assert_eq!(s.to_str().unwrap(), path.to_str().unwrap());
        drop(g);
        assert!(TEMPS[i].load(Ordering::SeqCst) != p);
    }
}
