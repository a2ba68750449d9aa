//! Round 5, Experiment 3 with its instruments and the study's finger
//! sources (issue 28.2, 28.6): `study run --stage --gauge` and their
//! position flags refused with what is wrong before anything moves, the
//! stage's `sim:fail-after=N` spec read strictly, a twin never paired with
//! a real instrument; the finger flags `study run` shares with `session`
//! checked as `session` checks them.
//!
//! Fixtures in `{dir}/exp3`: a small CSV file, answers that end every
//! adjustment at once.

use super::*;

fn exp3() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../studies/paper-exp3.toml")
        .display()
        .to_string()
}

pub(crate) fn exp3_fixtures(dir: &Path) {
    let dir = dir.join("exp3");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("gap.csv"), "0,0,0,200,1\n86400,0,0,200,1\n").unwrap();
    std::fs::write(dir.join("same.txt"), "same\n".repeat(30)).unwrap();
}

pub(crate) fn exp3_cases() -> Vec<Case> {
    let run = |id: &str, more: &str| {
        format!(
            "study run {} --port autd3:emulator --out {{dir}}/exp3/out --time-scale 0.02 \
             --responses {{dir}}/exp3/same.txt --participant {id} --finger synthetic {more}",
            exp3()
        )
    };
    // The paper fixtures' protocol without the method of adjustment.
    let na = |id: &str, more: &str| {
        format!(
            "study run {{dir}}/paper/na.toml --port autd3:emulator --out {{dir}}/exp3/out \
             --responses {{dir}}/paper/na_ok.txt --participant {id} {more}"
        )
    };
    let c = |class: &'static str, args: String| case(class, &args);
    // 1. The instruments: `study run` of Experiment 3 with these flags
    // (each its own participant), refused with this text.
    let instruments = [
        // Both or neither, specs read strictly.
        ("--stage sim", "--gauge"),
        ("--gauge sim", "--stage"),
        ("--contact 3", "--stage"),
        (
            "--stage sim:fail-after=x --gauge sim",
            "stage `sim:fail-after=x`: give sim, sim:fail-after=N",
        ),
        (
            "--stage sim:fail-after=-1 --gauge sim",
            "give sim, sim:fail-after=N",
        ),
        (
            "--stage sim:reset --gauge sim",
            "give sim, sim:fail-after=N",
        ),
        // A twin never measures a real instrument, nor the reverse.
        (
            "--stage sim --gauge /dev/null",
            "a real gauge (/dev/null) on the simulated stage measures nothing",
        ),
        (
            "--stage /dev/null --stage-min 0 --stage-max 20 --contact 5 --gauge sim",
            "the simulated gauge cannot see the real stage on /dev/null",
        ),
        // A real stage's limits and contact are the rig's, never guessed.
        (
            "--stage /dev/null --gauge /dev/null",
            "give the stage's soft limits with both --stage-min and --stage-max",
        ),
        (
            "--stage /dev/null --stage-min 0 --stage-max 20 --gauge /dev/null",
            "give --contact",
        ),
        // Positions: checked against the limits and the protocol's depths.
        (
            "--stage sim --gauge sim --contact 25",
            "the deepest push (--contact + the protocol's max_mm) at 35 mm is outside the stage's soft limits 0..=30 mm",
        ),
        (
            "--stage sim --gauge sim --contact 5 --rest 6",
            "--rest 6 mm is past --contact 5 mm",
        ),
        (
            "--stage sim --gauge sim --rest -1",
            "--rest at -1 mm is outside the stage's soft limits 0..=30 mm",
        ),
        (
            "--stage sim --gauge sim --contact nan",
            "--contact and --rest must be finite",
        ),
        (
            "--stage sim --gauge sim --stage-speed 0",
            "stage speed 0 mm/s is outside 0.01..=50 mm/s",
        ),
        (
            "--stage sim --gauge sim --stage-speed inf",
            "stage speed inf mm/s is outside",
        ),
        (
            "--stage sim --gauge sim --stage-min 5 --stage-max 1",
            "stage limits must be finite with min < max",
        ),
        (
            "--stage sim --gauge sim --stage-axis D",
            "'D' is not an axis",
        ),
    ];
    let mut v: Vec<Case> = instruments
        .iter()
        .zip('a'..)
        .map(|((flags, want), id)| c(EXP3_INSTRUMENTS, run(&id.to_string(), flags)).err(want))
        .collect();
    v.extend([
        // Only a protocol with the method of adjustment pushes.
        c(EXP3_INSTRUMENTS, na("s", "--stage sim --gauge sim")).err(
            "--stage and --gauge run the method of adjustment ([adjustment]), which it has not",
        ),
        // 2. The finger flags `session` takes, checked as there.
        c(EXP3_SOURCES, run("t", "--depth {dir}/exp3/none.npy")).err("exclude each other"),
        c(EXP3_SOURCES, na("u", "--depth {dir}/exp3/none.npy"))
            .err("--scene is needed with --depth, --camera and --depth-stream"),
        c(EXP3_SOURCES, na("v", "--intrinsics {dir}/exp3/gap.csv"))
            .err("--intrinsics and --timestamps apply to --depth only"),
        c(
            EXP3_SOURCES,
            "study run {dir}/paper/na.toml --port autd3:emulator --out {dir}/exp3/out \
             --responses - --participant w --depth-stream - --scene {scenes}/paper.toml"
                .to_owned(),
        )
        .err("--depth-stream - reads stdin, so the answers need --responses FILE"),
        c(EXP3_SOURCES, na("x", "--synthetic --udp 9")).err("cannot be used with"),
        c(EXP3_SOURCES, na("y", "--stream {dir}/exp3/missing.csv")).err("missing.csv"),
    ]);
    v
}
