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
    let c = |class: &'static str, args: String| case(class, &args);
    vec![
        // 1. The instruments: both or neither, specs read strictly.
        c(EXP3_INSTRUMENTS, run("a", "--stage sim")).err("--gauge"),
        c(EXP3_INSTRUMENTS, run("b", "--gauge sim")).err("--stage"),
        c(EXP3_INSTRUMENTS, run("c", "--contact 3")).err("--stage"),
        c(EXP3_INSTRUMENTS, run("d", "--stage sim:fail-after=x --gauge sim"))
            .err("stage `sim:fail-after=x`: give sim, sim:fail-after=N"),
        c(EXP3_INSTRUMENTS, run("e", "--stage sim:fail-after=-1 --gauge sim"))
            .err("give sim, sim:fail-after=N"),
        c(EXP3_INSTRUMENTS, run("f", "--stage sim:reset --gauge sim"))
            .err("give sim, sim:fail-after=N"),
        // A twin never measures a real instrument, nor the reverse.
        c(EXP3_INSTRUMENTS, run("g", "--stage sim --gauge /dev/null"))
            .err("a real gauge (/dev/null) on the simulated stage measures nothing"),
        c(
            EXP3_INSTRUMENTS,
            run(
                "h",
                "--stage /dev/null --stage-min 0 --stage-max 20 --contact 5 --gauge sim",
            ),
        )
        .err("the simulated gauge cannot see the real stage on /dev/null"),
        // A real stage's limits and contact are the rig's, never guessed.
        c(EXP3_INSTRUMENTS, run("i", "--stage /dev/null --gauge /dev/null"))
            .err("give the stage's soft limits with both --stage-min and --stage-max"),
        c(
            EXP3_INSTRUMENTS,
            run("j", "--stage /dev/null --stage-min 0 --stage-max 20 --gauge /dev/null"),
        )
        .err("give --contact"),
        // Positions: checked against the limits and the protocol's depths.
        c(EXP3_INSTRUMENTS, run("k", "--stage sim --gauge sim --contact 25"))
            .err("the deepest push (--contact + the protocol's max_mm) at 35 mm is outside the stage's soft limits 0..30 mm"),
        c(EXP3_INSTRUMENTS, run("l", "--stage sim --gauge sim --contact 5 --rest 6"))
            .err("--rest 6 mm is past --contact 5 mm"),
        c(EXP3_INSTRUMENTS, run("m", "--stage sim --gauge sim --rest -1"))
            .err("--rest at -1 mm is outside the stage's soft limits 0..30 mm"),
        c(EXP3_INSTRUMENTS, run("n", "--stage sim --gauge sim --contact nan"))
            .err("--contact and --rest must be finite"),
        c(EXP3_INSTRUMENTS, run("o", "--stage sim --gauge sim --stage-speed 0"))
            .err("stage speed 0 mm/s is outside 0.01..50 mm/s"),
        c(EXP3_INSTRUMENTS, run("p", "--stage sim --gauge sim --stage-speed inf"))
            .err("stage speed inf mm/s is outside"),
        c(
            EXP3_INSTRUMENTS,
            run("q", "--stage sim --gauge sim --stage-min 5 --stage-max 1"),
        )
        .err("stage limits must be finite with min < max"),
        c(EXP3_INSTRUMENTS, run("r", "--stage sim --gauge sim --stage-axis D"))
            .err("'D' is not an axis"),
        // Only a protocol with the method of adjustment pushes.
        c(
            EXP3_INSTRUMENTS,
            "study run {dir}/paper/na.toml --port autd3:emulator --out {dir}/exp3/out \
             --responses {dir}/paper/na_ok.txt --participant s --stage sim --gauge sim"
                .to_owned(),
        )
        .err("--stage and --gauge run the method of adjustment ([adjustment]), which it has not"),
        // 2. The finger flags `session` takes, checked as there.
        c(EXP3_SOURCES, run("t", "--depth {dir}/exp3/none.npy"))
            .err("exclude each other"),
        c(
            EXP3_SOURCES,
            "study run {dir}/paper/na.toml --port autd3:emulator --out {dir}/exp3/out \
             --responses {dir}/paper/na_ok.txt --participant u --depth {dir}/exp3/none.npy"
                .to_owned(),
        )
        .err("--scene is needed with --depth, --camera and --depth-stream"),
        c(
            EXP3_SOURCES,
            "study run {dir}/paper/na.toml --port autd3:emulator --out {dir}/exp3/out \
             --responses {dir}/paper/na_ok.txt --participant v --intrinsics {dir}/exp3/gap.csv"
                .to_owned(),
        )
        .err("--intrinsics and --timestamps apply to --depth only"),
        c(
            EXP3_SOURCES,
            "study run {dir}/paper/na.toml --port autd3:emulator --out {dir}/exp3/out \
             --responses - --participant w --depth-stream - --scene {scenes}/paper.toml"
                .to_owned(),
        )
        .err("--depth-stream - reads stdin, so the answers need --responses FILE"),
        c(
            EXP3_SOURCES,
            "study run {dir}/paper/na.toml --port autd3:emulator --out {dir}/exp3/out \
             --responses {dir}/paper/na_ok.txt --participant x --synthetic --udp 9"
                .to_owned(),
        )
        .err("cannot be used with"),
        c(
            EXP3_SOURCES,
            "study run {dir}/paper/na.toml --port autd3:emulator --out {dir}/exp3/out \
             --responses {dir}/paper/na_ok.txt --participant y --stream {dir}/exp3/missing.csv"
                .to_owned(),
        )
        .err("missing.csv"),
    ]
}
