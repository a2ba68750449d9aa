//! The `lmhost` command line. The only place that maps errors to exit codes.

use std::process::ExitCode;

use clap::Parser;
use lmhost::{InputError, cmd::Command};

/// Plan, upload and stream lateral-modulation ultrasound haptics.
#[derive(Debug, Parser)]
#[command(name = "lmhost", version, about, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command.run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err}");
            for cause in err.chain().skip(1) {
                eprintln!("  caused by: {cause}");
            }
            if err.chain().any(|c| c.is::<InputError>()) {
                ExitCode::from(2)
            } else {
                ExitCode::from(1)
            }
        }
    }
}
