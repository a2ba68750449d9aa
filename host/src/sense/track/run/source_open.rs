//! Opening `lmhost track`'s frame source: exactly one of a recording, the
//! synthetic finger, the camera or a frame stream, and the camera setup it
//! is seen with.

use super::Options;
use crate::limits::show;
use crate::plan::scene::Scene;
use crate::sense::track::camera::CameraSetup;
use crate::sense::track::intrinsics::Intrinsics;
use crate::sense::track::settings_file::SettingsFile as _;
use crate::sense::track::source::{self, FrameSource};
use crate::sense::track::synth::{FingerSim, background_of};

/// The source `opts` name (exactly one) and the setup it is seen with.
pub(super) fn open_source(
    opts: &Options,
    scene: &Scene,
) -> anyhow::Result<(Box<dyn FrameSource>, CameraSetup)> {
    let picked = [
        opts.depth.is_some(),
        opts.synthetic,
        opts.camera,
        opts.stream.is_some(),
    ]
    .iter()
    .filter(|b| **b)
    .count();
    if picked != 1 {
        crate::bad_input!(
            "give exactly one source: --depth FILE.npy, --synthetic, --camera or --stream FILE"
        );
    }
    for (flag, given) in [
        ("--seconds", opts.seconds.is_some()),
        ("--noise-mm", opts.noise_mm.is_some()),
        ("--holes", opts.holes.is_some()),
    ] {
        if given && !opts.synthetic {
            crate::bad_input!(
                "{flag} applies to --synthetic only (it renders the synthetic finger)"
            );
        }
    }
    if opts.synthetic {
        let seconds = opts.seconds.unwrap_or(6.0);
        let noise_mm = opts.noise_mm.unwrap_or(0.5);
        let holes = opts.holes.unwrap_or(0.02);
        if !(seconds.is_finite() && seconds > 0.0 && seconds <= 3600.0) {
            crate::bad_input!("--seconds {} must be in (0, 3600]", show(seconds));
        }
        if !(noise_mm.is_finite() && (0.0..=50.0).contains(&noise_mm)) {
            crate::bad_input!("--noise-mm {} must be in [0, 50]", show(noise_mm));
        }
        if !(holes.is_finite() && (0.0..=1.0).contains(&holes)) {
            crate::bad_input!("--holes {} must be in [0, 1]", show(holes));
        }
        let intr = match &opts.intrinsics {
            Some(p) => Intrinsics::load(p)?,
            None => Intrinsics::D435_848X480,
        };
        let setup = CameraSetup::of_scene_or_default(scene);
        let mut sim = FingerSim::new(setup, intr, background_of(scene));
        sim.noise_mm = noise_mm;
        sim.holes = holes;
        if (seconds * sim.rate_hz).round() < 1.0 {
            crate::bad_input!(
                "--seconds {} renders no frame at {} fps; give at least {} s",
                show(seconds),
                sim.rate_hz,
                show(0.5 / sim.rate_hz)
            );
        }
        return Ok((Box::new(source::Synthetic::new(sim, seconds)), setup));
    }
    let setup = CameraSetup::of_scene(scene)?;
    if let Some(d) = &opts.depth {
        let r = source::Replay::open_with_defaults(
            d,
            opts.intrinsics.as_deref(),
            opts.timestamps.as_deref(),
        )?;
        return Ok((Box::new(r), setup));
    }
    // Live streams are read on their own thread (the device's
    // housekeeping goes on while no frame arrives) and held to the
    // live deadlines (source::HEADER_DEADLINE, source::FRAME_DEADLINE).
    let src: Box<dyn FrameSource> = if opts.camera {
        Box::new(source::camera()?)
    } else {
        match opts.stream.as_deref() {
            Some(p) if p.as_os_str() == "-" => {
                Box::new(source::Live::start("stdin", None, || {
                    source::Stream::new(std::io::stdin(), "stdin")
                })?)
            }
            Some(p) => {
                let f = crate::files::open_input("--stream file", p)?;
                let what = p.display().to_string();
                Box::new(source::Live::start(&what.clone(), None, move || {
                    source::Stream::new(std::io::BufReader::new(f), &what)
                })?)
            }
            None => crate::bad_input!(
                "give exactly one source: --depth FILE.npy, --synthetic, --camera or --stream FILE"
            ),
        }
    };
    if let Some(ip) = &opts.intrinsics {
        let given = Intrinsics::load(ip)?;
        let got = src.intrinsics();
        given.check_frames(got.width, got.height, "the stream")?;
    }
    Ok((src, setup))
}
