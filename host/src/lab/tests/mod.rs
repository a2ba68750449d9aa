//! A mutation fuzzer over every host reader of user input: the files,
//! lines and streams a user or another program hands lmhost.
//!
//! ```text
//! cargo test --release -p lmhost --lib long_random_readers -- --ignored --nocapture
//! ```
//!
//! Each reader gets its valid seeds (the repository's scenes, studies and
//! test fixtures; built in memory where a reader takes bytes), every
//! truncation of each, and thousands of mutants ([`mutate`]). Beyond
//! "never panics", a refusal must be one line of at most
//! [`harness::MAX_SHOWN_CHARS`] characters as shown, an acceptance keep
//! the reader's own invariants (finite numbers, the limits of
//! `crate::limits`), and no case allocate more than 64 MiB at once.
//! `LM_HOST_FUZZ_SEED` (decimal or 0x hex) changes the run, printed at
//! its start; `LM_HOST_FUZZ_ONLY=NAME` runs one reader and
//! `LM_HOST_FUZZ_CASE=N` one case of it; `LM_LONG_SCALE` in (0, 1] runs
//! that share of the full size (the everyday CI's debug run).

mod harness;
mod mutate;
mod readers_files;
mod readers_study;
mod readers_text;

#[global_allocator]
static WATCH: harness::Watch = harness::Watch;

/// The long run's share of its full size: `LM_LONG_SCALE` in (0, 1] (the
/// CI's everyday run), 1 when unset (`cargo xtask ci --full`).
fn long_scale() -> f64 {
    let s = std::env::var("LM_LONG_SCALE")
        .ok()
        .and_then(|s| s.parse().ok());
    s.filter(|s: &f64| *s > 0.0 && *s <= 1.0).unwrap_or(1.0)
}

fn env_u64(name: &str) -> Option<u64> {
    let v = std::env::var(name).ok()?;
    let v = v.trim();
    match v.strip_prefix("0x") {
        Some(h) => u64::from_str_radix(h, 16).ok(),
        None => v.parse().ok(),
    }
}

#[test]
#[ignore = "long: run by cargo xtask ci's long runs"]
fn long_random_readers_refuse_in_one_line_and_accept_only_valid_values() {
    let seed = env_u64("LM_HOST_FUZZ_SEED").unwrap_or(0x1a2b_3c4d);
    let only = std::env::var("LM_HOST_FUZZ_ONLY").ok();
    let only_case = env_u64("LM_HOST_FUZZ_CASE");
    let scale = long_scale();
    println!("readers fuzz: LM_HOST_FUZZ_SEED={seed:#x}, scale {scale}");
    let mut readers = readers_text::readers();
    readers.extend(readers_files::readers());
    readers.extend(readers_study::readers());
    let mut failures = Vec::new();
    for r in &readers {
        if only.as_deref().is_some_and(|o| o != r.name) {
            continue;
        }
        let mutants = (r.cases as f64 * scale).round() as u64;
        let stride = (1.0 / scale).round() as usize;
        let before = failures.len();
        let t = harness::run(r, seed, mutants, stride, only_case, &mut failures);
        println!(
            "{:>26}: {:>6} cases, {:>5} accepted, {} kinds of failure",
            r.name,
            t.cases,
            t.accepted,
            failures.len() - before
        );
    }
    for f in &failures {
        println!("\n{f}");
    }
    assert!(
        failures.is_empty(),
        "{} kinds of failure (seed {seed:#x}): above",
        failures.len()
    );
}
