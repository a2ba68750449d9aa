//! Shared by the QEMU end-to-end tests: find (or build) the firmware ELF and
//! launch `qemu-system-arm` (`mps2-an500`, the Cortex-M7 the STM32H743
//! has) with UART0 on a TCP port.
//!
//! The ELF comes from `LM_FW_QEMU_ELF` (set by `cargo xtask ci`, which builds
//! it first); without it it is built with
//! `cargo build --release -p lm-fw-qemu --target thumbv7em-none-eabihf` into
//! the test's own target dir.
#![allow(dead_code)]

use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The firmware's target.
pub const THUMB: &str = "thumbv7em-none-eabihf";

/// Whether `qemu-system-arm` runs (tests skip, with a message, without it).
pub fn qemu_installed() -> bool {
    Command::new("qemu-system-arm")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// True where `qemu-system-arm` is missing, saying so: the test is
/// skipped.
pub fn skip_without_qemu() -> bool {
    if qemu_installed() {
        return false;
    }
    println!("SKIPPED: qemu-system-arm is not installed (`cargo xtask ci` installs it)");
    true
}

/// The firmware ELF: from xtask, or built here into our own target dir.
pub fn firmware_elf() -> PathBuf {
    if let Some(p) = std::env::var_os("LM_FW_QEMU_ELF") {
        let p = PathBuf::from(p);
        assert!(p.exists(), "LM_FW_QEMU_ELF={} does not exist", p.display());
        return p;
    }
    let target_dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("lm-fw-qemu");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let status = Command::new(cargo)
        .current_dir(root)
        .args([
            "build",
            "--release",
            "-p",
            "lm-fw-qemu",
            "--bin",
            "lm-fw-qemu",
            "--target",
            THUMB,
        ])
        .arg("--target-dir")
        .arg(&target_dir)
        .status()
        .expect("run cargo to build the QEMU firmware");
    assert!(
        status.success(),
        "building the QEMU firmware failed (is the {THUMB} target installed? `rustup target add {THUMB}`)"
    );
    target_dir.join(THUMB).join("release/lm-fw-qemu")
}

/// A free TCP port on 127.0.0.1: bind, read it, release it for QEMU.
pub fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// `qemu-system-arm` running `elf` with UART0 as a TCP server on `port`.
/// With `wait`, the guest starts only once a client has connected.
/// `-icount shift=0`: virtual time is 1 ns per guest instruction, so the
/// firmware's timer follows its own work, not the host's load, and a
/// deadline is missed only if the firmware itself is too slow.
pub fn qemu_command(elf: &Path, port: u16, wait: bool) -> Command {
    qemu_command_icount(elf, port, wait, "shift=0")
}

/// [`qemu_command`] with another `-icount` setting (`shift=auto,sleep=on`:
/// the guest's clock follows the host's, for comparing device counts with
/// host times).
pub fn qemu_command_icount(elf: &Path, port: u16, wait: bool, icount: &str) -> Command {
    let wait = if wait { "on" } else { "off" };
    let mut cmd = Command::new("qemu-system-arm");
    cmd.args(["-M", "mps2-an500", "-display", "none", "-monitor", "none"])
        .args(["-semihosting-config", "enable=on,target=native"])
        .args(["-icount", icount])
        .arg("-serial")
        .arg(format!("tcp:127.0.0.1:{port},server=on,wait={wait}"))
        .arg("-kernel")
        .arg(elf);
    cmd
}

/// A running QEMU; killed on drop. Its console output goes to a log file
/// that is printed if the test fails.
pub struct Qemu {
    child: Child,
    log: PathBuf,
}

impl Qemu {
    /// Starts `cmd` (QEMU serving UART0 on `port`), its console output to
    /// a log file.
    pub fn spawn(mut cmd: std::process::Command, port: u16) -> std::io::Result<Qemu> {
        let log = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("qemu-{port}.log"));
        let out = std::fs::File::create(&log)?;
        let child = cmd.stdout(out.try_clone()?).stderr(out).spawn()?;
        Ok(Qemu { child, log })
    }

    /// Starts the firmware `elf` waiting for a client on a free port, and
    /// connects to its UART.
    pub fn start(elf: &Path) -> (Qemu, TcpStream) {
        let port = free_port();
        let mut q =
            Qemu::spawn(qemu_command(elf, port, true), port).expect("start qemu-system-arm");
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            match TcpStream::connect(("127.0.0.1", port)) {
                Ok(s) => {
                    s.set_nodelay(true).unwrap();
                    return (q, s);
                }
                Err(e) if Instant::now() > deadline => {
                    panic!(
                        "cannot connect to QEMU's UART on port {port}: {e}\n{}",
                        q.output()
                    )
                }
                Err(_) => {
                    if let Ok(Some(st)) = q.child.try_wait() {
                        panic!("QEMU exited early ({st})\n{}", q.output());
                    }
                    std::thread::sleep(Duration::from_millis(50));
                }
            }
        }
    }

    /// What QEMU printed so far.
    pub fn output(&self) -> String {
        format!(
            "--- QEMU output ---\n{}",
            std::fs::read_to_string(&self.log).unwrap_or_default()
        )
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        if std::thread::panicking() {
            eprintln!("{}", self.output());
        }
    }
}

/// The firmware `elf` under QEMU on a free port (not waiting for a
/// client), and the port that reaches it.
pub fn serving(elf: &Path) -> std::io::Result<(Qemu, lmhost::device::link::PortSpec)> {
    let port = free_port();
    let q = Qemu::spawn(qemu_command(elf, port, false), port)?;
    Ok((q, port_spec(port)))
}

/// The firmware ELF; `None` where `qemu-system-arm` is missing (the test
/// is skipped, saying so).
pub fn firmware_or_skip() -> Option<PathBuf> {
    (!skip_without_qemu()).then(firmware_elf)
}

/// The firmware under QEMU and the port that reaches it; `None` where
/// `qemu-system-arm` is missing.
pub fn serving_or_skip() -> Option<(Qemu, lmhost::device::link::PortSpec)> {
    let elf = firmware_or_skip()?;
    Some(serving(&elf).expect("start qemu-system-arm"))
}

/// lmhost's device layer opened on the firmware under QEMU (the paper's
/// default scene); `None` where `qemu-system-arm` is missing.
pub fn device_or_skip() -> Option<(Qemu, Box<dyn lmhost::device::backend::Backend>)> {
    let (qemu, spec) = serving_or_skip()?;
    let scene = lmhost::plan::scene::Scene::default();
    let dev = within_20_s(|| lmhost::device::connect::open(&spec, &scene))
        .unwrap_or_else(|e| panic!("{e:#}"));
    Some((qemu, dev))
}

/// Polls `dev` every 20 ms until its player has stopped (a timed play
/// ending on the device's own count) and returns that status; each status
/// before it goes to `running` first. Fails after 60 s: a guard against
/// hanging, not a timing goal.
pub fn until_stopped(
    dev: &mut dyn lmhost::device::backend::Backend,
    mut running: impl FnMut(&lm_proto::Status),
) -> lm_proto::Status {
    let give_up = Instant::now() + Duration::from_secs(60);
    loop {
        let st = dev.status().unwrap();
        if st.state == lm_proto::DeviceState::Stopped {
            return st;
        }
        running(&st);
        assert!(Instant::now() < give_up, "never stopped: {st:?}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// `connect` retried for 20 s while QEMU starts listening.
pub fn within_20_s<T>(mut connect: impl FnMut() -> anyhow::Result<T>) -> anyhow::Result<T> {
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        match connect() {
            Ok(t) => return Ok(t),
            Err(e) if Instant::now() > deadline => return Err(e),
            Err(_) => std::thread::sleep(Duration::from_millis(50)),
        }
    }
}

/// Lets `d` pass on the firmware's own clock: QEMU's virtual time may run
/// slower than the wall clock, so wait until the player has stepped that
/// long (it steps while muted too). A player that stops on its own (a
/// timed play) or was stopped counts no more: then `d` of wall time passes,
/// the least it would have taken.
pub fn wait_on_device(
    dev: &mut dyn lmhost::device::backend::Backend,
    d: Duration,
    steps: u64,
    dwell_us: f64,
) -> anyhow::Result<()> {
    let pos = |st: &lm_proto::Status| u64::from(st.cycles) * steps + u64::from(st.step);
    let begun = Instant::now();
    let start = pos(&dev.status()?);
    let need = (d.as_secs_f64() * 1e6 / dwell_us).ceil() as u64 + 1;
    let give_up = begun + d * 50 + Duration::from_secs(10);
    loop {
        std::thread::sleep(Duration::from_millis(5));
        let st = dev.status()?;
        if matches!(
            st.state,
            lm_proto::DeviceState::Stopped | lm_proto::DeviceState::Idle
        ) {
            std::thread::sleep(d.saturating_sub(begun.elapsed()));
            return Ok(());
        }
        // (A slot taking over restarts the count: the wait only gets longer.)
        if pos(&st) >= start + need {
            return Ok(());
        }
        anyhow::ensure!(
            Instant::now() < give_up,
            "the firmware's player did not advance"
        );
    }
}

/// The port spec of the firmware under QEMU on `port`, with the response
/// timeout `LMHOST_TIMEOUT_MS` asks for (as the CLI takes it): QEMU's
/// speed follows the host's load, and CI runs it beside other work.
pub fn port_spec(port: u16) -> lmhost::device::link::PortSpec {
    let mut spec = lmhost::device::link::PortSpec::new(Some(format!("tcp:127.0.0.1:{port}")));
    spec.timeout_ms = std::env::var("LMHOST_TIMEOUT_MS")
        .ok()
        .map(|v| v.parse().expect("LMHOST_TIMEOUT_MS: milliseconds"));
    spec
}
