//! `cargo xtask ci`: every step, side by side where they do not depend on
//! each other.
//!
//! The steps form a graph ([`STEPS`]: each names the steps it needs). A step
//! starts as soon as those have passed, on a thread of its own, its output
//! going to `target/ci/<id>.log`, printed whole when it ends. Two cores
//! cannot build two things faster than one, and every `cargo` shares one
//! target dir (cargo's own lock runs them one at a time), so what overlaps
//! is a build with work that waits: tests on pipes, ptys and child
//! processes, QEMU, pip, apt. Steps off the critical path run at a lower
//! CPU priority (`nice` 10, inherited by everything they start), so the
//! tests they overlap keep their timing. A failed step stops what needs
//! it; the others run on, and the summary names every failure.

use std::collections::BTreeMap;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use crate::ctx::Ctx;
use crate::proc::Log;
use crate::{ethercat, firmware, gateware, host, lint, long, python, setup};

/// How a CI run was asked for.
#[derive(Debug, Clone, Default)]
pub struct Opts {
    /// `--full`: the scheduled run: long runs in release at full size, the
    /// opt-in backends (EtherCAT links, `flash`) built, the gateware at
    /// full width under Verilator, the extension built by maturin.
    pub full: bool,
    /// `--only A,B`: just these steps (what they need is taken as done).
    pub only: Option<Vec<String>>,
}

/// One CI step.
struct Step {
    /// Short name for `--only` and the `after` lists.
    id: &'static str,
    /// What it does, for the summary.
    name: &'static str,
    /// Steps that must pass first.
    after: &'static [&'static str],
    /// Off the critical path: runs at a lower CPU priority.
    background: bool,
    run: fn(&Ctx, &Log, &Opts) -> Result<(), String>,
}

/// The CI. Add a step by adding an entry (and a function in its module).
const STEPS: &[Step] = &[
    Step {
        id: "toolchain",
        name: "setup: thumb target, clippy and rustfmt",
        after: &[],
        background: false,
        run: |_, log, _| {
            setup::ensure_thumb_target(log)?;
            setup::ensure_components(log)?;
            match crate::ctx::clippy_driver() {
                Some(d) => {
                    log.line(format!("clippy-driver: {}", d.display()));
                    Ok(())
                }
                None => {
                    Err("no clippy-driver in this toolchain (`rustup component add clippy`)".into())
                }
            }
        },
    },
    Step {
        id: "apt",
        name: "setup: qemu-system-arm, verilator, yosys, libpcap-dev, chromium, chromium-driver (apt, as root)",
        after: &[],
        background: true,
        run: |_, log, _| setup::ensure_apt(log, setup::APT),
    },
    Step {
        id: "venvs",
        name: "setup: Python venvs under target/ (maturin, numpy, pytest; amaranth)",
        after: &[],
        background: true,
        run: |c, log, _| {
            setup::venv(c, log, "py-venv", python::PACKAGES)?;
            gateware::venv(c, log).map(|_| ())
        },
    },
    Step {
        id: "lint",
        name: "lint: cargo fmt --check, module cycles and wing order in every crate, clap only in the CLI",
        after: &["toolchain"],
        background: false,
        run: |c, log, _| lint::source(c, log),
    },
    Step {
        id: "build",
        name: "cargo build: every host test, bench and example and the lmhost binary, linted by clippy as they compile",
        after: &["toolchain"],
        background: false,
        run: |c, log, _| host::build(c, log),
    },
    Step {
        id: "firmware",
        name: "thumb build: lm-proto + lm-fw-core (plain, defmt), QEMU firmware + on-target tests, Nucleo-H743 (embassy-stm32, defmt): handlers, size report; linted as they compile",
        after: &["build"],
        background: true,
        run: |c, log, _| firmware::thumb(c, log),
    },
    Step {
        id: "test",
        name: "cargo test: the host crates' and end-to-end test executables side by side (the browser test required), then doc tests",
        // apt: the browser test needs Chromium installed before it runs.
        after: &["build", "apt"],
        background: false,
        run: |c, log, _| host::test(c, log, host::Which::Host),
    },
    Step {
        id: "qemu",
        name: "on-target tests under QEMU (-icount shift=0), then lmhost against the firmware under QEMU (e2e)",
        after: &["firmware", "apt", "build"],
        background: false,
        run: |c, log, _| {
            firmware::qemu_selftest(c, log)?;
            host::test(c, log, host::Which::Firmware)
        },
    },
    Step {
        id: "python",
        name: "python: the lmhost package (the host build's extension; --full: maturin develop) in its venv + pytest",
        after: &["build", "venvs"],
        background: true,
        run: |c, log, o| python::step(c, log, o.full),
    },
    Step {
        id: "gateware",
        name: "gateware: driver simulation on the core's LM-M SPI frames (Amaranth); --full: then full width: plan → core → SPI → Verilator, 16 boards",
        after: &["build", "venvs", "apt"],
        background: true,
        run: |c, log, o| {
            let mode = gateware::Mode {
                host_built: true,
                full_width: o.full,
            };
            gateware::step(c, log, mode)
        },
    },
    Step {
        id: "doc",
        name: "lint: rustdoc -D warnings (lmhost, lm-proto, lm-fw-core)",
        after: &["build", "firmware"],
        background: true,
        run: |c, log, _| lint::doc(c, log),
    },
    Step {
        id: "ethercat",
        name: "--full: cargo build: lmhost with both EtherCAT links (as root) and flash (probe-rs), the missing-adapter smoke test, lmhost doctor",
        after: &["build", "firmware", "apt"],
        background: true,
        run: |c, log, o| {
            if o.full {
                ethercat::step(c, log, true)
            } else {
                // A feature set of its own: most of the workspace compiled
                // again, for code that changes rarely.
                log.line("ethercat: the opt-in backends are built by `cargo xtask ci --full` and `cargo xtask ethercat`");
                Ok(())
            }
        },
    },
    Step {
        id: "long",
        name: "long runs: proto fuzz, core robustness, planner accuracy, faulty uploads, 90 Hz streaming (a tenth; --full: release, whole)",
        after: &["build"],
        background: true,
        run: |c, log, o| long::step(c, log, o.full),
    },
];

/// What became of a step.
#[derive(Debug, Clone, PartialEq)]
enum State {
    Waiting,
    Running(Instant),
    Passed(Duration, Duration),
    Failed(Duration, Duration, String),
    /// A step it needs failed.
    Skipped,
}

pub fn ci(c: &Ctx, args: &[String]) -> Result<(), String> {
    let opts = parse(args)?;
    std::fs::create_dir_all(c.ci_dir())
        .map_err(|e| format!("cannot create {}: {e}", c.ci_dir().display()))?;
    let start = Instant::now();
    let mut state: BTreeMap<&str, State> = STEPS.iter().map(|s| (s.id, State::Waiting)).collect();
    if let Some(only) = &opts.only {
        for s in STEPS.iter().filter(|s| !only.iter().any(|o| o == s.id)) {
            state.insert(s.id, State::Passed(Duration::ZERO, Duration::ZERO));
        }
    }
    let (tx, rx) = mpsc::channel::<(&'static str, Result<(), String>)>();
    std::thread::scope(|scope| {
        loop {
            // Start every step whose needs have passed; skip those whose
            // needs failed.
            for s in STEPS {
                if state[s.id] != State::Waiting {
                    continue;
                }
                let needs: Vec<&State> = s.after.iter().map(|a| &state[a]).collect();
                if needs
                    .iter()
                    .any(|n| matches!(n, State::Failed(..) | State::Skipped))
                {
                    state.insert(s.id, State::Skipped);
                    println!("==> skipped: {} (a step it needs failed)", s.id);
                    continue;
                }
                if !needs.iter().all(|n| matches!(n, State::Passed(..))) {
                    continue;
                }
                let log_path = c.ci_dir().join(format!("{}.log", s.id));
                let tx = tx.clone();
                let opts = &opts;
                state.insert(s.id, State::Running(Instant::now()));
                println!(
                    "==> [{:>6.1} s] start {}: {}",
                    start.elapsed().as_secs_f64(),
                    s.id,
                    s.name
                );
                scope.spawn(move || {
                    if s.background {
                        lower_priority();
                    }
                    let r = Log::file(&log_path).and_then(|log| (s.run)(c, &log, opts));
                    let _ = tx.send((s.id, r));
                });
            }
            if !state.values().any(|s| matches!(s, State::Running(_))) {
                break;
            }
            let Ok((id, r)) = rx.recv() else { break };
            let State::Running(t0) = state[id] else {
                continue;
            };
            let (began, took) = (t0 - start, t0.elapsed());
            let log_path = c.ci_dir().join(format!("{id}.log"));
            println!(
                "\n==> [{:>6.1} s] {} {id} ({:.1} s); its output ({}):",
                start.elapsed().as_secs_f64(),
                if r.is_ok() { "passed" } else { "FAILED" },
                took.as_secs_f64(),
                log_path.display()
            );
            match std::fs::read_to_string(&log_path) {
                Ok(text) => print!("{text}"),
                Err(e) => println!("(cannot read the log: {e})"),
            }
            if let Err(e) = &r {
                println!("==> {id} failed: {e}");
            }
            state.insert(
                id,
                match r {
                    Ok(()) => State::Passed(began, took),
                    Err(e) => State::Failed(began, took, e),
                },
            );
        }
    });
    summary(&state, start.elapsed(), opts.only.is_some())
}

fn parse(args: &[String]) -> Result<Opts, String> {
    let mut o = Opts::default();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--full" => o.full = true,
            "--only" => {
                let list = it.next().ok_or("--only needs a list of step ids")?;
                let ids: Vec<String> = list.split(',').map(str::to_string).collect();
                if let Some(bad) = ids
                    .iter()
                    .find(|i| !STEPS.iter().any(|s| s.id == i.as_str()))
                {
                    return Err(format!("--only: no step `{bad}` (steps: {})", step_ids()));
                }
                o.only = Some(ids);
            }
            _ => return Err(usage()),
        }
    }
    Ok(o)
}

pub fn usage() -> String {
    format!(
        "usage: cargo xtask ci [--full] [--only STEP[,STEP...]] (steps: {})",
        step_ids()
    )
}

/// Every step's id, comma-separated.
fn step_ids() -> String {
    STEPS.iter().map(|s| s.id).collect::<Vec<_>>().join(", ")
}

fn summary(state: &BTreeMap<&str, State>, total: Duration, only: bool) -> Result<(), String> {
    println!("\n==> timing (start, duration; steps overlap)");
    let mut failed = Vec::new();
    let mut ran = 0;
    for s in STEPS {
        // A step that ran: its start and duration.
        let timed = |word: &str, b: &Duration, d: &Duration| {
            format!(
                "  {word:<4} {:>6.1} s {:>6.1} s  {}",
                b.as_secs_f64(),
                d.as_secs_f64(),
                s.name
            )
        };
        let line = match &state[s.id] {
            State::Passed(_, d) if *d == Duration::ZERO && only => continue,
            State::Passed(b, d) => timed("ok", b, d),
            State::Failed(b, d, _) => {
                failed.push(s.id);
                timed("FAIL", b, d)
            }
            State::Skipped => {
                failed.push(s.id);
                format!("  skip                   {}", s.name)
            }
            State::Waiting | State::Running(_) => format!("  ?                      {}", s.name),
        };
        ran += 1;
        println!("{line}");
    }
    println!(
        "         {:>6.1} s           total (wall clock)",
        total.as_secs_f64()
    );
    if failed.is_empty() {
        println!("ci: {ran} of {} steps run, all passed", STEPS.len());
        Ok(())
    } else {
        Err(format!("ci: failed or skipped: {}", failed.join(", ")))
    }
}

/// Lowers this thread's CPU priority (Linux: per thread; children inherit
/// it), so a background step yields the cores to the critical path.
fn lower_priority() {
    unsafe extern "C" {
        fn nice(inc: i32) -> i32;
    }
    // SAFETY: nice(2) takes an integer and changes only the calling
    // thread's scheduling priority; its result needs no check (a failure
    // leaves the priority as it was).
    unsafe {
        nice(10);
    }
}
