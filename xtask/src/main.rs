//! `cargo xtask <task>`: project tasks.
//!
//! - `ci [--full] [--only STEP,...]`: THE test command. Installs what is
//!   missing (the thumb target, clippy and rustfmt; as root the Debian
//!   packages), then runs every step of [`ci::STEPS`](ci), side by side
//!   where they do not depend on each other, printing each step's output
//!   when it ends and a timing summary. `--full` is the scheduled run: the
//!   long randomised runs in release at their whole size and the `flash`
//!   backend built too.
//! - `python`, `gateware`, `ethercat`: one CI step alone.
//! - `bitstream [--channels N] [--first F] [--total T] | --all [--total T]`:
//!   the driver for the iCE40-HX8K Breakout Board (Yosys, nextpnr-ice40,
//!   icestorm from Debian); not part of `ci`.
//! - `build-fw`: release build of the QEMU firmware and the Nucleo board.
//! - `qemu [--tcp PORT]`: run the firmware under QEMU, UART0 on a pty
//!   (default) or on a TCP port on 127.0.0.1.
//! - `size`: memory map of the built firmware ELF.

mod bitstream;
mod ci;
mod ctx;
mod elf;
mod ethercat;
mod firmware;
mod gateware;
mod host;
mod lint;
mod long;
mod proc;
mod python;
mod setup;

use std::process::ExitCode;

use ctx::Ctx;
use proc::Log;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut c = Ctx::new();
    let log = &Log::Terminal;
    let result = match args.first().map(String::as_str) {
        Some("ci") => {
            // Every build of a CI run compiles the workspace through clippy.
            c.lint = true;
            ci::ci(&c, &args[1..])
        }
        Some("build-fw") if args.len() == 1 => firmware::build_fw(&c),
        Some("qemu") => firmware::qemu(&c, &args[1..]),
        Some("size") if args.len() == 1 => firmware::size(&c),
        Some("python") if args.len() == 1 => python::step(&c, log, true),
        Some("gateware") if args.len() == 1 => gateware::step(
            &c,
            log,
            gateware::Mode {
                host_built: false,
                full_width: true,
            },
        ),
        Some("bitstream") => bitstream::bitstream(&c, &args[1..]),
        Some("ethercat") if args.len() == 1 => ethercat::step(&c, log, true),
        _ => Err(format!(
            "usage: cargo xtask <ci | python | gateware | ethercat | bitstream [--channels N] [--first F] [--total T] | bitstream --all [--total T] | build-fw | qemu [--tcp PORT] | size>\n{}",
            ci::usage()
        )),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::FAILURE
        }
    }
}
