//! The simulated device: the firmware core ([`lm_fw_core`]) on the host,
//! behind a pseudo-terminal with a real clock (`lmhost sim`), or in process
//! behind a [`Transport`] with a real or virtual clock (the demo, tests).
//!
//! Time is [`crate::clock`]'s: microseconds of `CLOCK_MONOTONIC`, shared
//! with the host.

use std::collections::VecDeque;
use std::os::fd::{AsFd, OwnedFd};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use anyhow::Context as _;

use crate::clock::{Clock, STATS_RING, monotonic_us, push_ring};
use crate::device::link::Transport;
use crate::device::link::proxy::{Faults, Faulty};

/// Ask for real-time (FIFO) scheduling of the calling thread, so step
/// deadlines and centroid updates are not delayed behind other processes.
/// The loops that call it sleep between events, so they cannot starve the
/// machine. Returns whether the system granted it (it needs
/// `CAP_SYS_NICE`); without it everything works, with more jitter.
pub fn try_realtime() -> bool {
    let param = libc::sched_param { sched_priority: 10 };
    // SAFETY: plain FFI call on the current thread with a valid parameter.
    unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) == 0 }
}

/// A device core the simulator can run: bytes in, bytes out, a clock.
pub trait Core: Send {
    /// Handle received bytes at `now_us`; append response bytes to `out`.
    fn receive(&mut self, now_us: u64, bytes: &[u8], out: &mut Vec<u8>);
    /// Play every step due by `now_us`; returns the next deadline, if any.
    fn poll(&mut self, now_us: u64) -> Option<u64>;
    /// What the simulator measured so far.
    fn stats(&self) -> SimStats;
}

/// Measurements only a simulated device can make.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct SimStats {
    /// Output frames written (steps played, muted or not).
    pub frames: u64,
    /// Output frames written muted.
    pub muted_frames: u64,
    /// Centroid updates applied to an output frame.
    pub centroids_applied: u64,
    /// Per applied centroid: µs from `host_time_us` to the start of the
    /// first step that used it. Bounded ring of the most recent.
    pub latencies_us: VecDeque<u64>,
    /// Per output frame: µs between its due time and when it was written
    /// (the simulator's own scheduling error). Bounded ring.
    pub step_late_us: VecDeque<u64>,
    /// Whether the last frame was muted.
    pub muted_now: bool,
    /// Mute transitions: (µs the first frame of the new state went out:
    /// its due time, or later when it was written late, muted), the most
    /// recent [`STATS_RING`]. A late frame counts when it went out, so a
    /// mute caused by a centroid is never stamped before that centroid.
    pub mute_changes: VecDeque<(u64, bool)>,
}

/// The device in process, as a [`Transport`]: every send is handled at
/// once; a receive with nothing pending waits for the timeout (real clock)
/// or advances the virtual clock by it, playing the steps due meanwhile.
pub struct InProcess<C: Core> {
    core: Arc<Mutex<C>>,
    clock: Clock,
    pending: VecDeque<u8>,
}

impl<C: Core> InProcess<C> {
    /// Wrap `core`, sharing it so the caller can read its stats.
    pub fn new(core: Arc<Mutex<C>>, clock: Clock) -> Self {
        Self {
            core,
            clock,
            pending: VecDeque::new(),
        }
    }

    /// Play the steps due up to `until_us` (virtual clock: also sets it).
    pub fn advance_to(&mut self, until_us: u64) {
        let mut core = self.core.lock().unwrap_or_else(|e| e.into_inner());
        if self.clock.is_manual() {
            let mut now = self.clock.now_us();
            // Step through every deadline so the player never sees a jump.
            while let Some(next) = core.poll(now) {
                if next > until_us {
                    break;
                }
                now = next.max(now + 1);
            }
            self.clock.set_us(until_us.max(now));
            core.poll(until_us);
        } else {
            core.poll(self.clock.now_us());
        }
    }
}

impl<C: Core> Transport for InProcess<C> {
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        let now = self.clock.now_us();
        self.advance_to(now);
        let mut out = Vec::new();
        self.core
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .receive(now, bytes, &mut out);
        self.pending.extend(out);
        Ok(())
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> std::io::Result<usize> {
        if self.pending.is_empty() {
            if !self.clock.is_manual() {
                std::thread::sleep(timeout);
            }
            let until = self.clock.now_us() + timeout.as_micros() as u64;
            self.advance_to(until);
            return Ok(0);
        }
        let n = self.pending.len().min(buf.len());
        for (b, p) in buf.iter_mut().zip(self.pending.drain(..n)) {
            *b = p;
        }
        Ok(n)
    }

    fn describe(&self) -> String {
        "in-process simulated device".into()
    }

    fn discard_input(&mut self) -> std::io::Result<()> {
        self.pending.clear();
        Ok(())
    }

    fn now(&self) -> Duration {
        self.clock.now()
    }
}

/// A pseudo-terminal pair: the device holds the master, clients open the
/// slave by path.
pub struct Pty {
    master: OwnedFd,
    /// Held open so the master never sees a hang-up between clients.
    _slave: OwnedFd,
    /// The slave's path, for `--port`.
    pub path: String,
}

impl Pty {
    /// Open a raw-mode pty.
    pub fn open() -> anyhow::Result<Self> {
        let (master, slave, path) = raw_pty()?;
        let flags = nix::fcntl::fcntl(&master, nix::fcntl::FcntlArg::F_GETFL)
            .context("reading pty flags")?;
        let flags = nix::fcntl::OFlag::from_bits_truncate(flags) | nix::fcntl::OFlag::O_NONBLOCK;
        nix::fcntl::fcntl(&master, nix::fcntl::FcntlArg::F_SETFL(flags))
            .context("making the pty non-blocking")?;
        Ok(Self {
            master,
            _slave: slave,
            path,
        })
    }
}

/// A raw-mode pty, blocking both ends: its master, its slave and the
/// slave's path (for a `--port`; an instrument's peer in the tests).
pub fn raw_pty() -> anyhow::Result<(OwnedFd, OwnedFd, String)> {
    use nix::sys::termios;
    let pair = nix::pty::openpty(None, None).context("opening a pseudo-terminal")?;
    let mut t = termios::tcgetattr(&pair.slave).context("reading pty settings")?;
    termios::cfmakeraw(&mut t);
    termios::tcsetattr(&pair.slave, termios::SetArg::TCSANOW, &t)
        .context("setting the pty to raw mode")?;
    let path = nix::unistd::ttyname(&pair.slave)
        .context("naming the pty")?
        .to_string_lossy()
        .into_owned();
    Ok((pair.master, pair.slave, path))
}

/// Options of a served simulated device.
#[derive(Debug, Clone, Default)]
pub struct ServeOptions {
    /// Damage the device's side of the link (both directions).
    pub faults: Option<(Faults, u64)>,
}

/// Where [`serve`] listens: a pty (its slave is held open so the master
/// never sees a hang-up between clients) or one end of a socket pair.
pub enum Endpoint {
    /// A raw-mode pty.
    Pty(Pty),
    /// Any non-blocking byte-stream fd.
    Fd(OwnedFd),
}

impl From<Pty> for Endpoint {
    fn from(p: Pty) -> Self {
        Self::Pty(p)
    }
}

impl From<OwnedFd> for Endpoint {
    fn from(fd: OwnedFd) -> Self {
        Self::Fd(fd)
    }
}

/// Serve `core` at `at` with the real clock until `stop` is set.
pub fn serve<C: Core>(
    core: Arc<Mutex<C>>,
    at: impl Into<Endpoint>,
    opts: ServeOptions,
    stop: Arc<AtomicBool>,
) -> anyhow::Result<()> {
    let (fd, _slave) = match at.into() {
        Endpoint::Pty(Pty { master, _slave, .. }) => (master, Some(_slave)),
        Endpoint::Fd(fd) => (fd, None),
    };
    struct Master(OwnedFd);
    impl Transport for Master {
        fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
            let mut rest = bytes;
            while !rest.is_empty() {
                match nix::unistd::write(&self.0, rest) {
                    Ok(n) => rest = &rest[n..],
                    Err(nix::errno::Errno::EAGAIN) => std::thread::sleep(Duration::from_micros(50)),
                    Err(e) => return Err(e.into()),
                }
            }
            Ok(())
        }
        fn recv(&mut self, buf: &mut [u8], _timeout: Duration) -> std::io::Result<usize> {
            match nix::unistd::read(self.0.as_fd(), buf) {
                Ok(n) => Ok(n),
                Err(nix::errno::Errno::EAGAIN) | Err(nix::errno::Errno::EIO) => Ok(0),
                Err(e) => Err(e.into()),
            }
        }
        fn describe(&self) -> String {
            "pty master".into()
        }
    }
    let poll_fd = fd.try_clone().context("duplicating the device fd")?;
    let mut link: Box<dyn Transport> = match opts.faults {
        Some((f, seed)) => Box::new(Faulty::new(Master(fd), f, seed)),
        None => Box::new(Master(fd)),
    };
    let mut buf = vec![0u8; 4096];
    let mut out = Vec::new();
    try_realtime();
    while !stop.load(Ordering::Relaxed) {
        let now = monotonic_us();
        let next = core.lock().unwrap_or_else(|e| e.into_inner()).poll(now);
        // Sleep in the kernel until input or the next step, at most 20 ms so
        // `stop` is seen.
        let wait_us = next.map_or(20_000, |n| n.saturating_sub(now)).min(20_000);
        let ts = nix::sys::time::TimeSpec::from_duration(Duration::from_micros(wait_us));
        let mut fds = [nix::poll::PollFd::new(
            poll_fd.as_fd(),
            nix::poll::PollFlags::POLLIN,
        )];
        let ready = nix::poll::ppoll(&mut fds, Some(ts), None).unwrap_or(0);
        let n = link
            .recv(&mut buf, Duration::ZERO)
            .context("reading the pty")?;
        if ready > 0 && n == 0 {
            // Readable but nothing read (a hang-up, or bytes the fault
            // injector dropped): never spin, least of all at real-time
            // priority.
            std::thread::sleep(Duration::from_micros(200));
        }
        if n > 0 {
            let now = monotonic_us();
            let mut c = core.lock().unwrap_or_else(|e| e.into_inner());
            c.poll(now);
            c.receive(now, &buf[..n], &mut out);
            drop(c);
            if !out.is_empty() {
                link.send(&out).context("writing the pty")?;
                out.clear();
            }
        }
    }
    Ok(())
}

/// Settings of a simulated device.
#[derive(Debug, Clone, Copy)]
pub struct SimConfig {
    /// Steps at the full transducer count of a raw sequence; the library
    /// holds twice that (the two slots of protocol version 2; the default
    /// 400 is more than the boards' library,
    /// [`lm_fw_core::BOARD_LIBRARY_BYTES`]).
    pub slot_steps: u32,
    /// Most transducers.
    pub max_transducers: u16,
    /// Centroid timeout (µs) before the output mutes.
    pub centroid_timeout_us: u32,
    /// Mute from `Play` until the first centroid.
    pub require_tracking: bool,
    /// An SPI loopback jumper for `SelfTest` (`None`: the device has no
    /// self-test, as QEMU's board).
    pub loopback: Option<Loopback>,
}

/// The simulated board's SPI loopback (`lmhost sim --loopback`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Loopback {
    /// A jumper from MOSI to MISO: every byte comes back.
    Ok,
    /// No jumper: MISO floats high and reads 0xFF.
    Broken,
}

impl Default for SimConfig {
    /// Four AUTD3 (996 transducers), 400 steps per slot, the firmware's
    /// default 100 ms centroid timeout, tracking required, no self-test.
    fn default() -> Self {
        Self {
            slot_steps: 400,
            max_transducers: lm_fw_core::DEFAULT_TRANSDUCERS,
            centroid_timeout_us: lm_fw_core::DEFAULT_CENTROID_TIMEOUT_US,
            require_tracking: true,
            loopback: None,
        }
    }
}

/// Output driver of the simulator: counts frames, notes muting and when
/// each accepted centroid first reached an output frame.
struct Probe<'a> {
    out: &'a mut Watched,
    now_us: u64,
}

/// What the simulator keeps of the device's output between calls.
#[derive(Default)]
struct Watched {
    stats: SimStats,
    /// Accepted centroids waiting for their first frame: host stamp (µs).
    waiting: Vec<u64>,
    capture: Option<Vec<CapturedFrame>>,
    loopback: Option<Loopback>,
}

/// An output frame kept by [`FwCore::set_capture`] (tests compare them
/// with the sequence that was uploaded).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CapturedFrame {
    /// Slot it came from.
    pub slot: u8,
    /// Step within the cycle.
    pub step: u16,
    /// Amplitude (0 = muted).
    pub amplitude: u8,
    /// Intensity (the entry's, scaled by its table's level for this step).
    pub intensity: u8,
    /// Phases as sent to the transducers.
    pub phases: Vec<u8>,
}

impl lm_fw_core::OutputDriver for Probe<'_> {
    type Error = core::convert::Infallible;
    fn write_frame(&mut self, frame: &lm_fw_core::OutputFrame<'_>) -> Result<(), Self::Error> {
        self.out.stats.frames += 1;
        let muted = frame.amplitude == 0;
        if muted != self.out.stats.muted_now || self.out.stats.frames == 1 {
            if self.out.stats.mute_changes.len() == STATS_RING {
                self.out.stats.mute_changes.pop_front();
            }
            let out_us = self.now_us.max(frame.due);
            self.out.stats.mute_changes.push_back((out_us, muted));
        }
        self.out.stats.muted_now = muted;
        if muted {
            self.out.stats.muted_frames += 1;
        }
        push_ring(
            &mut self.out.stats.step_late_us,
            self.now_us.saturating_sub(frame.due),
        );
        if let Some(c) = self.out.capture.as_mut() {
            c.push(CapturedFrame {
                slot: frame.slot,
                step: frame.step,
                amplitude: frame.amplitude,
                intensity: frame.intensity,
                phases: frame.phases.to_vec(),
            });
        }
        for host_us in self.out.waiting.drain(..) {
            self.out.stats.centroids_applied += 1;
            push_ring(
                &mut self.out.stats.latencies_us,
                frame.due.saturating_sub(host_us),
            );
        }
        Ok(())
    }

    /// The firmware core's loopback test over the simulated jumper.
    fn self_test(&mut self) -> lm_proto::SelfTest {
        let Some(lb) = self.out.loopback else {
            return lm_proto::SelfTest::Unsupported;
        };
        lm_fw_core::output::loopback_test(|sent: &[u8], got: &mut [u8]| {
            match lb {
                Loopback::Ok => got.copy_from_slice(sent),
                Loopback::Broken => got.fill(0xFF),
            }
            Ok::<(), core::convert::Infallible>(())
        })
    }
}

/// [`lm_fw_core::Device`] with a 1 MHz timer (counts = µs) as a [`Core`].
pub struct FwCore {
    device: lm_fw_core::Device<'static>,
    /// Whether the device has seen the clock: it counts `uptime_ms` from
    /// the first time it does (its reset, on a clock it shares with the
    /// host).
    started: bool,
    watch: lm_proto::FrameDecoder,
    out: Watched,
}

impl FwCore {
    /// A device with `cfg`. Its sequence memory lives as long as the
    /// process (the simulator is built once per run).
    pub fn new(cfg: SimConfig) -> anyhow::Result<Self> {
        let t = cfg.max_transducers as usize;
        let bytes = lm_fw_core::memory_bytes(2 * cfg.slot_steps as usize * t, t);
        let mem: &'static mut [u8] = Box::leak(vec![0u8; bytes].into_boxed_slice());
        let mut c = lm_fw_core::Config::new(1_000_000);
        c.max_transducers = cfg.max_transducers;
        c.centroid_timeout_us = cfg.centroid_timeout_us;
        c.require_tracking = cfg.require_tracking;
        c.clock = lm_proto::ClockSource::Emulated;
        let device = lm_fw_core::Device::new(c, mem)
            .map_err(|e| anyhow::anyhow!("building the simulated device: {e}"))?;
        Ok(Self {
            device,
            started: false,
            watch: lm_proto::FrameDecoder::new(),
            out: Watched {
                loopback: cfg.loopback,
                ..Watched::default()
            },
        })
    }

    /// Keep every output frame from now on (or stop keeping them).
    pub fn set_capture(&mut self, on: bool) {
        self.out.capture = on.then(Vec::new);
    }

    /// The frames kept since the last call.
    pub fn take_captured(&mut self) -> Vec<CapturedFrame> {
        self.out
            .capture
            .as_mut()
            .map(std::mem::take)
            .unwrap_or_default()
    }

    /// The device's status at `now_us`.
    pub fn status(&self, now_us: u64) -> lm_proto::Status {
        self.device.status(now_us)
    }

    /// Sets the time the device was reset, from which its `uptime_ms`
    /// counts (a test's device that has been on for a while); without it
    /// the device counts from the first moment it sees the clock.
    pub fn set_epoch(&mut self, epoch_us: u64) {
        self.device.set_epoch(epoch_us);
        self.started = true;
    }

    /// The device's reset is the first moment it sees the clock.
    fn start(&mut self, now_us: u64) {
        if !self.started {
            self.device.set_epoch(now_us);
            self.started = true;
        }
    }
}

impl Core for FwCore {
    fn receive(&mut self, now_us: u64, bytes: &[u8], out: &mut Vec<u8>) {
        self.start(now_us);
        // Watch for centroids so their latency can be measured; the device
        // decodes the same bytes itself.
        let mut centroids = Vec::new();
        let mut input = bytes;
        loop {
            input = match self.watch.feed(input) {
                lm_proto::FeedResult::Consumed => break,
                lm_proto::FeedResult::Frame { frame, remaining } => {
                    if let lm_proto::Message::Centroid(c) = frame.message {
                        centroids.push(c);
                    }
                    remaining
                }
                lm_proto::FeedResult::Error { remaining, .. } => remaining,
            };
        }
        let before = self.device.status(now_us).last_centroid_seq;
        let mut probe = Probe {
            out: &mut self.out,
            now_us,
        };
        self.device
            .feed(bytes, now_us, &mut probe, &mut |reply: &[u8]| {
                out.extend_from_slice(reply)
            });
        let after = self.device.status(now_us).last_centroid_seq;
        if after != before
            && let Some(c) = centroids.iter().find(|c| c.seq == after && c.present)
        {
            self.out.waiting.push(c.host_time_us);
        }
        self.poll(now_us);
    }

    fn poll(&mut self, now_us: u64) -> Option<u64> {
        self.start(now_us);
        let mut probe = Probe {
            out: &mut self.out,
            now_us,
        };
        // Nothing plays: centroids are not waiting for a frame.
        let next = self.device.poll(now_us, &mut probe);
        if next.is_none() {
            self.out.waiting.clear();
        }
        next
    }

    fn stats(&self) -> SimStats {
        self.out.stats.clone()
    }
}

/// A simulated device served on a pty from a thread of this process
/// (the demo's device). Stops when dropped.
pub struct SimThread {
    /// The device, to read its measurements.
    pub core: Arc<Mutex<FwCore>>,
    /// The pty path to connect to.
    pub path: String,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<anyhow::Result<()>>>,
}

impl SimThread {
    /// Start serving a device built from `cfg` on one end of a Unix socket
    /// pair; returns the other end for the host. No pty: the kernel wakes
    /// the device directly, without the tty layer's deferred work.
    pub fn start_socket(cfg: SimConfig) -> anyhow::Result<(Self, std::os::unix::net::UnixStream)> {
        let core = Arc::new(Mutex::new(FwCore::new(cfg)?));
        let (host, dev) =
            std::os::unix::net::UnixStream::pair().context("creating a socket pair")?;
        dev.set_nonblocking(true)
            .context("making the device socket non-blocking")?;
        let stop = Arc::new(AtomicBool::new(false));
        let (c, s) = (core.clone(), stop.clone());
        let thread = std::thread::Builder::new()
            .name("lmhost-sim".into())
            .spawn(move || serve(c, OwnedFd::from(dev), ServeOptions::default(), s))
            .context("starting the simulator thread")?;
        let path = "socket pair".to_owned();
        Ok((
            Self {
                core,
                path,
                stop,
                thread: Some(thread),
            },
            host,
        ))
    }

    /// Start serving a device built from `cfg`.
    pub fn start(cfg: SimConfig) -> anyhow::Result<Self> {
        let core = Arc::new(Mutex::new(FwCore::new(cfg)?));
        let pty = Pty::open()?;
        let path = pty.path.clone();
        let stop = Arc::new(AtomicBool::new(false));
        let (c, s) = (core.clone(), stop.clone());
        let thread = std::thread::Builder::new()
            .name("lmhost-sim".into())
            .spawn(move || serve(c, pty, ServeOptions::default(), s))
            .context("starting the simulator thread")?;
        Ok(Self {
            core,
            path,
            stop,
            thread: Some(thread),
        })
    }

    /// What the device measured so far.
    pub fn stats(&self) -> SimStats {
        self.core.lock().unwrap_or_else(|e| e.into_inner()).stats()
    }

    /// Stop serving; reports a failure of the serving loop.
    pub fn stop(mut self) -> anyhow::Result<()> {
        self.halt()
    }

    fn halt(&mut self) -> anyhow::Result<()> {
        self.stop.store(true, Ordering::Relaxed);
        match self.thread.take().map(|t| t.join()) {
            Some(Ok(r)) => r,
            Some(Err(_)) => Err(anyhow::anyhow!("the simulator thread failed")),
            None => Ok(()),
        }
    }
}

impl Drop for SimThread {
    fn drop(&mut self) {
        let _ = self.halt();
    }
}
