//! Shared by the link end-to-end tests: find (and build) the real `lmhost`
//! binary, run it, and run `lmhost sim` for the length of a test.
#![allow(dead_code)]

use std::io::{BufRead, BufReader, Write as _};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::OnceLock;

/// Path of the `lmhost` binary: `LMHOST_BIN` when set (the CI builds it
/// once and runs test executables side by side, which must not wait on
/// cargo's lock), else built once per test process in this test's target
/// dir and profile (`CARGO_BIN_EXE_*` only exists within a package, and
/// lmhost lives in another).
pub fn lmhost() -> PathBuf {
    static BIN: OnceLock<PathBuf> = OnceLock::new();
    BIN.get_or_init(|| {
        if let Some(bin) = std::env::var_os("LMHOST_BIN") {
            return PathBuf::from(bin);
        }
        // target/<profile>/deps/<test>-<hash>
        let exe = std::env::current_exe().expect("test executable path");
        let profile_dir = exe
            .parent()
            .and_then(|d| d.parent())
            .expect("target/<profile>");
        let target_dir = profile_dir.parent().expect("target dir");
        let release = profile_dir.file_name().is_some_and(|n| n == "release");
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let mut cmd = Command::new(cargo);
        cmd.args([
            "build",
            "--quiet",
            "-p",
            "lmhost-cli",
            "--bin",
            "lmhost",
            "--target-dir",
        ])
        .arg(target_dir);
        if release {
            cmd.arg("--release");
        }
        let status = cmd.status().expect("running cargo build -p lmhost-cli");
        assert!(status.success(), "cargo build -p lmhost-cli failed");
        profile_dir.join("lmhost")
    })
    .clone()
}

/// A fresh, empty scratch folder `name` (unique to this test process),
/// removed when the guard drops; kept, and its path said on stderr, when
/// the test failed, for a look.
pub fn scratch_dir(name: &str) -> Scratch {
    let d = std::env::temp_dir().join(format!("lmhost-e2e-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    Scratch(d)
}

/// See [`scratch_dir`]; derefs to its path.
pub struct Scratch(PathBuf);

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if std::thread::panicking() {
            eprintln!(
                "scratch folder kept for the failed test: {}",
                self.0.display()
            );
        } else {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// Run `lmhost args…` to completion (no `LMHOST_PORT` from outside).
pub fn run(args: &[&str]) -> Output {
    Command::new(lmhost())
        .args(args)
        .env_remove("LMHOST_PORT")
        .output()
        .expect("running lmhost")
}

/// stdout as text, asserting exit 0 (with stderr in the message).
pub fn ok(args: &[&str]) -> String {
    let out = run(args);
    assert!(
        out.status.success(),
        "lmhost {args:?} failed ({:?}): {}",
        out.status.code(),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("utf-8 stdout")
}

/// The stderr of a run that must have ended with exit `code` and said
/// exactly one line of UTF-8 there; that line (with its line break).
#[track_caller]
pub fn one_line_error(out: &Output, code: i32) -> String {
    said_one_line(out, code, "")
}

/// Runs `lmhost args…`, which must end with exit `code` and exactly one
/// line on stderr; that line.
#[track_caller]
pub fn fails(args: &[&str], code: i32) -> String {
    said_one_line(&run(args), code, &format!("{args:?}: "))
}

/// [`one_line_error`], its failures' messages starting with `what`.
#[track_caller]
fn said_one_line(out: &Output, code: i32, what: &str) -> String {
    let err = String::from_utf8(out.stderr.clone())
        .unwrap_or_else(|e| panic!("{what}stderr is not UTF-8: {e}"));
    assert_eq!(out.status.code(), Some(code), "{what}{err}");
    assert_eq!(err.lines().count(), 1, "{what}{err}");
    err
}

/// Sends `child` the signal named `sig` (`TERM`, `INT`, `HUP`, …) with
/// kill(1), which must succeed.
#[track_caller]
pub fn send_signal(child: &Child, sig: &str) {
    let st = Command::new("kill")
        .args([&format!("-{sig}"), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(st.success(), "kill -{sig}");
}

/// The line a UDP finger source ends with, after its `lmhost: ` in a
/// study: what it counted on local `port`, none lost in the kernel.
pub fn udp_counts(port: u16, datagrams: u32, bad: u32) -> String {
    format!(
        "UDP 127.0.0.1:{port}: {datagrams} datagrams, {bad} skipped as bad, 0 lost in the kernel's receive buffer"
    )
}

/// Parse stdout of a `--json` command.
pub fn json(args: &[&str]) -> serde_json::Value {
    let text = ok(args);
    serde_json::from_str(text.trim()).unwrap_or_else(|e| panic!("{args:?}: bad JSON {e}: {text}"))
}

/// The JSON file a run wrote at `path`, parsed.
pub fn json_file(path: impl AsRef<Path>) -> serde_json::Value {
    let path = path.as_ref();
    let text =
        std::fs::read_to_string(path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: bad JSON {e}", path.display()))
}

/// The JSON stdout of a run that must have succeeded.
pub fn success_json(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
}

/// `lmhost stream --port <port> <args…> --json`, its report parsed.
pub fn stream_json(port: &str, args: &[&str]) -> serde_json::Value {
    let mut all = vec!["stream", "--port", port];
    all.extend_from_slice(args);
    all.push("--json");
    json(&all)
}

/// Asserts the fields `keys` of the JSON report `v` are `want` (an array,
/// in the same order); the failure names them and shows the whole report.
#[track_caller]
pub fn assert_fields(v: &serde_json::Value, keys: &[&str], want: serde_json::Value) {
    let got: Vec<serde_json::Value> = keys.iter().map(|k| v[*k].clone()).collect();
    assert_eq!(serde_json::Value::Array(got), want, "{keys:?} of {v}");
}

/// The latency summary `key` of the JSON object `at` in the report `v`:
/// `[p50, p99, max]`, asserted to be numbers in that order (a summary
/// with its figures swapped or missing fails here, naming `key`).
#[track_caller]
pub fn spread(v: &serde_json::Value, at: &serde_json::Value, key: &str) -> [f64; 3] {
    let f = |k: &str| {
        at[key][k]
            .as_f64()
            .unwrap_or_else(|| panic!("{key}.{k} is not a number: {v}"))
    };
    let s = [f("p50"), f("p99"), f("max")];
    assert!(
        s[0] <= s[1] && s[1] <= s[2],
        "{key} {s:?} out of order: {v}"
    );
    s
}

/// `lmhost CMD --port autd3:emulator ARGS… --json`, its report parsed.
pub fn emulator_json(cmd: &str, args: &[&str]) -> serde_json::Value {
    let mut all = vec![cmd, "--port", "autd3:emulator"];
    all.extend_from_slice(args);
    all.push("--json");
    json(&all)
}

/// `lmhost upload --port <port> <extra…> --json`, its report parsed. What
/// it plays lasts only while lmhost holds it: unless `extra` says
/// `--no-play` or `--hold`, it holds for [`BRIEF_HOLD`] and stops (its
/// second line, the status after the hold, is left out).
pub fn upload_json(port: &str, extra: &[&str]) -> serde_json::Value {
    let mut args = vec!["upload", "--port", port];
    args.extend_from_slice(extra);
    if !extra.iter().any(|a| *a == "--no-play" || *a == "--hold") {
        args.extend_from_slice(&["--hold", BRIEF_HOLD]);
    }
    args.push("--json");
    let text = ok(&args);
    let first = text.lines().next().unwrap_or("");
    serde_json::from_str(first).unwrap_or_else(|e| panic!("{args:?}: bad JSON {e}: {text}"))
}

/// Seconds a test's `upload` or `play` holds what it plays before it
/// stops (`--hold`).
pub const BRIEF_HOLD: &str = "0.05";

/// Runs `lmhost args…` (a command that plays and holds the device), takes
/// its first stdout line, then kills it with SIGKILL, as a crash would:
/// what it played plays on for its host lease (the tests give `--lease
/// 60`; every later request renews it), then stops by itself. How the
/// tests look at a playing device from other lmhost processes.
pub fn detached(args: &[&str]) -> String {
    let h = Holder::start(args);
    let line = h.line();
    h.kill();
    line
}

/// A running lmhost that holds the device (`upload`, `play`, `stream`):
/// its stdout lines as they come; killed on drop.
pub struct Holder {
    child: Child,
    lines: std::sync::mpsc::Receiver<String>,
}

impl Holder {
    /// Starts `lmhost args…`.
    pub fn start(args: &[&str]) -> Holder {
        let mut child = Command::new(lmhost())
            .args(args)
            .env_remove("LMHOST_PORT")
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("starting lmhost");
        let out = child.stdout.take().expect("stdout");
        let (tx, lines) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Holder { child, lines }
    }

    /// Its next stdout line (within 60 s).
    pub fn line(&self) -> String {
        self.lines
            .recv_timeout(std::time::Duration::from_secs(60))
            .expect("a line from the holding lmhost")
    }

    /// Kills it with SIGKILL, as a crash would: nothing of it runs on.
    pub fn kill(mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// Ends it with SIGTERM (Ctrl-C's twin) and waits for its exit code.
    pub fn terminate(mut self) -> Option<i32> {
        let _ = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status();
        self.child.wait().ok().and_then(|s| s.code())
    }
}

impl Drop for Holder {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Another lmhost holding `port`: a synthetic stream for 10 minutes, its
/// output discarded.
pub fn spawn_port_holder(port: &str) -> Child {
    Command::new(lmhost())
        .args(["stream", "--port", port, "--synthetic", "--seconds", "600"])
        .env_remove("LMHOST_PORT")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawning the port holder")
}

/// Starts a [`spawn_port_holder`] on `port`, waits until it holds the port
/// (a status there is refused as in use, exit 1), then kills it with
/// SIGKILL, as a crash would: no destructor of it runs.
pub fn kill_a_holder_of(port: &str) {
    let mut holder = spawn_port_holder(port);
    // A guard against hanging, not a timing goal.
    let give_up = std::time::Instant::now() + std::time::Duration::from_secs(20);
    loop {
        let o = run(&["status", "--port", port]);
        let err = String::from_utf8_lossy(&o.stderr);
        if !o.status.success() && err.contains("in use by another process") {
            assert_eq!(o.status.code(), Some(1), "{err}");
            break;
        }
        assert!(
            std::time::Instant::now() < give_up,
            "the holder never held {port}: {err}"
        );
        // A status of ours held the port just as the holder opened it (the
        // holder was refused, as it should be): start it again.
        if holder.try_wait().unwrap().is_some() {
            holder = spawn_port_holder(port);
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    holder.kill().expect("SIGKILL to the holder");
    holder.wait().unwrap();
}

/// Run `lmhost stream --port <port> <extra…>` with `input` on stdin, to
/// completion (stdout and stderr captured).
pub fn stream_stdin(port: &str, extra: &[&str], input: &str) -> Output {
    let mut args = vec!["stream", "--port", port];
    args.extend_from_slice(extra);
    run_stdin(&args, input.as_bytes())
}

/// `lmhost args` with `input` on its stdin (then closed); its output.
pub fn run_stdin(args: &[&str], input: &[u8]) -> Output {
    let mut child = Command::new(lmhost())
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(input).unwrap();
    child.wait_with_output().unwrap()
}

/// A running `lmhost sim`, killed on drop.
pub struct Sim {
    child: Child,
    /// The pty path it printed.
    pub port: String,
}

impl Sim {
    /// Start `lmhost sim extra…` and wait for its pty path.
    pub fn start(extra: &[&str]) -> Sim {
        let mut child = Command::new(lmhost())
            .arg("sim")
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("starting lmhost sim");
        let mut line = String::new();
        BufReader::new(child.stdout.take().expect("sim stdout"))
            .read_line(&mut line)
            .expect("reading the sim's pty path");
        let port = line.trim().to_owned();
        assert!(port.starts_with("/dev/"), "sim printed {line:?}");
        Sim { child, port }
    }

    /// Start `lmhost sim` with the default upload (planned with
    /// `upload_extra…`) played briefly into slot 0, for what plays it again.
    pub fn uploaded(upload_extra: &[&str]) -> Sim {
        let sim = Sim::start(&[]);
        let mut args = vec!["upload", "--port", sim.port.as_str()];
        args.extend_from_slice(upload_extra);
        args.extend_from_slice(&["--hold", BRIEF_HOLD]);
        ok(&args);
        sim
    }
}

impl Drop for Sim {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Reads what `conn` (its read timeout set) has: `Ok(None)` when nothing
/// came within the timeout, `Ok(Some(0))` at its end (a fake device's
/// loop polls its firmware between reads).
pub fn read_within(
    conn: &mut impl std::io::Read,
    buf: &mut [u8],
) -> std::io::Result<Option<usize>> {
    match conn.read(buf) {
        Ok(n) => Ok(Some(n)),
        Err(e)
            if matches!(
                e.kind(),
                std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
            ) =>
        {
            Ok(None)
        }
        Err(e) => Err(e),
    }
}

/// Asserts `closed` is a session's `closed` event whose `finger` says
/// `samples` read and `[out_of_order, time_jumps, out_of_range, jumps]`
/// dropped: the classes of the `lmhost: finger:` end line.
#[track_caller]
pub fn assert_closed_counts(closed: &serde_json::Value, samples: u64, dropped: [u64; 4]) {
    assert_eq!(closed["event"], "closed", "{closed}");
    let [out_of_order, time_jumps, out_of_range, jumps] = dropped;
    let want = serde_json::json!({
        "samples": samples, "dropped": dropped.iter().sum::<u64>(),
        "out_of_order": out_of_order, "time_jumps": time_jumps,
        "out_of_range": out_of_range, "jumps": jumps,
    });
    assert_eq!(closed["finger"], want, "{closed}");
}
