//! `lmhost track`: depth frames in, the paper's contact-area centroid out,
//! optionally filtered, gated and streamed to the device
//! ([`lmhost::sense::track::run`] does the work).

use std::path::PathBuf;

use super::args::PortArgs;
use crate::cmd::plan::StimulusFlags;
use lmhost::plan::sequence::Plan;
use lmhost::plan::stimulus::Stimulus;
use lmhost::plan::trajectory::Steps;
use lmhost::sense::stream::filter::FilterKind;
use lmhost::sense::track::presence::{self, Hysteresis};
use lmhost::sense::track::run::{
    Device, Options, Plot, Source, SyntheticFinger, TrackRun, ZProfile,
};

/// Track the finger in depth frames: the contact area inside the scene's
/// detection box and its centroid, one result per frame.
///
/// Sources: a recording (`--depth F.npy`, uint16 frames × height × width,
/// with `--intrinsics` and optional `--timestamps`), the synthetic finger
/// (`--synthetic`), a RealSense camera (`--camera`, through the bundled
/// pyrealsense2 bridge) or an LMDEPTH1 stream (`--stream FILE|-`).
/// With `--port` the filtered, gated centre is streamed to the device.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "The stimulus (with --port), alike on every backend: with any \
    stimulus flag (--radius, --foci, --spacing, --freq, --step, --steps, --center, --z, \
    --method, --iterations, --weights) that stimulus is planned for the device (on AUTD3's \
    25 µs dwell grid), uploaded into a free slot and played before tracking, with a \
    one-line summary on stderr. With none, the LM firmware plays the entry it plays or \
    played last (what `lmhost upload` put there), tracked, and otherwise, like \
    an AUTD3, plays the default stimulus (LM-S, A = 3 mm, 5 Hz, 0.23 mm steps); what \
    plays stops when tracking ends. Without --port a stimulus flag cannot apply and is refused. \
    With --replan the stimulus's radius and steps are --z-profile's and its depth \
    profile is measured, so --step and --z are refused."
)]
pub struct Args {
    /// Stream the filtered centre to the device on this port (only when
    /// `--port` is given; $LMHOST_PORT alone does not enable streaming).
    #[command(flatten)]
    port: PortArgs,
    // Sources, tracking, output and gating (a group of their own so they
    // become the library's options in one move).
    #[command(flatten)]
    track: TrackFlags,
    /// With --port: the stimulus played while tracking (see below).
    #[command(flatten)]
    stimulus: StimulusFlags,
}

/// `lmhost track`'s own flags: the library's [`Options`] but for the
/// device, which `--port` decides. A synthetic finger's flag given with
/// another source is clap's conflict; the rest of the combinations are
/// what [`TrackFlags::options`] maps.
#[derive(Debug, clap::Args)]
struct TrackFlags {
    /// Recorded depth frames: `.npy`, uint16, (frames, height, width).
    #[arg(long, value_name = "FILE.npy")]
    depth: Option<PathBuf>,
    /// Frame time stamps: `.npy`, float64 seconds, one per frame
    /// [default: FILE.timestamps.npy beside --depth, else 90 fps].
    // The other sources are stated as conflicts: clap waives `requires`
    // when --depth conflicts with a flag given, e.g. --seconds.
    #[arg(long, value_name = "T.npy", requires = "depth", conflicts_with_all = ["synthetic", "camera", "stream", "seconds", "noise_mm", "holes"])]
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
    #[arg(long, value_name = "S", allow_negative_numbers = true, conflicts_with_all = NOT_SYNTHETIC)]
    seconds: Option<f64>,
    /// Synthetic finger: depth noise (mm, 1 σ), in [0, 50] [default: 0.5].
    #[arg(long, value_name = "MM", allow_negative_numbers = true, conflicts_with_all = NOT_SYNTHETIC)]
    noise_mm: Option<f64>,
    /// Synthetic finger: fraction of pixels with no data, in [0, 1]
    /// [default: 0.02].
    #[arg(long, value_name = "FRACTION", allow_negative_numbers = true, conflicts_with_all = NOT_SYNTHETIC)]
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
    /// Replay as fast as possible instead of at the recorded speed (a
    /// recording or the synthetic finger: the camera and a stream come as
    /// they come).
    #[arg(long, conflicts_with_all = ["camera", "stream"])]
    fast: bool,
    /// One JSON object per frame per line.
    #[arg(long)]
    json: bool,
    /// Write a PNG of one frame (box, contact area, centroid) into DIR.
    #[arg(long, value_name = "DIR")]
    plot: Option<PathBuf>,
    /// The frame to plot [default: the first with a contact area].
    #[arg(long, value_name = "N", requires = "plot", value_parser = super::whole::whole::<u64>(0, u64::MAX))]
    plot_frame: Option<u64>,
    /// Centroid filter [default: gaussian (the paper's) with --port, else none].
    #[arg(long, value_parser = super::args::filter())]
    filter: Option<FilterKind>,
    /// Also measure the finger surface's depth z_j along a circle of
    /// RADIUS_MM in STEPS steps (no spaces) about the centroid (relative to the centre,
    /// along the box's third axis): JSON key `z_profile_mm`, and `replan`
    /// when it moved more than --replan-mm from the last planned profile.
    #[arg(long, value_name = "RADIUS_MM,STEPS")]
    z_profile: Option<String>,
    /// Re-plan threshold for --z-profile, 0..=100 mm (a planned depth lies
    /// within ±100 mm: a larger threshold would never re-plan).
    #[arg(long, value_name = "MM", default_value_t = ZProfile::DEFAULT_REPLAN_MM, requires = "z_profile")]
    replan_mm: f64,
    /// With --port and --z-profile: when the surface profile moves more
    /// than --replan-mm, plan the stimulus of the stimulus flags (the
    /// paper's LM-S at 5 Hz by default; LM-M with --foci) with the radius
    /// and steps of --z-profile and that depth profile, for the device (on
    /// an AUTD3 its 25 µs grid), upload it into a slot that is neither
    /// playing nor queued and play it at the next cycle boundary. Off by default: each
    /// re-plan uploads steps × transducers bytes and holds the centroid
    /// stream meanwhile (about 0.45 s for 100 steps × 996 transducers,
    /// 38 kB, at 921600 baud; a pty takes milliseconds), so use it on fast links.
    #[arg(long, requires_all = ["z_profile", "port"])]
    replan: bool,
    /// Consecutive frames with a contact area that open the device gate.
    #[arg(long, value_name = "N", default_value_t = presence::DEFAULT_FRAMES, value_parser = super::whole::whole::<u32>(1, presence::MAX_FRAMES.into()))]
    enter_frames: u32,
    /// Consecutive frames without one that close it.
    #[arg(long, value_name = "N", default_value_t = presence::DEFAULT_FRAMES, value_parser = super::whole::whole::<u32>(1, presence::MAX_FRAMES.into()))]
    leave_frames: u32,
}

/// The sources the synthetic finger's own flags cannot go with.
const NOT_SYNTHETIC: [&str; 3] = ["depth", "camera", "stream"];

impl TrackFlags {
    /// The library's options, each value checked as it is read; `device`:
    /// a device is streamed to.
    fn options(self, device: bool) -> Result<Options, lmhost::InputError> {
        let intrinsics = self.intrinsics;
        let source = match (self.depth, self.synthetic, self.camera, self.stream) {
            (Some(depth), false, false, None) => Source::Recorded {
                depth,
                timestamps: self.timestamps,
                intrinsics,
            },
            (None, true, false, None) => Source::Synthetic {
                finger: SyntheticFinger::new(self.seconds, self.noise_mm, self.holes)?,
                intrinsics,
            },
            (None, false, true, None) => Source::Camera { intrinsics },
            (None, false, false, Some(path)) => Source::Stream { path, intrinsics },
            _ => lmhost::bad_input!(
                "give exactly one source: --depth FILE.npy, --synthetic, --camera or --stream FILE"
            ),
        };
        let z_profile = self
            .z_profile
            .map(|spec| ZProfile::parse(&spec, self.replan_mm, self.replan))
            .transpose()?;
        Ok(Options {
            scene: self.scene,
            source,
            record: self.record,
            plot: self.plot.map(|dir| Plot {
                dir,
                frame: self.plot_frame,
            }),
            fast: self.fast,
            json: self.json,
            gate: Hysteresis::new(self.enter_frames, self.leave_frames)?,
            filter: self.filter,
            z_profile,
            device,
        })
    }
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        let Args {
            port,
            track,
            stimulus,
        } = self;
        let opts = track.options(port.port.is_some())?;
        let (replan, json) = (opts.z_profile.is_some_and(|z| z.replan()), opts.json);
        let given = stimulus.given();
        if let (Some(f), None) = (port.spec().link_settings_given().first(), &port.port) {
            lmhost::bad_input!(
                "{f} applies with --port only: without it nothing is streamed to a device"
            );
        }
        if let (Some(f), None) = (given.first(), &port.port) {
            lmhost::bad_input!(
                "{f} applies with --port only: the stimulus is planned for and played on the device"
            );
        }
        for (flag, given) in [
            ("--z", stimulus.z.is_some()),
            ("--step", stimulus.step.is_some()),
        ] {
            if replan && given {
                lmhost::bad_input!(
                    "{flag} cannot apply with --replan: the re-plan's steps and depth profile come from --z-profile"
                );
            }
        }
        // The flags' stimulus (the default one when none is given), refused
        // before the tracking opens.
        let base = stimulus.stimulus()?;
        let session = TrackRun::open(opts)?;
        let mut print = |line: &str| lmhost::outln!("{line}");
        let report = if port.port.is_some() {
            let target = port.spec().device()?.target();
            let mut stim = (!given.is_empty()).then(|| base.clone());
            // --replan: the stimulus on --z-profile's circle, checked once.
            let replan_stim = match session.z_profile().filter(|z| z.replan()) {
                None => None,
                Some(z) => {
                    let s = replan_stimulus(base, &stimulus, z.radius_mm(), z.steps())?;
                    s.plan_for(&target, session.scene().clone()).map_err(|e| {
                        lmhost::InputError::new(format!(
                            "--replan: the stimulus on the --z-profile circle cannot be planned for this device: {e}"
                        ))
                    })?;
                    if stim.is_some() {
                        stim = Some(s.clone());
                    }
                    Some(s)
                }
            };
            // The stimulus is uploaded and played first on every backend
            // (an AUTD3 without stimulus flags: the default); an AUTD3 is
            // left silent at the end.
            let (mut dev, _upload) =
                super::opening::open_playing(&port.spec(), session.scene(), stim.as_ref())?;
            let scene = session.scene().clone();
            let mut plan_with = replan_stim.map(|s| {
                move |z: &[f64]| -> anyhow::Result<Plan> {
                    let mut s = s.clone();
                    s.cycle.z_profile_mm = z.to_vec();
                    Ok(s.plan_for(&target, scene.clone())?.plan)
                }
            });
            let silence_at_end = dev.needs_host();
            let device = Device {
                backend: dev.as_mut(),
                silence_at_end,
                replan: plan_with
                    .as_mut()
                    .map(|f| f as &mut dyn FnMut(&[f64]) -> anyhow::Result<Plan>),
            };
            session.run(Some(device), &mut print)?
        } else {
            session.run(None, &mut print)?
        };
        for w in &report.warnings {
            lmhost::errln!("warning: {w}");
        }
        for line in &report.summary {
            if json {
                lmhost::errln!("{line}");
            } else {
                lmhost::outln!("{line}")?;
            }
        }
        Ok(())
    }
}

/// The re-plan's stimulus: `s` on the `--z-profile` circle (radius `r`,
/// `n` steps). A --radius or --steps that names another circle cannot
/// apply and is refused.
fn replan_stimulus(
    mut s: Stimulus,
    flags: &StimulusFlags,
    r: f64,
    n: usize,
) -> Result<Stimulus, lmhost::InputError> {
    if let Some(a) = flags.radius.filter(|&a| a != r) {
        lmhost::bad_input!(
            "--radius {a} differs from --z-profile's radius {r}: the re-plan plays the circle the surface is measured on (leave --radius out)"
        );
    }
    if let Some(k) = flags.steps.filter(|&k| k != n) {
        lmhost::bad_input!(
            "--steps {k} differs from --z-profile's {n} steps: the re-plan plays one step per measured depth (leave --steps out)"
        );
    }
    s.cycle.radius_mm = r;
    s.cycle.steps = Steps::Count(n);
    Ok(s)
}
