//! `lmhost track`: depth frames in, the paper's contact-area centroid out,
//! optionally filtered, gated and streamed to the device
//! ([`lmhost::track::session`] does the work).

use std::path::PathBuf;

use super::args::PortArgs;
use lmhost::stream::filter::FilterKind;
use lmhost::track::session::{Device, Options, Session};

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

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        let Args {
            port,
            depth,
            timestamps,
            intrinsics,
            scene,
            synthetic,
            seconds,
            noise_mm,
            holes,
            camera,
            stream,
            record,
            fast,
            json,
            plot,
            plot_frame,
            filter,
            z_profile,
            replan_mm,
            replan,
            enter_frames,
            leave_frames,
        } = self;
        let session = Session::open(Options {
            scene,
            depth,
            timestamps,
            intrinsics,
            synthetic,
            seconds,
            noise_mm,
            holes,
            camera,
            stream,
            record,
            fast,
            json,
            plot,
            plot_frame,
            filter,
            z_profile,
            replan_mm,
            replan,
            enter_frames,
            leave_frames,
            device: port.port.is_some(),
        })?;
        let mut print = |line: &str| lmhost::outln!("{line}");
        let report = if port.port.is_some() {
            // AUTD3: the default stimulus for the scene is uploaded and
            // played first, and the array is left silent at the end.
            let (mut dev, upload) =
                super::session::open_playing_default(&port.spec(), session.scene())?;
            let device = Device {
                backend: dev.as_mut(),
                silence_at_end: upload.is_some(),
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
