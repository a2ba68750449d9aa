//! A tracking session (`lmhost track`): depth frames from one source
//! through the [`Pipeline`], one result per frame, optionally recorded,
//! plotted, scored against the synthetic finger's ground truth, measured
//! for the finger surface's depth profile and streamed to a device, which
//! re-plans its circle when that profile moves.
//!
//! The [`Options`] are typed: one [`Source`] of four, each value checked
//! when made (an [`InputError`] naming its flag). [`TrackRun::open`]
//! checks what spans them (a scene but for the synthetic finger, a device
//! for `--replan`) and opens the source; [`TrackRun::run`] tracks until
//! the source ends or a stop is requested ([`crate::stop`]), hands every
//! output line to the caller as it comes and returns the [`Report`].
//! The session prints nothing itself: the caller prints the lines, the
//! warnings and the closing summary.

use std::cell::RefCell;
use std::rc::Rc;
use std::time::{Duration, Instant};

use anyhow::Context as _;

use super::contact::Tracker;
use super::intrinsics::Intrinsics;
use super::source::{Frame, FrameSource, Recorder};
use super::surface::Replanner;
use super::{FrameResult, Pipeline};
use crate::clock::Spread;
use crate::device::backend::Backend;
use crate::error::InputError;
use crate::geom;
use crate::limits::show;
use crate::plan::scene::Scene;
use crate::plan::sequence::Plan;
use crate::sense::stream::Sample;
use crate::sense::stream::filter::{FilterKind, Passthrough};
use crate::sense::stream::run::{Feed, Next, Pace, StreamReport, stream};

mod options;
mod replan;
mod source_open;

pub use options::{Options, Plot, Source, SyntheticFinger, ZProfile};
use replan::DeviceReplan;
use source_open::open_source;

/// Plans the device's stimulus with a measured depth profile (mm along
/// the LM plane's c axis, one value per step): the caller's stimulus, on
/// the device's dwell grid (`--replan`).
pub type Replan<'a> = &'a mut dyn FnMut(&[f64]) -> anyhow::Result<Plan>;

/// The device a session streams to.
pub struct Device<'a> {
    /// The device, its stimulus playing.
    pub backend: &'a mut dyn Backend,
    /// Stop it at the end (an AUTD3, which lmhost started playing).
    pub silence_at_end: bool,
    /// With [`ZProfile::replan`]: how to plan a measured profile (its
    /// length is the `--z-profile` step count).
    pub replan: Option<Replan<'a>>,
}

/// What a session measured, for the caller to print.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// Warnings about the run (without a `warning: ` prefix).
    pub warnings: Vec<String>,
    /// The closing summary, one line each.
    pub summary: Vec<String>,
}

/// An opened `lmhost track` run: [`TrackRun::run`] it.
pub struct TrackRun {
    opts: Options,
    scene: Scene,
    intr: Intrinsics,
    filter: FilterKind,
    /// Why no frame can find a finger; said once the run is over (a run
    /// that fails says its error alone).
    hopeless: Option<InputError>,
    live: bool,
    replanner: Option<DeviceReplan>,
    run: Run,
    /// The run's seconds count from here (a device opened in between
    /// counts too).
    started: Instant,
}

impl TrackRun {
    /// Checks `opts`, loads the scene and opens the source, the recording
    /// and the plot directory. From here on Ctrl-C / SIGTERM end the
    /// session cleanly ([`crate::stop::graceful`]), and the run's time
    /// counts (opening the device included).
    pub fn open(opts: Options) -> anyhow::Result<Self> {
        let scene = Scene::load_or_default(opts.scene.as_deref())?;
        let synthetic = matches!(opts.source, Source::Synthetic { .. });
        if opts.scene.is_none() && !synthetic {
            crate::bad_input!("--scene is needed: its [camera] and [tracking] place the box");
        }
        let replan = opts.z_profile.is_some_and(|z| z.replan());
        if replan && !opts.device {
            crate::bad_input!(
                "--replan needs --port: the re-planned stimulus is uploaded to the device"
            );
        }
        // Every source ends on Ctrl-C / SIGTERM: the recording is finished,
        // the device muted and the report printed.
        crate::stop::graceful();
        let (src, setup) = open_source(&opts.source, &scene)?;
        let intr = src.intrinsics();
        let filter = opts.filter.unwrap_or(if opts.device {
            FilterKind::Gaussian
        } else {
            FilterKind::None
        });
        let tracker = Tracker::new(intr, setup);
        let hopeless = super::check_rig(&tracker).err();
        let pipe = Pipeline::new(tracker, opts.gate, filter.build());
        // Every output before any is made: a --plot folder at the
        // recording's path (or a file's beside it) was made, and the
        // recording failed on it at the end, its other files left.
        if let (Some(r), Some(p)) = (&opts.record, &opts.plot) {
            let mut outs = Recorder::outputs(r, src.colour_camera().is_some());
            outs.push(("--plot", p.dir.clone()));
            crate::files::distinct_outputs(&outs)?;
        }
        let rec = match &opts.record {
            Some(p) => Some(Recorder::create(p, intr, src.colour_camera())?),
            None => None,
        };
        let plot_dir = match &opts.plot {
            Some(p) => Some(crate::files::output_dir("--plot", &p.dir)?),
            None => None,
        };
        let live = src.live();
        let replanner = match replan {
            true => Some(DeviceReplan::new(&scene, &setup)?),
            false => None,
        };
        let run = Run {
            z_profile: opts.z_profile.map(|z| (z, Replanner::new(z.replan_mm()))),
            replans: 0,
            pending: replanner.as_ref().map(|_| Rc::new(RefCell::new(None))),
            src,
            pipe,
            rec,
            json: opts.json,
            paced: !opts.fast && !live && !opts.device,
            start: None,
            plot_at: opts.plot.as_ref().and_then(|p| p.frame),
            plot_frame: None,
            want_plot: opts.plot.is_some(),
            _plot_dir: plot_dir,
            tally: Tally::default(),
            second: Tally::default(),
            next_summary: f64::NEG_INFINITY,
            prev_truth: [None; 2],
            prev_t_s: None,
        };
        Ok(Self {
            opts,
            scene,
            intr,
            filter,
            hopeless,
            live,
            replanner,
            run,
            started: Instant::now(),
        })
    }

    /// The gated centre of every frame as a finger sample, paced like the
    /// source (a replay at its recorded speed unless `fast`), until the
    /// source ends or a stop is requested: the finger source of the session
    /// session. Nothing is printed.
    pub fn samples(mut self) -> impl Iterator<Item = anyhow::Result<Sample>> {
        let mut done = false;
        std::iter::from_fn(move || {
            if done || crate::stop::requested() {
                return None;
            }
            let r = self.run.next(&mut |_| Ok(()));
            match r {
                Ok(Some(res)) => Some(Ok(res.sample())),
                Ok(None) => None,
                Err(e) => {
                    done = true;
                    Some(Err(e))
                }
            }
        })
    }

    /// The scene the session tracks in (the device's stimulus is planned
    /// in it).
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The surface's depth profile, if measured: its circle is a
    /// re-plan's radius and step count.
    pub fn z_profile(&self) -> Option<&ZProfile> {
        self.run.z_profile.as_ref().map(|(z, _)| z)
    }

    /// Tracks every frame until the source ends or a stop is requested,
    /// streaming the gated, filtered centre to `device` if given, and
    /// hands each output line (a JSON object per frame, or a summary per
    /// second; the recording and the plot written) to `print` as it
    /// comes. Finishes the recording and writes the plot.
    pub fn run(
        mut self,
        device: Option<Device<'_>>,
        print: &mut dyn FnMut(&str) -> anyhow::Result<()>,
    ) -> anyhow::Result<Report> {
        let mut streamed = None;
        if let Some(Device {
            backend,
            silence_at_end,
            mut replan,
        }) = device
        {
            if self.replanner.is_some() && replan.is_none() {
                anyhow::bail!("--replan needs a planner for the device's stimulus");
            }
            let where_ = backend.describe();
            let pace = if self.opts.fast || self.live {
                Pace::Arrival
            } else {
                Pace::Timestamps
            };
            let scene = &self.scene;
            let replanner = &mut self.replanner;
            let pending = self.run.pending.clone();
            let report = stream(
                &mut *backend,
                RunFeed {
                    run: &mut self.run,
                    print: &mut *print,
                },
                &mut Passthrough,
                |p| scene.drive_point(p),
                pace,
                |client, _, _| match (&mut *replanner, &pending, &mut replan) {
                    (Some(r), Some(p), Some(plan)) => r.maybe_upload(client, p, &mut **plan),
                    _ => Ok(()),
                },
            )
            .map_err(|e| {
                if e.downcast_ref::<InputError>().is_some() {
                    e
                } else {
                    e.context(format!("streaming centroids to {where_}"))
                }
            })?;
            if silence_at_end {
                backend.stop().context("silencing the array")?;
            }
            streamed = Some((report, where_));
        } else {
            while !crate::stop::requested() && self.run.next(print)?.is_some() {}
        }
        let seconds = self.started.elapsed().as_secs_f64();
        let opts = &self.opts;
        let run = &mut self.run;
        if let (Some(r), Some(path)) = (run.rec.take(), &opts.record) {
            let n = r.finish()?;
            if !opts.json {
                print(&format!("recorded {n} frames to {}", path.display()))?;
            }
        }
        let plot = opts.plot.as_ref();
        if let (Some(p), Some((i, depth))) = (plot, &run.plot_frame) {
            let path = p.dir.join(format!("track_frame_{i}.png"));
            super::plot::frame_png(&run.pipe.tracker, depth, &path)?;
            if !opts.json {
                print(&format!("plot {}", path.display()))?;
            }
        } else if let Some(n) = plot.and_then(|p| p.frame) {
            crate::bad_input!("--plot-frame {n} is beyond the {} frames", run.tally.frames);
        }
        let stopped = crate::stop::requested();
        let t = &run.tally;
        let mut warnings = Vec::new();
        if plot.is_some_and(|p| p.frame.is_none()) && run.plot_frame.is_none() {
            warnings.push(format!(
                "--plot wrote nothing: the run had no frame ({} frames)",
                t.frames
            ));
        }
        match &self.hopeless {
            Some(why) => warnings.push(why.to_string()),
            None if t.frames > 0 && t.present == 0 && !stopped => warnings.push(format!(
                "no frame of {} had a contact area in the tracking box: check the camera pose, the box and depth_scale",
                t.frames
            )),
            None => {}
        }
        let mut summary = vec![format!(
            "{} frames of {}×{} in {:.2} s: {} with a contact area, {} gated present; box rectangle {} px; track {} per frame (budget 11.1 ms at 90 fps); filter {}",
            t.frames,
            self.intr.pinhole.width,
            self.intr.pinhole.height,
            seconds,
            t.present,
            t.gated,
            run.pipe.tracker.roi().pixels(),
            t.track_us().map_or("n/a".to_owned(), |s| format!(
                "p50 {:.1} µs, p99 {:.1} µs",
                s.p50, s.p99
            )),
            self.filter.name()
        )];
        if matches!(opts.source, Source::Synthetic { .. }) {
            summary.push(format!(
                "vs ground truth: centroid error {:.3} mm RMS over {} frames, presence wrong on {} frames away from transitions",
                (t.err2 / t.err_n.max(1) as f64).sqrt(),
                t.err_n,
                t.presence_wrong
            ));
        }
        if let Some((z, _)) = &run.z_profile {
            summary.push(format!(
                "surface depth profile: {} re-plans above {} mm in {} frames",
                run.replans,
                z.replan_mm(),
                t.frames
            ));
        }
        if let Some(r) = &self.replanner {
            summary.push(format!(
                "device re-plans: {} uploaded and played{}, {} skipped while no slot was free, {} failed{}",
                r.uploaded,
                r.last_plan
                    .map_or(String::new(), |(n, f, d)| format!(
                        " (last: {n} steps × {f} foci, dwell {d:.1} µs)"
                    )),
                r.skipped,
                r.failed,
                r.last_failure
                    .as_ref()
                    .map_or(String::new(), |e| format!(" (last: {e})"))
            ));
        }
        if stopped {
            summary.push(format!(
                "stopped by {}{}",
                crate::stop::cause().map_or("a signal".into(), |c| c.to_string()),
                if streamed.as_ref().is_some_and(|(r, _)| r.muted_at_end) {
                    "; device muted"
                } else {
                    ""
                }
            ));
        }
        if let Some((r, where_)) = streamed {
            summary.extend(device_lines(&r, &where_, t, self.filter));
        }
        Ok(Report { warnings, summary })
    }
}

/// The closing lines about the centroids streamed to the device.
fn device_lines(r: &StreamReport, where_: &str, t: &Tally, filter: FilterKind) -> [String; 2] {
    let ack = r.ack_us();
    [
        format!(
            "device refusals: {} centroids outside the work volume (muted until one is inside), {} dropped by the plausibility gate ({} out of range, {} jumps, {} out of order, {})",
            r.outside_work_volume,
            r.rejected.total(),
            r.rejected.out_of_range,
            r.rejected.jumps,
            r.rejected.out_of_order,
            crate::out::count(r.rejected.time_jumps, "time jump")
        ),
        format!(
            "streamed {} centroids ({} present) to {where_}; frame → Centroid frame: track p50 {} + device ack {}, plus the {} filter's lag {:.1} ms (90 fps)",
            r.acked,
            r.present,
            t.track_p50(),
            Spread::describe_or(ack.as_ref(), |us| format!("{us} µs")),
            filter.name(),
            super::report::filter_lag_ms(filter, 90.0)
        ),
    ]
}

/// Per-run counters.
#[derive(Debug, Default)]
struct Tally {
    frames: u64,
    present: u64,
    gated: u64,
    /// Tracking time per frame (ns).
    track_ns: Vec<u64>,
    err2: f64,
    err_n: u64,
    presence_wrong: u64,
}

impl Tally {
    /// The tracking time per frame (µs); `None` with no frame.
    fn track_us(&self) -> Option<Spread<f64>> {
        Spread::of_f64(self.track_ns.iter().map(|&ns| ns as f64 / 1e3))
    }

    /// The median tracking time per frame, as the per-second and device
    /// lines print it.
    fn track_p50(&self) -> String {
        self.track_us()
            .map_or("n/a".to_owned(), |s| format!("{:.0} µs", s.p50))
    }
}

/// The frame loop's state.
struct Run {
    z_profile: Option<(ZProfile, Replanner)>,
    replans: u64,
    /// The latest re-planned profile not yet uploaded (with `replan`).
    pending: Option<Rc<RefCell<Option<Vec<f64>>>>>,
    src: Box<dyn FrameSource>,
    pipe: Pipeline,
    rec: Option<Recorder>,
    json: bool,
    paced: bool,
    start: Option<(Instant, f64)>,
    plot_at: Option<u64>,
    plot_frame: Option<(u64, Vec<u16>)>,
    want_plot: bool,
    /// The `--plot` folder made: removed, while empty, with the run.
    _plot_dir: Option<crate::files::MadeDirs>,
    tally: Tally,
    second: Tally,
    next_summary: f64,
    prev_truth: [Option<(bool, bool)>; 2],
    prev_t_s: Option<f64>,
}

/// The tracked centres of a [`Run`] as the streaming loop's feed: a live
/// source idles (the loop ticks the device) while no frame arrives.
struct RunFeed<'a> {
    run: &'a mut Run,
    print: &'a mut dyn FnMut(&str) -> anyhow::Result<()>,
}

impl Feed for RunFeed<'_> {
    fn next_within(&mut self, wait: Duration) -> Next<anyhow::Result<Sample>> {
        match self.run.next_within(wait, self.print) {
            Ok(Next::Ready(r)) => Next::Ready(Ok(r.sample())),
            Ok(Next::Idle) => Next::Idle,
            Ok(Next::End) => Next::End,
            Err(e) => Next::Ready(Err(e)),
        }
    }
}

impl Run {
    fn next(
        &mut self,
        print: &mut dyn FnMut(&str) -> anyhow::Result<()>,
    ) -> anyhow::Result<Option<FrameResult>> {
        loop {
            match self.next_within(Duration::from_secs(3600), print)? {
                Next::Ready(r) => return Ok(Some(r)),
                Next::Idle => {}
                Next::End => return Ok(None),
            }
        }
    }

    /// The next frame's result if a frame comes within `wait`.
    fn next_within(
        &mut self,
        wait: Duration,
        print: &mut dyn FnMut(&str) -> anyhow::Result<()>,
    ) -> anyhow::Result<Next<FrameResult>> {
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
                .partial_cmp(&crate::limits::MAX_REPLAY_GAP_S)
                .is_some_and(|o| o.is_le())
        {
            crate::bad_input!(
                "frame {index}: time stamp {} s is {} s after the previous frame's; at most {} s between frames",
                show(frame.t_s),
                show(frame.t_s - prev),
                crate::limits::MAX_REPLAY_GAP_S
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
                InputError::new(format!(
                    "frame {index}: time stamp {} s cannot be replayed",
                    show(frame.t_s)
                ))
            })?;
            if let Some(wait) = due.checked_sub(t0.elapsed()) {
                std::thread::sleep(wait);
            }
        }
        let res = self.pipe.step(frame.t_s, &frame.depth);
        let profile = self.z_profile(&frame, &res);
        self.report(&frame, &res, profile, print)?;
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
        let (z, replan) = self.z_profile.as_mut()?;
        let c = r.centroid_mm()?;
        let tb = &self.pipe.tracker.setup().track_box;
        let rel = geom::sub(c, tb.center_mm);
        let ab = [geom::dot(tb.axes[0], rel), geom::dot(tb.axes[1], rel)];
        let prof = super::surface::profile(
            &self.pipe.tracker,
            &frame.depth,
            ab,
            z.radius_mm(),
            z.steps(),
        );
        let rel = super::surface::relative(&prof)?;
        let due = replan.update(&rel);
        self.replans += due as u64;
        if let (true, Some(p)) = (due, &self.pending) {
            *p.borrow_mut() = Some(rel.clone());
        }
        Some((rel, due))
    }

    /// Counts the frame, scores it against the ground truth and prints its
    /// line (or the summary line of the second it ends).
    fn report(
        &mut self,
        frame: &Frame,
        r: &FrameResult,
        profile: Option<(Vec<f64>, bool)>,
        print: &mut dyn FnMut(&str) -> anyhow::Result<()>,
    ) -> anyhow::Result<()> {
        for t in [&mut self.tally, &mut self.second] {
            t.frames += 1;
            t.present += r.present as u64;
            t.gated += r.gated as u64;
            t.track_ns.push((r.track_s * 1e9) as u64);
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
                // The presence gate always runs: its verdict is what
                // `--enter-frames` / `--leave-frames` change.
                "gated_present": r.gated,
                // What a device is sent: the gate's centre (held through a
                // dropout), through the filter if one is given; so a
                // replay of these lines streams what the live run did.
                "filtered_mm": r.filtered_mm,
            });
            if self.z_profile.is_some() {
                v["z_profile_mm"] = serde_json::json!(profile.as_ref().map(|p| &p.0));
                v["replan"] = profile.as_ref().is_some_and(|p| p.1).into();
            }
            if let Some(truth) = &frame.truth {
                v["truth_present"] = truth.present.into();
                v["truth_mm"] = serde_json::json!(truth.contact.centroid_mm);
            }
            print(&v.to_string())?;
        } else if r.t_s >= self.next_summary {
            let s = std::mem::take(&mut self.second);
            let c = r.centroid_mm().map_or("none".to_owned(), |c| {
                format!("({:.2}, {:.2}, {:.2}) mm", c[0], c[1], c[2])
            });
            print(&format!(
                "t {:>7.2} s  frames {:>3}  present {:>3}  gated {:>3}  points {:>4}  centroid {c}  track p50 {}",
                r.t_s,
                s.frames,
                s.present,
                s.gated,
                r.contact.points,
                s.track_p50()
            ))?;
            self.next_summary = (r.t_s + 1.0).floor();
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
