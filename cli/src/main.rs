//! The `lmhost` command line. The only place that maps errors to exit codes.
//!
//! - exit 0: success, or stdout was closed early (`lmhost plan --json |
//!   head -c 10`): output to a closed pipe ends quietly, as ripgrep does;
//! - exit 2: bad input (the error chain contains [`InputError`]);
//! - exit 1: the operation failed (a failed write to stdout included:
//!   `lmhost plan > /dev/full`).
//!
//! Errors are printed as one line: `error: outer: cause: root cause`. All
//! output goes through [`lmhost::out`]; a lost stderr changes nothing but
//! what can be said.
#![deny(clippy::print_stdout, clippy::print_stderr)]

use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches, Parser};
use lmhost::{InputError, errln, out::StdoutClosed};

mod cmd;

use cmd::Command;

/// Plan, upload and stream lateral-modulation ultrasound haptics.
#[derive(Debug, Parser)]
#[command(name = "lmhost", version, about, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// Set by the panic hook when a panic was a `print!` in a dependency
/// hitting a closed pipe (lmhost's own output never panics).
static STDOUT_CLOSED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// A dependency's `println!` panics when stdout is a closed pipe (Rust
/// ignores SIGPIPE). That one panic is silenced here and `main` turns it
/// into a quiet exit 0 after unwinding, so `Drop` still runs (an AUTD3
/// link is left silent). Any other panic keeps the default report.
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

/// Exit code for `result`, after printing its error as one line.
fn finish(result: anyhow::Result<()>) -> ExitCode {
    let result = result.and_then(|()| lmhost::out::flush_stdout());
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) if err.chain().any(|c| c.is::<StdoutClosed>()) => ExitCode::SUCCESS,
        Err(err) => {
            let line = lmhost::error::one_line(&err);
            errln!("error: {line}");
            if err.chain().any(|c| c.is::<InputError>()) {
                ExitCode::from(2)
            } else {
                ExitCode::from(1)
            }
        }
    }
}

/// The environment variable a refused value came from, when it did: clap
/// names the flag (`--timeout-ms`), which a user who set
/// `LMHOST_TIMEOUT_MS` in a shell profile never typed.
fn value_from_env(e: &clap::Error) -> Option<String> {
    use clap::error::{ContextKind, ContextValue};
    let Some(ContextValue::String(arg)) = e.get(ContextKind::InvalidArg) else {
        return None;
    };
    let flag = arg.split_whitespace().next()?;
    let long = flag.strip_prefix("--")?;
    let typed = std::env::args_os().skip(1).any(|a| {
        a.to_str()
            .is_some_and(|a| a == flag || a.starts_with(&format!("{flag}=")))
    });
    fn env_of(c: &clap::Command, long: &str) -> Option<String> {
        c.get_arguments()
            .find(|a| a.get_long() == Some(long))
            .and_then(|a| a.get_env())
            .map(|v| v.to_string_lossy().into_owned())
            .or_else(|| c.get_subcommands().find_map(|s| env_of(s, long)))
    }
    let var = env_of(&Cli::command(), long)?;
    (!typed && std::env::var_os(&var).is_some()).then_some(var)
}

/// When no argument is other than UTF-8, the refusal of a flag's
/// environment variable that is (clap said only "invalid UTF-8 was
/// detected in one or more arguments", naming neither).
fn env_not_utf8() -> Option<InputError> {
    if std::env::args_os().all(|a| a.to_str().is_some()) {
        fn find(c: &clap::Command) -> Option<InputError> {
            c.get_arguments()
                .find_map(|a| {
                    let var = a.get_env()?;
                    let raw = std::env::var_os(var)?;
                    let flag = a.get_long()?;
                    raw.to_str().is_none().then(|| {
                        lmhost::error::env_not_utf8(
                            &var.to_string_lossy(),
                            &raw,
                            &format!("the --{flag} value"),
                        )
                    })
                })
                .or_else(|| c.get_subcommands().find_map(find))
        }
        return find(&Cli::command());
    }
    None
}

/// `text` (clap's rendering of `e`) with each value the user gave that
/// holds a line end written with `\n`, so that taking its first paragraph
/// does not cut a value (`--radius $'3\n\nx'`) short; and one longer than
/// an error repeats cut around its length wherever it is echoed (clap's
/// `invalid value '…'` and the parser's own words): a value of 20 000
/// characters with spaces in it was repeated whole, twice, as no cut of
/// long words catches it.
fn values_on_one_line(e: &clap::Error, mut text: String) -> String {
    use clap::error::{ContextKind, ContextValue};
    for kind in [
        ContextKind::InvalidValue,
        ContextKind::InvalidArg,
        ContextKind::InvalidSubcommand,
    ] {
        if let Some(ContextValue::String(v)) = e.get(kind) {
            let one_line = v.replace('\n', "\\n").replace('\r', "\\r");
            if one_line != *v {
                text = text.replace(v.as_str(), &one_line);
            }
            if one_line.chars().count() > lmhost::error::MAX_ECHO_CHARS {
                text = text.replace(&one_line, &lmhost::error::short_echo(&one_line));
            }
        }
    }
    text
}

/// `args` with a flag's value spelled `-inf`, `-infinity` or `-nan` (any
/// case) joined to its flag (`--radius=-inf`): clap takes a negative
/// number for a value, but these words for a cluster of short flags, so
/// `--radius -inf` said "unexpected argument '-i' found" instead of the
/// flag's own refusal of an infinite radius.
fn negative_words_as_values(
    args: impl IntoIterator<Item = std::ffi::OsString>,
) -> Vec<std::ffi::OsString> {
    let mut out: Vec<std::ffi::OsString> = Vec::new();
    // After a bare `--` every word is a positional value, left as it is.
    let mut positional = false;
    for a in args {
        let word = a.to_str().map(str::to_ascii_lowercase);
        let negative_word =
            !positional && matches!(word.as_deref(), Some("-inf" | "-infinity" | "-nan"));
        positional |= a == "--";
        let flag = out
            .last()
            .and_then(|f| f.to_str())
            .filter(|f| f.starts_with("--") && f.len() > 2 && !f.contains('='))
            .map(str::to_owned);
        match (negative_word, flag) {
            (true, Some(f)) => {
                out.pop();
                let mut joined = std::ffi::OsString::from(format!("{f}="));
                joined.push(&a);
                out.push(joined);
            }
            _ => out.push(a),
        }
    }
    out
}

fn main() -> ExitCode {
    quiet_on_closed_stdout();
    // Plain styles: clap's rendered errors then carry no escape codes of
    // clap's own, and one in a value the user gave stays to be shown
    // escaped (`ansi()` below); `to_string()` would drop it silently and
    // show `--radius 3\e[2J` as '3'.
    let command = Cli::command().styles(clap::builder::Styles::plain());
    let cli = match cmd::exact_floats(cmd::negative_numbers_are_values(command))
        .try_get_matches_from(negative_words_as_values(std::env::args_os()))
        .and_then(|m| Cli::from_arg_matches(&m))
    {
        Ok(cli) => cli,
        // --help, --version: printed to stdout through the one path.
        Err(e) if !e.use_stderr() => {
            let text = e.render().to_string();
            return finish(lmhost::out!("{text}"));
        }
        Err(e) if e.kind() == clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            errln!("{}", e.render().to_string().trim_end());
            return ExitCode::from(2);
        }
        Err(e) => {
            if e.kind() == clap::error::ErrorKind::InvalidUtf8
                && let Some(refused) = env_not_utf8()
            {
                return finish(Err(refused.into()));
            }
            // Bad flags are bad input: one line, exit 2.
            // The first paragraph, its indented lines (e.g. the missing
            // arguments' names) joined onto the first.
            let text = values_on_one_line(&e, e.render().ansi().to_string());
            let para: Vec<&str> = text
                .lines()
                .skip_while(|l| l.trim().is_empty())
                .take_while(|l| !l.trim().is_empty())
                .map(str::trim)
                .collect();
            let line = para.join(" ");
            let line = line.strip_prefix("error: ").unwrap_or(&line);
            match value_from_env(&e) {
                Some(var) => errln!("error: {line} (the value of ${var}; see --help)"),
                None => errln!("error: {line} (see --help)"),
            }
            return ExitCode::from(2);
        }
    };
    if let Err(e) = lmhost::stop::install() {
        return finish(Err(e));
    }
    let result = match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| cli.command.run()))
    {
        Ok(r) => r,
        Err(_) if STDOUT_CLOSED.load(std::sync::atomic::Ordering::SeqCst) => {
            return ExitCode::SUCCESS;
        }
        Err(panic) => std::panic::resume_unwind(panic),
    };
    finish(result)
}
