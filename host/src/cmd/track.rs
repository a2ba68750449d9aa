//! `lmhost track`: depth frames in, the paper's contact-area centroid out,
//! optionally filtered, gated and streamed to the device.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::Context as _;

use super::args::PortArgs;
use lmhost::scene::Scene;
use lmhost::stream::Sample;
use lmhost::stream::filter::{FilterKind, Passthrough};
use lmhost::stream::run::{Feed, Next, Pace, stream};
use lmhost::track::contact::Tracker;
use lmhost::track::intrinsics::Intrinsics;
use lmhost::track::presence::Hysteresis;
use lmhost::track::rig::Rig;
use lmhost::track::source::{self, Frame, FrameSource, Recorder};
use lmhost::track::synth::{FingerSim, background_of};
use lmhost::track::{FrameResult, Pipeline};

/// Track the finger in depth frames: the contact area inside the scene's
/// detection box and its centroid, one result per frame.
///
/// Sources: a recording (`--depth F.npy`, uint16 frames × height × width,
/// with `--intrinsics` and optional `--timestamps`), the synthetic finger
/// (`--synthetic`), a RealSense camera (`--camera`, through the bundled
/// pyrealsense2 bridge) or an LMDEPTH1 stream (`--stream FILE|-`).
/// With `--port` the filtered, gated centre is streamed to the device.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Stream the filtered centre to the device on this port (only when
    /// `--port` is given; $LMHOST_PORT alone does not enable streaming).
    #[command(flatten)]
    port: PortArgs,
    /// Recorded depth frames: `.npy`, uint16, (frames, height, width).
    #[arg(long, value_name = "FILE.npy")]
    depth: Option<PathBuf>,
    /// Frame time stamps: `.npy`, float64 seconds, one per frame
    /// [default: FILE.timestamps.npy beside --depth, else 90 fps].
    #[arg(long, value_name = "T.npy", requires = "depth")]
    timestamps: Option<PathBuf>,
    /// Camera intrinsics TOML [default: FILE.intrinsics.toml beside
    /// --depth; the synthetic finger: a D435 at 848 × 480].
    #[arg(long, value_name = "CAM.toml")]
    intrinsics: Option<PathBuf>,
    /// Scene with `[camera]` and `[tracking]` (the synthetic finger falls
    /// back to a derived rig about the scene's centre).
    #[arg(long, value_name = "FILE")]
    scene: Option<PathBuf>,
    /// Render the synthetic finger (approach, rest with tremor, slide,
    /// leave) and report its ground truth too.
    #[arg(long)]
    synthetic: bool,
    /// Synthetic finger: seconds to render, in (0, 3600] [default: 6].
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    seconds: Option<f64>,
    /// Synthetic finger: depth noise (mm, 1 σ), in [0, 50] [default: 0.5].
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    noise_mm: Option<f64>,
    /// Synthetic finger: fraction of pixels with no data, in [0, 1]
    /// [default: 0.02].
    #[arg(long, value_name = "FRACTION", allow_negative_numbers = true)]
    holes: Option<f64>,
    /// Live RealSense camera (needs python3 with pyrealsense2).
    #[arg(long)]
    camera: bool,
    /// Read an LMDEPTH1 stream from FILE (`-` = stdin).
    #[arg(long, value_name = "FILE")]
    stream: Option<PathBuf>,
    /// Save the frames as FILE.npy, with FILE.intrinsics.toml and
    /// FILE.timestamps.npy beside it.
    #[arg(long, value_name = "FILE.npy")]
    record: Option<PathBuf>,
    /// Replay as fast as possible instead of at the recorded speed.
    #[arg(long)]
    fast: bool,
    /// One JSON object per frame per line.
    #[arg(long)]
    json: bool,
    /// Write a PNG of one frame (box, contact area, centroid) into DIR.
    #[arg(long, value_name = "DIR")]
    plot: Option<PathBuf>,
    /// The frame to plot [default: the first with a contact area].
    #[arg(long, value_name = "N", requires = "plot")]
    plot_frame: Option<u64>,
    /// Centroid filter [default: gaussian (the paper's) with --port, else none].
    #[arg(long, value_parser = super::args::filter())]
    filter: Option<FilterKind>,
    /// Also measure the finger surface's depth z_j along a circle of
    /// RADIUS_MM in STEPS steps about the centroid (relative to the centre,
    /// along the box's third axis): JSON key `z_profile_mm`, and `replan`
    /// when it moved more than --replan-mm from the last planned profile.
    #[arg(long, value_name = "RADIUS_MM,STEPS")]
    z_profile: Option<String>,
    /// Re-plan threshold for --z-profile (mm).
    #[arg(long, value_name = "MM", default_value_t = 0.3, requires = "z_profile")]
    replan_mm: f64,
    /// With --port and --z-profile: when the surface profile moves more
    /// than --replan-mm, plan the paper's LM-S circle (5 Hz, radius and
    /// steps of --z-profile, about the scene centre) with that depth
    /// profile, upload it into a slot that is neither playing nor queued
    /// and play it at the next cycle boundary. Off by default: each
    /// re-plan uploads steps × transducers bytes and holds the centroid
    /// stream meanwhile (about 0.45 s for 100 steps × 996 transducers,
    /// 38 kB, at 921600 baud; a pty takes milliseconds), so use it on fast links.
    #[arg(long, requires_all = ["z_profile", "port"])]
    replan: bool,
    /// Consecutive frames with a contact area that open the device gate.
    #[arg(long, value_name = "N", default_value_t = 2)]
    enter_frames: u32,
    /// Consecutive frames without one that close it.
    #[arg(long, value_name = "N", default_value_t = 2)]
    leave_frames: u32,
}

/// Per-run counters.
#[derive(Debug, Default)]
struct Tally {
    frames: u64,
    present: u64,
    gated: u64,
    track_us: Vec<f64>,
    err2: f64,
    err_n: u64,
    presence_wrong: u64,
}

struct Run {
    z_profile: Option<(f64, usize, lmhost::track::surface::Replanner)>,
    replans: u64,
    /// The latest re-planned profile not yet uploaded (with --replan).
    pending: Option<std::rc::Rc<std::cell::RefCell<Option<Vec<f64>>>>>,
    src: Box<dyn FrameSource>,
    pipe: Pipeline,
    rec: Option<Recorder>,
    json: bool,
    show_filtered: bool,
    paced: bool,
    start: Option<(Instant, f64)>,
    plot_at: Option<u64>,
    plot_frame: Option<(u64, Vec<u16>)>,
    want_plot: bool,
    tally: Tally,
    second: Tally,
    next_summary: f64,
    prev_truth: [Option<(bool, bool)>; 2],
    prev_t_s: Option<f64>,
}

/// The tracked centres of a [`Run`] as the streaming loop's feed: a live
/// source idles (the loop ticks the device) while no frame arrives.
struct RunFeed<'a>(&'a mut Run);

impl Feed for RunFeed<'_> {
    fn next_within(&mut self, wait: Duration) -> Next<anyhow::Result<Sample>> {
        match self.0.next_within(wait) {
            Ok(Next::Ready(r)) => Next::Ready(Ok(r.sample())),
            Ok(Next::Idle) => Next::Idle,
            Ok(Next::End) => Next::End,
            Err(e) => Next::Ready(Err(e)),
        }
    }
}

impl Run {
    fn next(&mut self) -> anyhow::Result<Option<FrameResult>> {
        loop {
            match self.next_within(Duration::from_secs(3600))? {
                Next::Ready(r) => return Ok(Some(r)),
                Next::Idle => {}
                Next::End => return Ok(None),
            }
        }
    }

    /// The next frame's result if a frame comes within `wait`.
    fn next_within(&mut self, wait: Duration) -> anyhow::Result<Next<FrameResult>> {
        let frame = match self.src.next_frame_within(wait)? {
            Next::Ready(f) => f,
            Next::Idle => return Ok(Next::Idle),
            Next::End => return Ok(Next::End),
        };
        // Every source: a gap between frames is at most what a replay may
        // sleep, so a wild time stamp is an error naming the frame, not a
        // panic or a day-long wait (paced or not, as `stream` does).
        let index = self.tally.frames;
        // NaN counts as too far: `is_some_and` keeps only a gap within it.
        if let Some(prev) = self.prev_t_s
            && !(frame.t_s - prev)
                .partial_cmp(&lmhost::limits::MAX_REPLAY_GAP_S)
                .is_some_and(|o| o.is_le())
        {
            lmhost::bad_input!(
                "frame {index}: time stamp {} s is {} s after the previous frame's; at most {} s between frames",
                lmhost::limits::show(frame.t_s),
                lmhost::limits::show(frame.t_s - prev),
                lmhost::limits::MAX_REPLAY_GAP_S
            );
        }
        self.prev_t_s = Some(frame.t_s);
        if let Some(r) = &mut self.rec {
            r.push(&frame)?;
        }
        if self.paced {
            let (t0, ft0) = *self.start.get_or_insert((Instant::now(), frame.t_s));
            // Finite by now: consecutive gaps are bounded above, and every
            // source refuses non-finite or decreasing stamps.
            let due = Duration::try_from_secs_f64((frame.t_s - ft0).max(0.0)).map_err(|_| {
                lmhost::InputError::new(format!(
                    "frame {index}: time stamp {} s cannot be replayed",
                    lmhost::limits::show(frame.t_s)
                ))
            })?;
            if let Some(wait) = due.checked_sub(t0.elapsed()) {
                std::thread::sleep(wait);
            }
        }
        let res = self.pipe.step(frame.t_s, &frame.depth);
        let profile = self.z_profile(&frame, &res);
        self.report(&frame, &res, profile)?;
        let index = self.tally.frames - 1;
        if self.want_plot {
            let keep = match self.plot_at {
                Some(n) => index == n,
                // The first frame with a contact area, else the first frame.
                None => res.present || self.plot_frame.is_none(),
            };
            if keep {
                self.plot_frame = Some((index, frame.depth.clone()));
                self.want_plot = self.plot_at.is_none() && !res.present;
            }
        }
        Ok(Next::Ready(res))
    }

    /// The relative depth profile about the raw centroid, and whether a
    /// re-plan is due.
    fn z_profile(&mut self, frame: &Frame, r: &FrameResult) -> Option<(Vec<f64>, bool)> {
        let (radius, steps, replan) = self.z_profile.as_mut()?;
        let c = r.centroid_mm()?;
        let tb = &self.pipe.tracker.rig().track_box;
        let rel = lmhost::geom::sub(c, tb.center_mm);
        let ab = [
            lmhost::geom::dot(tb.axes[0], rel),
            lmhost::geom::dot(tb.axes[1], rel),
        ];
        let prof =
            lmhost::track::surface::profile(&self.pipe.tracker, &frame.depth, ab, *radius, *steps);
        let rel = lmhost::track::surface::relative(&prof)?;
        let due = replan.update(&rel);
        self.replans += due as u64;
        if let (true, Some(p)) = (due, &self.pending) {
            *p.borrow_mut() = Some(rel.clone());
        }
        Some((rel, due))
    }

    fn report(
        &mut self,
        frame: &Frame,
        r: &FrameResult,
        profile: Option<(Vec<f64>, bool)>,
    ) -> anyhow::Result<()> {
        for t in [&mut self.tally, &mut self.second] {
            t.frames += 1;
            t.present += r.present as u64;
            t.gated += r.gated as u64;
            t.track_us.push(r.track_s * 1e6);
        }
        if let Some(truth) = &frame.truth {
            // Presence is judged away from transitions: frame k-1 counts when
            // the truth of k-2, k-1 and k agree (so at most one frame late or
            // early is forgiven); evaluated one frame behind.
            if let [Some((t2, _)), Some((t1, raw1))] = self.prev_truth
                && t2 == t1
                && t1 == truth.present
                && raw1 != t1
            {
                self.tally.presence_wrong += 1;
            }
            self.prev_truth = [self.prev_truth[1], Some((truth.present, r.present))];
            if let (true, Some(c), Some(tc)) =
                (truth.present, r.centroid_mm(), truth.contact.centroid_mm)
            {
                let e2: f64 = (0..3).map(|k| (c[k] - tc[k]).powi(2)).sum();
                self.tally.err2 += e2;
                self.tally.err_n += 1;
            }
        }
        if self.json {
            let mut v = serde_json::json!({
                "t_s": r.t_s,
                "points": r.contact.points,
                "present": r.present,
                "centroid_mm": r.centroid_mm(),
            });
            if self.show_filtered {
                v["gated_present"] = r.gated.into();
                v["filtered_mm"] = serde_json::json!(r.filtered_mm);
            }
            if self.z_profile.is_some() {
                v["z_profile_mm"] = serde_json::json!(profile.as_ref().map(|p| &p.0));
                v["replan"] = profile.as_ref().is_some_and(|p| p.1).into();
            }
            if let Some(truth) = &frame.truth {
                v["truth_present"] = truth.present.into();
                v["truth_mm"] = serde_json::json!(truth.contact.centroid_mm);
            }
            lmhost::outln!("{v}")?;
        } else if r.t_s >= self.next_summary {
            let s = std::mem::take(&mut self.second);
            let c = r.centroid_mm().map_or("none".to_owned(), |c| {
                format!("({:.2}, {:.2}, {:.2}) mm", c[0], c[1], c[2])
            });
            lmhost::outln!(
                "t {:>7.2} s  frames {:>3}  present {:>3}  gated {:>3}  points {:>4}  centroid {c}  track p50 {:.0} µs",
                r.t_s,
                s.frames,
                s.present,
                s.gated,
                r.contact.points,
                percentile(&s.track_us, 50.0)
            )?;
            self.next_summary = (r.t_s + 1.0).floor();
        }
        Ok(())
    }
}

/// Uploads re-planned depth profiles to the device (`--replan`).
struct DeviceReplan {
    scene: Scene,
    params: lmhost::trajectory::LmParams,
    /// Box c (mm) → LM plane c (mm): ±1, the axes being checked parallel.
    sign: f64,
    uploaded: u64,
    skipped: u64,
    failed: u64,
    last_failure: Option<String>,
}

impl DeviceReplan {
    /// The paper's LM-S about the scene centre with `radius_mm` and
    /// `steps` (checked by planning it flat once). The surface profile is
    /// sampled on the tracking box's a–b circle, so the box must lie in the
    /// LM plane (axes parallel within 1°).
    fn new(scene: &Scene, rig: &Rig, radius_mm: f64, steps: usize) -> anyhow::Result<Self> {
        let b = &rig.track_box;
        let pl = &scene.lm_plane;
        let cos1 = 1f64.to_radians().cos();
        let aligned = |u: lmhost::geom::Vec3, v: lmhost::geom::Vec3| {
            lmhost::geom::dot(u, v) >= cos1 * lmhost::geom::norm(u) * lmhost::geom::norm(v)
        };
        if !(aligned(b.axes[0], pl.a) && aligned(b.axes[1], pl.b)) {
            lmhost::bad_input!(
                "--replan needs the tracking box's first two axes along the scene's lm_plane a and b (within 1°): the surface profile is sampled in the box and planned in the LM plane"
            );
        }
        let sign = lmhost::geom::dot(b.axes[2], pl.c).signum();
        let mut params = lmhost::trajectory::LmParams::paper(scene.center_mm);
        params.radius_mm = radius_mm;
        params.steps = lmhost::trajectory::Steps::Count(steps);
        lmhost::sequence::Plan::new(scene.clone(), &params, &lmhost::sequence::Synthesis::Linear)
            .map_err(|e| {
            lmhost::InputError::new(format!(
                "--replan: the circle of --z-profile cannot be planned: {e}"
            ))
        })?;
        Ok(Self {
            scene: scene.clone(),
            params,
            sign,
            uploaded: 0,
            skipped: 0,
            failed: 0,
            last_failure: None,
        })
    }

    /// Upload and queue the pending profile, if any and a slot is free
    /// (else it stays pending for the next sample).
    fn maybe_upload(
        &mut self,
        client: &mut dyn lmhost::backend::Backend,
        pending: &std::cell::RefCell<Option<Vec<f64>>>,
    ) -> anyhow::Result<()> {
        let Some(profile) = pending.borrow().clone() else {
            return Ok(());
        };
        let info = client.info().context("re-plan: reading the device info")?;
        let st = client
            .status()
            .context("re-plan: reading the device status")?;
        let Some(slot) = lmhost::backend::free_slot(info.slots, &st) else {
            self.skipped += 1;
            return Ok(());
        };
        let mut params = self.params.clone();
        params.z_profile_mm = profile.iter().map(|z| z * self.sign).collect();
        // A measured profile the planner refuses (out of range) is a
        // re-plan failure, counted and reported; the session goes on.
        let plan = match lmhost::sequence::Plan::new(
            self.scene.clone(),
            &params,
            &lmhost::sequence::Synthesis::Linear,
        ) {
            Ok(plan) => plan,
            Err(e) => {
                *pending.borrow_mut() = None;
                self.failed += 1;
                self.last_failure = Some(e.to_string());
                return Ok(());
            }
        };
        client
            .upload(&plan, Some(slot))
            .with_context(|| format!("re-plan: uploading to slot {slot}"))?;
        client
            .play(slot, false)
            .with_context(|| format!("re-plan: playing slot {slot}"))?;
        *pending.borrow_mut() = None;
        self.uploaded += 1;
        Ok(())
    }
}

fn percentile(v: &[f64], p: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[((p / 100.0) * (s.len() - 1) as f64).round() as usize]
}

impl Args {
    fn source(&self, scene: &Scene) -> anyhow::Result<(Box<dyn FrameSource>, Rig)> {
        let picked = [
            self.depth.is_some(),
            self.synthetic,
            self.camera,
            self.stream.is_some(),
        ]
        .iter()
        .filter(|b| **b)
        .count();
        if picked != 1 {
            lmhost::bad_input!(
                "give exactly one source: --depth FILE.npy, --synthetic, --camera or --stream FILE"
            );
        }
        for (flag, given) in [
            ("--seconds", self.seconds.is_some()),
            ("--noise-mm", self.noise_mm.is_some()),
            ("--holes", self.holes.is_some()),
        ] {
            if given && !self.synthetic {
                lmhost::bad_input!(
                    "{flag} applies to --synthetic only (it renders the synthetic finger)"
                );
            }
        }
        if self.synthetic {
            let seconds = self.seconds.unwrap_or(6.0);
            let noise_mm = self.noise_mm.unwrap_or(0.5);
            let holes = self.holes.unwrap_or(0.02);
            if !(seconds.is_finite() && seconds > 0.0 && seconds <= 3600.0) {
                lmhost::bad_input!(
                    "--seconds {} must be in (0, 3600]",
                    lmhost::limits::show(seconds)
                );
            }
            if !(noise_mm.is_finite() && (0.0..=50.0).contains(&noise_mm)) {
                lmhost::bad_input!(
                    "--noise-mm {} must be in [0, 50]",
                    lmhost::limits::show(noise_mm)
                );
            }
            if !(holes.is_finite() && (0.0..=1.0).contains(&holes)) {
                lmhost::bad_input!("--holes {} must be in [0, 1]", lmhost::limits::show(holes));
            }
            let intr = match &self.intrinsics {
                Some(p) => Intrinsics::load(p)?,
                None => Intrinsics::D435_848X480,
            };
            let rig = Rig::of_scene_or_default(scene);
            let mut sim = FingerSim::new(rig, intr, background_of(scene));
            sim.noise_mm = noise_mm;
            sim.holes = holes;
            if (seconds * sim.rate_hz).round() < 1.0 {
                lmhost::bad_input!(
                    "--seconds {} renders no frame at {} fps; give at least {} s",
                    lmhost::limits::show(seconds),
                    sim.rate_hz,
                    lmhost::limits::show(0.5 / sim.rate_hz)
                );
            }
            return Ok((Box::new(source::Synthetic::new(sim, seconds)), rig));
        }
        let rig = Rig::of_scene(scene)?;
        if let Some(d) = &self.depth {
            let r = source::Replay::open_with_defaults(
                d,
                self.intrinsics.as_deref(),
                self.timestamps.as_deref(),
            )?;
            return Ok((Box::new(r), rig));
        }
        // Live streams are read on their own thread (the device's
        // housekeeping goes on while no frame arrives) and held to the
        // live deadlines (source::HEADER_DEADLINE, source::FRAME_DEADLINE).
        let src: Box<dyn FrameSource> = if self.camera {
            Box::new(source::camera()?)
        } else {
            match self.stream.as_deref() {
                Some(p) if p.as_os_str() == "-" => {
                    Box::new(source::Live::start("stdin", None, || {
                        source::Stream::new(std::io::stdin(), "stdin")
                    })?)
                }
                Some(p) => {
                    let f = lmhost::files::open_input("--stream file", p)?;
                    let what = p.display().to_string();
                    Box::new(source::Live::start(&what.clone(), None, move || {
                        source::Stream::new(std::io::BufReader::new(f), &what)
                    })?)
                }
                None => lmhost::bad_input!(
                    "give exactly one source: --depth FILE.npy, --synthetic, --camera or --stream FILE"
                ),
            }
        };
        if let Some(ip) = &self.intrinsics {
            let given = Intrinsics::load(ip)?;
            let got = src.intrinsics();
            given.check_frames(got.width, got.height, "the stream")?;
        }
        Ok((src, rig))
    }

    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        for (name, v) in [
            ("--enter-frames", self.enter_frames),
            ("--leave-frames", self.leave_frames),
        ] {
            if !(1..=90).contains(&v) {
                lmhost::bad_input!("{name} {v} must be between 1 and 90");
            }
        }
        let scene = Scene::load_or_default(self.scene.as_deref())?;
        if self.scene.is_none() && !self.synthetic {
            lmhost::bad_input!("--scene is needed: its [camera] and [tracking] place the box");
        }
        // Every source ends on Ctrl-C / SIGTERM: the recording is finished,
        // the device muted and the report printed.
        lmhost::stop::graceful();
        let (src, rig) = self.source(&scene)?;
        let intr = src.intrinsics();
        let device = self.port.port.is_some();
        let kind = self.filter.unwrap_or(if device {
            FilterKind::Gaussian
        } else {
            FilterKind::None
        });
        let show_filtered = device || self.filter.is_some();
        let tracker = Tracker::new(intr, rig);
        // Said once the run is over (a run that fails says its error alone).
        let hopeless = lmhost::track::check_rig(&tracker).err();
        let pipe = Pipeline::new(
            tracker,
            Hysteresis::new(self.enter_frames, self.leave_frames),
            kind.build(),
        );
        let rec = match &self.record {
            Some(p) => Some(Recorder::create(p, intr)?),
            None => None,
        };
        if let Some(d) = &self.plot {
            lmhost::files::output_dir("--plot", d)?;
        }
        let z_profile = match &self.z_profile {
            None => None,
            Some(spec) => {
                let bad = || {
                    lmhost::InputError::new(format!(
                        "--z-profile `{spec}` must be RADIUS_MM,STEPS with 0 < RADIUS_MM <= 20 and 1 <= STEPS <= 1000"
                    ))
                };
                let (r, n) = spec.split_once(',').ok_or_else(bad)?;
                let r: f64 = r.trim().parse().map_err(|_| bad())?;
                let n: usize = n.trim().parse().map_err(|_| bad())?;
                if !(r > 0.0 && r <= 20.0 && (1..=1000).contains(&n)) {
                    return Err(bad().into());
                }
                if !(self.replan_mm.is_finite() && self.replan_mm >= 0.0) {
                    lmhost::bad_input!("--replan-mm {} must be ≥ 0", self.replan_mm);
                }
                Some((r, n, lmhost::track::surface::Replanner::new(self.replan_mm)))
            }
        };
        let live = src.live();
        let replanner = match (&z_profile, self.replan) {
            (Some((r, n, _)), true) => Some(DeviceReplan::new(&scene, &rig, *r, *n)?),
            _ => None,
        };
        let pending = replanner
            .as_ref()
            .map(|_| std::rc::Rc::new(std::cell::RefCell::new(None)));
        let mut run = Run {
            z_profile,
            replans: 0,
            pending: pending.clone(),
            src,
            pipe,
            rec,
            json: self.json,
            show_filtered,
            paced: !self.fast && !live && !device,
            start: None,
            plot_at: self.plot_frame,
            plot_frame: None,
            want_plot: self.plot.is_some(),
            tally: Tally::default(),
            second: Tally::default(),
            next_summary: f64::NEG_INFINITY,
            prev_truth: [None; 2],
            prev_t_s: None,
        };
        let started = Instant::now();
        let mut device_report = None;
        let mut replanner = replanner;
        if device {
            // AUTD3: the default stimulus for the scene is uploaded and
            // played first, and the array is left silent at the end.
            let (mut dev, session) =
                crate::cmd::session::open_playing_default(&self.port.spec(), &scene)?;
            let where_ = dev.describe();
            let pace = if self.fast || live {
                Pace::Arrival
            } else {
                Pace::Timestamps
            };
            let samples = RunFeed(&mut run);
            let report = stream(
                dev.as_mut(),
                samples,
                &mut Passthrough,
                |p| scene.drive_point(p),
                pace,
                |client, _, _| match (&mut replanner, &pending) {
                    (Some(r), Some(p)) => r.maybe_upload(client, p),
                    _ => Ok(()),
                },
            )
            .map_err(|e| {
                if e.downcast_ref::<lmhost::InputError>().is_some() {
                    e
                } else {
                    e.context(format!("streaming centroids to {where_}"))
                }
            })?;
            if session.is_some() {
                dev.stop().context("silencing the array")?;
            }
            device_report = Some((report, where_));
        } else {
            while !lmhost::stop::requested() && run.next()?.is_some() {}
        }
        let seconds = started.elapsed().as_secs_f64();
        if let Some(r) = run.rec.take() {
            let n = r.finish()?;
            if !self.json {
                lmhost::outln!(
                    "recorded {n} frames to {}",
                    self.record.as_ref().expect("recording").display()
                )?;
            }
        }
        if let (Some(dir), Some((i, depth))) = (&self.plot, &run.plot_frame) {
            let path = dir.join(format!("track_frame_{i}.png"));
            lmhost::track::plot::frame_png(&run.pipe.tracker, depth, &path)?;
            if !self.json {
                lmhost::outln!("plot {}", path.display())?;
            }
        } else if let (Some(_), Some(n)) = (&self.plot, self.plot_frame) {
            lmhost::bad_input!("--plot-frame {n} is beyond the {} frames", run.tally.frames);
        }
        if self.plot.is_some() && run.plot_frame.is_none() && self.plot_frame.is_none() {
            lmhost::errln!(
                "warning: --plot wrote nothing: the run had no frame ({} frames)",
                run.tally.frames
            );
        }
        let t = &run.tally;
        match &hopeless {
            Some(why) => lmhost::errln!("warning: {why}"),
            None if t.frames > 0 && t.present == 0 && !lmhost::stop::requested() => {
                lmhost::errln!(
                    "warning: no frame of {} had a contact area in the tracking box: check the camera pose, the box and depth_scale",
                    t.frames
                )
            }
            None => {}
        }
        let out = |line: String| {
            if self.json {
                lmhost::errln!("{line}");
                Ok(())
            } else {
                lmhost::outln!("{line}")
            }
        };
        out(format!(
            "{} frames of {}×{} in {:.2} s: {} with a contact area, {} gated present; box rectangle {} px; track p50 {:.1} µs, p99 {:.1} µs per frame (budget 11.1 ms at 90 fps); filter {}",
            t.frames,
            intr.width,
            intr.height,
            seconds,
            t.present,
            t.gated,
            run.pipe.tracker.roi().pixels(),
            percentile(&t.track_us, 50.0),
            percentile(&t.track_us, 99.0),
            kind.name()
        ))?;
        if self.synthetic {
            out(format!(
                "vs ground truth: centroid error {:.3} mm RMS over {} frames, presence wrong on {} frames away from transitions",
                (t.err2 / t.err_n.max(1) as f64).sqrt(),
                t.err_n,
                t.presence_wrong
            ))?;
        }
        if run.z_profile.is_some() {
            out(format!(
                "surface depth profile: {} re-plans above {} mm in {} frames",
                run.replans, self.replan_mm, t.frames
            ))?;
        }
        if let Some(r) = &replanner {
            out(format!(
                "device re-plans: {} uploaded and played, {} skipped while no slot was free, {} failed{}",
                r.uploaded,
                r.skipped,
                r.failed,
                r.last_failure
                    .as_ref()
                    .map_or(String::new(), |e| format!(" (last: {e})"))
            ))?;
        }
        if lmhost::stop::requested() {
            out(format!(
                "stopped by signal{}",
                if device_report.as_ref().is_some_and(|(r, _)| r.muted_at_end) {
                    "; device muted"
                } else {
                    ""
                }
            ))?;
        }
        if let Some((r, where_)) = device_report {
            out(format!(
                "device refusals: {} centroids outside the work volume (muted until one is inside), {} dropped by the plausibility gate ({} out of range, {} jumps, {} out of order)",
                r.outside_work_volume,
                r.rejected.total(),
                r.rejected.out_of_range,
                r.rejected.jumps,
                r.rejected.out_of_order
            ))?;
            let p = |q| r.ack_percentile_us(q).unwrap_or(0);
            out(format!(
                "streamed {} centroids ({} present) to {where_}; frame → Centroid frame: track p50 {:.0} µs + device ack p50 {} µs, p99 {} µs, plus the {} filter's lag {:.1} ms (90 fps)",
                r.acked,
                r.present,
                percentile(&t.track_us, 50.0),
                p(50.0),
                p(99.0),
                kind.name(),
                lmhost::track::report::filter_lag_ms(kind, 90.0)
            ))?;
        }
        Ok(())
    }
}
