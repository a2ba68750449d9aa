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
use super::npy::{DepthNpy, DepthNpyWriter, read_timestamps, write_f64_1d};
use super::synth::{FingerSim, Truth};
use crate::InputError;
use crate::stream::run::Next;

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
    /// thread, [`on_thread`], can idle; others block until it comes).
    fn next_frame_within(&mut self, _wait: std::time::Duration) -> anyhow::Result<Next<Frame>> {
        Ok(self.next_frame()?.map_or(Next::End, Next::Ready))
    }
}

/// Frames buffered between a reader thread and the tracker (a few: a
/// frame is up to a few MB).
const FRAMES_AHEAD: usize = 4;

/// A live source read on its own thread ([`on_thread`]), so the streaming
/// loop keeps the device's housekeeping running while no frame arrives.
pub struct Threaded {
    rx: std::sync::mpsc::Receiver<anyhow::Result<Frame>>,
    intr: Intrinsics,
}

/// Read `src` on a thread of its own. The thread is never joined: when
/// the reader is dropped first, the thread ends at its next frame (the
/// channel is closed) or with the process, even if blocked reading stdin.
pub fn on_thread(mut src: Box<dyn FrameSource + Send>) -> Threaded {
    let intr = src.intrinsics();
    let (tx, rx) = std::sync::mpsc::sync_channel(FRAMES_AHEAD);
    std::thread::Builder::new()
        .name("lmhost-frames".into())
        .spawn(move || {
            loop {
                let f = match src.next_frame() {
                    Ok(Some(f)) => Ok(f),
                    Ok(None) => break,
                    Err(e) => Err(e),
                };
                let end = f.is_err();
                if tx.send(f).is_err() || end || crate::stop::requested() {
                    break;
                }
            }
        })
        .expect("spawning the frame reader thread");
    Threaded { rx, intr }
}

impl FrameSource for Threaded {
    fn intrinsics(&self) -> Intrinsics {
        self.intr
    }
    fn live(&self) -> bool {
        true
    }
    fn next_frame(&mut self) -> anyhow::Result<Option<Frame>> {
        self.rx.recv().ok().transpose()
    }
    fn next_frame_within(&mut self, wait: std::time::Duration) -> anyhow::Result<Next<Frame>> {
        use std::sync::mpsc::RecvTimeoutError;
        match self.rx.recv_timeout(wait) {
            Ok(f) => Ok(Next::Ready(f?)),
            Err(RecvTimeoutError::Timeout) => Ok(Next::Idle),
            Err(RecvTimeoutError::Disconnected) => Ok(Next::End),
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
            tracker: Tracker::new(sim.intr, sim.rig),
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

/// Start the RealSense bridge and read its stream: the live camera.
/// Fails (exit 1) with one line when python3, pyrealsense2 or a camera is
/// missing.
pub fn camera() -> anyhow::Result<Stream<std::process::ChildStdout>> {
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
    let stdout = child.stdout.take().expect("piped stdout");
    let mut stderr = child.stderr.take().expect("piped stderr");
    match Stream::new(stdout, "the RealSense bridge") {
        Ok(mut s) => {
            // Drain the bridge's diagnostics so it never blocks on them.
            std::thread::spawn(move || std::io::copy(&mut stderr, &mut std::io::sink()));
            s.child = Some(child);
            Ok(s)
        }
        Err(_) => {
            let _ = child.wait();
            let mut msg = String::new();
            let _ = stderr.read_to_string(&mut msg);
            let line = msg
                .lines()
                .rev()
                .find(|l| !l.trim().is_empty())
                .unwrap_or("the RealSense bridge sent no stream")
                .trim()
                .to_owned();
            anyhow::bail!("{line}")
        }
    }
}

/// Records what a source delivers: `REC.npy` plus intrinsics and time
/// stamps beside it.
pub struct Recorder {
    path: PathBuf,
    writer: DepthNpyWriter,
    intr: Intrinsics,
    times: Vec<f64>,
}

impl Recorder {
    /// Start recording frames of `intr` to `path`.
    pub fn create(path: &Path, intr: Intrinsics) -> anyhow::Result<Self> {
        use anyhow::Context as _;
        let writer = DepthNpyWriter::create(path, intr.width, intr.height)
            .with_context(|| format!("creating {}", path.display()))?;
        std::fs::write(intrinsics_beside(path), intr.to_toml())
            .with_context(|| format!("writing {}", intrinsics_beside(path).display()))?;
        Ok(Self {
            path: path.to_owned(),
            writer,
            intr,
            times: Vec::new(),
        })
    }

    /// Append a frame.
    pub fn push(&mut self, f: &Frame) -> anyhow::Result<()> {
        use anyhow::Context as _;
        self.writer
            .push(&f.depth)
            .with_context(|| format!("writing {}", self.path.display()))?;
        self.times.push(f.t_s);
        Ok(())
    }

    /// Finish the files; returns the frame count.
    pub fn finish(self) -> anyhow::Result<u64> {
        use anyhow::Context as _;
        let n = self
            .writer
            .finish()
            .with_context(|| format!("writing {}", self.path.display()))?;
        let tp = timestamps_beside(&self.path);
        write_f64_1d(&tp, &self.times).with_context(|| format!("writing {}", tp.display()))?;
        let _ = self.intr;
        Ok(n)
    }
}
