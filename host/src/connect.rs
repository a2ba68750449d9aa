//! Opening the device `--port` names: the LM firmware ([`LmBackend`] over
//! a [`Client`]) or an AUTD3 rig ([`Autd3Backend`]), both behind
//! [`Backend`]; and holding an AUTD3 link while it plays.

use std::io::IsTerminal as _;

use anyhow::Context as _;
use lm_proto::{Centroid, Encoding, Info, NackCode, PlayAt, Status};

use crate::autd3::{Autd3Backend, Autd3Port, GridTiming};
use crate::backend::{
    Backend, BackendInfo, CentroidOutcome, Kind, Result as BResult, Transfer, UploadReport,
    check_slot, free_slot,
};
use crate::link::{Client, LinkError, PortSpec, Transport, UploadSpec, discover};
use crate::scene::Scene;
use crate::sequence::{Plan, Synthesis};
use crate::trajectory::LmParams;

impl PortSpec {
    /// Which kind of device the port (or `$LMHOST_PORT`) names; a malformed
    /// `autd3:` port is an [`InputError`](crate::InputError) (exit 2).
    pub fn target(&self) -> Result<Target, crate::InputError> {
        let env = std::env::var(discover::PORT_ENV).ok();
        let port = self.port.as_deref().or(env.as_deref());
        if let Some((prefix, _)) = port.and_then(|p| p.split_once(':'))
            && ["tcp", "autd3"]
                .iter()
                .any(|k| prefix.eq_ignore_ascii_case(k) && prefix != *k)
        {
            return Err(crate::InputError::new(format!(
                "--port {}: port prefixes are lowercase: tcp:HOST:PORT, autd3:emulator, \
                 autd3:soem[:IF], autd3:ethercrab[:IF], autd3:remote:HOST:PORT, or a serial port path",
                port.unwrap_or_default()
            )));
        }
        match port {
            Some(p) if Autd3Port::is_autd3(p) => Ok(Target::Autd3(Autd3Port::parse(p)?)),
            _ => Ok(Target::Lm),
        }
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
    /// `params` planned for this device: on AUTD3 on its 25 µs dwell grid
    /// (with the realised timing), else as asked.
    pub fn plan_on_grid(
        &self,
        params: &LmParams,
        scene: &Scene,
        synthesis: &Synthesis,
    ) -> anyhow::Result<(Plan, Option<GridTiming>)> {
        match self {
            Self::Lm => Ok((Plan::new(scene.clone(), params, synthesis)?, None)),
            Self::Autd3(_) => {
                let (plan, g) = crate::autd3::timing::plan(params, scene, synthesis)?;
                Ok((plan, Some(g)))
            }
        }
    }
}

/// Opens the device `port` names for `scene` (an AUTD3 rig is built from
/// the scene's devices; the LM firmware ignores it).
pub fn open(port: &PortSpec, scene: &Scene) -> anyhow::Result<Box<dyn Backend>> {
    open_with(port, scene, Encoding::Delta, false)
}

/// [`open`], uploading to the LM firmware with `encoding`, with a progress
/// bar on stderr when `progress` and stderr is a terminal.
pub fn open_with(
    port: &PortSpec,
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

    fn info(&mut self) -> BResult<BackendInfo> {
        let i = self.lm_info()?;
        let [a, b, c] = i.fw_version;
        Ok(BackendInfo {
            backend: "lm-firmware".into(),
            port: self.describe(),
            devices: 1,
            transducers: usize::from(i.max_transducers),
            slots: i.slots,
            firmware: vec![format!("{a}.{b}.{c}")],
            kind: Kind::LmFirmware(i),
        })
    }

    fn status(&mut self) -> BResult<Status> {
        Ok(self.client.status()?)
    }

    fn upload(&mut self, plan: &Plan, slot: Option<u8>) -> BResult<UploadReport> {
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
                    crate::out::stderr_fmt(format_args!(
                        "\ruploading [{bar:<30}] {:>3.0} %",
                        pct * 100.0
                    ));
                    if done == total {
                        crate::errln!();
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
            transfer: Transfer::Wire(report),
        })
    }

    fn play_at(&mut self, slot: u8, at: PlayAt, untracked: bool) -> BResult<()> {
        let info = self.lm_info()?;
        check_slot(slot, &info)?;
        Ok(self
            .client
            .play(slot, at, untracked)
            .with_context(|| format!("playing slot {slot}"))?)
    }

    /// Sent as `Play.steps` with `NextCycle` (at once from silence): the
    /// firmware counts the steps and stops itself.
    fn play_for(&mut self, slot: u8, untracked: bool, steps: u32) -> BResult<()> {
        let info = self.lm_info()?;
        check_slot(slot, &info)?;
        Ok(self
            .client
            .play_steps(slot, PlayAt::NextCycle, untracked, steps)
            .with_context(|| format!("playing slot {slot} for {steps} steps"))?)
    }

    fn stop(&mut self) -> BResult<()> {
        Ok(self.client.stop().context("stopping the device")?)
    }

    fn centroid(&mut self, c: &Centroid) -> BResult<CentroidOutcome> {
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
/// SIGTERM ([`crate::stop::requested`]) or `max` elapses.
/// Returns whether a stop was requested.
pub fn hold(dev: &mut dyn Backend, max: Option<std::time::Duration>) -> anyhow::Result<bool> {
    let end = max.map(|d| std::time::Instant::now() + d);
    loop {
        if crate::stop::requested() {
            return Ok(true);
        }
        if end.is_some_and(|e| std::time::Instant::now() >= e) {
            return Ok(false);
        }
        dev.tick()?;
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
}
