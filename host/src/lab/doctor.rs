//! `lmhost doctor`: what is connected, whether it is healthy, and for each
//! missing or broken piece one line saying what to do.
//!
//! Checks, in the order a rig is brought up (BRINGUP.md):
//! - **LM board**: every serial port with a known board's USB id (or the
//!   `--port`s given) answers `Info` and `Status`; its clock source, array
//!   size and state are reported.
//! - **Debug probe**: an ST-LINK on USB, and whether this user may open it
//!   (probe-rs needs its udev rules).
//! - **AUTD3 over EtherCAT**: a link built into this binary, a network
//!   interface to search, raw-socket privileges (CAP_NET_RAW) and
//!   CAP_SYS_NICE for the link thread's real-time priority; an `autd3:`
//!   `--port` is opened and its firmware reported.
//! - **Depth camera**: a RealSense on USB, Python 3 and `pyrealsense2` for
//!   the bridge `lmhost track --camera` runs.
//!
//! Everything the checks read comes through [`Env`] (sysfs roots, the
//! process's capabilities), so they are tested on fake trees.

use std::path::{Path, PathBuf};
use std::time::Duration;

use serde::Serialize;

use crate::device::autd3::Autd3Port;
use crate::device::backend::Kind;
use crate::device::connect;
use crate::device::link::PortSpec;
use crate::device::link::discover::{self, PortInfo};
use crate::plan::scene::Scene;

/// How a check came out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// Present and healthy.
    Ok,
    /// Present and working, with something worth fixing.
    Warn,
    /// Not present (nothing connected, or not built in).
    Missing,
    /// Present and not working.
    Fail,
}

/// One line of the report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Check {
    /// What was checked (`lm board`, `ethercat`, ...).
    pub what: String,
    /// How it came out.
    pub outcome: Outcome,
    /// What was found.
    pub detail: String,
    /// What to do about it, when there is something to do.
    pub fix: Option<String>,
}

impl Check {
    fn new(what: &str, outcome: Outcome, detail: impl Into<String>) -> Self {
        Self {
            what: what.into(),
            outcome,
            detail: detail.into(),
            fix: None,
        }
    }

    fn fix(mut self, f: impl Into<String>) -> Self {
        self.fix = Some(f.into());
        self
    }

    /// The check as one line: `ok    lm board: ... (fix: ...)`.
    pub fn line(&self) -> String {
        let tag = match self.outcome {
            Outcome::Ok => "ok",
            Outcome::Warn => "warn",
            Outcome::Missing => "missing",
            Outcome::Fail => "FAIL",
        };
        match &self.fix {
            Some(f) => format!("{tag:<7} {}: {} — {f}", self.what, self.detail),
            None => format!("{tag:<7} {}: {}", self.what, self.detail),
        }
    }
}

/// Whether everything that is there works: no check failed.
pub fn healthy(checks: &[Check]) -> bool {
    checks.iter().all(|c| c.outcome != Outcome::Fail)
}

/// Where the checks look: the live system, or a fake tree in tests.
#[derive(Debug, Clone)]
pub struct Env {
    /// `/sys/class/tty`.
    pub sys_class_tty: PathBuf,
    /// `/sys/bus/usb/devices`.
    pub sys_usb: PathBuf,
    /// `/sys/class/net`.
    pub sys_class_net: PathBuf,
    /// `/dev/bus/usb` (the nodes probe-rs opens).
    pub dev_usb: PathBuf,
    /// The process's effective capabilities (`CapEff` of
    /// `/proc/self/status`), or `None` when unknown.
    pub cap_eff: Option<u64>,
    /// The Python interpreter the camera bridge runs.
    pub python: String,
}

/// CAP_NET_RAW's bit in a capability set.
const CAP_NET_RAW: u32 = 13;
/// CAP_SYS_NICE's bit.
const CAP_SYS_NICE: u32 = 23;

/// Intel's USB vendor id; RealSense D4xx cameras use product ids 0x0ad0 to
/// 0x0b6f.
const INTEL: u16 = 0x8086;

impl Env {
    /// The live system.
    pub fn live() -> Self {
        let cap_eff = std::fs::read_to_string("/proc/self/status")
            .ok()
            .and_then(|s| parse_cap_eff(&s));
        Self {
            sys_class_tty: "/sys/class/tty".into(),
            sys_usb: "/sys/bus/usb/devices".into(),
            sys_class_net: "/sys/class/net".into(),
            dev_usb: "/dev/bus/usb".into(),
            cap_eff,
            python: "python3".into(),
        }
    }

    fn has_cap(&self, bit: u32) -> Option<bool> {
        self.cap_eff.map(|c| c & (1 << bit) != 0)
    }
}

/// `CapEff` from the text of `/proc/self/status`.
fn parse_cap_eff(status: &str) -> Option<u64> {
    status
        .lines()
        .find_map(|l| l.strip_prefix("CapEff:"))
        .and_then(|v| u64::from_str_radix(v.trim(), 16).ok())
}

/// A USB device in sysfs: its ids and bus/device numbers.
#[derive(Debug, Clone, PartialEq, Eq)]
struct UsbDevice {
    vid: u16,
    pid: u16,
    bus: u32,
    dev: u32,
}

fn read_trim(p: &Path) -> Option<String> {
    std::fs::read_to_string(p).ok().map(|s| s.trim().to_owned())
}

fn usb_devices(root: &Path) -> Vec<UsbDevice> {
    let Ok(rd) = std::fs::read_dir(root) else {
        return Vec::new();
    };
    let mut v: Vec<UsbDevice> = rd
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            let d = e.path();
            let hex = |n: &str| u16::from_str_radix(&read_trim(&d.join(n))?, 16).ok();
            let num = |n: &str| read_trim(&d.join(n))?.parse().ok();
            Some(UsbDevice {
                vid: hex("idVendor")?,
                pid: hex("idProduct")?,
                bus: num("busnum")?,
                dev: num("devnum")?,
            })
        })
        .collect();
    v.sort_by_key(|d| (d.bus, d.dev));
    v
}

/// What the checks are asked about beyond what they find themselves.
#[derive(Debug, Clone, Default)]
pub struct Options {
    /// Ports to check as well as the boards found (`--port`, repeatable):
    /// a serial path, `tcp:...`, or `autd3:...`.
    pub ports: Vec<String>,
    /// Response timeout per request (ms) for LM boards.
    pub timeout_ms: u64,
}

impl Options {
    /// The ports given (`--port`), else `$LMHOST_PORT` when set (the device
    /// every other command uses, which doctor left unchecked without a
    /// word), checked ([`Options::check`]).
    pub fn given(ports: Vec<String>, timeout_ms: u64) -> Result<Self, crate::InputError> {
        let ports = match (ports.is_empty(), discover::env_port()?) {
            (true, Some(p)) => {
                discover::empty_env(&p)?;
                vec![p]
            }
            _ => ports,
        };
        let o = Self { ports, timeout_ms };
        o.check()?;
        Ok(o)
    }

    /// Refuses what no check can use: a port given twice (checked once,
    /// without a word, or an AUTD3 link opened twice).
    pub fn check(&self) -> Result<(), crate::InputError> {
        crate::limits::each_once("--port", "port", &self.ports)
    }
}

/// Runs every check.
pub fn run(env: &Env, opts: &Options) -> Vec<Check> {
    let mut v = Vec::new();
    v.extend(lm_boards(env, opts));
    v.push(probe(env));
    v.extend(ethercat(env, opts));
    v.extend(camera(env));
    v
}

fn lm_boards(env: &Env, opts: &Options) -> Vec<Check> {
    let found = discover::scan(&env.sys_class_tty);
    let mut ports: Vec<(String, Option<&'static str>)> = found
        .iter()
        .filter_map(|p: &PortInfo| p.board().map(|b| (p.path.clone(), Some(b))))
        .collect();
    for p in &opts.ports {
        if !Autd3Port::is_autd3(p) && !ports.iter().any(|(q, _)| q == p) {
            ports.push((p.clone(), None));
        }
    }
    if ports.is_empty() {
        let seen = if found.is_empty() {
            "no serial ports".to_owned()
        } else {
            format!(
                "serial ports: {}",
                found
                    .iter()
                    .map(|p| p.path.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        };
        return vec![
            Check::new(
                "lm board",
                Outcome::Missing,
                format!("no LM board on USB ({seen})"),
            )
            .fix(
                "plug the Nucleo's ST-LINK USB connector (CN1) into this machine and flash it \
                 (BRINGUP.md), or pass --port for a board on another port",
            ),
        ];
    }
    ports
        .into_iter()
        .map(|(port, board)| lm_board(&port, board, opts))
        .collect()
}

fn lm_board(port: &str, board: Option<&str>, opts: &Options) -> Check {
    let name = match board {
        Some(b) => format!("{port} ({b})"),
        None => port.to_owned(),
    };
    let spec = PortSpec {
        timeout_ms: Some(opts.timeout_ms.max(1)),
        tries: Some(2),
        ..PortSpec::new(Some(port.to_owned()))
    };
    let mut dev = match connect::open(&spec, &Scene::default()) {
        Ok(d) => d,
        Err(e) => {
            let msg = crate::error::one_line(&e);
            let fix = if msg.contains("permission denied") {
                "add this user to the `dialout` group (then log in again), or use the udev rule in BRINGUP.md"
            } else {
                "check the cable and the port name"
            };
            return Check::new("lm board", Outcome::Fail, format!("{name}: {msg}")).fix(fix);
        }
    };
    let info = match dev.info() {
        Ok(i) => i,
        Err(e) => {
            return Check::new(
                "lm board",
                Outcome::Fail,
                // The link's errors name the port, and say whether nothing
                // answered or what did (another protocol version, ...).
                e.to_string(),
            )
            .fix(
                "flash the LM firmware (`lmhost flash --board nucleo-h743`), and give --baud if it \
                 was built with another LM_BAUD",
            );
        }
    };
    let status = dev.status();
    let Kind::LmFirmware(fw) = info.kind else {
        return Check::new(
            "lm board",
            Outcome::Fail,
            format!("{name}: answers, but not as LM firmware"),
        );
    };
    let state = match &status {
        Ok(s) => format!("{:?}", s.state).to_lowercase(),
        Err(e) => format!("no status ({e})"),
    };
    let detail = format!(
        "{name}: LM firmware {}.{}.{} (protocol v{}), {} transducers, {} slots, timer {} Hz from {}, {state}",
        fw.fw_version[0],
        fw.fw_version[1],
        fw.fw_version[2],
        fw.proto_version,
        fw.max_transducers,
        fw.slots,
        fw.timer_hz,
        match fw.clock {
            lm_proto::ClockSource::Crystal => "a crystal",
            lm_proto::ClockSource::InternalRc => "the internal RC oscillator",
            lm_proto::ClockSource::Emulated => "the host's clock (emulated)",
            _ => "an unknown source",
        }
    );
    if status.is_err() {
        return Check::new("lm board", Outcome::Fail, detail)
            .fix("power-cycle the board; if it stays, reflash it");
    }
    if fw.clock == lm_proto::ClockSource::InternalRc {
        return Check::new("lm board", Outcome::Warn, detail).fix(
            "the ST-LINK's 8 MHz clock does not reach the MCU (HSE): dwells are only ±1 % \
             accurate; see firmware/nucleo-h743/README.md on the MCO solder bridges",
        );
    }
    Check::new("lm board", Outcome::Ok, detail)
}

fn probe(env: &Env) -> Check {
    let usb = usb_devices(&env.sys_usb);
    let Some(st) = usb.iter().find(|d| {
        discover::ST_LINKS
            .iter()
            .any(|s| (s.0, s.1) == (d.vid, d.pid))
    }) else {
        return Check::new("debug probe", Outcome::Missing, "no ST-LINK on USB")
            .fix("only needed to flash the Nucleo: plug its ST-LINK USB connector (CN1)");
    };
    let node = env
        .dev_usb
        .join(format!("{:03}", st.bus))
        .join(format!("{:03}", st.dev));
    let what = format!(
        "ST-LINK {:04x}:{:04x} on bus {} device {}",
        st.vid, st.pid, st.bus, st.dev
    );
    match std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(&node)
    {
        Ok(_) => Check::new("debug probe", Outcome::Ok, what),
        Err(e) => Check::new(
            "debug probe",
            Outcome::Fail,
            format!(
                "{what}: {} cannot be opened ({})",
                node.display(),
                crate::files::reason(&e)
            ),
        )
        .fix("install probe-rs's udev rules (BRINGUP.md) and plug the board in again"),
    }
}

fn ethercat(env: &Env, opts: &Options) -> Vec<Check> {
    let mut v = Vec::new();
    let links: Vec<&str> = [
        cfg!(feature = "autd3-soem").then_some("soem"),
        cfg!(feature = "autd3-ethercrab").then_some("ethercrab"),
    ]
    .into_iter()
    .flatten()
    .collect();
    let ifs = crate::device::autd3::ethercat::candidates(&env.sys_class_net);
    if links.is_empty() {
        v.push(
            Check::new(
                "ethercat",
                Outcome::Missing,
                "this lmhost has no EtherCAT link built in (autd3:emulator and autd3:remote work)",
            )
            .fix("for AUTD3 on EtherCAT: cargo build --release -p lmhost-cli --features autd3-soem (or autd3-ethercrab)"),
        );
    } else if ifs.is_empty() {
        v.push(
            Check::new(
                "ethercat",
                Outcome::Missing,
                "no network interface to search",
            )
            .fix("connect a wired Ethernet adapter for the AUTD3 chain"),
        );
    } else {
        let raw = env.has_cap(CAP_NET_RAW);
        let nice = env.has_cap(CAP_SYS_NICE);
        let detail = format!("links {}, interfaces {}", links.join(", "), ifs.join(", "));
        let exe =
            std::env::current_exe().map_or_else(|_| "lmhost".into(), |p| p.display().to_string());
        let setcap = format!("sudo setcap cap_net_raw,cap_net_admin,cap_sys_nice+ep {exe}");
        v.push(match (raw, nice) {
            (Some(false), _) => Check::new(
                "ethercat",
                Outcome::Fail,
                format!("{detail}; no raw-socket privilege (CAP_NET_RAW)"),
            )
            .fix(format!("run as root, or once `{setcap}`")),
            (_, Some(false)) => Check::new(
                "ethercat",
                Outcome::Warn,
                format!(
                    "{detail}; no CAP_SYS_NICE: the link thread runs without real-time priority"
                ),
            )
            .fix(format!("once `{setcap}`")),
            _ => Check::new("ethercat", Outcome::Ok, detail),
        });
    }
    for p in opts.ports.iter().filter(|p| Autd3Port::is_autd3(p)) {
        v.push(autd3(p));
    }
    v
}

fn autd3(port: &str) -> Check {
    let spec = PortSpec::new(Some(port.to_owned()));
    match connect::open(&spec, &Scene::default()).and_then(|mut d| Ok(d.info()?)) {
        Ok(i) => Check::new(
            "autd3",
            Outcome::Ok,
            format!(
                "{port}: {} devices, {} transducers, firmware {}",
                i.devices,
                i.transducers,
                i.firmware.first().map_or("?", String::as_str)
            ),
        ),
        Err(e) => Check::new("autd3", Outcome::Fail, crate::error::one_line(&e))
            .fix("see BRINGUP.md, AUTD3"),
    }
}

fn camera(env: &Env) -> Vec<Check> {
    let usb = usb_devices(&env.sys_usb);
    let cam = usb
        .iter()
        .find(|d| d.vid == INTEL && (0x0ad0..=0x0b6f).contains(&d.pid));
    let mut v = vec![match cam {
        Some(d) => Check::new(
            "camera",
            Outcome::Ok,
            format!("RealSense {:04x}:{:04x} on bus {}", d.vid, d.pid, d.bus),
        ),
        None => Check::new("camera", Outcome::Missing, "no RealSense camera on USB").fix(
            "plug the D435 into a USB 3 port for `lmhost track --camera`; recordings and \
             --synthetic need none",
        ),
    }];
    let bridge = python_has_realsense(&env.python);
    v.push(match (bridge, cam.is_some()) {
        (Ok(()), _) => Check::new("camera bridge", Outcome::Ok, "python3 with pyrealsense2"),
        (Err(why), true) => Check::new("camera bridge", Outcome::Fail, why)
            .fix("pip install pyrealsense2 (the bridge `lmhost track --camera` runs)"),
        (Err(why), false) => Check::new("camera bridge", Outcome::Missing, why)
            .fix("pip install pyrealsense2 when a camera is used"),
    });
    v
}

/// Whether `python` imports `pyrealsense2`, within a few seconds.
fn python_has_realsense(python: &str) -> Result<(), String> {
    let mut child = std::process::Command::new(python)
        .args(["-c", "import pyrealsense2"])
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .map_err(|e| format!("no {python} ({})", crate::files::reason(&e)))?;
    let deadline = std::time::Instant::now() + Duration::from_secs(10);
    loop {
        match child.try_wait() {
            Ok(Some(s)) if s.success() => return Ok(()),
            Ok(Some(_)) => return Err(format!("{python} has no pyrealsense2")),
            Ok(None) if std::time::Instant::now() < deadline => {
                std::thread::sleep(Duration::from_millis(20));
            }
            _ => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!("{python} did not answer within 10 s"));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tree(name: &str) -> crate::files::Scratch {
        crate::files::scratch(&format!("doctor-{name}"))
    }

    fn usb(root: &Path, name: &str, vid: u16, pid: u16, bus: u32, dev: u32) {
        let d = root.join(name);
        std::fs::create_dir_all(&d).unwrap();
        for (f, v) in [
            ("idVendor", format!("{vid:04x}")),
            ("idProduct", format!("{pid:04x}")),
            ("busnum", bus.to_string()),
            ("devnum", dev.to_string()),
        ] {
            std::fs::write(d.join(f), v + "\n").unwrap();
        }
    }

    fn bare(root: &Path) -> Env {
        Env {
            sys_class_tty: root.join("tty"),
            sys_usb: root.join("usb"),
            sys_class_net: root.join("net"),
            dev_usb: root.join("dev"),
            cap_eff: Some(0),
            python: "/nonexistent/python3".into(),
        }
    }

    #[test]
    fn a_machine_without_hardware_names_each_missing_piece_in_one_line() {
        let root = tree("bare");
        let checks = run(&bare(&root), &Options::default());
        let missing: Vec<&str> = checks
            .iter()
            .filter(|c| c.outcome == Outcome::Missing)
            .map(|c| c.what.as_str())
            .collect();
        assert_eq!(
            missing,
            [
                "lm board",
                "debug probe",
                "ethercat",
                "camera",
                "camera bridge"
            ]
        );
        assert!(healthy(&checks));
        for c in &checks {
            let l = c.line();
            assert!(!l.contains('\n') && c.fix.is_some(), "{l}");
        }
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn a_probe_this_user_cannot_open_fails_with_the_udev_hint() {
        let root = tree("probe");
        let env = bare(&root);
        usb(&env.sys_usb, "1-2", 0x0483, 0x374e, 1, 7);
        let c = probe(&env);
        assert_eq!(c.outcome, Outcome::Fail, "{c:?}");
        assert!(c.fix.as_deref().unwrap().contains("udev"), "{c:?}");
        // With its node there (this test's user can open its own file).
        std::fs::create_dir_all(env.dev_usb.join("001")).unwrap();
        std::fs::write(env.dev_usb.join("001").join("007"), b"").unwrap();
        assert_eq!(probe(&env).outcome, Outcome::Ok);
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn a_camera_without_its_bridge_fails() {
        let root = tree("cam");
        let env = bare(&root);
        usb(&env.sys_usb, "2-1", INTEL, 0x0b07, 2, 3);
        let c = camera(&env);
        assert_eq!(c[0].outcome, Outcome::Ok);
        assert_eq!(c[1].outcome, Outcome::Fail);
        assert!(!healthy(&c));
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn capabilities_come_from_cap_eff() {
        let s = "Name:\tx\nCapEff:\t0000000000802000\n";
        let c = parse_cap_eff(s).unwrap();
        let env = Env {
            cap_eff: Some(c),
            ..Env::live()
        };
        assert_eq!(env.has_cap(CAP_NET_RAW), Some(true));
        assert_eq!(env.has_cap(CAP_SYS_NICE), Some(true));
        assert_eq!(env.has_cap(12), Some(false));
    }
}
