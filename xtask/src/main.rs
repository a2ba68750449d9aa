//! `cargo xtask <task>`: project tasks.
//!
//! - `ci [--from STEP]`: THE test command. Installs what is missing (the thumb target,
//!   clippy and rustfmt, `qemu-system-arm` when root), then runs every step in [`STEPS`] in order,
//!   streaming output, stopping at the first failure, and printing a timing
//!   summary.
//! - `python`: the CI's Python step alone: builds the `lmhost` package
//!   into a venv under the target dir and runs `pytest python/tests`.
//! - `gateware`: the CI's gateware step alone: dumps the core's SPI frames for
//!   a planned LM-M sequence, then simulates the transducer driver
//!   (`gateware/`, Amaranth in a venv under the target dir) against
//!   `firmware/DRIVER.md`; then the full-width chain (the paper's LM-M,
//!   996 channels on four boards) as Verilog under Verilator (Yosys and
//!   Verilator from Debian, installed as root when missing).
//! - `ethercat`: the CI's opt-in backends step alone: builds lmhost with
//!   `flash` and (as root, installing libpcap-dev and CMake ≥ 3.28) both
//!   EtherCAT links, then checks that opening them without an adapter or
//!   without privileges is one line and exit 1.
//! - `bitstream [--first F] [--total T]`: synthesises the driver for the
//!   iCE40-HX8K Breakout Board (64 channels, PLL, its pin map) with Yosys,
//!   nextpnr-ice40 and icepack from Debian (installed when missing and
//!   root); prints utilisation and fmax. Not part of `ci`.
//! - `build-fw`: release build of the QEMU firmware and the Nucleo board.
//! - `qemu [--tcp PORT]`: run the firmware under QEMU, UART0 on a pty
//!   (default) or on a TCP port on 127.0.0.1.
//! - `size`: memory map of the built firmware ELF.
//!
//! std only: the ELF reader for `size` is in [`elf`].

mod elf;

use std::borrow::BorrowMut;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::time::{Duration, Instant};

/// The thumb target every firmware crate builds for.
const THUMB: &str = "thumbv7em-none-eabihf";
/// Package name of the QEMU board crate.
const QEMU_PKG: &str = "lm-fw-qemu";
/// Package (and binary) name of the Nucleo-H743 board crate.
const NUCLEO_PKG: &str = "lm-fw-nucleo-h743";
/// Binary that runs the on-target tests under QEMU.
const SELFTEST_BIN: &str = "lm-fw-qemu-selftest";
/// QEMU machine: AN500, a Cortex-M7 with FPv5 as on the STM32H743; the
/// same map where the image lives as the AN386 (M4F) it replaced: ZBT
/// SSRAM1 at 0 and SSRAM2&3 at 0x2000_0000 (4 MiB each), CMSDK UART0 at
/// 0x4000_4000, TIMER0 at 0x4000_0000 on the 25 MHz APB clock.
const QEMU_MACHINE: &str = "mps2-an500";
/// Wall-clock limit for one QEMU on-target run (it normally takes seconds).
const QEMU_TIMEOUT: Duration = Duration::from_secs(600);

/// One CI step: a name for the summary and the function that runs it.
struct Step {
    name: &'static str,
    run: fn(&Ctx) -> Result<(), String>,
}

/// The CI, in order. Add a step by adding a line (and a function below).
const STEPS: &[Step] = &[
    Step {
        name: "setup: thumb target + qemu-system-arm",
        run: step_setup,
    },
    Step {
        name: "lint: cargo fmt --check, module cycles at every folder level",
        run: step_lint_source,
    },
    Step {
        name: "thumb build: lm-proto + lm-fw-core (no_std; plain and with defmt)",
        run: step_thumb_libs,
    },
    Step {
        name: "thumb build: QEMU firmware + on-target tests",
        run: step_build_qemu_fw,
    },
    Step {
        name: "cargo build (host crates + firmware core)",
        run: step_host_build,
    },
    Step {
        name: "cargo test (host crates + firmware core + e2e)",
        run: step_host_test,
    },
    Step {
        name: "python: the lmhost package (maturin develop, own venv under target/) + pytest",
        run: step_python,
    },
    Step {
        name: "gateware: driver simulation on the core's LM-M SPI frames (Amaranth, own venv), then full width: plan → core → SPI → Verilator, 996 channels",
        run: step_gateware,
    },
    Step {
        name: "on-target tests under QEMU (-icount shift=0)",
        run: step_qemu_selftest,
    },
    Step {
        name: "thumb build: Nucleo-H743 board (crystal clock), size report",
        run: step_build_nucleo,
    },
    Step {
        name: "cargo build: lmhost with its opt-in backends (flash; as root, EtherCAT: SOEM, ethercrab) and the EtherCAT missing-adapter smoke test",
        run: step_optional_backends,
    },
    Step {
        name: "lint: clippy -D warnings (host crates; thumb crates per board), rustdoc -D warnings",
        run: step_lint_clippy_doc,
    },
    Step {
        name: "long run: lm-proto fuzz (release, ignored)",
        run: step_proto_fuzz,
    },
    Step {
        name: "long run: lm-fw-core robustness (release, ignored)",
        run: step_core_robustness,
    },
    Step {
        name: "long run: planner accuracy, 10^5 seeded frames (release, ignored)",
        run: step_planner_accuracy,
    },
    Step {
        name: "long run: 10,000 faulty uploads through the fault proxy (release, ignored)",
        run: step_fault_uploads,
    },
    Step {
        name: "long run: 10 minutes of 90 Hz centroid streaming (release, ignored)",
        run: step_stream_soak,
    },
];

/// Paths shared by the steps.
struct Ctx {
    root: PathBuf,
    target_dir: PathBuf,
}

impl Ctx {
    fn new() -> Ctx {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"))
            .parent()
            .expect("xtask lives one level below the workspace root")
            .to_path_buf();
        let target_dir = match std::env::var_os("CARGO_TARGET_DIR") {
            Some(d) if Path::new(&d).is_absolute() => PathBuf::from(d),
            Some(d) => root.join(d),
            None => root.join("target"),
        };
        Ctx { root, target_dir }
    }

    /// `cargo` as invoked by the user (the alias sets `CARGO`).
    fn cargo(&self, args: &[&str]) -> Command {
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        let mut cmd = Command::new(cargo);
        cmd.current_dir(&self.root).args(args);
        cmd
    }

    fn thumb_release_dir(&self) -> PathBuf {
        self.target_dir.join(THUMB).join("release")
    }

    fn firmware_elf(&self) -> PathBuf {
        self.thumb_release_dir().join(QEMU_PKG)
    }

    fn selftest_elf(&self) -> PathBuf {
        self.thumb_release_dir().join(SELFTEST_BIN)
    }

    fn nucleo_elf(&self) -> PathBuf {
        self.thumb_release_dir().join(NUCLEO_PKG)
    }
}

/// Runs `cmd` with inherited stdio (output streams live); fails on non-zero exit.
fn run(mut cmd: impl BorrowMut<Command>) -> Result<(), String> {
    let cmd = cmd.borrow_mut();
    println!("$ {}", show(cmd));
    let status = cmd
        .status()
        .map_err(|e| format!("cannot start `{}`: {e}", show(cmd)))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("`{}` failed ({status})", show(cmd)))
    }
}

fn show(cmd: &Command) -> String {
    let program = Path::new(cmd.get_program());
    let mut s = program
        .file_name()
        .unwrap_or(program.as_os_str())
        .to_string_lossy()
        .into_owned();
    for a in cmd.get_args() {
        s.push(' ');
        s.push_str(&a.to_string_lossy());
    }
    s
}

fn have_program(name: &str) -> bool {
    Command::new(name)
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

fn thumb_target_installed() -> bool {
    let out = Command::new("rustc")
        .args(["--print", "target-libdir", "--target", THUMB])
        .output();
    match out {
        Ok(o) if o.status.success() => {
            let dir = String::from_utf8_lossy(&o.stdout).trim().to_string();
            std::fs::read_dir(&dir).is_ok_and(|mut d| d.next().is_some())
        }
        _ => false,
    }
}

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}

fn ensure_thumb_target() -> Result<(), String> {
    if thumb_target_installed() {
        println!("thumb target {THUMB}: installed");
        return Ok(());
    }
    run(Command::new("rustup").args(["target", "add", THUMB])).map_err(|e| {
        format!("{e}\nthe {THUMB} target is missing; install it with `rustup target add {THUMB}`")
    })
}

fn ensure_qemu() -> Result<(), String> {
    if have_program("qemu-system-arm") {
        println!("qemu-system-arm: installed");
        return Ok(());
    }
    if !is_root() || !have_program("apt-get") {
        return Err(
            "qemu-system-arm is not installed and this is not a root shell with apt-get; \
             install it (Debian/Ubuntu: `sudo apt-get install -y qemu-system-arm`) and rerun"
                .into(),
        );
    }
    run(Command::new("apt-get").arg("update"))?;
    run(Command::new("apt-get")
        .args([
            "install",
            "-y",
            "--no-install-recommends",
            "qemu-system-arm",
        ])
        .env("DEBIAN_FRONTEND", "noninteractive"))?;
    if have_program("qemu-system-arm") {
        Ok(())
    } else {
        Err("apt-get installed qemu-system-arm but it is still not on PATH".into())
    }
}

/// `cargo build --release --target thumbv7em-none-eabihf` plus `args`.
fn thumb_build(c: &Ctx, args: &[&str]) -> Result<(), String> {
    let mut all = vec!["build", "--release", "--target", THUMB];
    all.extend_from_slice(args);
    run(c.cargo(&all))
}

fn step_setup(_: &Ctx) -> Result<(), String> {
    ensure_thumb_target()?;
    ensure_components()?;
    ensure_qemu()
}

/// clippy and rustfmt, which the lint steps run.
fn ensure_components() -> Result<(), String> {
    for (sub, component) in [("clippy", "clippy"), ("fmt", "rustfmt")] {
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        let have = Command::new(cargo)
            .args([sub, "--version"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if have {
            println!("{component}: installed");
            continue;
        }
        run(Command::new("rustup").args(["component", "add", component])).map_err(|e| {
            format!(
                "{e}\n{component} is missing; install it with `rustup component add {component}`"
            )
        })?;
    }
    Ok(())
}

/// Formatting and the module graph: cheap, so they run first.
fn step_lint_source(c: &Ctx) -> Result<(), String> {
    run(c.cargo(&["fmt", "--all", "--", "--check"]))?;
    run(Command::new("python3")
        .current_dir(&c.root)
        .args(["xtask/module_cycles.py", "host/src"]))
}

/// Lints every crate with the warnings it must not have: clippy's default
/// set plus undocumented `unsafe`, `print!`-family output (host) and APIs
/// newer than the declared `rust-version` (clippy's `incompatible_msrv`);
/// rustdoc's broken links. The thumb crates are linted for the thumb target,
/// each board in its own invocation (see `nucleo_build`).
fn step_lint_clippy_doc(c: &Ctx) -> Result<(), String> {
    const DENY: [&str; 4] = ["-D", "warnings", "-D", "clippy::undocumented_unsafe_blocks"];
    let clippy = |args: &[&str]| {
        let mut all = vec!["clippy"];
        all.extend_from_slice(args);
        all.push("--");
        all.extend_from_slice(&DENY);
        run(c.cargo(&all))
    };
    clippy(&[
        "--workspace",
        "--exclude",
        QEMU_PKG,
        "--exclude",
        NUCLEO_PKG,
        "--all-targets",
    ])?;
    clippy(&["--target", THUMB, "-p", "lm-proto", "-p", "lm-fw-core"])?;
    clippy(&["--target", THUMB, "-p", QEMU_PKG, "--bins"])?;
    clippy(&["--target", THUMB, "-p", NUCLEO_PKG])?;
    run(c
        .cargo(&[
            "doc",
            "--no-deps",
            "-p",
            "lmhost",
            "-p",
            "lm-proto",
            "-p",
            "lm-fw-core",
        ])
        .env("RUSTDOCFLAGS", "-D warnings"))
}

fn step_thumb_libs(c: &Ctx) -> Result<(), String> {
    thumb_build(c, &["-p", "lm-proto", "-p", "lm-fw-core"])?;
    // The defmt logging feature must build too (it is off everywhere else).
    thumb_build(c, &["-p", "lm-fw-core", "--features", "defmt"])
}

fn build_qemu_fw(c: &Ctx) -> Result<(), String> {
    thumb_build(c, &["-p", QEMU_PKG, "--bins"])
}

fn step_build_qemu_fw(c: &Ctx) -> Result<(), String> {
    build_qemu_fw(c)
}

fn step_host_build(c: &Ctx) -> Result<(), String> {
    run(c.cargo(&["build"]))
}

/// The opt-in backends, built once together so none rots unnoticed:
/// `flash` (probe-rs, minutes to build) always; as root also the EtherCAT
/// links (`autd3-soem` builds SOEM with CMake ≥ 3.28, `autd3-ethercrab`
/// links libpcap), installing what they need, then the smoke test.
fn step_optional_backends(c: &Ctx) -> Result<(), String> {
    if !is_root() {
        println!(
            "ethercat: skipped (not root: the EtherCAT build needs libpcap-dev from apt and the smoke test raw sockets); building `flash` alone"
        );
        return run(c.cargo(&["build", "-p", "lmhost", "--features", "flash"]));
    }
    let path = ensure_ethercat_tools(c)?;
    run(c
        .cargo(&[
            "build",
            "-p",
            "lmhost",
            "--features",
            "flash,autd3-soem,autd3-ethercrab",
        ])
        .env("PATH", path))?;
    ethercat_smoke(&c.target_dir.join("debug").join("lmhost"))
}

/// libpcap-dev (apt) and CMake ≥ 3.28 (Debian's or, when older, from the
/// package index into a venv under the target dir); returns the PATH for
/// the build.
fn ensure_ethercat_tools(c: &Ctx) -> Result<std::ffi::OsString, String> {
    if Path::new("/usr/include/pcap/pcap.h").exists() {
        println!("libpcap-dev: installed");
    } else {
        if !have_program("apt-get") {
            return Err("libpcap-dev is missing and there is no apt-get; install libpcap's headers and rerun".into());
        }
        run(Command::new("apt-get")
            .args(["install", "-y", "--no-install-recommends", "libpcap-dev"])
            .env("DEBIAN_FRONTEND", "noninteractive"))
        .or_else(|_| {
            run(Command::new("apt-get").arg("update"))?;
            run(Command::new("apt-get")
                .args(["install", "-y", "--no-install-recommends", "libpcap-dev"])
                .env("DEBIAN_FRONTEND", "noninteractive"))
        })?;
    }
    let path = std::env::var_os("PATH").unwrap_or_default();
    if cmake_at_least(Path::new("cmake"), (3, 28)) {
        println!("cmake ≥ 3.28: installed");
        return Ok(path);
    }
    let venv = c.target_dir.join("tools-venv");
    let bin = venv.join("bin");
    if !cmake_at_least(&bin.join("cmake"), (3, 28)) {
        if !venv.join("bin").join("python").exists() {
            run(Command::new("python3").arg("-m").arg("venv").arg(&venv)).map_err(|e| {
                format!(
                    "{e}\nthe EtherCAT build needs python3 with its venv module for CMake ≥ 3.28"
                )
            })?;
        }
        // SOEM's CMakeLists predate CMake 4's removal of old policies.
        run(Command::new(bin.join("python")).args([
            "-m",
            "pip",
            "install",
            "--disable-pip-version-check",
            "-q",
            "cmake>=3.28,<4",
        ]))?;
    }
    let mut p = std::ffi::OsString::from(bin.as_os_str());
    p.push(":");
    p.push(path);
    Ok(p)
}

/// Whether `cmake --version` says at least `min`.
fn cmake_at_least(cmake: &Path, min: (u32, u32)) -> bool {
    let Ok(out) = Command::new(cmake).arg("--version").output() else {
        return false;
    };
    let text = String::from_utf8_lossy(&out.stdout);
    let v: Vec<u32> = text
        .split_whitespace()
        .nth(2)
        .unwrap_or("")
        .split('.')
        .take(2)
        .filter_map(|x| x.parse().ok())
        .collect();
    v.len() == 2 && (v[0], v[1]) >= min
}

/// Runs `cmd` with a deadline; `None` when it had to be killed.
fn output_within(
    mut cmd: Command,
    limit: Duration,
) -> Result<Option<std::process::Output>, String> {
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start `{}`: {e}", show(&cmd)))?;
    let t0 = Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(_)) => {
                return child
                    .wait_with_output()
                    .map(Some)
                    .map_err(|e| e.to_string());
            }
            Ok(None) if t0.elapsed() > limit => {
                let _ = child.kill();
                let _ = child.wait();
                return Ok(None);
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => return Err(e.to_string()),
        }
    }
}

/// Opening each EtherCAT link without an adapter (a missing interface,
/// no AUTD3 on any) and without privileges (as `nobody`, via setpriv)
/// must fail in one line with exit 1, within a bound.
fn ethercat_smoke(lmhost: &Path) -> Result<(), String> {
    let mut cases: Vec<(Vec<String>, &str, &str)> = Vec::new();
    for link in ["soem", "ethercrab"] {
        cases.push((
            vec![format!("autd3:{link}:lm-no-such-if0")],
            "no network interface",
            "",
        ));
        cases.push((vec![format!("autd3:{link}")], "no AUTD", ""));
    }
    let privileged = cases.len();
    if have_program("setpriv") {
        for link in ["soem", "ethercrab"] {
            cases.push((
                vec![format!("autd3:{link}")],
                "raw-socket privileges",
                "nobody",
            ));
        }
    } else {
        println!("ethercat: setpriv missing, the unprivileged cases are skipped");
    }
    let (mut passed, mut failed) = (0, 0);
    for (i, (port, want, _)) in cases.iter().enumerate() {
        let mut cmd = if i >= privileged {
            let mut c = Command::new("setpriv");
            c.args(["--reuid=65534", "--regid=65534", "--clear-groups"])
                .arg(lmhost)
                .current_dir("/tmp");
            c
        } else {
            Command::new(lmhost)
        };
        cmd.args(["info", "--port", &port[0]])
            .env_remove("RUST_BACKTRACE");
        let who = if i >= privileged { " (as nobody)" } else { "" };
        let verdict = match output_within(cmd, Duration::from_secs(60))? {
            None => Err("did not end within 60 s".to_string()),
            Some(o) => {
                let err = String::from_utf8_lossy(&o.stderr).to_string();
                let lines = err.trim_end().lines().count();
                if o.status.code() != Some(1) {
                    Err(format!("exit {:?}, want 1: {err}", o.status.code()))
                } else if lines != 1 || !err.starts_with("error: ") {
                    Err(format!(
                        "{lines} lines on stderr, want one `error: ` line: {err}"
                    ))
                } else if !err.to_lowercase().contains(&want.to_lowercase()) {
                    Err(format!("`{}` does not say `{want}`", err.trim_end()))
                } else {
                    Ok(err.trim_end().to_string())
                }
            }
        };
        match verdict {
            Ok(line) => {
                passed += 1;
                println!("ok   {}{who}: {line}", port[0]);
            }
            Err(e) => {
                failed += 1;
                println!("FAIL {}{who}: {e}", port[0]);
            }
        }
    }
    println!("ethercat smoke: {passed} passed, {failed} failed");
    if failed == 0 {
        Ok(())
    } else {
        Err(format!("{failed} EtherCAT smoke cases failed"))
    }
}

fn step_host_test(c: &Ctx) -> Result<(), String> {
    // The e2e QEMU test uses the firmware built above instead of building its
    // own. --no-fail-fast: one failing test target must not hide the others.
    run(c
        .cargo(&["test", "--no-fail-fast"])
        .env("LM_FW_QEMU_ELF", c.firmware_elf()))
}

/// The Python package: a virtual environment of its own under the target
/// dir (nothing global), maturin, numpy and pytest from the package index,
/// the binding built in the workspace's target dir and dev profile (pyo3
/// and lmhost compiled once, shared with the other steps), then pytest
/// against the real `target/debug/lmhost`.
fn step_python(c: &Ctx) -> Result<(), String> {
    let venv = c.target_dir.join("py-venv");
    let bin = venv.join("bin");
    let python = bin.join("python");
    if !python.exists() {
        run(Command::new("python3").arg("-m").arg("venv").arg(&venv))
            .map_err(|e| format!("{e}\nthe python step needs python3 with its venv module"))?;
    }
    run(Command::new(&python).args([
        "-m",
        "pip",
        "install",
        "--quiet",
        "--disable-pip-version-check",
        "maturin>=1.5,<2",
        "numpy",
        "pytest",
    ]))?;
    run(c.cargo(&["build", "-p", "lmhost"]))?;
    let path = match std::env::var_os("PATH") {
        Some(p) => {
            let mut all = vec![bin.clone()];
            all.extend(std::env::split_paths(&p));
            std::env::join_paths(all).map_err(|e| format!("PATH: {e}"))?
        }
        None => bin.clone().into_os_string(),
    };
    run(Command::new(bin.join("maturin"))
        .current_dir(c.root.join("python"))
        .args(["develop", "--quiet"])
        .env("VIRTUAL_ENV", &venv)
        .env("PATH", &path)
        .env("CARGO_TARGET_DIR", &c.target_dir))?;
    run(Command::new(&python)
        .current_dir(&c.root)
        .args([
            "-m",
            "pytest",
            "python/tests",
            "-q",
            "-p",
            "no:cacheprovider",
        ])
        .env("LMHOST_BIN", c.target_dir.join("debug").join("lmhost"))
        .env("CARGO_TARGET_DIR", &c.target_dir))
}

/// The transducer-driver gateware: the exact SPI frames `lm-fw-core` sends
/// for a planned LM-M sequence (its `spi_frames` test writes them to
/// `target/gateware/frames.bin`), then the Amaranth simulation tests in a
/// virtual environment of their own under the target dir (pure Python, no
/// Yosys needed to simulate).
fn step_gateware(c: &Ctx) -> Result<(), String> {
    let out = c.target_dir.join("gateware");
    let frames = out.join("frames.bin");
    let _ = std::fs::remove_file(&frames);
    run(c
        .cargo(&["test", "-q", "-p", "lm-fw-core", "--test", "spi_frames"])
        .env("LM_GW_FRAMES_OUT", &frames))?;
    let venv = c.target_dir.join("gw-venv");
    let python = venv.join("bin").join("python");
    if !python.exists() {
        run(Command::new("python3").arg("-m").arg("venv").arg(&venv))
            .map_err(|e| format!("{e}\nthe gateware step needs python3 with its venv module"))?;
    }
    run(Command::new(&python).args([
        "-m",
        "pip",
        "install",
        "--quiet",
        "--disable-pip-version-check",
        "amaranth>=0.5,<0.6",
    ]))?;
    run(Command::new(&python)
        .current_dir(c.root.join("gateware"))
        .arg("sim_lmdriver.py")
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .env("LM_GW_OUT", &out))?;
    full_width(c, &python, &out)
}

/// Transducers of the paper's rig (`scenes/paper.toml`) and the channels
/// of one driver board in the full-width run.
const FULL_WIDTH: (&str, &str) = ("996", "256");

/// The whole chain at full width: `lmhost plan` (the paper's LM-M on the
/// paper's scene) → lm-fw-core (`spi_frames`' full-width test) → the SPI
/// bytes → the driver as Verilog (Yosys) on four boards under Verilator →
/// every edge of every channel against the plan (`gateware/full_width.py`).
fn full_width(c: &Ctx, python: &Path, out: &Path) -> Result<(), String> {
    let missing: Vec<&str> = ["yosys", "verilator"]
        .into_iter()
        .filter(|p| !has_program(p))
        .collect();
    if !missing.is_empty() {
        if !is_root() || !have_program("apt-get") {
            return Err(format!(
                "the full-width gateware run needs {} (Debian: `sudo apt-get install -y yosys verilator`)",
                missing.join(" and ")
            ));
        }
        run(Command::new("apt-get")
            .args(["install", "-y", "--no-install-recommends"])
            .args(&missing)
            .env("DEBIAN_FRONTEND", "noninteractive"))?;
    }
    run(c.cargo(&["build", "-q", "-p", "lmhost"]))?;
    let phases = out.join("lmm-paper.bin");
    run(Command::new(c.target_dir.join("debug").join("lmhost"))
        .current_dir(&c.root)
        .args([
            "plan",
            "--scene",
            "scenes/paper.toml",
            "--radius",
            "3",
            "--foci",
            "4",
            "--out",
        ])
        .arg(&phases))?;
    let frames = out.join("frames-full.bin");
    let _ = std::fs::remove_file(&frames);
    run(c
        .cargo(&[
            "test",
            "-q",
            "-p",
            "lm-fw-core",
            "--test",
            "spi_frames",
            "--",
            "--ignored",
            "full_width",
        ])
        .env("LM_GW_PHASES", &phases)
        .env("LM_GW_CHANNELS", FULL_WIDTH.0)
        .env("LM_GW_FRAMES_OUT", &frames))?;
    run(Command::new(python)
        .current_dir(c.root.join("gateware"))
        .arg("full_width.py")
        .arg(&frames)
        .args(["--total", FULL_WIDTH.0, "--board", FULL_WIDTH.1, "--work"])
        .arg(out.join("verilator"))
        .env("PYTHONDONTWRITEBYTECODE", "1"))
}

/// Yosys + nextpnr-ice40 + icepack for one iCE40-HX8K Breakout Board
/// (`gateware/hx8k.py`: 64 channels, the PLL from a 10.24 MHz reference to
/// the documented 81.92 MHz, pins in `gateware/ice40hx8k-b-evn.pcf`);
/// `--first F --total T`: the board drives frame channels F..F + 64 of T.
fn bitstream(c: &Ctx, args: &[String]) -> Result<(), String> {
    let (mut first, mut total) = ("0".to_string(), "64".to_string());
    let mut rest = args.iter();
    while let Some(flag) = rest.next() {
        let v = rest.next().filter(|v| v.parse::<u16>().is_ok());
        match (flag.as_str(), v) {
            ("--first", Some(v)) => first = v.clone(),
            ("--total", Some(v)) => total = v.clone(),
            _ => return Err("usage: cargo xtask bitstream [--first F] [--total T]".into()),
        }
    }
    if !has_program("yosys") || !has_program("nextpnr-ice40") || !has_program("icepack") {
        if !is_root() {
            return Err("bitstream needs yosys, nextpnr-ice40 and icepack: \
                        apt-get install -y yosys nextpnr-ice40 fpga-icestorm"
                .into());
        }
        run(Command::new("apt-get").args([
            "install",
            "-y",
            "yosys",
            "nextpnr-ice40",
            "fpga-icestorm",
        ]))?;
    }
    let python = c.target_dir.join("gw-venv").join("bin").join("python");
    if !python.exists() {
        return Err("run `cargo xtask gateware` first (it sets up the venv)".into());
    }
    let out = c.target_dir.join("gateware").join("bitstream");
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    let stem = format!("hx8k_{first}_of_{total}");
    let il = out.join(format!("{stem}.il"));
    let json = out.join(format!("{stem}.json"));
    let asc = out.join(format!("{stem}.asc"));
    let bin = out.join(format!("{stem}.bin"));
    let log = out.join(format!("nextpnr_{stem}.log"));
    run(Command::new(&python)
        .arg(c.root.join("gateware").join("hx8k.py"))
        .args(["--first", &first, "--total", &total])
        .arg(&il)
        .env("PYTHONDONTWRITEBYTECODE", "1"))?;
    run(Command::new("yosys").arg("-q").arg("-p").arg(format!(
        "read_rtlil {}; synth_ice40 -top top -json {}",
        il.display(),
        json.display()
    )))?;
    let pnr = Command::new("nextpnr-ice40")
        .args(["--hx8k", "--package", "ct256", "--freq", "81.92"])
        .arg("--pcf")
        .arg(c.root.join("gateware").join("ice40hx8k-b-evn.pcf"))
        .arg("--json")
        .arg(&json)
        .arg("--asc")
        .arg(&asc)
        .arg("--log")
        .arg(&log)
        .stderr(Stdio::null())
        .status()
        .map_err(|e| format!("cannot start nextpnr-ice40: {e}"))?;
    let text = std::fs::read_to_string(&log).unwrap_or_default();
    let keep = |l: &&str| {
        l.contains("ICESTORM_LC:")
            || l.contains("SB_IO:")
            || l.contains("ICESTORM_PLL:")
            || l.contains("ERROR")
    };
    for line in text.lines().filter(keep) {
        println!("{}", line.trim_start_matches("Info: ").trim());
    }
    // nextpnr reports fmax after placement and again after routing: the last counts.
    if let Some(line) = text.lines().rfind(|l| l.contains("Max frequency")) {
        println!(
            "after routing: {}",
            line.trim_start_matches("Info: ").trim()
        );
    }
    if !pnr.success() {
        return Err(format!(
            "nextpnr-ice40 failed ({pnr}); see {}",
            log.display()
        ));
    }
    run(Command::new("icepack").arg(&asc).arg(&bin))?;
    println!("bitstream: {}", bin.display());
    Ok(())
}

/// Whether `name` is on `PATH`.
fn has_program(name: &str) -> bool {
    std::env::var_os("PATH")
        .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join(name).is_file()))
}

/// QEMU command line for `elf`: no display, semihosting for output and exit
/// status, and optionally a fixed 1 ns of virtual time per instruction.
fn qemu_cmd(elf: &Path, icount: bool) -> Command {
    let mut cmd = Command::new("qemu-system-arm");
    cmd.args(["-M", QEMU_MACHINE, "-display", "none", "-monitor", "none"])
        .args(["-semihosting-config", "enable=on,target=native"]);
    if icount {
        cmd.args(["-icount", "shift=0"]);
    }
    cmd.arg("-kernel").arg(elf);
    cmd
}

/// Runs `cmd` with a wall-clock limit; the child's exit status is the verdict.
fn run_with_timeout(mut cmd: impl BorrowMut<Command>, limit: Duration) -> Result<(), String> {
    let cmd = cmd.borrow_mut();
    println!("$ {}", show(cmd));
    let mut child = cmd
        .spawn()
        .map_err(|e| format!("cannot start `{}`: {e}", show(cmd)))?;
    let start = Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(status)) if status.success() => return Ok(()),
            Ok(Some(status)) => return Err(format!("`{}` failed ({status})", show(cmd))),
            Ok(None) if start.elapsed() > limit => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!("`{}` did not finish within {limit:?}", show(cmd)));
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(50)),
            Err(e) => return Err(format!("waiting for QEMU: {e}")),
        }
    }
}

fn step_qemu_selftest(c: &Ctx) -> Result<(), String> {
    let elf = c.selftest_elf();
    if !elf.exists() {
        return Err(format!(
            "{} is missing; run `cargo xtask build-fw`",
            elf.display()
        ));
    }
    // -serial null: the self-test talks only over semihosting.
    run_with_timeout(qemu_cmd(&elf, true).args(["-serial", "null"]), QEMU_TIMEOUT)
}

/// Its own cargo invocation: built together with the QEMU board, the
/// Nucleo PAC's `rt` feature would switch on cortex-m-rt's `device` feature
/// for the QEMU board too (see ARCHITECTURE.md, Memory maps).
fn nucleo_build(c: &Ctx) -> Result<(), String> {
    thumb_build(c, &["-p", NUCLEO_PKG])
}

/// The real board, on its crystal clock (`firmware/nucleo-h743/src/clocks.rs`:
/// its dividers are checked at compile time), and its memory map.
fn step_build_nucleo(c: &Ctx) -> Result<(), String> {
    nucleo_build(c)?;
    let elf_path = c.nucleo_elf();
    let bytes =
        std::fs::read(&elf_path).map_err(|e| format!("cannot read {}: {e}", elf_path.display()))?;
    let report = elf::memory_map(&bytes).map_err(|e| format!("{}: {e}", elf_path.display()))?;
    println!("== Nucleo-H743: {}", elf_path.display());
    print!("{report}");
    Ok(())
}

/// Runs the ignored long tests of one test target in release mode.
fn long_run(c: &Ctx, pkg: &str, target: &[&str], filter: &str) -> Result<(), String> {
    let mut args = vec!["test", "--release", "-p", pkg];
    args.extend_from_slice(target);
    args.extend_from_slice(&["--", "--ignored", filter]);
    run(c.cargo(&args))
}

fn step_proto_fuzz(c: &Ctx) -> Result<(), String> {
    long_run(c, "lm-proto", &["--test", "fuzz"], "")
}

fn step_fault_uploads(c: &Ctx) -> Result<(), String> {
    long_run(c, "lm-e2e", &["--test", "fault_upload"], "")
}

fn step_stream_soak(c: &Ctx) -> Result<(), String> {
    long_run(c, "lm-e2e", &["--test", "stream_soak"], "")
}

fn step_planner_accuracy(c: &Ctx) -> Result<(), String> {
    long_run(c, "lmhost", &["--lib"], "long_random")
}

fn step_core_robustness(c: &Ctx) -> Result<(), String> {
    long_run(c, "lm-fw-core", &["--test", "robustness"], "")
}

/// `ci` runs every step; `ci --from N` resumes at step N (1-based) after a fix.
fn ci(c: &Ctx, args: &[String]) -> Result<(), String> {
    let first = match args {
        [] => 1,
        [flag, n] if flag == "--from" => match n.parse::<usize>() {
            Ok(n) if (1..=STEPS.len()).contains(&n) => n,
            _ => {
                return Err(format!(
                    "--from needs a step number 1-{}, got `{n}`",
                    STEPS.len()
                ));
            }
        },
        _ => return Err("usage: cargo xtask ci [--from STEP]".into()),
    };
    let mut times: Vec<(&str, Duration, bool)> = Vec::new();
    let start = Instant::now();
    let mut failure = None;
    for (i, step) in STEPS.iter().enumerate().skip(first - 1) {
        println!("\n==> [{}/{}] {}", i + 1, STEPS.len(), step.name);
        let t = Instant::now();
        let r = (step.run)(c);
        times.push((step.name, t.elapsed(), r.is_ok()));
        if let Err(e) = r {
            failure = Some(format!("step `{}` failed: {e}", step.name));
            break;
        }
    }
    println!("\n==> timing");
    for (name, d, ok) in &times {
        let mark = if *ok { "ok  " } else { "FAIL" };
        println!("  {mark} {:>7.1} s  {name}", d.as_secs_f64());
    }
    println!("       {:>7.1} s  total", start.elapsed().as_secs_f64());
    match failure {
        Some(e) => Err(e),
        None => {
            println!(
                "ci: {} of {} steps run, all passed",
                times.len(),
                STEPS.len()
            );
            Ok(())
        }
    }
}

fn build_fw(c: &Ctx) -> Result<(), String> {
    ensure_thumb_target()?;
    build_qemu_fw(c)?;
    nucleo_build(c)?;
    println!("QEMU firmware: {}", c.firmware_elf().display());
    println!("QEMU on-target tests: {}", c.selftest_elf().display());
    println!("Nucleo-H743 firmware: {}", c.nucleo_elf().display());
    Ok(())
}

fn qemu(c: &Ctx, args: &[String]) -> Result<(), String> {
    let serial = match args {
        [] => "pty".to_string(),
        [flag, port] if flag == "--tcp" => {
            let port: u16 = port
                .parse()
                .map_err(|_| format!("--tcp needs a port number 1-65535, got `{port}`"))?;
            format!("tcp:127.0.0.1:{port},server=on,wait=off")
        }
        _ => return Err("usage: cargo xtask qemu [--tcp PORT]".into()),
    };
    ensure_thumb_target()?;
    ensure_qemu()?;
    build_qemu_fw(c)?;
    let elf = c.firmware_elf();
    let mut cmd = qemu_cmd(&elf, false);
    cmd.args(["-serial", &serial]);
    println!("$ {}", show(&cmd));
    if let Some(port) = serial
        .strip_prefix("tcp:127.0.0.1:")
        .and_then(|s| s.split(',').next())
    {
        println!(
            "UART0 (the protocol) on TCP 127.0.0.1:{port}: `lmhost info --port tcp:127.0.0.1:{port}`"
        );
    }
    println!("stop with Ctrl-C");
    // QEMU names the pty on stdout; pass its output through and point at it.
    let mut child = cmd
        .stdout(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start qemu-system-arm: {e}"))?;
    if let Some(out) = child.stdout.take() {
        use std::io::BufRead;
        for line in std::io::BufReader::new(out).lines().map_while(Result::ok) {
            println!("{line}");
            if let Some(rest) = line.strip_prefix("char device redirected to ") {
                let path = rest.split_whitespace().next().unwrap_or(rest);
                println!("UART0 (the protocol) on {path}: `lmhost info --port {path}`");
            }
        }
    }
    let status = child.wait().map_err(|e| format!("waiting for QEMU: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("QEMU exited ({status})"))
    }
}

fn size(c: &Ctx) -> Result<(), String> {
    let qemu_elf = c.firmware_elf();
    if !qemu_elf.exists() {
        build_qemu_fw(c)?;
    }
    let nucleo_elf = c.nucleo_elf();
    for (board, elf_path) in [("QEMU mps2-an500", qemu_elf), ("Nucleo-H743", nucleo_elf)] {
        if !elf_path.exists() {
            println!(
                "{board}: {} not built (run `cargo xtask build-fw`)",
                elf_path.display()
            );
            continue;
        }
        let bytes = std::fs::read(&elf_path)
            .map_err(|e| format!("cannot read {}: {e}", elf_path.display()))?;
        let report = elf::memory_map(&bytes).map_err(|e| format!("{}: {e}", elf_path.display()))?;
        println!("== {board}: {}", elf_path.display());
        print!("{report}");
    }
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let c = Ctx::new();
    let result = match args.first().map(String::as_str) {
        Some("ci") => ci(&c, &args[1..]),
        Some("build-fw") if args.len() == 1 => build_fw(&c),
        Some("qemu") => qemu(&c, &args[1..]),
        Some("size") if args.len() == 1 => size(&c),
        Some("python") if args.len() == 1 => step_python(&c),
        Some("gateware") if args.len() == 1 => step_gateware(&c),
        Some("bitstream") => bitstream(&c, &args[1..]),
        Some("ethercat") if args.len() == 1 => step_optional_backends(&c),
        _ => Err(
            "usage: cargo xtask <ci [--from STEP] | python | gateware | ethercat | bitstream [--first F] [--total T] | build-fw | qemu [--tcp PORT] | size>"
                .into(),
        ),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::FAILURE
        }
    }
}
