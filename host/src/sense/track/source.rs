//! Where depth frames come from: a recording (`.npy`), the synthetic
//! finger, or a live stream in the `LMDEPTH1` format (the RealSense bridge,
//! or any tool writing it to stdin); and the recorder.
//!
//! `LMDEPTH1` stream (all little-endian):
//! - header, 56 bytes: the 8 ASCII bytes `LMDEPTH1`, `u32` width, `u32`
//!   height, then `f64` fx, fy, ppx, ppy, depth_scale (see [`Intrinsics`]);
//! - then per frame: `f64` time stamp (s), width × height `u16` depth values,
//!   row-major (Z16: 0 = no data).
//!
//! The stream ends at a frame boundary; a partial frame is an error.
//!
//! The live camera (`lmhost track --camera`) is this stream produced by a
//! small Python bridge on the `pyrealsense2` wheel ([`BRIDGE_PY`], embedded
//! and run as `python3 -c`; `LMHOST_PYTHON` picks another interpreter). A
//! direct V4L2 path was not taken: the crates.io V4L2 bindings (`v4l` /
//! `v4l2-sys-mit`) run bindgen at build time, which needs libclang and
//! kernel headers, and librealsense's own wheel also sets the depth units
//! and reports calibrated intrinsics. The bridge needs no Cargo feature:
//! nothing is linked. Any other tool can write the stream to
//! `lmhost track --stream -`.
//!
//! A recording `REC.npy` is replayed with its intrinsics from
//! `REC.intrinsics.toml` and time stamps from `REC.timestamps.npy` when
//! those files sit beside it and no other is given.

use std::io::Read;
use std::path::{Path, PathBuf};

use super::contact::Tracker;
use super::intrinsics::Intrinsics;
use super::synth::{FingerSim, Truth};
use crate::InputError;
use crate::npy::{DepthNpy, DepthNpyWriter, read_timestamps, write_f64_1d};
use crate::sense::stream::run::Next;

/// Stream magic.
pub const MAGIC: &[u8; 8] = b"LMDEPTH1";

/// Default frame rate when a recording has no time stamps (the paper's 90 fps).
pub const DEFAULT_FPS: f64 = 90.0;

/// One depth frame.
#[derive(Debug, Clone)]
pub struct Frame {
    /// Time stamp (s).
    pub t_s: f64,
    /// Row-major depth values.
    pub depth: Vec<u16>,
    /// Ground truth (synthetic frames only).
    pub truth: Option<Truth>,
}

/// A source of frames.
pub trait FrameSource {
    /// The frames' intrinsics.
    fn intrinsics(&self) -> Intrinsics;
    /// The next frame, `None` at the end.
    fn next_frame(&mut self) -> anyhow::Result<Option<Frame>>;
    /// Whether the source is live (already paced by the sensor).
    fn live(&self) -> bool {
        false
    }
    /// The next frame if one comes within `wait` (a source read on its own
    /// thread, [`Live`], can idle; others block until it comes).
    fn next_frame_within(&mut self, _wait: std::time::Duration) -> anyhow::Result<Next<Frame>> {
        Ok(self.next_frame()?.map_or(Next::End, Next::Ready))
    }
}

/// Frames buffered between a reader thread and the tracker (a few: a
/// frame is up to a few MB).
const FRAMES_AHEAD: usize = 4;

/// How long a live source may take to send its `LMDEPTH1` header (the
/// camera's start-up included) before it counts as stalled.
pub const HEADER_DEADLINE: std::time::Duration = std::time::Duration::from_secs(10);
/// The longest silence between two frames of a live source (or inside a
/// frame) before it counts as stalled: the run ends with an error and the
/// camera bridge is killed.
pub const FRAME_DEADLINE: std::time::Duration = std::time::Duration::from_secs(5);

/// A live `LMDEPTH1` source (the camera bridge, `--stream`), read on its
/// own thread ([`crate::sense::reader`]) so the streaming loop keeps the device's
/// housekeeping running while no frame arrives, and held to
/// [`HEADER_DEADLINE`] and [`FRAME_DEADLINE`]: a source that stalls, even in
/// the middle of a frame, ends the run with a clear error in bounded time.
pub struct Live {
    frames: crate::sense::reader::Reader<Frame>,
    intr: Intrinsics,
    what: String,
    last: std::time::Instant,
    /// The bridge process, killed on a stall and when the source is dropped.
    child: Option<u32>,
}

impl Live {
    /// Reads the stream `open` makes (on the reader thread: opening it may
    /// block) and waits at most [`HEADER_DEADLINE`] for its header. `child`
    /// is the producing process, if lmhost started one.
    pub fn start<R, F>(what: &str, child: Option<u32>, open: F) -> anyhow::Result<Live>
    where
        R: Read + 'static,
        F: FnOnce() -> anyhow::Result<Stream<R>> + Send + 'static,
    {
        let (htx, hrx) = std::sync::mpsc::sync_channel(1);
        let frames = crate::sense::reader::spawn("lmhost-frames", FRAMES_AHEAD, move || {
            let stream = open();
            let (header, stream) = match stream {
                Ok(s) => (Ok(s.intr), Some(s)),
                Err(e) => (Err(e), None),
            };
            let _ = htx.send(header);
            let mut stream = stream;
            std::iter::from_fn(move || stream.as_mut()?.next_frame().transpose())
        })?;
        let mut live = Live {
            frames,
            intr: Intrinsics::D435_848X480,
            what: what.to_owned(),
            last: std::time::Instant::now(),
            child,
        };
        match hrx.recv_timeout(HEADER_DEADLINE) {
            Ok(Ok(intr)) => live.intr = intr,
            Ok(Err(e)) => return Err(e),
            Err(_) => {
                live.kill();
                anyhow::bail!(
                    "{what} sent no LMDEPTH1 header within {} s: it is stalled (or not an LMDEPTH1 source)",
                    HEADER_DEADLINE.as_secs()
                );
            }
        }
        live.last = std::time::Instant::now();
        Ok(live)
    }

    fn kill(&mut self) {
        if let Some(pid) = self.child.take() {
            // SAFETY: kill(2) on a pid this process spawned; no memory is touched.
            unsafe { libc::kill(pid as libc::pid_t, libc::SIGKILL) };
        }
    }

    fn stalled(&mut self) -> anyhow::Error {
        self.kill();
        anyhow::anyhow!(
            "{}: no frame for {} s: the source is stalled{}",
            self.what,
            FRAME_DEADLINE.as_secs(),
            if self.child.is_none() {
                ""
            } else {
                " (killed)"
            }
        )
    }
}

impl Drop for Live {
    fn drop(&mut self) {
        self.kill();
    }
}

impl FrameSource for Live {
    fn intrinsics(&self) -> Intrinsics {
        self.intr
    }
    fn live(&self) -> bool {
        true
    }
    fn next_frame(&mut self) -> anyhow::Result<Option<Frame>> {
        loop {
            match self.next_frame_within(std::time::Duration::from_millis(100))? {
                Next::Ready(f) => return Ok(Some(f)),
                Next::End => return Ok(None),
                Next::Idle if crate::stop::requested() => return Ok(None),
                Next::Idle => {}
            }
        }
    }
    fn next_frame_within(&mut self, wait: std::time::Duration) -> anyhow::Result<Next<Frame>> {
        let left = FRAME_DEADLINE.saturating_sub(self.last.elapsed());
        if left.is_zero() {
            return Err(self.stalled());
        }
        match self.frames.next_within(wait.min(left)) {
            Next::Ready(f) => {
                self.last = std::time::Instant::now();
                Ok(Next::Ready(f?))
            }
            Next::Idle => Ok(Next::Idle),
            Next::End => Ok(Next::End),
        }
    }
}

/// `REC.intrinsics.toml` beside `REC.npy`.
pub fn intrinsics_beside(npy: &Path) -> PathBuf {
    npy.with_extension("intrinsics.toml")
}

/// `REC.timestamps.npy` beside `REC.npy`.
pub fn timestamps_beside(npy: &Path) -> PathBuf {
    npy.with_extension("timestamps.npy")
}

/// Replay of a `.npy` recording.
pub struct Replay {
    npy: DepthNpy,
    intr: Intrinsics,
    times: Option<Vec<f64>>,
    index: u64,
}

impl Replay {
    /// Open `depth` with `intr`; `times` (s) must have one entry per frame.
    pub fn open(
        depth: &Path,
        intr: Intrinsics,
        times: Option<Vec<f64>>,
    ) -> Result<Self, InputError> {
        let npy = DepthNpy::open(depth)?;
        intr.check_frames(npy.width, npy.height, &depth.display().to_string())?;
        if let Some(t) = &times
            && t.len() as u64 != npy.frames
        {
            return Err(InputError::new(format!(
                "{} time stamps for {} frames in {}",
                t.len(),
                npy.frames,
                depth.display()
            )));
        }
        Ok(Self {
            npy,
            intr,
            times,
            index: 0,
        })
    }

    /// Open `depth`, finding intrinsics and time stamps beside it unless given.
    pub fn open_with_defaults(
        depth: &Path,
        intrinsics: Option<&Path>,
        timestamps: Option<&Path>,
    ) -> Result<Self, InputError> {
        let ipath = match intrinsics {
            Some(p) => p.to_owned(),
            None => {
                let p = intrinsics_beside(depth);
                if !p.exists() {
                    return Err(InputError::new(format!(
                        "--intrinsics is needed (no {} beside the recording)",
                        p.display()
                    )));
                }
                p
            }
        };
        let intr = Intrinsics::load(&ipath)?;
        let tpath = timestamps.map(Path::to_owned).or_else(|| {
            let p = timestamps_beside(depth);
            p.exists().then_some(p)
        });
        let times = tpath.as_deref().map(read_timestamps).transpose()?;
        Self::open(depth, intr, times)
    }

    /// Frames in the recording.
    pub fn frames(&self) -> u64 {
        self.npy.frames
    }
}

impl FrameSource for Replay {
    fn intrinsics(&self) -> Intrinsics {
        self.intr
    }
    fn next_frame(&mut self) -> anyhow::Result<Option<Frame>> {
        let mut depth = Vec::new();
        if !self.npy.read_into(&mut depth)? {
            return Ok(None);
        }
        let i = self.index;
        self.index += 1;
        let t_s = match &self.times {
            Some(t) => t[i as usize],
            None => i as f64 / DEFAULT_FPS,
        };
        Ok(Some(Frame {
            t_s,
            depth,
            truth: None,
        }))
    }
}

/// The synthetic finger as a frame source.
pub struct Synthetic {
    sim: FingerSim,
    tracker: Tracker,
    frames: u64,
    index: u64,
}

impl Synthetic {
    /// `seconds` of the synthetic finger.
    pub fn new(sim: FingerSim, seconds: f64) -> Self {
        Self {
            tracker: Tracker::new(sim.intr, sim.setup),
            frames: (seconds * sim.rate_hz).round() as u64,
            sim,
            index: 0,
        }
    }
}

impl FrameSource for Synthetic {
    fn intrinsics(&self) -> Intrinsics {
        self.sim.intr
    }
    fn next_frame(&mut self) -> anyhow::Result<Option<Frame>> {
        if self.index >= self.frames {
            return Ok(None);
        }
        let mut depth = Vec::new();
        let (t_s, truth) = self.sim.render(self.index, &self.tracker, &mut depth);
        self.index += 1;
        Ok(Some(Frame {
            t_s,
            depth,
            truth: Some(truth),
        }))
    }
}

/// An `LMDEPTH1` stream.
pub struct Stream<R: Read> {
    reader: R,
    intr: Intrinsics,
    what: String,
    frames: u64,
    last_t: f64,
    child: Option<std::process::Child>,
}

fn read_full<R: Read>(r: &mut R, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut got = 0;
    while got < buf.len() {
        match r.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(got)
}

impl<R: Read> Stream<R> {
    /// Read the header from `reader`; `what` names the stream in errors.
    pub fn new(mut reader: R, what: &str) -> anyhow::Result<Self> {
        let mut h = [0u8; 56];
        let n = read_full(&mut reader, &mut h)?;
        if n < h.len() {
            return Err(InputError::new(format!(
                "{what}: ended after {n} bytes, before its 56-byte LMDEPTH1 header"
            ))
            .into());
        }
        if &h[..8] != MAGIC {
            return Err(
                InputError::new(format!("{what}: not an LMDEPTH1 stream (bad magic)")).into(),
            );
        }
        let u = |i: usize| u32::from_le_bytes(h[i..i + 4].try_into().expect("4 bytes"));
        let f = |i: usize| f64::from_le_bytes(h[i..i + 8].try_into().expect("8 bytes"));
        let intr = Intrinsics {
            width: u(8),
            height: u(12),
            fx: f(16),
            fy: f(24),
            ppx: f(32),
            ppy: f(40),
            depth_scale: f(48),
        };
        intr.check(what)?;
        Ok(Self {
            reader,
            intr,
            what: what.to_owned(),
            frames: 0,
            last_t: f64::NEG_INFINITY,
            child: None,
        })
    }
}

impl<R: Read> FrameSource for Stream<R> {
    fn intrinsics(&self) -> Intrinsics {
        self.intr
    }
    fn live(&self) -> bool {
        true
    }
    fn next_frame(&mut self) -> anyhow::Result<Option<Frame>> {
        let mut t = [0u8; 8];
        let n = read_full(&mut self.reader, &mut t)?;
        if n == 0 {
            if let Some(mut c) = self.child.take() {
                let status = c.wait()?;
                if !status.success() && self.frames == 0 {
                    anyhow::bail!("the RealSense bridge exited ({status}) before sending a frame");
                }
            }
            return Ok(None);
        }
        let px = self.intr.width as usize * self.intr.height as usize;
        let mut bytes = vec![0u8; px * 2];
        if n < 8 || read_full(&mut self.reader, &mut bytes)? < bytes.len() {
            return Err(InputError::new(format!(
                "{}: ended inside frame {}",
                self.what, self.frames
            ))
            .into());
        }
        let t_s = f64::from_le_bytes(t);
        if !t_s.is_finite() || t_s < self.last_t {
            return Err(InputError::new(format!(
                "{}: frame {} has time stamp {t_s}, not finite and non-decreasing",
                self.what, self.frames
            ))
            .into());
        }
        self.last_t = t_s;
        self.frames += 1;
        let depth = bytes
            .chunks_exact(2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]))
            .collect();
        Ok(Some(Frame {
            t_s,
            depth,
            truth: None,
        }))
    }
}

/// The header of an `LMDEPTH1` stream for `intr`.
pub fn stream_header(intr: &Intrinsics) -> Vec<u8> {
    let mut out = MAGIC.to_vec();
    out.extend_from_slice(&intr.width.to_le_bytes());
    out.extend_from_slice(&intr.height.to_le_bytes());
    for v in [intr.fx, intr.fy, intr.ppx, intr.ppy, intr.depth_scale] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// One frame of an `LMDEPTH1` stream.
pub fn stream_frame(t_s: f64, depth: &[u16]) -> Vec<u8> {
    let mut out = t_s.to_le_bytes().to_vec();
    for v in depth {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// The RealSense bridge (Python, `pyrealsense2`), embedded.
pub const BRIDGE_PY: &str = include_str!("realsense_bridge.py");

/// Start the RealSense bridge and read its stream: the live camera, held
/// to the live deadlines ([`Live`]). Fails (exit 1) with one line when
/// python3, pyrealsense2 or a camera is missing, or the bridge stalls (it
/// is killed then).
pub fn camera() -> anyhow::Result<Live> {
    use std::process::{Command, Stdio};
    let python = std::env::var("LMHOST_PYTHON").unwrap_or_else(|_| "python3".into());
    let mut child = Command::new(&python)
        .args(["-c", BRIDGE_PY])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|_| {
            anyhow::anyhow!(
                "no camera: cannot run `{python}` (the RealSense bridge needs python3 with pyrealsense2)"
            )
        })?;
    let pid = child.id();
    let (Some(stdout), Some(mut stderr)) = (child.stdout.take(), child.stderr.take()) else {
        anyhow::bail!("the RealSense bridge has no output pipes");
    };
    // Drain the bridge's diagnostics so it never blocks on them; keep the
    // last line for the error when it sends no stream.
    let last_line = std::sync::Arc::new(std::sync::Mutex::new(String::new()));
    let keep = last_line.clone();
    std::thread::spawn(move || {
        let mut msg = String::new();
        let _ = stderr.read_to_string(&mut msg);
        if let Some(l) = msg.lines().rev().find(|l| !l.trim().is_empty()) {
            *keep.lock().unwrap_or_else(|e| e.into_inner()) = l.trim().to_owned();
        }
    });
    let open = move || {
        let r = Stream::new(stdout, "the RealSense bridge");
        match r {
            Ok(mut s) => {
                s.child = Some(child);
                Ok(s)
            }
            Err(e) => {
                let _ = child.kill();
                let _ = child.wait();
                std::thread::sleep(std::time::Duration::from_millis(50));
                let line = last_line.lock().unwrap_or_else(|e| e.into_inner()).clone();
                if line.is_empty() {
                    Err(e)
                } else {
                    Err(anyhow::anyhow!("{line}"))
                }
            }
        }
    };
    Live::start("the RealSense bridge", Some(pid), open)
}

/// Records what a source delivers: `REC.npy` plus intrinsics and time
/// stamps beside it. Every file goes through [`crate::files`]: nothing
/// appears under its name until [`Recorder::finish`] (a run stopped by
/// Ctrl-C or SIGTERM finishes its recording; one ended by an error or
/// `kill -9` leaves none), and none may be one of the run's inputs.
pub struct Recorder {
    path: PathBuf,
    writer: DepthNpyWriter,
    intr: Intrinsics,
    times: Vec<f64>,
}

impl Recorder {
    /// Start recording frames of `intr` to `path`; refuses (exit 2) a
    /// recording or a file beside it that is one of this run's inputs.
    pub fn create(path: &Path, intr: Intrinsics) -> anyhow::Result<Self> {
        crate::files::distinct_outputs(&[
            ("--record", path),
            ("--record's intrinsics", &intrinsics_beside(path)),
            ("--record's time stamps", &timestamps_beside(path)),
        ])?;
        let writer = DepthNpyWriter::create(path, intr.width, intr.height)?;
        Ok(Self {
            path: path.to_owned(),
            writer,
            intr,
            times: Vec::new(),
        })
    }

    /// Append a frame.
    pub fn push(&mut self, f: &Frame) -> anyhow::Result<()> {
        self.writer.push(&f.depth)?;
        self.times.push(f.t_s);
        Ok(())
    }

    /// Finish the files (time stamps and intrinsics first, the recording
    /// last, so a recording that exists has both beside it); returns the
    /// frame count.
    pub fn finish(self) -> anyhow::Result<u64> {
        write_f64_1d(&timestamps_beside(&self.path), &self.times)?;
        crate::files::write_whole(
            &intrinsics_beside(&self.path),
            self.intr.to_toml().as_bytes(),
        )?;
        self.writer.finish()
    }
}
