//! Opening `lmhost track`'s frame source: a recording, the synthetic
//! finger, the camera or a frame stream, and the camera setup it is seen
//! with.

use std::path::Path;

use super::options::{Source, SyntheticFinger};
use crate::plan::scene::Scene;
use crate::sense::track::camera::CameraSetup;
use crate::sense::track::intrinsics::Intrinsics;
use crate::sense::track::settings_file::SettingsFile as _;
use crate::sense::track::source::{self, FrameSource};
use crate::sense::track::synth::{FingerSim, background_of};

/// The frame source `src` names and the setup it is seen with.
pub(super) fn open_source(
    src: &Source,
    scene: &Scene,
) -> anyhow::Result<(Box<dyn FrameSource>, CameraSetup)> {
    match src {
        Source::Synthetic { finger, intrinsics } => synthetic(finger, intrinsics.as_deref(), scene),
        Source::Recorded {
            depth,
            timestamps,
            intrinsics,
        } => {
            let setup = CameraSetup::of_scene(scene)?;
            let r = source::Replay::open_with_defaults(
                depth,
                intrinsics.as_deref(),
                timestamps.as_deref(),
            )?;
            Ok((Box::new(r), setup))
        }
        Source::Camera { intrinsics } => live(scene, intrinsics.as_deref(), || {
            Ok(Box::new(source::camera()?))
        }),
        Source::Stream { path, intrinsics } => live(scene, intrinsics.as_deref(), || stream(path)),
    }
}

/// The synthetic finger, rendered for `intrinsics` [default: a D435 at
/// 848 × 480] in `scene`'s setup or one about its centre.
fn synthetic(
    finger: &SyntheticFinger,
    intrinsics: Option<&Path>,
    scene: &Scene,
) -> anyhow::Result<(Box<dyn FrameSource>, CameraSetup)> {
    let intr = match intrinsics {
        Some(p) => Intrinsics::load(p)?,
        None => Intrinsics::D435_848X480,
    };
    let setup = CameraSetup::of_scene_or_default(scene);
    let mut sim = FingerSim::new(setup, intr, background_of(scene));
    sim.noise_mm = finger.noise_mm();
    sim.holes = finger.holes();
    Ok((
        Box::new(source::Synthetic::new(sim, finger.seconds())),
        setup,
    ))
}

/// A live source (`open`), once the scene's setup is known to be good;
/// given `intrinsics` are checked against the stream's own.
fn live(
    scene: &Scene,
    intrinsics: Option<&Path>,
    open: impl FnOnce() -> anyhow::Result<Box<dyn FrameSource>>,
) -> anyhow::Result<(Box<dyn FrameSource>, CameraSetup)> {
    let setup = CameraSetup::of_scene(scene)?;
    let src = open()?;
    if let Some(ip) = intrinsics {
        let given = Intrinsics::load(ip)?;
        let got = src.intrinsics();
        given.check_frames(got.pinhole.width, got.pinhole.height, "the stream")?;
    }
    Ok((src, setup))
}

/// An LMDEPTH1 stream from `path` (`-` = stdin), read on its own thread
/// (the device's housekeeping goes on while no frame arrives) and held to
/// the live deadlines (source::HEADER_DEADLINE, source::FRAME_DEADLINE),
/// as the camera is.
fn stream(path: &Path) -> anyhow::Result<Box<dyn FrameSource>> {
    if path.as_os_str() == "-" {
        return Ok(Box::new(source::Live::start("stdin", None, || {
            source::Stream::new(std::io::stdin(), "stdin")
        })?));
    }
    crate::files::not_a_pipe("--stream file", "--stream", path)?;
    let f = crate::files::open_input("--stream file", path)?;
    let what = path.display().to_string();
    Ok(Box::new(source::Live::start(
        &what.clone(),
        None,
        move || source::Stream::new(std::io::BufReader::new(f), &what),
    )?))
}
