//! Every command's help renders, names the command, and exits 0; the
//! version is the package's; an unknown flag is one line and exit 2.
//!
//! (Being an integration test of this package, it also makes `cargo test`
//! build the `lmhost` binary itself, with the same features as every other
//! test of the run: the CI takes the binary from that one build.)

use std::process::{Command, Output};

fn lmhost(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lmhost"))
        .args(args)
        .output()
        .expect("run lmhost")
}

/// The subcommand names under `Commands:` in a help text.
fn subcommands(help: &str) -> Vec<String> {
    help.lines()
        .skip_while(|l| l.trim_end() != "Commands:")
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|name| *name != "help")
        .map(str::to_string)
        .collect()
}

#[test]
fn every_command_has_help_that_names_it() {
    let top = lmhost(&["--help"]);
    assert!(top.status.success());
    let top = String::from_utf8(top.stdout).unwrap();
    let mut queue: Vec<Vec<String>> = subcommands(&top).into_iter().map(|s| vec![s]).collect();
    // The commands a user knows the tool by: a help that lost them is wrong.
    for known in ["plan", "upload", "session", "study", "simulate", "demo"] {
        assert!(
            queue.iter().any(|p| p[0] == known),
            "`lmhost --help` does not list {known}:\n{top}"
        );
    }
    let mut seen = 0;
    while let Some(path) = queue.pop() {
        let mut args: Vec<&str> = path.iter().map(String::as_str).collect();
        args.push("--help");
        let out = lmhost(&args);
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "lmhost {} --help: {}",
            path.join(" "),
            String::from_utf8_lossy(&out.stderr)
        );
        let usage = format!("Usage: lmhost {}", path.join(" "));
        assert!(
            text.contains(&usage),
            "lmhost {} --help lacks `{usage}`:\n{text}",
            path.join(" ")
        );
        for sub in subcommands(&text) {
            let mut p = path.clone();
            p.push(sub);
            queue.push(p);
        }
        seen += 1;
    }
    assert!(seen >= 20, "only {seen} commands found");
}

#[test]
fn version_is_the_packages() {
    let out = lmhost(&["--version"]);
    assert!(out.status.success());
    assert_eq!(
        String::from_utf8(out.stdout).unwrap().trim(),
        format!("lmhost {}", env!("CARGO_PKG_VERSION"))
    );
}

#[test]
fn unknown_flag_is_one_line_and_exit_2() {
    let out = lmhost(&["plan", "--no-such-flag"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("--no-such-flag"), "{err}");
}
