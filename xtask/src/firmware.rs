//! The firmware: thumb builds, the on-target tests under QEMU, the Nucleo
//! board and its ELF checks, `cargo xtask qemu`, `build-fw` and `size`.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use crate::ctx::{Ctx, NUCLEO_PKG, QEMU_PKG, THUMB};
use crate::elf;
use crate::proc::{Log, run, run_within, show};
use crate::setup;

/// QEMU machine: AN500, a Cortex-M7 with FPv5 as on the STM32H743; the
/// same map where the image lives as the AN386 (M4F) it replaced: ZBT
/// SSRAM1 at 0 and SSRAM2&3 at 0x2000_0000 (4 MiB each), CMSDK UART0 at
/// 0x4000_4000, TIMER0 at 0x4000_0000 on the 25 MHz APB clock.
pub const QEMU_MACHINE: &str = "mps2-an500";
/// Wall-clock limit for one QEMU on-target run (it normally takes seconds).
const QEMU_TIMEOUT: Duration = Duration::from_secs(600);

/// `cargo build --release --target thumbv7em-none-eabihf` plus `args`.
fn thumb_build(c: &Ctx, log: &Log, args: &[&str]) -> Result<(), String> {
    let mut all = vec!["build", "--release", "--target", THUMB];
    all.extend_from_slice(args);
    run(log, c.cargo(&all))
}

/// The no_std libraries (plain and with defmt), the QEMU board with its
/// on-target tests, and the Nucleo board with its checks: every thumb
/// build, each board in its own cargo invocation (see [`nucleo`]).
pub fn thumb(c: &Ctx, log: &Log) -> Result<(), String> {
    // The QEMU board builds lm-proto and lm-fw-core as they are (no
    // features); the Nucleo builds them with defmt: between them both
    // feature sets, each built once.
    qemu_fw(c, log)?;
    nucleo_checked(c, log)
}

fn qemu_fw(c: &Ctx, log: &Log) -> Result<(), String> {
    thumb_build(c, log, &["-p", QEMU_PKG, "--bins"])
}

/// Its own cargo invocation: built together with the QEMU board, the
/// Nucleo's `rt` feature (embassy-stm32 → stm32-metapac) would switch on
/// cortex-m-rt's `device` feature for the QEMU board too, and its defmt
/// features would reach the QEMU board's lm-fw-core (see firmware/core/STORE.md,
/// Memory maps).
fn nucleo(c: &Ctx, log: &Log) -> Result<(), String> {
    thumb_build(c, log, &["-p", NUCLEO_PKG])
}

/// Interrupts the Nucleo firmware must have handlers for (STM32H743
/// vector numbers, stm32-metapac): USART3's receive path, USB, the SPI
/// DMA streams, the timebase and the two executors.
const NUCLEO_IRQS: &[(u32, &str)] = &[
    (39, "USART3 (ST-LINK VCP, BufferedUart)"),
    (101, "OTG_FS (user USB)"),
    (11, "DMA1_STREAM0 (SPI1 TX)"),
    (12, "DMA1_STREAM1 (SPI1 RX)"),
    (28, "TIM2 (embassy-time, 1 MHz)"),
    (52, "UART4 (SPI task's executor)"),
    (53, "UART5 (USB task's executor)"),
];

/// The real board on embassy-stm32 (its clock plan is checked at compile
/// time, `firmware/nucleo-h743/logic/src/clocks.rs`), and what the ELF must
/// show: a handler for every interrupt it relies on (a missing one is how
/// the UART once stayed deaf), defmt's log table, RTT's control block in
/// the DTCM (coherent with the D-cache on); then its memory map.
fn nucleo_checked(c: &Ctx, log: &Log) -> Result<(), String> {
    nucleo(c, log)?;
    let elf_path = c.nucleo_elf();
    let bytes =
        std::fs::read(&elf_path).map_err(|e| format!("cannot read {}: {e}", elf_path.display()))?;
    let at = |e: String| format!("{}: {e}", elf_path.display());
    let unbound = elf::unbound_interrupts(&bytes, NUCLEO_IRQS).map_err(at)?;
    if !unbound.is_empty() {
        return Err(at(format!("no handler for {}", unbound.join(", "))));
    }
    if !elf::has_section(&bytes, ".defmt").map_err(at)? {
        return Err(at("no .defmt section: defmt logging is not linked".into()));
    }
    match elf::symbol_address(&bytes, "_SEGGER_RTT").map_err(at)? {
        Some(a) if (0x2000_0000..0x2002_0000).contains(&a) => {}
        Some(a) => return Err(at(format!("_SEGGER_RTT at {a:#010x}, not in the DTCM"))),
        None => return Err(at("no _SEGGER_RTT: defmt-rtt is not linked".into())),
    }
    log.line(format!(
        "Nucleo-H743: handlers for {} interrupts, defmt table, RTT block in the DTCM",
        NUCLEO_IRQS.len()
    ));
    let report = elf::memory_map(&bytes).map_err(at)?;
    log.line(format!("== Nucleo-H743: {}", elf_path.display()));
    log.line(report.trim_end());
    Ok(())
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

/// The on-target tests under QEMU (`-icount shift=0`).
pub fn qemu_selftest(c: &Ctx, log: &Log) -> Result<(), String> {
    let elf = c.selftest_elf();
    if !elf.exists() {
        return Err(format!(
            "{} is missing; run `cargo xtask build-fw`",
            elf.display()
        ));
    }
    // -serial null: the self-test talks only over semihosting.
    run_within(
        log,
        qemu_cmd(&elf, true).args(["-serial", "null"]),
        Some(QEMU_TIMEOUT),
    )
}

/// `cargo xtask build-fw`.
pub fn build_fw(c: &Ctx) -> Result<(), String> {
    let log = &Log::Terminal;
    setup::ensure_thumb_target(log)?;
    qemu_fw(c, log)?;
    nucleo(c, log)?;
    println!("QEMU firmware: {}", c.firmware_elf().display());
    println!("QEMU on-target tests: {}", c.selftest_elf().display());
    println!("Nucleo-H743 firmware: {}", c.nucleo_elf().display());
    Ok(())
}

/// `cargo xtask qemu [--tcp PORT]`: the firmware under QEMU, UART0 on a pty
/// or a TCP port on 127.0.0.1.
pub fn qemu(c: &Ctx, args: &[String]) -> Result<(), String> {
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
    let log = &Log::Terminal;
    setup::ensure_thumb_target(log)?;
    setup::ensure_apt(log, &setup::APT[..1])?;
    qemu_fw(c, log)?;
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

/// `cargo xtask size`: the memory map of each built firmware ELF.
pub fn size(c: &Ctx) -> Result<(), String> {
    let qemu_elf = c.firmware_elf();
    if !qemu_elf.exists() {
        qemu_fw(c, &Log::Terminal)?;
    }
    let nucleo_elf = c.nucleo_elf();
    let qemu_board = format!("QEMU {QEMU_MACHINE}");
    for (board, elf_path) in [(qemu_board.as_str(), qemu_elf), ("Nucleo-H743", nucleo_elf)] {
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
