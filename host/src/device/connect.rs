//! Opening the device `--port` names: the LM firmware ([`LmBackend`] over
//! a [`Client`]) or an AUTD3 rig ([`Autd3Backend`]), both behind
//! [`Backend`]; and holding an AUTD3 link while it plays.

use std::io::IsTerminal as _;

use anyhow::Context as _;
use lm_proto::{Centroid, DeviceState, Encoding, Info, NackCode, PlayAt, SelfTest, Status};

use crate::device::autd3::{Autd3Backend, Autd3Port};
use crate::device::backend::{
    Backend, BackendInfo, CentroidOutcome, Kind, Result as BResult, Transfer, UploadReport,
    check_shape, check_slot, free_slot,
};
use crate::device::link::{Client, LinkError, PortSpec, Transport, UploadSpec, discover};
use crate::device::simdev::{FwCore, InProcess, SimConfig};
use crate::plan::scene::Scene;
use crate::plan::sequence::Plan;
use crate::plan::target::Target;
use std::sync::{Arc, Mutex};

/// Longest port name (bytes): a device path's limit (`PATH_MAX` less its
/// NUL), far above any `tcp:HOST:PORT` or `autd3:` form.
pub const MAX_PORT_BYTES: usize = 4095;

impl PortSpec {
    /// Which kind of device the port (or `$LMHOST_PORT`) names; a malformed
    /// `autd3:` port, or an AUTD3 port given a serial link's setting
    /// (`--baud`, `--tries`, `--lease`, a `--timeout-ms` other than
    /// `$LMHOST_TIMEOUT_MS`'s), is an
    /// [`InputError`](crate::InputError) (exit 2).
    pub fn device(&self) -> Result<DeviceKind, crate::InputError> {
        let env = discover::env_port()?;
        let port = self.port.as_deref().or(env.as_deref());
        let named = match self.port {
            Some(_) => "--port".to_owned(),
            None => format!("${}", discover::PORT_ENV),
        };
        // Longer than any device path (PATH_MAX) or `tcp:HOST:PORT` (a
        // host name is at most 253 bytes): refused here, never echoed
        // whole by every message that names the port (40 kB on one line).
        if let Some(p) = port.filter(|p| p.len() > MAX_PORT_BYTES) {
            return Err(crate::InputError::new(format!(
                "{named} `{}`: {} bytes is longer than any port name (at most {MAX_PORT_BYTES})",
                crate::error::short_echo(p),
                p.len()
            )));
        }
        if let Some(p) = port {
            if self.port.is_none() {
                discover::empty_env(p)?;
            }
            discover::check_name(&named, p)?;
        }
        if let Some((prefix, _)) = port.and_then(|p| p.split_once(':'))
            && ["tcp", "autd3"]
                .iter()
                .any(|k| prefix.eq_ignore_ascii_case(k) && prefix != *k)
        {
            // Named as given: `$LMHOST_PORT` was called `--port`.
            return Err(crate::InputError::new(format!(
                "{named} {}: port prefixes are lowercase: tcp:HOST:PORT, autd3:emulator, \
                 autd3:soem[:IF], autd3:ethercrab[:IF], autd3:remote:HOST:PORT, or a serial port path",
                port.unwrap_or_default()
            )));
        }
        match port {
            Some(p) if Autd3Port::is_autd3(p) => {
                let kind = Autd3Port::parse(p)?;
                // An AUTD3 has no serial link: a setting of one would be
                // dropped without a word.
                if let Some(first) = self.link_settings_given().first() {
                    return Err(serial_link_only(first, p));
                }
                // A timeout set for every device ($LMHOST_TIMEOUT_MS) is
                // no setting of this one; one given for it (another value)
                // would be dropped as the others would.
                if self.timeout_ms.is_some() && self.timeout_ms != timeout_from_env() {
                    return Err(serial_link_only("--timeout-ms", p));
                }
                Ok(DeviceKind::Autd3(kind))
            }
            _ => Ok(DeviceKind::Lm),
        }
    }
}

/// The response timeout `$LMHOST_TIMEOUT_MS` sets, if it is a number.
fn timeout_from_env() -> Option<u64> {
    std::env::var(discover::TIMEOUT_ENV)
        .ok()?
        .trim()
        .parse()
        .ok()
}

/// The refusal of a serial-link setting (`flag`) for the AUTD3 at `port`,
/// which has no serial link: the one wording for every such flag.
pub fn serial_link_only(flag: &str, port: impl std::fmt::Display) -> crate::InputError {
    crate::InputError::new(format!(
        "{flag} applies to the LM firmware's serial link; {port} is an AUTD3, which has none"
    ))
}

/// The device `--port` names, before it is opened.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DeviceKind {
    /// The LM firmware on a serial port, pty or TCP socket.
    Lm,
    /// An AUTD3 rig.
    Autd3(Autd3Port),
}

impl DeviceKind {
    /// What the planner needs of this device: its dwell grid and limits.
    pub fn target(&self) -> Target {
        match self {
            Self::Lm => Target::Lm,
            Self::Autd3(_) => Target::Autd3,
        }
    }

    /// Whether the device lives in this process and ends with it (autd3's
    /// emulator): nothing outside can use it after lmhost exits.
    pub fn in_process(&self) -> bool {
        matches!(self, Self::Autd3(p) if p.is_emulator())
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
    Ok(match port.device()? {
        DeviceKind::Lm => {
            let mut b = LmBackend::new(port.connect()?, encoding);
            b.progress &= progress;
            Box::new(b)
        }
        DeviceKind::Autd3(p) => Box::new(Autd3Backend::open(&p, scene)?),
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
    /// A play of this host may be sounding: keep its lease renewed.
    playing: bool,
}

impl<T: Transport> LmBackend<T> {
    /// Wraps `client`; a progress bar is drawn when stderr is a terminal.
    pub fn new(client: Client<T>, encoding: Encoding) -> Self {
        Self {
            client,
            encoding,
            progress: std::io::stderr().is_terminal(),
            info: None,
            playing: false,
        }
    }

    fn lm_info(&mut self) -> anyhow::Result<Info> {
        if let Some(i) = self.info {
            return Ok(i);
        }
        // Checked by the client (it names the port).
        let i = self.client.info()?;
        self.info = Some(i);
        Ok(i)
    }
}

/// Leaves the array silent when the backend goes away while something it
/// played plays (an error, an early return): one try, so a dead link
/// does not hold the exit up; should it fail, the host lease ends the
/// play.
impl<T: Transport> Drop for LmBackend<T> {
    fn drop(&mut self) {
        if self.playing {
            self.client.tries = 1;
            let _ = self.client.stop();
        }
    }
}

/// The simulated LM firmware in process, as a backend.
pub type Simulated = LmBackend<InProcess<FwCore>>;

/// The simulated LM firmware ([`FwCore`] with its default configuration)
/// in process on `clock`, without a progress bar: the device of tests,
/// benches and the conformance table. The core comes back too, to read its
/// output or counters.
pub fn simulated(clock: crate::clock::Clock) -> anyhow::Result<(Simulated, Arc<Mutex<FwCore>>)> {
    let core = Arc::new(Mutex::new(FwCore::new(SimConfig::default())?));
    let mut dev = LmBackend::new(
        Client::new(InProcess::new(core.clone(), clock)),
        Encoding::Delta,
    );
    dev.progress = false;
    Ok((dev, core))
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
        let s = self.client.status()?;
        if !matches!(s.state, DeviceState::Playing | DeviceState::Muted) {
            // Stopped by itself (a timed play's end, the lease): nothing
            // left to renew.
            self.playing = false;
        }
        Ok(s)
    }

    fn upload(&mut self, plan: &Plan, slot: Option<u8>) -> BResult<UploadReport> {
        check_shape(plan)?;
        if plan.am.is_some() && plan.sequence.intensity_table.is_none() {
            // Never played unmodulated: the LM firmware plays AM only as
            // the intensity table `Stimulus::plan_for` makes for it.
            return Err(crate::error::InputError::new(
                "this amplitude-modulated plan has no intensity table for the LM firmware: \
                 plan it for the LM target (`--target lm`)",
            )
            .into());
        }
        let spec = UploadSpec::from_plan(plan, self.encoding)?;
        let info = self.lm_info()?;
        let where_ = self.describe();
        // Within 1..=MAX_CHUNK: the client checked the Info.
        let chunk = usize::from(info.max_chunk);
        let slot = match slot {
            Some(s) => {
                check_slot(s, &info)?;
                s
            }
            None => {
                let st = self.client.status()?;
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
            .with_context(|| format!("uploading to slot {slot}"))?;
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
        self.client
            .play(slot, at, untracked)
            .with_context(|| format!("playing slot {slot}"))?;
        self.playing = true;
        Ok(())
    }

    /// Sent as `Play.steps` with `NextCycle` (at once from silence): the
    /// firmware counts the steps and stops itself.
    fn play_for(&mut self, slot: u8, untracked: bool, steps: u32) -> BResult<()> {
        let info = self.lm_info()?;
        check_slot(slot, &info)?;
        self.client
            .play_steps(slot, PlayAt::NextCycle, untracked, steps)
            .with_context(|| format!("playing slot {slot} for {steps} steps"))?;
        self.playing = true;
        Ok(())
    }

    fn stop(&mut self) -> BResult<()> {
        self.client.stop().context("stopping")?;
        self.playing = false;
        Ok(())
    }

    /// Renews the host lease when a quarter of it has passed without a
    /// request the device accepted (a streaming host's centroids renew it
    /// for free).
    fn tick(&mut self) -> BResult<()> {
        if self.playing && self.client.renew_due() {
            self.client
                .renew()
                .context("renewing the host lease (the device stops without it)")?;
        }
        Ok(())
    }

    fn needs_host(&self) -> bool {
        self.playing
    }

    fn self_test(&mut self) -> BResult<SelfTest> {
        Ok(self.client.self_test().context("running the self-test")?)
    }

    /// The firmware's player keeps one queued slot: a later play replaces
    /// it (`lm_fw_core::player::Player::queue`).
    fn replaces_queued(&self) -> bool {
        true
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

/// How often [`hold`] reads the device's status.
pub const HOLD_STATUS_EVERY: std::time::Duration = std::time::Duration::from_secs(1);

/// Holds the link, ticking every 10 ms (an AUTD3's safety gate, the LM
/// firmware's host lease), until Ctrl-C / SIGTERM
/// ([`crate::stop::requested`]) or `max` elapses. The status is read
/// every [`HOLD_STATUS_EVERY`]: a device that restarted (its library gone,
/// `link::reply::restarted`) ends the hold with an error rather than
/// holding nothing. Returns whether a stop was requested.
pub fn hold(dev: &mut dyn Backend, max: Option<std::time::Duration>) -> anyhow::Result<bool> {
    let end = max.map(|d| std::time::Instant::now() + d);
    let mut next_status = std::time::Instant::now();
    loop {
        if crate::stop::requested() {
            return Ok(true);
        }
        let now = std::time::Instant::now();
        if end.is_some_and(|e| now >= e) {
            return Ok(false);
        }
        dev.tick()?;
        if now >= next_status {
            dev.status().context("reading the device status")?;
            next_status = now + HOLD_STATUS_EVERY;
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
}

#[cfg(test)]
#[path = "connect_tests.rs"]
mod tests;
