//! One device interface for every kind of rig.
//!
//! [`Backend`] is what the subcommands need from a device: `info`,
//! `status`, `upload`, `play`, `stop` and centroid streaming. [`open`]
//! picks one from `--port`:
//! - `autd3:...` → [`crate::autd3::Autd3Backend`]: AUTD3 arrays through the
//!   autd3 crates, their firmware emulator included;
//! - anything else → [`LmBackend`]: the LM firmware over serial / pty / TCP
//!   ([`crate::link::Client`]).
//!
//! Status is the firmware's own [`lm_proto::Status`] for both (an AUTD3
//! fills the fields it has, `mute_reason` included, and zeroes the wire
//! counters it has no use for). Positions and centroids are in drive
//! coordinates (the mirrored frame when the scene has a reflector), as on
//! the wire.

use std::io::IsTerminal as _;

use anyhow::Context as _;
use lm_proto::{Centroid, Encoding, Info, NackCode, PlayAt, Status};
use serde::Serialize;

use crate::autd3::{Autd3Backend, Autd3Port, GridTiming};
use crate::cmd::plan::PlanArgs;
use crate::cmd::upload::{check_slot, free_slot};
use crate::link::{Client, LinkError, PortArgs, Transport, UploadSpec};
use crate::scene::Scene;
use crate::sequence::Plan;

/// What a device says about itself.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BackendInfo {
    /// Backend kind, e.g. `autd3` or `lm-firmware`.
    pub backend: String,
    /// The port it was opened on.
    pub port: String,
    /// Devices (boards) in the rig.
    pub devices: usize,
    /// Transducers in the rig.
    pub transducers: usize,
    /// Sequence slots (an AUTD3's two STM segments).
    pub slots: u8,
    /// Firmware version per device.
    pub firmware: Vec<String>,
    /// Dwell grid (µs), when the device samples on one.
    pub dwell_grid_us: Option<u32>,
    /// The LM firmware's own `Info` (LM firmware only).
    #[serde(skip)]
    pub lm: Option<Info>,
}

/// The result of an upload.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UploadReport {
    /// Slot written.
    pub slot: u8,
    /// Steps per cycle.
    pub steps: usize,
    /// Transducers per step.
    pub transducers: usize,
    /// Dwell per step (µs).
    pub dwell_us: f64,
    /// LM frequency (Hz).
    pub freq_hz: f64,
    /// Link frames the upload took (AUTD3 emulator; 0 where not counted).
    pub frames: u64,
    /// Phases read back from the device that differ from the plan
    /// (`None` when the device cannot be read back).
    pub readback_mismatches: Option<u64>,
    /// The serial link's transfer report (LM firmware only).
    #[serde(skip)]
    pub wire: Option<crate::link::UploadReport>,
}

/// What a centroid update did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CentroidOutcome {
    /// Accepted: the gate and the correction follow it.
    Applied,
    /// Refused: outside the playing slot's work volume; the output mutes
    /// until a present centroid inside it arrives.
    OutOfRange,
}

/// A device lmhost can drive.
pub trait Backend {
    /// Where the device is, for messages (`/dev/ttyACM0`, `autd3:emulator`).
    fn describe(&self) -> String;
    /// Identity and capabilities.
    fn info(&mut self) -> anyhow::Result<BackendInfo>;
    /// Playing state, in the firmware's terms.
    fn status(&mut self) -> anyhow::Result<Status>;
    /// Uploads `plan` into `slot` (`None`: a slot neither playing nor
    /// queued) without touching the playing one; a failed upload leaves
    /// the playing slot playing.
    fn upload(&mut self, plan: &Plan, slot: Option<u8>) -> anyhow::Result<UploadReport>;
    /// Plays `slot` at `at`; muted until tracked unless `untracked`.
    fn play_at(&mut self, slot: u8, at: PlayAt, untracked: bool) -> anyhow::Result<()>;
    /// Plays `slot`, switching at the end of the playing cycle.
    fn play(&mut self, slot: u8, untracked: bool) -> anyhow::Result<()> {
        self.play_at(slot, PlayAt::NextCycle, untracked)
    }
    /// Silences the array.
    fn stop(&mut self) -> anyhow::Result<()>;
    /// Applies a centroid update (correction and safety gate).
    fn centroid(&mut self, c: &Centroid) -> anyhow::Result<CentroidOutcome>;
    /// Housekeeping the host must run between updates (≥ every 10 ms
    /// while playing): staleness muting where the device cannot time it.
    fn tick(&mut self) -> anyhow::Result<()> {
        Ok(())
    }
    /// Whether output lasts only while lmhost holds the link (AUTD3).
    fn needs_host(&self) -> bool {
        false
    }
}

/// The device `--port` names, before it is opened.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Target {
    /// The LM firmware on a serial port, pty or TCP socket.
    Lm,
    /// An AUTD3 rig.
    Autd3(Autd3Port),
}

impl Target {
    /// The plan for this device: the 25 µs dwell grid on AUTD3 (with its
    /// realised timing), else the plan the flags ask for.
    pub fn plan(&self, args: &PlanArgs) -> anyhow::Result<(Plan, Option<GridTiming>)> {
        match self {
            Self::Lm => Ok((args.plan()?, None)),
            Self::Autd3(_) => {
                let scene = args.load_scene()?;
                let params = args.params(&scene)?;
                let (plan, g) = crate::autd3::timing::plan(&params, &scene, &args.synthesis()?)?;
                Ok((plan, Some(g)))
            }
        }
    }
}

/// The device a command talks to: its port and, for AUTD3 ports, the
/// scene whose devices the rig has (`info`, `status`, `play`, `stop`).
#[derive(Debug, clap::Args)]
pub struct DeviceArgs {
    #[command(flatten)]
    port: PortArgs,
    /// AUTD3 ports: scene file whose devices the rig has [default: the
    /// built-in array].
    #[arg(long, value_name = "FILE")]
    scene: Option<std::path::PathBuf>,
}

impl DeviceArgs {
    /// Loads the scene and opens the device (see [`open`]).
    pub fn open(&self) -> anyhow::Result<Box<dyn Backend>> {
        let scene = Scene::load_or_default(self.scene.as_deref())?;
        open(&self.port, &scene)
    }
}

/// Opens the device `port` names for `scene` (an AUTD3 rig is built from
/// the scene's devices; the LM firmware ignores it).
pub fn open(port: &PortArgs, scene: &Scene) -> anyhow::Result<Box<dyn Backend>> {
    open_with(port, scene, Encoding::Delta, false)
}

/// [`open`], uploading to the LM firmware with `encoding`, with a progress
/// bar on stderr when `progress` and stderr is a terminal.
pub fn open_with(
    port: &PortArgs,
    scene: &Scene,
    encoding: Encoding,
    progress: bool,
) -> anyhow::Result<Box<dyn Backend>> {
    Ok(match port.target()? {
        Target::Lm => {
            let mut b = LmBackend::new(port.connect()?, encoding);
            b.progress &= progress;
            Box::new(b)
        }
        Target::Autd3(p) => Box::new(Autd3Backend::open(&p, scene)?),
    })
}

/// The LM firmware behind a [`Client`].
pub struct LmBackend<T: Transport> {
    /// The link.
    pub client: Client<T>,
    /// Wire encoding for uploads.
    pub encoding: Encoding,
    /// Draw a progress bar on stderr while uploading.
    pub progress: bool,
    info: Option<Info>,
}

impl<T: Transport> LmBackend<T> {
    /// Wraps `client`; a progress bar is drawn when stderr is a terminal.
    pub fn new(client: Client<T>, encoding: Encoding) -> Self {
        Self {
            client,
            encoding,
            progress: std::io::stderr().is_terminal(),
            info: None,
        }
    }

    fn lm_info(&mut self) -> anyhow::Result<Info> {
        if let Some(i) = self.info {
            return Ok(i);
        }
        let where_ = self.describe();
        let i = self
            .client
            .info()
            .with_context(|| format!("asking {where_} for its info"))?;
        self.info = Some(i);
        Ok(i)
    }
}

impl<T: Transport> Backend for LmBackend<T> {
    fn describe(&self) -> String {
        self.client.transport().describe()
    }

    fn info(&mut self) -> anyhow::Result<BackendInfo> {
        let i = self.lm_info()?;
        let [a, b, c] = i.fw_version;
        Ok(BackendInfo {
            backend: "lm-firmware".into(),
            port: self.describe(),
            devices: 1,
            transducers: usize::from(i.max_transducers),
            slots: i.slots,
            firmware: vec![format!("{a}.{b}.{c}")],
            dwell_grid_us: None,
            lm: Some(i),
        })
    }

    fn status(&mut self) -> anyhow::Result<Status> {
        Ok(self.client.status()?)
    }

    fn upload(&mut self, plan: &Plan, slot: Option<u8>) -> anyhow::Result<UploadReport> {
        let spec = UploadSpec::from_plan(plan, self.encoding)?;
        let info = self.lm_info()?;
        let where_ = self.describe();
        let chunk = (info.max_chunk as usize).clamp(1, lm_proto::MAX_CHUNK);
        let slot = match slot {
            Some(s) => {
                check_slot(s, &info)?;
                s
            }
            None => {
                let st = self.client.status().context("reading the device status")?;
                free_slot(info.slots, &st).ok_or_else(|| {
                    anyhow::anyhow!(
                        "no free slot on {where_}: every slot is playing or queued; \
                         use --slot N or `lmhost stop` first"
                    )
                })?
            }
        };
        spec.check_fits(&info, slot).map_err(|e| {
            crate::InputError::new(format!("the sequence does not fit {where_}: {e}"))
        })?;
        let tty = self.progress;
        let report = self
            .client
            .upload(&spec, slot, chunk, |done, total| {
                if tty {
                    let pct = done as f64 / total.max(1) as f64;
                    let bar = "#".repeat((pct * 30.0) as usize);
                    eprint!("\ruploading [{bar:<30}] {:>3.0} %", pct * 100.0);
                    if done == total {
                        eprintln!();
                    }
                }
            })
            .with_context(|| format!("uploading to slot {slot} of {where_}"))?;
        let h = &spec.header;
        Ok(UploadReport {
            slot,
            steps: usize::from(h.steps),
            transducers: usize::from(h.transducers),
            dwell_us: plan.sequence.dwell_us(),
            freq_hz: 1e6 / f64::from(h.period_us.max(1)),
            frames: 0,
            readback_mismatches: None,
            wire: Some(report),
        })
    }

    fn play_at(&mut self, slot: u8, at: PlayAt, untracked: bool) -> anyhow::Result<()> {
        let info = self.lm_info()?;
        check_slot(slot, &info)?;
        self.client
            .play(slot, at, untracked)
            .with_context(|| format!("playing slot {slot}"))
    }

    fn stop(&mut self) -> anyhow::Result<()> {
        self.client.stop().context("stopping the device")
    }

    fn centroid(&mut self, c: &Centroid) -> anyhow::Result<CentroidOutcome> {
        match self.client.centroid(*c) {
            Ok(()) => Ok(CentroidOutcome::Applied),
            Err(LinkError::Nack {
                code: NackCode::OutOfRange,
                ..
            }) => Ok(CentroidOutcome::OutOfRange),
            Err(e) => Err(e.into()),
        }
    }
}

/// Holds the link, ticking the safety gate every 10 ms, until Ctrl-C /
/// SIGTERM ([`crate::stream::run::stop_requested`]) or `max` elapses.
/// Returns whether a stop was requested.
pub fn hold(dev: &mut dyn Backend, max: Option<std::time::Duration>) -> anyhow::Result<bool> {
    let end = max.map(|d| std::time::Instant::now() + d);
    loop {
        if crate::stream::run::stop_requested() {
            return Ok(true);
        }
        if end.is_some_and(|e| std::time::Instant::now() >= e) {
            return Ok(false);
        }
        dev.tick()?;
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
}

/// What [`open_playing`] uploaded before a session (AUTD3 only).
#[derive(Debug, Clone, Serialize)]
pub struct SessionUpload {
    /// The upload.
    pub upload: UploadReport,
    /// Realised timing on the 25 µs grid.
    pub timing: GridTiming,
}

/// Opens the device for a streaming session (`stream`, `track`, `demo`).
/// The LM firmware already holds its sequence (uploaded and played with
/// `lmhost upload`); an AUTD3 holds one only while lmhost holds the link,
/// so there the plan the flags ask for (or the defaults) is planned on the
/// 25 µs grid, uploaded, read back and played, tracked, first. Returns the
/// device and, on AUTD3, what was uploaded.
pub fn open_playing(
    port: &PortArgs,
    plan: &PlanArgs,
) -> anyhow::Result<(Box<dyn Backend>, Option<SessionUpload>)> {
    let target = port.target()?;
    let Target::Autd3(_) = &target else {
        let scene = plan.load_scene()?;
        return Ok((open(port, &scene)?, None));
    };
    let (plan, grid) = target.plan(plan)?;
    let timing = grid.context("an AUTD3 plan is on its grid")?;
    let mut dev = open(port, &plan.scene)?;
    let upload = dev.upload(&plan, None)?;
    let where_ = dev.describe();
    if let Some(n) = upload.readback_mismatches.filter(|&n| n > 0) {
        anyhow::bail!("{where_} holds {n} phases that differ from the plan");
    }
    dev.play(upload.slot, false)?;
    eprintln!(
        "{where_}: uploaded {} steps, dwell {} µs, {:.3} Hz (asked {} Hz), step {:.4} mm, read-back {}; \
         playing slot {}, muted until tracked; left silent on exit",
        upload.steps,
        upload.dwell_us,
        upload.freq_hz,
        timing.requested_freq_hz,
        timing.step_mm,
        upload
            .readback_mismatches
            .map_or("not available".into(), |n| format!("{n} mismatches")),
        upload.slot
    );
    Ok((dev, Some(SessionUpload { upload, timing })))
}

/// The stimulus flags' defaults for `scene` (what `lmhost upload --scene
/// FILE` plans with no other flag): the plan `track --port autd3:...` plays.
pub fn default_plan_args(scene: Option<&std::path::Path>) -> anyhow::Result<PlanArgs> {
    #[derive(clap::Parser)]
    struct Defaults {
        #[command(flatten)]
        plan: PlanArgs,
    }
    let mut args = vec![std::ffi::OsString::from("lmhost")];
    if let Some(s) = scene {
        args.push("--scene".into());
        args.push(s.into());
    }
    use clap::Parser as _;
    Ok(Defaults::try_parse_from(args)?.plan)
}
