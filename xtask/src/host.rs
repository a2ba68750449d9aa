//! The host crates: one build of every test and the binary (linted as it
//! compiles), then the test binaries run side by side.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crate::ctx::Ctx;
use crate::proc::{Log, run, run_to};

/// One test executable cargo built.
#[derive(Debug, Clone)]
struct TestBin {
    /// `package/target` for the summary.
    name: String,
    /// The executable.
    exe: PathBuf,
    /// Its package's directory: cargo runs tests there.
    dir: PathBuf,
    /// Its package's name (`CARGO_PKG_NAME` at run time).
    package: String,
}

/// Test binaries that take longest, started first so they do not end the
/// run alone (names as in the summary; the rest keep cargo's order).
const SLOW_FIRST: &[&str] = &[
    "lm-e2e/qemu",
    "lm-e2e/qemu_device",
    "lm-e2e/hostile",
    "lm-e2e/docs_commands",
    "lm-e2e/session_cli",
    "lm-e2e/study",
    "lm-e2e/browser",
    "lm-e2e/autd3_cli",
    "lm-e2e/track_cli",
    "lmhost/lmhost",
];

/// The test executables that talk to the firmware under QEMU: they run in
/// the `qemu` step, once the thumb build is done, so the host tests need
/// not wait for it.
pub const NEEDS_FIRMWARE: &[&str] = &["lm-e2e/qemu", "lm-e2e/qemu_device", "lm-e2e/upload_qemu"];

/// Which of the listed test executables a step runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Which {
    /// Every one but [`NEEDS_FIRMWARE`], then the doc tests.
    Host,
    /// Only [`NEEDS_FIRMWARE`].
    Firmware,
}

/// How many test binaries run at once: most of their time is spent
/// waiting on devices, pipes and child processes, not on a core.
const JOBS: usize = 4;

/// `cargo test --no-run --all-targets` for the default members: every
/// test, bench and example, linted as it compiles, in one cargo call, so
/// every artifact shares one feature set (a second call with other
/// packages selected would unify other features and compile lmhost
/// again). The same call leaves the `lmhost` binary (the CLI's own
/// integration test needs it) and the Python extension (the e2e crate
/// depends on the binding); the binary is copied where the tests find it
/// (`LMHOST_BIN`), and the list of test executables kept for [`test`].
pub fn build(c: &Ctx, log: &Log) -> Result<(), String> {
    let list = c.ci_dir().join("tests.json");
    let out = std::fs::File::create(&list)
        .map_err(|e| format!("cannot create {}: {e}", list.display()))?;
    run_to(
        log,
        &mut c.cargo(&[
            "test",
            "--no-run",
            "--all-targets",
            "--message-format=json-render-diagnostics",
        ]),
        out,
    )?;
    // The binary must be this build's (a file left by another build would
    // test other code): cargo's messages name what it built or found fresh.
    if !list_names(&list, &c.lmhost())? {
        return Err(format!(
            "the test build did not produce {}",
            c.lmhost().display()
        ));
    }
    log.line(format!(
        "python extension: {}",
        python_extension(c)?.display()
    ));
    let bin = c.lmhost_for_tests();
    // Through a new file and a rename: a running test may still execute
    // the old binary (writing over it is "text file busy").
    let tmp = bin.with_extension("new");
    std::fs::copy(c.lmhost(), &tmp)
        .and_then(|_| std::fs::rename(&tmp, &bin))
        .map_err(|e| format!("cannot copy the lmhost binary to {}: {e}", bin.display()))?;
    let bins = test_bins(&list)?;
    log.line(format!("{} test executables", bins.len()));
    Ok(())
}

/// Whether cargo's messages name `path` among the artifacts it built or
/// found fresh in this build.
fn list_names(list: &Path, path: &Path) -> Result<bool, String> {
    let text = std::fs::read_to_string(list)
        .map_err(|e| format!("cannot read {}: {e}", list.display()))?;
    let want = path.to_string_lossy();
    Ok(text.lines().any(|l| l.contains(want.as_ref())))
}

/// The Python extension (`lmhost._lmhost`, a cdylib) the host build left:
/// built as the e2e crate's dependency, it stays in `deps/`, so its path
/// comes from cargo's messages.
pub fn python_extension(c: &Ctx) -> Result<PathBuf, String> {
    let list = c.ci_dir().join("tests.json");
    let text = std::fs::read_to_string(&list)
        .map_err(|e| format!("cannot read {}: {e}", list.display()))?;
    text.lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|m| m["reason"] == "compiler-artifact" && m["target"]["name"] == "_lmhost")
        .flat_map(|m| {
            m["filenames"]
                .as_array()
                .map(|f| {
                    f.iter()
                        .filter_map(|v| v.as_str().map(PathBuf::from))
                        .collect()
                })
                .unwrap_or_else(Vec::new)
        })
        .find(|p| p.extension().is_some_and(|e| e == "so"))
        .ok_or_else(|| {
            format!(
                "{} names no Python extension (lib_lmhost.so)",
                list.display()
            )
        })
}

/// A test executable of the host build, set up as `cargo test` runs it
/// (its package's directory and variables, the binary under test); for
/// steps that run one on its own with arguments of their own.
pub fn test_command(c: &Ctx, name: &str) -> Result<Command, String> {
    let b = test_bins(&c.ci_dir().join("tests.json"))?
        .into_iter()
        .find(|b| b.name == name)
        .ok_or_else(|| format!("no test executable {name} was built"))?;
    let mut cmd = Command::new(&b.exe);
    cmd.current_dir(&b.dir)
        .env("CARGO_MANIFEST_DIR", &b.dir)
        .env("CARGO_PKG_NAME", &b.package)
        .env("LMHOST_BIN", c.lmhost_for_tests())
        .env("CARGO_TARGET_DIR", &c.target_dir)
        .stdin(Stdio::null());
    Ok(cmd)
}

/// The test executables in cargo's JSON messages (benches are built for
/// the lints, not run: criterion times them with `cargo bench`).
fn test_bins(list: &Path) -> Result<Vec<TestBin>, String> {
    let text = std::fs::read_to_string(list)
        .map_err(|e| format!("cannot read {}: {e}", list.display()))?;
    let mut v = Vec::new();
    for line in text.lines() {
        let Ok(m) = serde_json::from_str::<serde_json::Value>(line) else {
            continue;
        };
        if m["reason"] != "compiler-artifact" || m["profile"]["test"] != true {
            continue;
        }
        let Some(exe) = m["executable"].as_str() else {
            continue;
        };
        let kinds: Vec<&str> = m["target"]["kind"]
            .as_array()
            .map(|k| k.iter().filter_map(|s| s.as_str()).collect())
            .unwrap_or_default();
        if kinds.contains(&"bench") {
            continue;
        }
        let manifest = PathBuf::from(m["manifest_path"].as_str().unwrap_or_default());
        let package = m["package_id"]
            .as_str()
            .and_then(package_name)
            .unwrap_or_default();
        let target = m["target"]["name"].as_str().unwrap_or_default();
        v.push(TestBin {
            name: format!("{package}/{target}"),
            exe: PathBuf::from(exe),
            dir: manifest.parent().map(Path::to_path_buf).unwrap_or_default(),
            package,
        });
    }
    if v.is_empty() {
        return Err(format!("{} lists no test executable", list.display()));
    }
    Ok(v)
}

/// The package name in a cargo package id (`path+file:///…/tests#lm-e2e@0.1.0`
/// or `registry+…#name@version`).
fn package_name(id: &str) -> Option<String> {
    let (path, after) = id.rsplit_once('#')?;
    match after.split_once('@') {
        Some((name, _)) => Some(name.to_string()),
        // No explicit name: the package is named as its directory.
        None => path.rsplit('/').next().map(str::to_string),
    }
}

/// A folder `lmhost-ci-<pid>-<tag>` in the system's temporary folder for one
/// run's tests, removed on drop; folders of runs whose process is gone
/// (killed before they could clean up) are removed when the next starts.
struct RunTmp(PathBuf);

impl RunTmp {
    fn new(tag: &str) -> Result<Self, String> {
        let base = std::env::temp_dir();
        if let Ok(entries) = std::fs::read_dir(&base) {
            for e in entries.flatten() {
                let name = e.file_name();
                let gone = name
                    .to_str()
                    .and_then(|n| n.strip_prefix("lmhost-ci-"))
                    .and_then(|rest| rest.split('-').next())
                    .is_some_and(|pid| !Path::new("/proc").join(pid).exists());
                if gone {
                    let _ = std::fs::remove_dir_all(e.path());
                }
            }
        }
        let dir = base.join(format!("lmhost-ci-{}-{tag}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        Ok(Self(dir))
    }
}

impl Drop for RunTmp {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// What one test executable did.
struct Outcome {
    name: String,
    ok: bool,
    passed: u64,
    failed: u64,
    took: Duration,
    output: String,
}

/// Runs every test executable [`build`] listed, [`JOBS`] at a time, each
/// as `cargo test` would (in its package's directory, with cargo's
/// variables), then the doc tests; prints each executable's output whole
/// as it ends and one summary line.
pub fn test(c: &Ctx, log: &Log, which: Which) -> Result<(), String> {
    let mut bins = test_bins(&c.ci_dir().join("tests.json"))?;
    bins.retain(|b| NEEDS_FIRMWARE.contains(&b.name.as_str()) == (which == Which::Firmware));
    bins.sort_by_key(|b| {
        SLOW_FIRST
            .iter()
            .position(|s| *s == b.name)
            .unwrap_or(SLOW_FIRST.len())
    });
    let queue = Arc::new(Mutex::new(
        bins.into_iter().collect::<std::collections::VecDeque<_>>(),
    ));
    let results = Arc::new(Mutex::new(Vec::<Outcome>::new()));
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut env: Vec<(&str, std::ffi::OsString)> = vec![
        ("CARGO", cargo),
        ("LMHOST_BIN", c.lmhost_for_tests().into_os_string()),
        ("LM_FW_QEMU_ELF", c.firmware_elf().into_os_string()),
        ("CARGO_TARGET_DIR", c.target_dir.clone().into_os_string()),
        // The browser test (lm-e2e/browser) fails rather than skips without
        // Chromium: the apt step installed it.
        ("LM_REQUIRE_BROWSER", "1".into()),
    ];
    // The tests' scratch folders (std::env::temp_dir()) go to one folder
    // of this run's, removed when the tests end: a suite of this size left
    // ~150 MB in /tmp each run (depth recordings, sockets, figures).
    let tmp = RunTmp::new(match which {
        Which::Host => "host",
        Which::Firmware => "firmware",
    })?;
    env.push(("TMPDIR", tmp.0.clone().into_os_string()));
    let mut jobs = JOBS;
    if which == Which::Firmware {
        // Each of these runs QEMU per test: one executable at a time, two
        // tests at a time, and a response timeout for an emulated board
        // that runs beside the host tests (QEMU slows with the machine).
        jobs = 1;
        env.push(("RUST_TEST_THREADS", "2".into()));
        env.push(("LMHOST_TIMEOUT_MS", "3000".into()));
    }
    std::thread::scope(|s| {
        for _ in 0..jobs {
            let (queue, results, env) = (queue.clone(), results.clone(), &env);
            s.spawn(move || {
                loop {
                    let Some(b) = queue.lock().unwrap_or_else(|e| e.into_inner()).pop_front()
                    else {
                        break;
                    };
                    let o = run_bin(&b, env);
                    log.line(format!(
                        "---- {} ({:.1} s) ----\n{}",
                        o.name,
                        o.took.as_secs_f64(),
                        o.output.trim_end()
                    ));
                    results.lock().unwrap_or_else(|e| e.into_inner()).push(o);
                }
            });
        }
    });
    let results = std::mem::take(&mut *results.lock().unwrap_or_else(|e| e.into_inner()));
    // Doc tests are compiled by rustdoc at run time, so they go through cargo.
    let doc = match which {
        Which::Host => run(log, c.cargo(&["test", "--doc"])),
        Which::Firmware => Ok(()),
    };
    let (passed, failed): (u64, u64) = results
        .iter()
        .fold((0, 0), |(p, f), o| (p + o.passed, f + o.failed));
    let bad: Vec<&str> = results
        .iter()
        .filter(|o| !o.ok)
        .map(|o| o.name.as_str())
        .collect();
    let mut times: BTreeMap<u64, &str> = BTreeMap::new();
    for o in &results {
        times.insert(o.took.as_millis() as u64, o.name.as_str());
    }
    let slowest: Vec<String> = times
        .iter()
        .rev()
        .take(3)
        .map(|(ms, n)| format!("{n} {:.0} s", *ms as f64 / 1000.0))
        .collect();
    log.line(format!(
        "{} tests: {passed} passed, {failed} failed in {} executables (slowest: {}){}",
        match which {
            Which::Host => "host",
            Which::Firmware => "firmware-under-QEMU",
        },
        results.len(),
        slowest.join(", "),
        match (which, doc.is_ok()) {
            (Which::Firmware, _) => "",
            (Which::Host, true) => ", doc tests passed",
            (Which::Host, false) => ", doc tests FAILED",
        }
    ));
    if !bad.is_empty() {
        return Err(format!("failing test executables: {}", bad.join(", ")));
    }
    doc
}

/// Runs one test executable to its end, capturing what it prints.
fn run_bin(b: &TestBin, env: &[(&str, std::ffi::OsString)]) -> Outcome {
    let t0 = Instant::now();
    let mut cmd = Command::new(&b.exe);
    cmd.current_dir(&b.dir)
        .env("CARGO_MANIFEST_DIR", &b.dir)
        .env("CARGO_PKG_NAME", &b.package)
        .stdin(Stdio::null());
    for (k, v) in env {
        cmd.env(k, v);
    }
    let (ok, output) = match cmd.output() {
        Ok(o) => {
            let mut s = String::from_utf8_lossy(&o.stdout).into_owned();
            s.push_str(&String::from_utf8_lossy(&o.stderr));
            (o.status.success(), s)
        }
        Err(e) => (false, format!("cannot start {}: {e}", b.exe.display())),
    };
    let (mut passed, mut failed) = (0, 0);
    for l in output.lines().filter(|l| l.starts_with("test result:")) {
        passed += count(l, "passed").unwrap_or(0);
        failed += count(l, "failed").unwrap_or(0);
    }
    Outcome {
        name: b.name.clone(),
        ok,
        passed,
        failed,
        took: t0.elapsed(),
        output,
    }
}

/// `N key` in a `test result:` line.
fn count(line: &str, key: &str) -> Option<u64> {
    let words: Vec<&str> = line
        .split(|ch: char| ch == ';' || ch == '.' || ch.is_whitespace())
        .filter(|w| !w.is_empty())
        .collect();
    words
        .windows(2)
        .find(|w| w[1] == key)
        .and_then(|w| w[0].parse().ok())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_come_from_the_result_line() {
        let l = "test result: ok. 218 passed; 3 failed; 1 ignored; 0 measured; 0 filtered out; finished in 22.25s";
        assert_eq!(count(l, "passed"), Some(218));
        assert_eq!(count(l, "failed"), Some(3));
        assert_eq!(count(l, "ignored"), Some(1));
    }

    #[test]
    fn package_names_come_from_ids() {
        assert_eq!(
            package_name("path+file:///work/main/tests#lm-e2e@0.1.0").as_deref(),
            Some("lm-e2e")
        );
        assert_eq!(
            package_name("path+file:///work/main/host#0.1.0").as_deref(),
            Some("host")
        );
    }
}
