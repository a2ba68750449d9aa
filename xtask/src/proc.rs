//! Running commands: echoed, into a step's log, with deadlines.

use std::borrow::BorrowMut;
use std::fs::File;
use std::io::Write as _;
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Where a step's output goes: the terminal (a task run on its own) or its
/// log file (a CI step running beside others, printed whole when it ends).
pub enum Log {
    /// Straight to this process's stdout and stderr.
    Terminal,
    /// Appended to a file.
    File(Mutex<File>),
}

impl Log {
    /// A log file at `path`, created empty.
    pub fn file(path: &Path) -> Result<Log, String> {
        File::create(path)
            .map(|f| Log::File(Mutex::new(f)))
            .map_err(|e| format!("cannot create {}: {e}", path.display()))
    }

    /// One line of the step's own.
    pub fn line(&self, s: impl AsRef<str>) {
        match self {
            Log::Terminal => println!("{}", s.as_ref()),
            Log::File(f) => {
                let mut f = f.lock().unwrap_or_else(|e| e.into_inner());
                let _ = writeln!(f, "{}", s.as_ref());
            }
        }
    }

    /// Stdout and stderr for a child that writes into this log.
    fn stdio(&self) -> Result<(Stdio, Stdio), String> {
        match self {
            Log::Terminal => Ok((Stdio::inherit(), Stdio::inherit())),
            Log::File(f) => {
                let f = f.lock().unwrap_or_else(|e| e.into_inner());
                let out = f.try_clone().map_err(|e| format!("log: {e}"))?;
                let err = f.try_clone().map_err(|e| format!("log: {e}"))?;
                Ok((out.into(), err.into()))
            }
        }
    }
}

/// Runs `cmd` with its output in `log`; fails on a non-zero exit.
pub fn run(log: &Log, mut cmd: impl BorrowMut<Command>) -> Result<(), String> {
    run_within(log, cmd.borrow_mut(), None)
}

/// [`run`] with its standard output in `out` (the log keeps its errors).
pub fn run_to(log: &Log, cmd: &mut Command, out: std::fs::File) -> Result<(), String> {
    spawn_wait(log, cmd, Some(out), None)
}

/// [`run`] with a wall-clock limit: killed and failed past it.
pub fn run_within(log: &Log, cmd: &mut Command, limit: Option<Duration>) -> Result<(), String> {
    spawn_wait(log, cmd, None, limit)
}

fn spawn_wait(
    log: &Log,
    cmd: &mut Command,
    stdout: Option<std::fs::File>,
    limit: Option<Duration>,
) -> Result<(), String> {
    log.line(format!("$ {}", show(cmd)));
    let (log_out, err) = log.stdio()?;
    let out: Stdio = match stdout {
        Some(f) => f.into(),
        None => log_out,
    };
    let mut child = cmd
        .stdout(out)
        .stderr(err)
        .spawn()
        .map_err(|e| format!("cannot start `{}`: {e}", show(cmd)))?;
    let start = Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(status)) if status.success() => return Ok(()),
            Ok(Some(status)) => return Err(format!("`{}` failed ({status})", show(cmd))),
            Ok(None) if limit.is_some_and(|l| start.elapsed() > l) => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!(
                    "`{}` did not finish within {:?}",
                    show(cmd),
                    limit.unwrap_or_default()
                ));
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => return Err(format!("waiting for `{}`: {e}", show(cmd))),
        }
    }
}

/// Runs `cmd` with a deadline, capturing its output; `None` when it had
/// to be killed.
pub fn output_within(
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

/// The command as typed (program's file name, then its arguments).
pub fn show(cmd: &Command) -> String {
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

/// Whether `name` is on `PATH`.
pub fn has_program(name: &str) -> bool {
    std::env::var_os("PATH")
        .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join(name).is_file()))
}

/// Whether this process runs as root (installs need it).
pub fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}
