//! Hostile inputs: the real `lmhost` binary against `lmhost sim`, one table
//! of cases, each the kind of thing a tracker, a script or a typo feeds it.
//!
//! Every case asserts the exit code, that an error is exactly one line of
//! stderr, that nothing `panicked`, and that the run ends within
//! [`TIME_LIMIT`] (one with a client beside it: [`TIME_LIMIT_WITH_CLIENT`]),
//! killed and failed otherwise. To add a case, append a
//! row `CLASS "args …" .expectation(..)…;` to a case table (one file per
//! round: `cases_r1.rs`, `cases_r3.rs`, … `cases_r14.rs`); `{port}` is
//! the shared simulated device, `{fake:NAME}` a device that lies (round
//! 9), `{dir}` a scratch directory with the fixtures of [`fixtures`],
//! `{scenes}` the repository's `scenes/`. A case may run a client of the
//! command beside it (`.during(f)`).
//!
//! Run with `--nocapture` to see the summary line
//! `hostile inputs: N cases, K classes, 0 panics, 0 hangs`. With
//! `LMHOST_HOSTILE_CLASS=r9-1` only the classes whose name starts so run
//! (the coverage checks of the whole table are then skipped).

mod classes;
#[path = "../link_support/mod.rs"]
mod link_support;

use std::collections::BTreeSet;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use classes::*;
use link_support::{Sim, kill_a_holder_of, lmhost, ok, spawn_port_holder};

/// Longest any case may run before it counts as a hang.
const TIME_LIMIT: Duration = Duration::from_secs(20);

/// The limit for a case with a client beside it: the client waits for the
/// command to come up (a study plans its library first, slow on a loaded
/// machine) and has deadlines of its own, so the hang check only backs
/// those up.
const TIME_LIMIT_WITH_CLIENT: Duration = Duration::from_secs(60);

/// What a run produced, for custom checks.
struct Run {
    code: Option<i32>,
    stdout: String,
    stderr: String,
    /// What the `during` client found.
    during: Result<(), String>,
}

/// Where the fixtures and the devices are.
struct Ctx {
    port: String,
    /// A device of its own for the play-state cases (`{dev}`), run in order.
    dev: String,
    /// A device with a 10-minute centroid timeout for the work-volume
    /// cases (`{wv}`), so a status right after a stream is not stale.
    wv: String,
    /// A device whose slots hold 10 steps (`{small}`).
    small: String,
    dir: PathBuf,
    scenes: PathBuf,
    /// A small full-able tmpfs (`{full}`), when the tests run as root.
    full: Option<PathBuf>,
    /// A device another lmhost holds open for the whole suite (`{busy}`).
    busy: String,
    /// A device of its own for the session cases (`{sess}`), whose
    /// library they fill.
    sess: String,
    /// A device whose holder was killed with SIGKILL (`{stale}`).
    stale: String,
    /// Free local TCP ports for the session's `--tcp` (`{tcp}`) and the
    /// view (`{viewport}`), found at the start (fixed numbers collide with
    /// whatever else runs on the machine).
    tcp: u16,
    view_port: u16,
}

type Check = fn(&Ctx, &Run) -> Result<(), String>;

/// Runs beside the command (a client of it), given its process id.
type During = fn(&Ctx, u32) -> Result<(), String>;

/// One hostile input and what must happen.
#[derive(Clone)]
struct Case {
    class: &'static str,
    args: Vec<String>,
    stdin: Vec<u8>,
    /// Keep stdin open (a live tracker) until the case ends.
    hold_stdin: bool,
    code: i32,
    stderr_has: Vec<String>,
    stdout_has: Vec<String>,
    /// Close our end of stdout at once (a reader that went away).
    close_stdout: bool,
    /// Datagrams sent to 127.0.0.1:port after the command started.
    udp: Option<(u16, Vec<Vec<u8>>)>,
    /// Send this signal after this many ms.
    signal: Option<(&'static str, u64)>,
    /// A command run after this one, whose stdout must contain the text.
    then: Option<(Vec<String>, String)>,
    check: Option<Check>,
    /// Send stdout / stderr to this file instead of a pipe (`/dev/full`).
    stdout_to: Option<String>,
    stderr_to: Option<String>,
    /// Environment variables set for the run (values expanded).
    env: Vec<(String, String)>,
    /// Runs while the command does; its error fails the case.
    during: Option<During>,
}

fn words(args: &str) -> Vec<String> {
    args.split_whitespace().map(str::to_owned).collect()
}

/// A case in `class` running `lmhost args` (split on whitespace); by
/// default it must exit 2.
fn case(class: &'static str, args: &str) -> Case {
    Case {
        class,
        args: words(args),
        stdin: Vec::new(),
        hold_stdin: false,
        code: 2,
        stderr_has: Vec::new(),
        stdout_has: Vec::new(),
        close_stdout: false,
        udp: None,
        signal: None,
        then: None,
        check: None,
        stdout_to: None,
        stderr_to: None,
        env: Vec::new(),
        during: None,
    }
}

impl Case {
    /// How long this case may run before it counts as a hang.
    fn limit(&self) -> Duration {
        if self.during.is_some() {
            TIME_LIMIT_WITH_CLIENT
        } else {
            TIME_LIMIT
        }
    }
    fn code(mut self, c: i32) -> Self {
        self.code = c;
        self
    }
    fn ok(self) -> Self {
        self.code(0)
    }
    fn err(mut self, s: &str) -> Self {
        self.stderr_has.push(s.to_owned());
        self
    }
    fn out(mut self, s: &str) -> Self {
        self.stdout_has.push(s.to_owned());
        self
    }
    fn stdin(mut self, b: impl AsRef<[u8]>) -> Self {
        self.stdin = b.as_ref().to_vec();
        self
    }
    fn hold_stdin(mut self) -> Self {
        self.hold_stdin = true;
        self
    }
    /// More arguments, split on whitespace.
    fn args(mut self, more: &str) -> Self {
        self.args.extend(words(more));
        self
    }
    /// `track` over the depth fixture `npy` with intrinsics `cam`.
    fn depth(self, npy: &str, cam: &str) -> Self {
        self.args(&format!(
            "--depth {{dir}}/{npy} --intrinsics {{dir}}/{cam} --scene {{scenes}}/paper.toml --fast"
        ))
    }
    fn closed_stdout(mut self) -> Self {
        self.close_stdout = true;
        self.code = 0;
        self
    }
    fn udp(mut self, port: u16, datagrams: Vec<Vec<u8>>) -> Self {
        self.udp = Some((port, datagrams));
        self
    }
    fn signal(mut self, sig: &'static str, after_ms: u64) -> Self {
        self.signal = Some((sig, after_ms));
        self
    }
    fn then(mut self, args: &str, want: &str) -> Self {
        self.then = Some((words(args), want.to_owned()));
        self
    }
    fn check(mut self, f: Check) -> Self {
        self.check = Some(f);
        self
    }
    fn during(mut self, f: During) -> Self {
        self.during = Some(f);
        self
    }
    fn env(mut self, k: &str, v: &str) -> Self {
        self.env.push((k.to_owned(), v.to_owned()));
        self
    }
    /// Stdout to `/dev/full`: a failed write is one line and exit 1.
    fn full_stdout(mut self) -> Self {
        self.stdout_to = Some("/dev/full".to_owned());
        self.code(1)
            .err("cannot write to standard output: no space left on device")
    }
    /// Stderr to a file (`{dir}` expanded) that a check reads: for a run
    /// that prints progress before it is stopped.
    fn stderr_file(mut self, path: &str) -> Self {
        self.stderr_to = Some(path.to_owned());
        self
    }
    /// Stderr to `/dev/full`: the exit code alone tells, and no panic.
    fn full_stderr(mut self) -> Self {
        self.stderr_to = Some("/dev/full".to_owned());
        self
    }
}

/// The case table, one case a row: `CLASS "args" .expectation(..)…;`
/// stands for `case(CLASS, "args").expectation(..)…`.
macro_rules! table {
    ($($class:ident $args:literal $(.$m:ident($($a:expr),*))*;)*) => {
        vec![$(case($class, $args)$(.$m($($a),*))*),*]
    };
}

fn csv(lines: &[&str]) -> String {
    lines.iter().map(|l| format!("{l}\n")).collect()
}

fn garbage(n: usize) -> Vec<Vec<u8>> {
    (0..n)
        .map(|i| format!("garbage {i}").into_bytes())
        .collect()
}

fn good_udp(n: usize) -> Vec<Vec<u8>> {
    (0..n)
        .map(|i| format!("{},0,0,200,1", i as f64 / 90.0).into_bytes())
        .collect()
}

mod cases_r1;
mod cases_r10;
mod cases_r11;
mod cases_r12;
mod cases_r13;
mod cases_r13b;
mod cases_r14;
mod cases_r14b;
mod cases_r15a;
mod cases_r15b;
mod cases_r16a;
mod cases_r16w;
mod cases_r3;
mod cases_r4_device;
mod cases_r4_files;
mod cases_r4_paper;
mod cases_r4_session;
mod cases_r4_study;
mod cases_r4_view;
mod cases_r5_exp3;
mod cases_r6_sweep;
mod cases_r7_files;
mod cases_r7_wire;
mod cases_r8;
mod cases_r9;
mod checks;
mod fixtures;

use cases_r1::cases;
use cases_r3::round3_cases;
use cases_r4_device::round4_device_cases;
use cases_r4_files::{round4_files_cases, round4_files_fixtures};
use cases_r4_paper::{paper_cases, paper_fixtures};
use cases_r4_study::{study_cases, study_fixtures};
use cases_r5_exp3::{exp3_cases, exp3_fixtures};
use cases_r6_sweep::{long_value_cases, sweep_cases, sweep_fixtures};
use cases_r7_files::{files_cases, files_fixtures};
use cases_r7_wire::{wire_cases, wire_fixtures};
use cases_r8::{round8_cases, round8_fixtures};
use cases_r9::round9_cases;
use cases_r10::{round10_cases, round10_fixtures};
use cases_r11::{round11_cases, round11_fixtures};
use cases_r12::round12_cases;
use cases_r13::{round13_cases, round13_fixtures};
use cases_r13b::{round13b_cases, round13b_fixtures};
use cases_r14::{round14_cases, round14_fixtures};
use cases_r14b::{round14b_cases, round14b_fixtures};
use cases_r15a::{round15a_cases, round15a_fixtures};
use cases_r15b::{round15b_cases, round15b_fixtures};
use cases_r16a::{round16a_cases, round16a_fixtures};
use cases_r16w::round16w_cases;
use checks::*;
use fixtures::*;

fn expand(s: &str, ctx: &Ctx) -> String {
    cases_r9::expand_fakes(s)
        .replace("{port}", &ctx.port)
        .replace("{dev}", &ctx.dev)
        .replace("{wv}", &ctx.wv)
        .replace("{small}", &ctx.small)
        .replace("{busy}", &ctx.busy)
        .replace("{sess}", &ctx.sess)
        .replace("{stale}", &ctx.stale)
        .replace("{tcp}", &ctx.tcp.to_string())
        .replace("{viewport}", &ctx.view_port.to_string())
        .replace("{dir}", &ctx.dir.display().to_string())
        .replace("{scenes}", &ctx.scenes.display().to_string())
        .replace(
            "{full}",
            &ctx.full
                .as_ref()
                .map_or(String::new(), |p| p.display().to_string()),
        )
}

/// Where stdout or stderr of a case goes: a pipe, or the file named
/// (made when missing).
fn sink(to: &Option<String>, ctx: &Ctx) -> Stdio {
    match to {
        None => Stdio::piped(),
        Some(p) => Stdio::from(
            std::fs::OpenOptions::new()
                .write(true)
                .create(true)
                .truncate(!p.starts_with("/dev/"))
                .open(expand(p, ctx))
                .expect("opening the case's output file"),
        ),
    }
}

/// Runs `lmhost args`, feeding stdin and datagrams and sending a signal as
/// the case asks; kills it after its [`Case::limit`] (`None` = a hang).
fn execute(c: &Case, ctx: &Ctx) -> Option<Run> {
    let args: Vec<String> = c.args.iter().map(|a| expand(a, ctx)).collect();
    let mut child = Command::new(lmhost())
        .args(&args)
        .env_remove("LMHOST_PORT")
        .env("RUST_BACKTRACE", "0")
        .envs(c.env.iter().map(|(k, v)| (k.clone(), expand(v, ctx))))
        .stdin(Stdio::piped())
        .stdout(sink(&c.stdout_to, ctx))
        .stderr(sink(&c.stderr_to, ctx))
        .spawn()
        .expect("spawning lmhost");
    let mut stdin = child.stdin.take();
    let input = c.stdin.clone();
    let hold = c.hold_stdin;
    let feeder = std::thread::spawn(move || {
        if let Some(mut s) = stdin.take() {
            let _ = s.write_all(&input);
            if hold {
                std::thread::sleep(TIME_LIMIT);
            }
        }
    });
    let out_pipe = child.stdout.take();
    let close = c.close_stdout;
    let reader = std::thread::spawn(move || {
        let mut s = Vec::new();
        if let Some(mut p) = out_pipe
            && !close
        {
            let _ = p.read_to_end(&mut s);
        }
        String::from_utf8_lossy(&s).into_owned()
    });
    let err_pipe = child.stderr.take();
    let err_reader = std::thread::spawn(move || {
        let mut s = Vec::new();
        if let Some(mut p) = err_pipe {
            let _ = p.read_to_end(&mut s);
        }
        String::from_utf8_lossy(&s).into_owned()
    });
    if let Some((port, datagrams)) = &c.udp {
        std::thread::sleep(Duration::from_millis(400));
        let sock = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
        for d in datagrams {
            let _ = sock.send_to(d, ("127.0.0.1", *port));
            std::thread::sleep(Duration::from_micros(300));
        }
    }
    if let Some((sig, after_ms)) = c.signal {
        std::thread::sleep(Duration::from_millis(after_ms));
        let _ = Command::new("kill")
            .arg(format!("-{sig}"))
            .arg(child.id().to_string())
            .status();
    }
    let start = Instant::now();
    let pid = child.id();
    let (status, during) = std::thread::scope(|s| {
        let during = c.during.map(|f| s.spawn(move || f(ctx, pid)));
        let mut failed = None;
        let status = loop {
            if let Some(st) = child.try_wait().unwrap() {
                break Some(st);
            }
            // A client that gave up will not end the command: end it, and
            // say what the client found rather than only that it hung.
            if failed.is_none() && during.as_ref().is_some_and(|h| h.is_finished()) {
                failed = Some(start.elapsed());
            }
            let client_gave_up =
                failed.is_some_and(|t| start.elapsed() > t + Duration::from_secs(5));
            if start.elapsed() > c.limit() || client_gave_up {
                let _ = child.kill();
                let st = child.wait().ok();
                break if client_gave_up { st } else { None };
            }
            std::thread::sleep(Duration::from_millis(10));
        };
        let during = during.map_or(Ok(()), |h| {
            h.join()
                .unwrap_or_else(|_| Err("the during client panicked".into()))
        });
        (status, during)
    });
    drop(feeder);
    let stdout = reader.join().unwrap();
    let stderr = err_reader.join().unwrap();
    status.map(|st| Run {
        code: st.code(),
        stdout,
        stderr,
        during,
    })
}

/// What is wrong with a run of `c`, if anything.
fn judge(c: &Case, ctx: &Ctx, r: &Run) -> Vec<String> {
    let mut bad = Vec::new();
    if r.stderr.contains("panicked") || r.code == Some(101) {
        bad.push("panicked".to_owned());
    }
    if r.code != Some(c.code) {
        bad.push(format!("exit {:?}, want {}", r.code, c.code));
    }
    if c.code != 0 && c.stderr_to.is_none() && r.stderr.lines().count() != 1 {
        bad.push(format!(
            "stderr is {} lines, want 1",
            r.stderr.lines().count()
        ));
    }
    if c.close_stdout && !r.stderr.is_empty() {
        bad.push("closed stdout must end quietly".to_owned());
    }
    for s in &c.stderr_has {
        if !r.stderr.contains(&expand(s, ctx)) {
            bad.push(format!("stderr lacks `{s}`"));
        }
    }
    for s in &c.stdout_has {
        if !r.stdout.contains(s.as_str()) {
            bad.push(format!("stdout lacks `{s}`"));
        }
    }
    if let Some(f) = c.check
        && let Err(e) = f(ctx, r)
    {
        bad.push(e);
    }
    if let Err(e) = &r.during {
        bad.push(format!("during: {e}"));
    }
    if let Some((args, want)) = &c.then {
        let args: Vec<String> = args.iter().map(|a| expand(a, ctx)).collect();
        let out = Command::new(lmhost()).args(&args).output().unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        if !text.contains(want.as_str()) {
            bad.push(format!("then {args:?}: stdout lacks `{want}`: {text}"));
        }
    }
    bad
}

#[test]
fn hostile_inputs_end_in_one_line_and_the_right_exit_code() {
    let sim = Sim::start(&[]);
    let dev = Sim::start(&[]);
    let wv = Sim::start(&["--centroid-timeout-ms", "600000"]);
    let small = Sim::start(&["--slot-steps", "10"]);
    let busy = Sim::start(&[]);
    let sess = Sim::start(&[]);
    let mut holder = spawn_port_holder(&busy.port);
    // A device whose holder dies without a word: killed once it holds it.
    let stale = Sim::start(&[]);
    kill_a_holder_of(&stale.port);
    std::thread::sleep(Duration::from_millis(500));
    let dir =
        Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("hostile-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let every_fixture: [fn(&Path); 19] = [
        fixtures,
        study_fixtures,
        paper_fixtures,
        exp3_fixtures,
        sweep_fixtures,
        files_fixtures,
        wire_fixtures,
        round8_fixtures,
        round4_files_fixtures,
        cases_r4_session::fixtures,
        round10_fixtures,
        round11_fixtures,
        round13_fixtures,
        round13b_fixtures,
        round14_fixtures,
        round14b_fixtures,
        round15b_fixtures,
        round15a_fixtures,
        round16a_fixtures,
    ];
    for write in every_fixture {
        write(&dir);
    }
    let full = FullDisk::mount(&dir);
    let ctx = Ctx {
        port: sim.port.clone(),
        dev: dev.port.clone(),
        wv: wv.port.clone(),
        small: small.port.clone(),
        dir: dir.clone(),
        scenes: Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes"),
        full: full.as_ref().ok().map(|f| f.0.clone()),
        busy: busy.port.clone(),
        stale: stale.port.clone(),
        tcp: free_port(),
        view_port: free_port(),
        sess: sess.port.clone(),
    };
    ok(&["upload", "--port", &ctx.port, "--hold", "0.05"]);

    let tables: [fn() -> Vec<Case>; 25] = [
        cases,
        study_cases,
        paper_cases,
        exp3_cases,
        sweep_cases,
        long_value_cases,
        files_cases,
        round4_files_cases,
        // Last: the session cases preload the shared device's library.
        cases_r4_session::cases,
        round4_device_cases,
        cases_r4_view::view_cases,
        wire_cases,
        round8_cases,
        round9_cases,
        round10_cases,
        round11_cases,
        round12_cases,
        round13_cases,
        round13b_cases,
        round14_cases,
        round14b_cases,
        round15b_cases,
        round15a_cases,
        round16w_cases,
        round16a_cases,
    ];
    let mut all: Vec<Case> = tables.iter().flat_map(|table| table()).collect();
    let only = std::env::var("LMHOST_HOSTILE_CLASS").ok();
    if let Some(prefix) = &only {
        all.retain(|c| c.class.starts_with(prefix.as_str()));
    }
    let classes: BTreeSet<&str> = all.iter().map(|c| c.class).collect();
    if let Err(why) = &full {
        let before = all.len();
        all.retain(|c| !c.args.iter().any(|a| a.contains("{full}")));
        println!("skipped {} disk-full cases: {why}", before - all.len());
    }
    let (mut panics, mut hangs) = (0, 0);
    let mut failures = Vec::new();
    for c in &all {
        let label = format!("[{}] lmhost {}", c.class, c.args.join(" "));
        match execute(c, &ctx) {
            None => {
                hangs += 1;
                failures.push(format!("{label}: no exit within {:?}", c.limit()));
            }
            Some(r) => {
                if r.stderr.contains("panicked") || r.code == Some(101) {
                    panics += 1;
                }
                let bad = judge(c, &ctx, &r);
                if !bad.is_empty() {
                    failures.push(format!(
                        "{label}: {}\n    stderr: {}",
                        bad.join("; "),
                        r.stderr.trim()
                    ));
                }
            }
        }
    }
    println!(
        "hostile inputs: {} cases, {} classes, {panics} panics, {hangs} hangs",
        all.len(),
        classes.len()
    );
    for class in &classes {
        let n = all.iter().filter(|c| c.class == *class).count();
        println!("  {class}: {n} cases");
    }
    let _ = holder.kill();
    let _ = holder.wait();
    // Unmounted first: removing a folder stops at the mount point inside
    // it, which left each run's fixtures (100+ MB) behind.
    drop(full);
    let _ = std::fs::remove_dir_all(&dir);
    if only.is_none() {
        assert!(all.len() >= 100, "only {} cases", all.len());
        let want: BTreeSet<&str> = CLASSES.into_iter().collect();
        assert_eq!(classes, want, "classes covered");
    } else {
        assert!(!all.is_empty(), "no class starts with {only:?}");
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        all.len(),
        failures.join("\n")
    );
}
