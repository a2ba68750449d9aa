//! The documents' commands, typed as a user types them: every `lmhost ...`
//! line (and `cargo run --release -p lmhost-cli -- ...`, as `lmhost ...`)
//! in a fenced `sh` block of the user documents runs here, in `sh`,
//! with `lmhost` on `PATH`, against `lmhost sim` (its pty stands in for
//! `/dev/pts/7`, and `LMHOST_PORT` for a board found by USB id), in a
//! scratch folder holding the repository's `scenes/` and `studies/` and the
//! files the documents assume a user has (`p.json`, `f.npy`, ...). A line
//! must exit 0 unless a rule below says what else it must do, so a refused
//! or renamed flag in a document fails here.
//!
//! Rules are matched on the document and a piece of the line; each names
//! why. A rule that no longer matches any line fails the test, so the table
//! cannot rot quietly. Lines that run long are shortened by an explicit
//! replacement (said in the rule) or skipped with a reason; hardware-only
//! lines run as far as a machine without the hardware lets them, which must
//! be the "failed operation" exit 1, never the "bad input" exit 2.

mod link_support;
use link_support::{Sim, lmhost, scratch_dir};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The documents whose fenced `sh` blocks hold `lmhost` command lines.
const DOCS: &[&str] = &["README.md", "BRINGUP.md", "firmware/nucleo-h743/README.md"];

/// What a matched line must do.
#[derive(Clone, Copy, Debug)]
enum Expect {
    /// Exit with this status, stdout or stderr containing the text.
    Exit(i32, &'static str),
    /// Says this text once it holds the device (its "until Ctrl-C" line),
    /// is still running [`HOLD`] later, and Ctrl-C (SIGINT) then ends it
    /// with exit 0. Waiting for the line, not a fixed time, so a slow
    /// machine's upload is not interrupted before it plays.
    Interrupt(&'static str),
    /// Not run here.
    Skip,
}

struct Rule {
    doc: &'static str,
    /// A piece of the line (after its comment is cut).
    has: &'static str,
    /// Text replacements made before it runs.
    replace: &'static [(&'static str, &'static str)],
    expect: Expect,
    why: &'static str,
}

/// Where on this machine there is certainly no serial port.
const ABSENT: &str = "./absent-port";

use Expect::{Exit, Interrupt, Skip};

/// Checked in order; the first rule matching a line applies.
const RULES: &[Rule] = &[
    // README.md
    Rule {
        doc: "README.md",
        has: "plan --target autd3 --radius 5",
        replace: &[],
        expect: Exit(0, "steps N = 136"),
        why: "the comment quotes 136 steps on the 25 µs grid",
    },
    Rule {
        doc: "README.md",
        has: "simulate --compare",
        replace: &[],
        expect: Skip,
        why: "fifteen fields: minutes in a debug build (simulate_cli.rs runs --compare on a small plane)",
    },
    Rule {
        doc: "README.md",
        has: "simulate --radius 3 --foci 4 --out field/",
        replace: &[("--out", "--plane-step 0.5 --out")],
        expect: Exit(0, "wrote field/"),
        why: "a 0.5 mm grid instead of 0.2 mm: 6× fewer points, same flags otherwise",
    },
    Rule {
        doc: "README.md",
        has: "lmhost sim &",
        replace: &[],
        expect: Skip,
        why: "the test runs its own lmhost sim and gives its pty for /dev/pts/7",
    },
    Rule {
        doc: "README.md",
        has: "--no-play",
        replace: &[],
        expect: Exit(0, "\"slot\":1"),
        why: "the comment says it takes the free slot",
    },
    Rule {
        doc: "README.md",
        has: "--untracked --hold 10",
        replace: &[("--hold 10", "--hold 1"), ("autd3:soem", "autd3:emulator")],
        expect: Exit(0, ""),
        why: "held 1 s instead of 10; an EtherCAT rig is autd3's emulator here",
    },
    Rule {
        doc: "README.md",
        has: "selftest --port /dev/pts/7",
        replace: &[],
        expect: Exit(1, "not supported by this board"),
        why: "a device without the loopback jumper (as QEMU): the text says exit 1",
    },
    Rule {
        doc: "README.md",
        has: "upload --port /dev/pts/7",
        replace: &[],
        expect: Interrupt("until Ctrl-C"),
        why: "plays until Ctrl-C, as the text says",
    },
    Rule {
        doc: "README.md",
        has: "my-tracker |",
        replace: &[(
            "my-tracker",
            "lmhost track --synthetic --seconds 1 --filter gaussian --json",
        )],
        expect: Exit(0, "gaussian filter"),
        why: "a tracker: lmhost track's own JSON lines, 1 s of them",
    },
    Rule {
        doc: "README.md",
        has: "--udp 9000",
        replace: &[("--udp 9000", "--udp 9000 --seconds 1")],
        expect: Exit(0, "streamed 0 samples"),
        why: "ends after --seconds (10 by default) without a datagram: 1 s here",
    },
    Rule {
        doc: "README.md",
        has: "--seconds 30 --away 10,12",
        replace: &[("--seconds 30 --away 10,12", "--seconds 3 --away 1,2")],
        expect: Exit(0, ""),
        why: "3 s of finger, away from 1 s to 2 s, instead of 30 s",
    },
    Rule {
        doc: "README.md",
        has: "stream --port /dev/pts/7 --synthetic --foci 4 --radius 3",
        replace: &[("--radius 3", "--radius 3 --seconds 2")],
        expect: Exit(0, ""),
        why: "2 s of synthetic finger instead of the default 10",
    },
    Rule {
        doc: "README.md",
        has: "--record rec.npy",
        replace: &[("--record", "--seconds 2 --record")],
        expect: Exit(0, "recorded 180 frames to rec.npy"),
        why: "2 s of frames instead of the default 6",
    },
    Rule {
        doc: "README.md",
        has: "--camera",
        replace: &[("autd3:soem", "autd3:emulator")],
        expect: Exit(1, "camera"),
        why: "no RealSense here: a failed operation, not refused flags",
    },
    Rule {
        doc: "README.md",
        has: "lmhost bench",
        replace: &[("lmhost bench", "lmhost bench --quick --section planner")],
        expect: Exit(0, ""),
        why: "every section takes minutes in a debug build: the planner's, quick",
    },
    Rule {
        doc: "README.md",
        has: "calibrate force --measured 0.022 --scene rig.toml --write",
        replace: &[],
        expect: Exit(0, "0.07223 N"),
        why: "rig.toml is a copy of scenes/paper.toml; the text quotes 0.0722 N",
    },
    Rule {
        doc: "README.md",
        has: "calibrate camera",
        replace: &[],
        expect: Skip,
        why: "needs depth recordings of a ball at known points (calibrate_cli.rs renders them)",
    },
    Rule {
        doc: "README.md",
        has: "lmhost session --library",
        replace: &[],
        expect: Interrupt("control socket"),
        why: "serves its control socket until quit or Ctrl-C (python/tests runs the README's client)",
    },
    Rule {
        doc: "README.md",
        has: "--responses answers.txt",
        replace: &[],
        expect: Exit(0, "30 of 30 trials done"),
        why: "answers.txt answers \"same\" to each of the 30 trials",
    },
    Rule {
        doc: "README.md",
        has: "lmhost study report results",
        replace: &[],
        expect: Exit(2, "no trial to report"),
        why: "the runs into results stop at their first question (stdin empty): no trial to summarise",
    },
    Rule {
        doc: "README.md",
        has: "lmhost study run",
        replace: &[],
        expect: Exit(2, "stdin ended: an answer"),
        why: "answers from keys at a terminal: with stdin empty it must reach the first question",
    },
    Rule {
        doc: "README.md",
        has: "gauge read --port sim",
        replace: &[],
        expect: Exit(0, "0.490 N"),
        why: "the twins; the text quotes 0.490 N",
    },
    Rule {
        doc: "README.md",
        has: "--port /dev/tty",
        replace: &[
            ("/dev/ttyACM0", ABSENT),
            ("/dev/ttyUSB0", ABSENT),
            ("/dev/ttyUSB1", ABSENT),
        ],
        expect: Exit(1, "absent-port"),
        why: "a real gauge or stage: a port that does not exist (never a real one here)",
    },
    Rule {
        doc: "README.md",
        has: "autd3:emulator --scene scenes/paper.toml --foci 4 --json",
        replace: &[],
        expect: Exit(0, "\"dwell_us\":2450.0"),
        why: "the comment quotes the report",
    },
    Rule {
        doc: "README.md",
        has: "stream --port autd3:soem --synthetic --foci 4",
        replace: &[
            ("autd3:soem", "autd3:emulator"),
            ("--foci 4", "--foci 4 --seconds 2"),
        ],
        expect: Exit(0, ""),
        why: "autd3's emulator for the EtherCAT rig; 2 s of synthetic finger instead of 10",
    },
    Rule {
        doc: "README.md",
        has: "autd3:soem",
        replace: &[
            ("autd3:soem:enp3s0", "autd3:emulator"),
            ("autd3:soem", "autd3:emulator"),
        ],
        expect: Exit(0, ""),
        why: "no EtherCAT rig here: autd3's emulator is the same backend",
    },
    // BRINGUP.md
    Rule {
        doc: "BRINGUP.md",
        has: "/dev/serial/by-id/",
        replace: &[],
        expect: Exit(1, "no such file"),
        why: "the Nucleo's ports: not on this machine",
    },
    Rule {
        doc: "BRINGUP.md",
        has: "selftest --port /dev/ttyACM0",
        replace: &[("/dev/ttyACM0", ABSENT)],
        expect: Exit(1, "absent-port"),
        why: "the Nucleo: a port that does not exist (never a real one here)",
    },
    Rule {
        doc: "BRINGUP.md",
        has: "lmhost upload --radius 3 --foci 4 --untracked",
        replace: &[],
        expect: Interrupt("until Ctrl-C"),
        why: "plays until Ctrl-C (LMHOST_PORT stands in for the board found by USB id)",
    },
    Rule {
        doc: "BRINGUP.md",
        has: "autd3:soem",
        replace: &[],
        expect: Exit(1, "autd3-soem"),
        why: "this build has no EtherCAT link: one line naming the feature",
    },
    Rule {
        doc: "README.md",
        has: "lmhost flash",
        replace: &[],
        expect: Skip,
        why: "needs the built ELF, an ST-LINK and a build with the flash feature",
    },
    // firmware/nucleo-h743/README.md
    Rule {
        doc: "firmware/nucleo-h743/README.md",
        has: "lmhost flash",
        replace: &[],
        expect: Skip,
        why: "needs the built ELF and an ST-LINK",
    },
];

/// A document's `lmhost` command lines: (line number, command without its
/// comment), continuation lines joined.
fn command_lines(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut fence: Option<String> = None;
    let mut lines = text.lines().enumerate();
    while let Some((i, line)) = lines.next() {
        if let Some(info) = line.trim_start().strip_prefix("```") {
            fence = match fence {
                None => Some(info.trim().to_owned()),
                Some(_) => None,
            };
            continue;
        }
        if !matches!(fence.as_deref(), Some("sh" | "bash" | "shell")) {
            continue;
        }
        let mut cmd = cut_comment(line).to_owned();
        while cmd.ends_with('\\') {
            cmd.pop();
            match lines.next() {
                Some((_, next)) => cmd.push_str(cut_comment(next)),
                None => break,
            }
        }
        let mut cmd = cmd.split_whitespace().collect::<Vec<_>>().join(" ");
        // `cargo run ... -p lmhost-cli [--features F] -- ARGS` is `lmhost ARGS`
        // built another way: the built binary stands in for it.
        if let Some(args) = cmd
            .strip_prefix("cargo run --release -p lmhost-cli ")
            .and_then(|rest| rest.split_once("-- "))
            .map(|(_, args)| args.to_owned())
        {
            cmd = format!("lmhost {args}");
        }
        let runs_lmhost = cmd
            .split(['|', '&', ';'])
            .any(|part| part.trim_start().starts_with("lmhost "));
        if runs_lmhost {
            out.push((i + 1, cmd));
        }
    }
    out
}

/// The line without its trailing `# comment`.
fn cut_comment(line: &str) -> &str {
    let t = line.trim_end();
    if t.trim_start().starts_with('#') {
        return "";
    }
    match t.find(" #") {
        Some(at) => t[..at].trim_end(),
        None => t,
    }
}

/// The files the documents assume a user already has.
fn fixtures(dir: &Path, root: &Path) {
    for d in ["scenes", "studies"] {
        std::os::unix::fs::symlink(root.join(d), dir.join(d)).unwrap();
    }
    // A rig's scene, as calibrate writes it: a copy of the paper's.
    std::fs::copy(root.join("scenes/paper.toml"), dir.join("rig.toml")).unwrap();
    // Phases as JSON: a planned LM-M's, with the dwell the README shows.
    let plan = Command::new(lmhost())
        .args(["plan", "--radius", "3", "--foci", "4", "--json", "--phases"])
        .output()
        .unwrap();
    assert!(plan.status.success());
    let plan: serde_json::Value = serde_json::from_slice(&plan.stdout).unwrap();
    let phases = serde_json::json!({"phases": plan["phases"], "dwell_us": 2450});
    std::fs::write(dir.join("p.json"), phases.to_string()).unwrap();
    // Foci: one focus around a 3 mm circle, 82 steps.
    let steps = 82;
    let foci: Vec<[f64; 3]> = (0..steps)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / steps as f64;
            [3.0 * a.cos(), 3.0 * a.sin(), 200.0]
        })
        .collect();
    let nested: Vec<Vec<[f64; 3]>> = foci.iter().map(|f| vec![*f]).collect();
    let json = serde_json::json!({"foci_mm": nested, "dwell_us": 25000});
    std::fs::write(dir.join("f.json"), json.to_string()).unwrap();
    let header = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': ({steps}, 1, 3), }}");
    let pad = 64 - (10 + header.len() + 1) % 64;
    let header = format!("{header}{}\n", " ".repeat(pad));
    let mut npy = b"\x93NUMPY\x01\x00".to_vec();
    npy.extend_from_slice(&(header.len() as u16).to_le_bytes());
    npy.extend_from_slice(header.as_bytes());
    for v in foci.iter().flatten() {
        npy.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(dir.join("f.npy"), npy).unwrap();
    // Experiment 3's answers: "same" (3) at each of its 30 trials.
    std::fs::write(dir.join("answers.txt"), "3\n".repeat(30)).unwrap();
}

/// A line that runs longer than this fails: shorten it or skip it above.
const DEADLINE: Duration = Duration::from_secs(120);
/// How long a command that holds the device must go on holding it after
/// saying so, before Ctrl-C.
const HOLD: Duration = Duration::from_millis(500);

/// Run `cmd` in `sh` and check it does what `expect` says; an error text
/// on failure.
fn check(cmd: &str, expect: Expect, dir: &Path, port: &str) -> Result<(), String> {
    let bin_dir = lmhost().parent().unwrap().to_owned();
    let path = std::env::var_os("PATH").unwrap_or_default();
    let mut paths = vec![bin_dir];
    paths.extend(std::env::split_paths(&path));
    // `exec` so that Ctrl-C reaches lmhost itself, as it would from a shell.
    let script = match expect {
        Interrupt(_) => format!("exec {cmd}"),
        _ => cmd.to_owned(),
    };
    let mut child = Command::new("sh")
        .args(["-c", &script])
        .current_dir(dir)
        .env("PATH", std::env::join_paths(paths).unwrap())
        .env("LMHOST_PORT", port)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| e.to_string())?;
    // Drain both pipes on threads, so a long report cannot block the child.
    let so = child.stdout.take().unwrap();
    let se = child.stderr.take().unwrap();
    // Both pipes, as they come (an `Interrupt` waits for a line of them).
    let both = Arc::new(Mutex::new(String::new()));
    let drain = |mut pipe: Box<dyn Read + Send>| {
        let both = both.clone();
        std::thread::spawn(move || {
            let mut own = Vec::new();
            let mut buf = [0u8; 4096];
            while let Ok(n @ 1..) = pipe.read(&mut buf) {
                own.extend_from_slice(&buf[..n]);
                both.lock()
                    .unwrap()
                    .push_str(&String::from_utf8_lossy(&buf[..n]));
            }
            String::from_utf8_lossy(&own).into_owned()
        })
    };
    let (so, se) = (drain(Box::new(so)), drain(Box::new(se)));
    let start = Instant::now();
    let mut held_since = None;
    let mut interrupted = false;
    let status = loop {
        if let Some(st) = child.try_wait().map_err(|e| e.to_string())? {
            break st;
        }
        if let Interrupt(says) = expect
            && held_since.is_none()
            && both.lock().unwrap().contains(says)
        {
            held_since = Some(Instant::now());
        }
        if !interrupted && held_since.is_some_and(|t| t.elapsed() >= HOLD) {
            Command::new("kill")
                .args(["-INT", &child.id().to_string()])
                .status()
                .unwrap();
            interrupted = true;
        }
        if start.elapsed() > DEADLINE {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!(
                "still running after {DEADLINE:?}: shorten or skip it"
            ));
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let (out, err) = (so.join().unwrap(), se.join().unwrap());
    let both = format!("{out}{err}");
    let tail = |s: &str| {
        s.chars()
            .rev()
            .take(600)
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
            .collect::<String>()
    };
    match expect {
        Exit(code, says) => {
            if status.code() != Some(code) {
                return Err(format!(
                    "exit {:?}, not {code}: {}",
                    status.code(),
                    tail(&err)
                ));
            }
            if !both.contains(says) {
                return Err(format!("output lacks {says:?}: {}", tail(&both)));
            }
        }
        Interrupt(says) => {
            if !interrupted {
                return Err(format!(
                    "ended (exit {:?}) before it said {says:?} and held {HOLD:?}, though it should hold until Ctrl-C: {}",
                    status.code(),
                    tail(&err)
                ));
            }
            if status.code() != Some(0) {
                return Err(format!(
                    "Ctrl-C: exit {:?}, not 0: {}",
                    status.code(),
                    tail(&err)
                ));
            }
        }
        Skip => unreachable!(),
    }
    Ok(())
}

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_owned()
}

#[test]
fn every_document_command_runs_as_written() {
    let root = repo_root();
    let mut used = vec![false; RULES.len()];
    let mut failures = Vec::new();
    let (mut ran, mut skipped) = (0, 0);
    for doc in DOCS {
        let text = std::fs::read_to_string(root.join(doc)).unwrap();
        let lines = command_lines(&text);
        assert!(!lines.is_empty(), "{doc}: no lmhost command lines found");
        // One device and one folder per document, its lines in order: a
        // later line may read what an earlier one wrote.
        let sim = Sim::start(&[]);
        let dir = scratch_dir(&format!("docs-{}", doc.replace('/', "-")));
        fixtures(&dir, &root);
        for (n, line) in lines {
            let rule = RULES
                .iter()
                .position(|r| r.doc == *doc && line.contains(r.has));
            let (expect, mut cmd) = match rule {
                Some(i) => {
                    used[i] = true;
                    (RULES[i].expect, line.clone())
                }
                None => (Exit(0, ""), line.clone()),
            };
            if let Some(i) = rule {
                for (from, to) in RULES[i].replace {
                    cmd = cmd.replace(from, to);
                }
            }
            cmd = cmd
                .replace("/dev/pts/7", &sim.port)
                .replace("/tmp/lm.sock", "lm.sock");
            if let Skip = expect {
                skipped += 1;
                continue;
            }
            ran += 1;
            if let Err(e) = check(&cmd, expect, &dir, &sim.port) {
                failures.push(format!("{doc}:{n}: `{line}`\n    ran `{cmd}`: {e}"));
            }
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
    for (i, r) in RULES.iter().enumerate() {
        if !used[i] {
            failures.push(format!(
                "rule {:?} in {} ({}) matches no command line: remove it",
                r.has, r.doc, r.why
            ));
        }
    }
    eprintln!("{ran} document commands ran, {skipped} skipped");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn extraction_finds_commands_and_cuts_comments() {
    let doc = "text `lmhost nope`\n```sh\nlmhost plan --radius 3   # a comment\n\
               cargo xtask ci\ncargo run --release -p lmhost-cli -- demo\nmy-tracker | lmhost stream \\\n    --filter gaussian\n\
               # lmhost in a comment\n```\n```toml\nlmhost = 1\n```\n";
    let got = command_lines(doc);
    assert_eq!(
        got,
        vec![
            (3, "lmhost plan --radius 3".to_owned()),
            (5, "lmhost demo".to_owned()),
            (6, "my-tracker | lmhost stream --filter gaussian".to_owned()),
        ]
    );
}

/// The way to a flashing lmhost that a build without probe-rs names must
/// work: its `cargo install --path DIR --features flash` is the crate
/// with the lmhost binary and that feature.
#[test]
fn flash_refusal_names_the_crate_that_builds_it() {
    let elf_dir = scratch_dir("docs-flash");
    let elf = elf_dir.join("fw.elf");
    std::fs::write(&elf, b"not flashed").unwrap();
    let out = Command::new(lmhost())
        .args(["flash", "--board", "nucleo-h743", "--elf"])
        .arg(&elf)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    if !err.contains("built without probe-rs") {
        // A build with the `flash` feature tries a probe instead.
        return;
    }
    assert_eq!(out.status.code(), Some(1), "{err}");
    let dir = err
        .split("cargo install --path ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .unwrap_or_else(|| panic!("no `cargo install --path DIR`: {err}"));
    let manifest = std::fs::read_to_string(repo_root().join(dir).join("Cargo.toml")).unwrap();
    assert!(
        manifest.contains("name = \"lmhost\""),
        "{dir} builds no lmhost binary"
    );
    assert!(
        manifest.contains("\nflash = "),
        "{dir} has no `flash` feature"
    );
}
