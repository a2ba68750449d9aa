//! Where depth frames come from: a recording (`.npy`), the synthetic
//! finger, or a live stream in the `LMDEPTH1` or `LMCOLOR1` format
//! ([`super::wire`]: the RealSense bridge, or any tool writing it to
//! stdin); and the recorder. A frame may carry the colour image captured
//! with it ([`Frame::colour`]); sources that have a colour stream say so in
//! [`FrameSource::colour_camera`].
//!
//! The live camera (`lmhost track --camera`) is this stream produced by a
//! small Python bridge on the `pyrealsense2` wheel ([`BRIDGE_PY`], embedded
//! and run as `python3 -c`; `LMHOST_PYTHON` picks another interpreter;
//! `LMHOST_CAMERA_COLOUR=0` asks it for depth only, `1` (the default) for
//! colour too; an empty or other value is refused, naming it). A
//! direct V4L2 path was not taken: the crates.io V4L2 bindings (`v4l` /
//! `v4l2-sys-mit`) run bindgen at build time, which needs libclang and
//! kernel headers, and librealsense's own wheel also sets the depth units
//! and reports calibrated intrinsics. The bridge needs no Cargo feature:
//! nothing is linked. Any other tool can write the stream to
//! `lmhost track --stream -`.
//!
//! A recording `REC.npy` is replayed with its intrinsics from
//! `REC.intrinsics.toml` and time stamps from `REC.timestamps.npy` when
//! those files sit beside it and no other is given. Its colour stream, when
//! recorded, is `REC.colour.npy` (uint8, frames × height × width × 3, RGB)
//! with `REC.colour.toml` (the [`ColourCamera`]) and
//! `REC.colour.timestamps.npy`; a replay hands each depth frame the newest
//! colour image not later than it (each once), as the live stream did.

use std::io::Read;
use std::path::{Path, PathBuf};

use super::colour::{ColourCamera, ColourImage};
use super::contact::Tracker;
pub use super::frame::{Cameras, Frame, FrameSource};
use super::intrinsics::Intrinsics;
use super::synth::FingerSim;
use super::synth_colour::ColourSim;
pub use super::wire::{
    MAGIC, MAGIC_COLOUR, Stream, stream_frame, stream_frame_colour, stream_header,
};
use crate::InputError;
use crate::npy::{
    ColourNpy, ColourNpyWriter, DepthNpy, DepthNpyWriter, read_timestamps, write_f64_1d,
};
use crate::sense::stream::run::Next;
use crate::sense::track::settings_file::SettingsFile as _;

/// Default frame rate when a recording has no time stamps (the paper's 90 fps).
pub const DEFAULT_FPS: f64 = 90.0;

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
    cameras: Cameras,
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
                Ok(s) => (Ok(s.cameras()), Some(s)),
                Err(e) => (Err(e), None),
            };
            let _ = htx.send(header);
            let mut stream = stream;
            std::iter::from_fn(move || stream.as_mut()?.next_frame().transpose())
        })?;
        let mut live = Live {
            frames,
            cameras: Cameras {
                depth: Intrinsics::D435_848X480,
                colour: None,
            },
            what: what.to_owned(),
            last: std::time::Instant::now(),
            child,
        };
        match hrx.recv_timeout(HEADER_DEADLINE) {
            Ok(Ok(cameras)) => live.cameras = cameras,
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
    fn cameras(&self) -> Cameras {
        self.cameras
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

/// `REC.colour.npy`, `REC.colour.toml` and `REC.colour.timestamps.npy`
/// beside `REC.npy`: the recording's colour stream.
pub fn colour_beside(npy: &Path) -> [PathBuf; 3] {
    [
        npy.with_extension("colour.npy"),
        npy.with_extension("colour.toml"),
        npy.with_extension("colour.timestamps.npy"),
    ]
}

/// A recording's colour stream, handed out with the depth frames.
struct ColourReplay {
    npy: ColourNpy,
    cam: ColourCamera,
    times: Vec<f64>,
    next: usize,
}

impl ColourReplay {
    /// The files beside `depth`, if its colour stream was recorded.
    fn open_beside(depth: &Path) -> Result<Option<Self>, InputError> {
        let [npy, toml, times] = colour_beside(depth);
        if !npy.exists() {
            return Ok(None);
        }
        let cam = ColourCamera::load(&toml)?;
        let times = read_timestamps(&times)?;
        let npy = ColourNpy::open(&npy)?;
        let what = npy_name(depth);
        if (npy.width, npy.height) != (cam.pinhole.width, cam.pinhole.height) {
            return Err(InputError::new(format!(
                "{what}'s colour frames are {}×{} but its colour camera says {}×{}",
                npy.width, npy.height, cam.pinhole.width, cam.pinhole.height
            )));
        }
        if times.len() as u64 != npy.frames {
            return Err(InputError::new(format!(
                "{} colour time stamps for {} colour frames beside {what}",
                times.len(),
                npy.frames
            )));
        }
        Ok(Some(Self {
            npy,
            cam,
            times,
            next: 0,
        }))
    }

    /// The newest colour image not later than `t_s` not handed out yet.
    fn upto(&mut self, t_s: f64) -> Result<Option<ColourImage>, InputError> {
        let mut last = None;
        while self.next < self.times.len() && self.times[self.next] <= t_s {
            let rgb = self.npy.read()?.ok_or_else(|| {
                InputError::new("a colour recording ended before its time stamps")
            })?;
            last = Some(ColourImage {
                t_s: self.times[self.next],
                width: self.cam.pinhole.width,
                height: self.cam.pinhole.height,
                rgb: std::sync::Arc::new(rgb),
            });
            self.next += 1;
        }
        Ok(last)
    }
}

fn npy_name(p: &Path) -> String {
    p.display().to_string()
}

/// Replay of a `.npy` recording.
pub struct Replay {
    npy: DepthNpy,
    intr: Intrinsics,
    times: Option<Vec<f64>>,
    index: u64,
    colour: Option<ColourReplay>,
}

impl Replay {
    /// Open `depth` with `intr`; `times` (s, and the file they were read
    /// from, named with the recording when they do not fit it) must have
    /// one entry per frame. A colour stream recorded beside it comes along.
    pub fn open(
        depth: &Path,
        intr: Intrinsics,
        times: Option<(Vec<f64>, &Path)>,
    ) -> Result<Self, InputError> {
        let npy = DepthNpy::open(depth)?;
        // Nothing to track: a run over it would report 0 frames as if it
        // had tracked something (and write a plot or recording of none).
        if npy.frames == 0 {
            return Err(InputError::new(format!(
                "{}: the recording holds no frames (shape (0, {}, {})): give one of at least 1 frame",
                depth.display(),
                npy.height,
                npy.width
            )));
        }
        intr.check_frames(npy.width, npy.height, &depth.display().to_string())?;
        if let Some((t, from)) = &times
            && t.len() as u64 != npy.frames
        {
            return Err(InputError::new(format!(
                "{}: {} time stamps for {} frames in {}",
                from.display(),
                t.len(),
                npy.frames,
                depth.display()
            )));
        }
        let times = times.map(|(t, _)| t);
        Ok(Self {
            npy,
            intr,
            times,
            index: 0,
            colour: ColourReplay::open_beside(depth)?,
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
        let times = match tpath.as_deref() {
            Some(p) => Some((read_timestamps(p)?, p)),
            None => None,
        };
        Self::open(depth, intr, times)
    }

    /// Frames in the recording.
    pub fn frames(&self) -> u64 {
        self.npy.frames
    }
}

impl FrameSource for Replay {
    fn cameras(&self) -> Cameras {
        Cameras {
            depth: self.intr,
            colour: self.colour.as_ref().map(|c| c.cam),
        }
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
        let colour = match &mut self.colour {
            Some(c) => c.upto(t_s)?,
            None => None,
        };
        Ok(Some(Frame {
            t_s,
            depth,
            truth: None,
            colour,
        }))
    }
}

/// The synthetic finger as a frame source.
pub struct Synthetic {
    sim: FingerSim,
    tracker: Tracker,
    frames: u64,
    index: u64,
    colour: Option<(ColourSim, u64)>,
}

impl Synthetic {
    /// `seconds` of the synthetic finger.
    pub fn new(sim: FingerSim, seconds: f64) -> Self {
        Self {
            tracker: Tracker::new(sim.intr, sim.setup),
            frames: (seconds * sim.rate_hz).round() as u64,
            sim,
            index: 0,
            colour: None,
        }
    }

    /// Also renders the colour image of every `every`-th frame (1: each
    /// one; 3: 30 fps beside depth at 90).
    pub fn with_colour(mut self, colour: ColourSim, every: u64) -> Self {
        self.colour = Some((colour, every.max(1)));
        self
    }
}

impl FrameSource for Synthetic {
    fn cameras(&self) -> Cameras {
        Cameras {
            depth: self.sim.intr,
            colour: self.colour.as_ref().map(|(c, _)| c.cam),
        }
    }
    fn next_frame(&mut self) -> anyhow::Result<Option<Frame>> {
        if self.index >= self.frames {
            return Ok(None);
        }
        let mut depth = Vec::new();
        let (t_s, truth) = self.sim.render(self.index, &self.tracker, &mut depth);
        let colour = match &self.colour {
            Some((c, every)) if self.index.is_multiple_of(*every) => {
                let mut rgb = Vec::new();
                c.render(truth.tip_mm, &mut rgb);
                Some(ColourImage {
                    t_s,
                    width: c.cam.pinhole.width,
                    height: c.cam.pinhole.height,
                    rgb: std::sync::Arc::new(rgb),
                })
            }
            _ => None,
        };
        self.index += 1;
        Ok(Some(Frame {
            t_s,
            depth,
            truth: Some(truth),
            colour,
        }))
    }
}

/// The RealSense bridge (Python, `pyrealsense2`), embedded.
pub const BRIDGE_PY: &str = include_str!("realsense_bridge.py");

/// Start the RealSense bridge and read its stream: the live camera, held
/// to the live deadlines ([`Live`]). Fails (exit 1) with one line when
/// python3, pyrealsense2 or a camera is missing, or the bridge stalls (it
/// is killed then).
pub fn camera() -> anyhow::Result<Live> {
    use std::process::{Command, Stdio};
    let python = bridge_python()?;
    let python_shown = python.to_string_lossy().into_owned();
    let mut child = Command::new(&python)
        .args(["-c", BRIDGE_PY])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|_| {
            anyhow::anyhow!(
                "no camera: cannot run `{python_shown}` (the RealSense bridge needs python3 with pyrealsense2)"
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

/// The bridge's interpreter, `$LMHOST_PYTHON` (else `python3`), after
/// `$LMHOST_CAMERA_COLOUR`, which the bridge reads, is checked. Each is
/// taken as it is or refused naming it: a value not UTF-8 ran `python3`
/// instead of the one named, an empty one "cannot run ``", and a colour
/// switch other than `0` (`no`, `false`, `off`) asked for colour.
fn bridge_python() -> Result<std::ffi::OsString, crate::InputError> {
    let echo = |v: &std::ffi::OsStr| {
        crate::error::short_echo(&v.to_string_lossy().escape_debug().to_string())
    };
    if let Some(v) = std::env::var_os("LMHOST_CAMERA_COLOUR")
        && v != "0"
        && v != "1"
    {
        return Err(crate::InputError::new(format!(
            "$LMHOST_CAMERA_COLOUR `{}` is neither 0 (depth only) nor 1 (depth and colour, the default): give one of them, or unset it",
            echo(&v)
        )));
    }
    match std::env::var_os("LMHOST_PYTHON") {
        None => Ok("python3".into()),
        Some(p) if p.is_empty() => Err(crate::InputError::new(
            "$LMHOST_PYTHON is empty: give the Python that runs the RealSense bridge, or unset it for python3",
        )),
        Some(p) if p.to_string_lossy().trim() != p.to_string_lossy() => {
            Err(crate::InputError::new(format!(
                "$LMHOST_PYTHON `{}` has spaces at an end: give the Python's name without them",
                echo(&p)
            )))
        }
        // As given, whatever its bytes: a path need not be UTF-8.
        Some(p) => Ok(p),
    }
}

/// Records what a source delivers: `REC.npy` plus intrinsics and time
/// stamps beside it, and its colour stream when it has one
/// ([`colour_beside`]). Every file goes through [`crate::files`]: nothing
/// appears under its name until [`Recorder::finish`] (a run stopped by
/// Ctrl-C or SIGTERM finishes its recording; one ended by an error or
/// `kill -9` leaves none), and none may be one of the run's inputs.
pub struct Recorder {
    path: PathBuf,
    writer: DepthNpyWriter,
    intr: Intrinsics,
    times: Vec<f64>,
    colour: Option<(ColourNpyWriter, ColourCamera, Vec<f64>)>,
}

impl Recorder {
    /// Every file a recording at `path` writes (with `colour` frames or
    /// not), each named for messages: for a check against each other and
    /// the run's other outputs before any is made.
    pub fn outputs(path: &Path, colour: bool) -> Vec<(&'static str, PathBuf)> {
        let mut outs = vec![
            ("--record", path.to_owned()),
            ("--record's intrinsics", intrinsics_beside(path)),
            ("--record's time stamps", timestamps_beside(path)),
        ];
        if colour {
            let [cnpy, ctoml, ctimes] = colour_beside(path);
            outs.extend([
                ("--record's colour frames", cnpy),
                ("--record's colour camera", ctoml),
                ("--record's colour time stamps", ctimes),
            ]);
        }
        outs
    }

    /// Start recording frames of `intr` (and colour images of `colour`) to
    /// `path`; refuses (exit 2) a recording or a file beside it that is one
    /// of this run's inputs.
    pub fn create(
        path: &Path,
        intr: Intrinsics,
        colour: Option<ColourCamera>,
    ) -> anyhow::Result<Self> {
        let [cnpy, ..] = colour_beside(path);
        crate::files::with_files_beside("--record", path)?;
        crate::files::distinct_outputs(&Self::outputs(path, colour.is_some()))?;
        let writer = DepthNpyWriter::create(path, intr.pinhole.width, intr.pinhole.height)?;
        let colour = match colour {
            Some(c) => Some((
                ColourNpyWriter::create(&cnpy, c.pinhole.width, c.pinhole.height)?,
                c,
                Vec::new(),
            )),
            None => None,
        };
        Ok(Self {
            path: path.to_owned(),
            writer,
            intr,
            times: Vec::new(),
            colour,
        })
    }

    /// Append a frame (and the colour image riding with it).
    pub fn push(&mut self, f: &Frame) -> anyhow::Result<()> {
        self.writer.push(&f.depth)?;
        self.times.push(f.t_s);
        if let (Some((w, _, times)), Some(c)) = (&mut self.colour, &f.colour) {
            w.push(&c.rgb)?;
            times.push(c.t_s);
        }
        Ok(())
    }

    /// Finish the files (the colour stream, time stamps and intrinsics
    /// first, the recording last, so a recording that exists has all of
    /// them beside it); returns the frame count.
    pub fn finish(self) -> anyhow::Result<u64> {
        if let Some((w, cam, times)) = self.colour {
            let [_, ctoml, ctimes] = colour_beside(&self.path);
            write_f64_1d(&ctimes, &times)?;
            crate::files::write_whole(&ctoml, cam.to_toml().as_bytes())?;
            w.finish()?;
        }
        write_f64_1d(&timestamps_beside(&self.path), &self.times)?;
        crate::files::write_whole(
            &intrinsics_beside(&self.path),
            self.intr.to_toml().as_bytes(),
        )?;
        self.writer.finish()
    }
}
