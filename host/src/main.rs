//! The `lmhost` command line. The only place that maps errors to exit codes.
//!
//! - exit 0: success, or stdout was closed early (`lmhost plan --json |
//!   head -c 10`): output to a closed pipe ends quietly, as ripgrep does;
//! - exit 2: bad input (the error chain contains [`InputError`]);
//! - exit 1: the operation failed.
//!
//! Errors are printed as one line: `error: outer: cause: root cause`.

use std::process::ExitCode;

use clap::Parser;
use lmhost::{InputError, cmd::Command, error::StdoutClosed};

/// Plan, upload and stream lateral-modulation ultrasound haptics.
#[derive(Debug, Parser)]
#[command(name = "lmhost", version, about, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// Whether the error is stdout closed by its reader.
fn is_broken_pipe(err: &anyhow::Error) -> bool {
    err.chain().any(|c| c.is::<StdoutClosed>())
}

/// Set by the panic hook when a panic was `println!` hitting a closed pipe.
static STDOUT_CLOSED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// `println!` panics when stdout is a closed pipe (Rust ignores SIGPIPE).
/// Every command prints with it, so that one panic is silenced here, once,
/// and `main` turns it into a quiet exit 0 after unwinding, so `Drop`
/// still runs (an AUTD3 link is left silent). Any other panic keeps the
/// default report.
fn quiet_on_closed_stdout() {
    let default = std::panic::take_hook();
    let epipe = std::io::Error::from(std::io::ErrorKind::BrokenPipe).to_string();
    let epipe_os = std::io::Error::from_raw_os_error(libc::EPIPE).to_string();
    std::panic::set_hook(Box::new(move |info| {
        let msg = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if msg.starts_with("failed printing to stdout")
            && (msg.contains(&epipe) || msg.contains(&epipe_os))
        {
            STDOUT_CLOSED.store(true, std::sync::atomic::Ordering::SeqCst);
            return;
        }
        default(info);
    }));
}

fn main() -> ExitCode {
    quiet_on_closed_stdout();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => e.exit(),
        Err(e) if e.kind() == clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            e.exit()
        }
        Err(e) => {
            // Bad flags are bad input: one line, exit 2.
            // The first paragraph, its indented lines (e.g. the missing
            // arguments' names) joined onto the first.
            let text = e.render().to_string();
            let para: Vec<&str> = text
                .lines()
                .skip_while(|l| l.trim().is_empty())
                .take_while(|l| !l.trim().is_empty())
                .map(str::trim)
                .collect();
            let line = para.join(" ");
            let line = line.strip_prefix("error: ").unwrap_or(&line);
            eprintln!("error: {line} (see --help)");
            return ExitCode::from(2);
        }
    };
    let result = match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| cli.command.run()))
    {
        Ok(r) => r,
        Err(_) if STDOUT_CLOSED.load(std::sync::atomic::Ordering::SeqCst) => {
            return ExitCode::SUCCESS;
        }
        Err(panic) => std::panic::resume_unwind(panic),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) if is_broken_pipe(&err) => ExitCode::SUCCESS,
        Err(err) => {
            // One line: the context chain joined with ": ".
            let line = format!("{err:#}").replace('\n', " ");
            eprintln!("error: {line}");
            if err.chain().any(|c| c.is::<InputError>()) {
                ExitCode::from(2)
            } else {
                ExitCode::from(1)
            }
        }
    }
}
