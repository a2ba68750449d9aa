//! A check over every subcommand's flags: a flag that needs another
//! (clap's `requires`) is refused without it whatever else is given.
//!
//! clap waives a requirement when the flag required conflicts with a flag
//! that is present (`--timestamps` needs `--depth`, `--seconds` conflicts
//! with `--depth`: `--seconds 1 --timestamps T` parsed, and the time
//! stamps were silently ignored). Such a pair needs the conflict stated on
//! the requiring flag too; this test finds every pair, so a new flag
//! cannot bring the hole back.
//!
//! And a check that every number flag refuses a value that underflows.

use clap::{Arg, CommandFactory, Parser, error::ErrorKind};

/// The whole command line, as `main` parses it.
#[derive(Debug, Parser)]
struct Cli {
    #[command(subcommand)]
    command: super::Command,
}

/// Values tried for a flag until one passes its parser.
const VALUES: [&str; 6] = ["1", "1,1,1", "0,0,200", "x", "sim", "a"];

/// Every leaf subcommand: its path of names and its clap command.
fn leaves(cmd: &clap::Command, path: Vec<String>, out: &mut Vec<(Vec<String>, clap::Command)>) {
    let subs: Vec<_> = cmd
        .get_subcommands()
        .filter(|s| s.get_name() != "help")
        .collect();
    if subs.is_empty() {
        out.push((path.clone(), cmd.clone()));
    }
    for s in subs {
        let mut p = path.clone();
        p.push(s.get_name().to_owned());
        leaves(s, p, out);
    }
}

/// Parses `args` as `main` does.
fn parse(args: &[String]) -> Result<(), clap::Error> {
    let argv = std::iter::once("lmhost".to_owned()).chain(args.iter().cloned());
    super::exact_floats(super::negative_numbers_are_values(Cli::command()))
        .try_get_matches_from(argv)
        .and_then(|m| <Cli as clap::FromArgMatches>::from_arg_matches(&m))
        .map(drop)
}

/// `arg` as words on a command line: its flag, and a value its parser
/// takes (the first possible value, else the first of [`VALUES`] that is
/// not refused as a value).
fn words(path: &[String], arg: &Arg) -> Vec<String> {
    let flag = arg.get_long().map(|l| format!("--{l}"));
    if !arg.get_action().takes_values() {
        return flag.into_iter().collect();
    }
    let possible = arg.get_possible_values();
    let candidates: Vec<String> = match possible.first() {
        Some(v) => vec![v.get_name().to_owned()],
        None => VALUES.iter().map(|v| (*v).to_owned()).collect(),
    };
    for v in &candidates {
        let w: Vec<String> = flag.iter().cloned().chain([v.clone()]).collect();
        let mut args = path.to_vec();
        args.extend(w.iter().cloned());
        match parse(&args) {
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::InvalidValue | ErrorKind::ValueValidation
                ) => {}
            _ => return w,
        }
    }
    flag.into_iter().chain([candidates[0].clone()]).collect()
}

#[test]
fn no_requirement_is_waived_by_a_conflict() {
    let mut all = Vec::new();
    let cli = super::negative_numbers_are_values(Cli::command());
    leaves(&cli, Vec::new(), &mut all);
    let mut waived = Vec::new();
    let mut checked = 0;
    for (path, cmd) in &all {
        let args: Vec<&Arg> = cmd
            .get_arguments()
            .filter(|a| !matches!(a.get_id().as_str(), "help" | "version"))
            .collect();
        // The smallest command line that parses: the required arguments.
        let mut base = path.clone();
        for a in args.iter().filter(|a| a.is_required_set()) {
            base.extend(words(path, a));
        }
        if parse(&base).is_err() {
            continue;
        }
        let with = |extra: &[&Arg]| {
            let mut v = base.clone();
            for a in extra {
                v.extend(words(path, a));
            }
            v
        };
        for a in args
            .iter()
            .filter(|a| !a.is_positional() && !a.is_required_set())
        {
            let Err(e) = parse(&with(&[a])) else {
                continue;
            };
            if e.kind() != ErrorKind::MissingRequiredArgument {
                continue;
            }
            // `a` needs more: no flag but those it names may stand in.
            let missing = e.to_string();
            for c in args
                .iter()
                .filter(|c| !c.is_positional() && c.get_id() != a.get_id())
            {
                let named = c
                    .get_long()
                    .is_some_and(|l| missing.contains(&format!("--{l}")));
                if named || parse(&with(&[c])).is_err() {
                    continue;
                }
                checked += 1;
                if parse(&with(&[a, c])).is_ok() {
                    waived.push(format!(
                        "lmhost {} --{} with --{}",
                        path.join(" "),
                        a.get_long().unwrap_or_default(),
                        c.get_long().unwrap_or_default()
                    ));
                }
            }
        }
    }
    assert!(
        checked > 50,
        "only {checked} pairs checked: the walk found too little"
    );
    assert!(
        waived.is_empty(),
        "a flag's requirement is waived by another flag (it would be ignored): {waived:#?}"
    );
}

#[test]
fn every_number_flag_refuses_a_value_that_underflows() {
    let mut all = Vec::new();
    leaves(&Cli::command(), Vec::new(), &mut all);
    let mut checked = 0;
    for (path, cmd) in &all {
        for a in cmd.get_arguments().filter(|a| {
            !a.is_positional() && a.get_value_parser().type_id() == std::any::TypeId::of::<f64>()
        }) {
            let mut args = path.clone();
            args.extend([
                format!("--{}", a.get_long().unwrap_or_default()),
                "1e-400".into(),
            ]);
            let e = parse(&args).expect_err(&args.join(" "));
            assert!(
                e.kind() == ErrorKind::ValueValidation
                    && e.to_string().contains("too small to represent"),
                "{}: {e}",
                args.join(" ")
            );
            checked += 1;
        }
    }
    assert!(checked > 50, "only {checked} number flags found");
}

/// The largest value of `arg`'s type when it takes a whole number.
fn whole_number_type_max(arg: &Arg) -> Option<u64> {
    use std::any::TypeId;
    let t = arg.get_value_parser().type_id();
    [
        (TypeId::of::<u8>(), u64::from(u8::MAX)),
        (TypeId::of::<u16>(), u64::from(u16::MAX)),
        (TypeId::of::<u32>(), u64::from(u32::MAX)),
        (TypeId::of::<u64>(), u64::MAX),
        (TypeId::of::<usize>(), usize::MAX as u64),
        (TypeId::of::<i32>(), i32::MAX as u64),
        (TypeId::of::<i64>(), i64::MAX as u64),
    ]
    .into_iter()
    .find_map(|(id, max)| (t == id).then_some(max))
}

/// Every whole-number flag refuses a sign, a fraction or more digits than
/// its type holds naming its own range ([`super::whole`]): never "invalid
/// digit found in string", "number too large to fit in target type", or
/// a type's range in place of the flag's (`-1 is not in 0..=4294967295`
/// for `--enter-frames`, which takes 1 to 90).
#[test]
fn every_whole_number_flag_names_its_own_range() {
    let mut all = Vec::new();
    leaves(&Cli::command(), Vec::new(), &mut all);
    let mut checked = 0;
    let mut bad = Vec::new();
    for (path, cmd) in &all {
        for a in cmd.get_arguments().filter(|a| !a.is_positional()) {
            let Some(type_max) = whole_number_type_max(a) else {
                continue;
            };
            let flag = format!("--{}", a.get_long().unwrap_or_default());
            // `--lease` takes seconds, its parser names them.
            if flag == "--lease" {
                continue;
            }
            for v in ["-1", "99999999999999999999999", "1.5", "x"] {
                let mut args = path.clone();
                args.extend([flag.clone(), v.into()]);
                let e = parse(&args).expect_err(&args.join(" ")).to_string();
                let named = e.contains(&format!("{v} is out of range: allowed "))
                    || e.contains(&format!("{v} is not a whole number: allowed "));
                let type_range = (e.contains(&format!("..={type_max}"))
                    || (type_max == u64::MAX && e.contains("..=2^64-1")))
                    && !own_range_is_the_types(&flag);
                if !named || type_range {
                    bad.push(format!("lmhost {}: {e}", args.join(" ")));
                }
            }
            checked += 1;
        }
    }
    assert!(checked > 25, "only {checked} whole-number flags found");
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// The flags whose range is their type's: a slot byte, a port, a baud
/// rate or a step count above 0, a seed, a frame number.
fn own_range_is_the_types(flag: &str) -> bool {
    [
        "--slot",
        "--udp",
        "--tcp",
        "--baud",
        "--steps",
        "--seed",
        "--plot-frame",
    ]
    .contains(&flag)
}
