//! Round 4, the paper's experiments (issue 28): "not perceived" answers
//! only where a question allows them, `--responses -` read a bounded line
//! at a time as asked, the report's `[report]` table checked with line and
//! field, and `--resume` refusing a different rig unless told to go on
//! (and then recording it).
//!
//! Fixtures in `{dir}/paper`: the small study protocol with `na` allowed
//! on its Likert question, and one real run of it to resume.

use super::*;

const RUN: &str =
    "study run {dir}/paper/na.toml --port autd3:emulator --out {dir}/paper/out --time-scale 0.02";
/// The same at another time scale (the resumed rig's).
const RUN_SLOWER: &str =
    "study run {dir}/paper/na.toml --port autd3:emulator --out {dir}/paper/out --time-scale 0.03";

pub(crate) fn paper_cases() -> Vec<Case> {
    let c = |class: &'static str, args: String| case(class, &args);
    let proto = |name: &str| {
        format!(
            "study run {{dir}}/paper/{name}.toml --port autd3:emulator --out {{dir}}/paper/out \
             --responses {{dir}}/paper/na_ok.txt --participant {name}"
        )
    };
    let resume = |id: &str| {
        format!("{RUN_SLOWER} --responses {{dir}}/paper/na_ok.txt --participant {id} --resume")
    };
    vec![
        // 1. "Not perceived": its own value where allowed, refused elsewhere
        //    before the device opens.
        c(
            PAPER_ANSWERS,
            format!("{RUN} --responses {{dir}}/paper/na_ok.txt --participant ok"),
        )
        .ok()
        .check(na_recorded),
        c(
            PAPER_ANSWERS,
            format!("{RUN} --responses {{dir}}/paper/na_guess.txt --participant g"),
        )
        .err("na_guess.txt line 2: `na` is not an answer to `guess`"),
        c(
            PAPER_ANSWERS,
            "study run {dir}/study/mini.toml --port autd3:emulator --out {dir}/paper/out \
             --responses {dir}/paper/na_ok.txt --participant strict"
                .to_owned(),
        )
        .err("line 1: `na` is not an answer to `vibration`: give 1 to 7"),
        c(PAPER_ANSWERS, proto("empty_label")).err("field `question[0].not_perceived`"),
        c(PAPER_ANSWERS, proto("na_option"))
            .err("option `NA` is what \"not perceived\" is typed as"),
        // `--responses -` reads stdin as answers are asked (mid-run
        // failures of its lines are in tests/study.rs): stdin cannot also
        // be the finger's stream.
        c(
            PAPER_ANSWERS,
            format!("{RUN} --responses - --stream - --participant both"),
        )
        .err("--stream - reads stdin, so the answers need --responses FILE"),
        // 2. [report]: checked with line and field.
        c(PAPER_REPORT, proto("alpha")).err("field `report.alpha`: 0 is not a significance level"),
        c(PAPER_REPORT, proto("friedman2"))
            .err("field `report.friedman`: factor `radius` has 2 levels"),
        c(PAPER_REPORT, proto("pairs_factor"))
            .err("field `report.pairs[0].factor`: `colour` is not a factor"),
        c(PAPER_REPORT, proto("pairs_level")).err("`7` is not a level of factor `radius`"),
        c(PAPER_REPORT, proto("report_key")).err("unknown field `tests`"),
        c(PAPER_REPORT, "study report {dir}/paper/out/R1".to_owned())
            .ok()
            .out("stats.csv")
            .out("stats.json")
            .out("stats.txt"),
        // 3. A different rig is refused with what differs, files as they
        //    were; --resume-anyway goes on and records it.
        c(PAPER_RIG, resume("rig"))
            .err("the time scale (0.02 then, 0.03 now)")
            .err("--resume-anyway")
            .check(rig_unchanged),
        c(PAPER_RIG, resume("rig_anyway") + " --resume-anyway")
            .ok()
            .err("warning: --resume-anyway")
            .check(rig_recorded),
        c(
            PAPER_RIG,
            format!("{RUN} --responses {{dir}}/paper/na_ok.txt --participant x --resume-anyway"),
        )
        .err("--resume"),
    ]
}

fn na_recorded(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let t = std::fs::read_to_string(ctx.dir.join("paper/out/ok/trials.csv"))
        .map_err(|e| e.to_string())?;
    let head: Vec<&str> = t.lines().next().unwrap_or_default().split(',').collect();
    let at = head
        .iter()
        .position(|h| *h == "vibration")
        .ok_or("no vibration")?;
    let first = t.lines().nth(1).ok_or("no row")?;
    match first.split(',').nth(at) {
        Some("na") => Ok(()),
        v => Err(format!("vibration is {v:?}, not na")),
    }
}

fn rig_unchanged(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let d = ctx.dir.join("paper/out/rig");
    let now = std::fs::read(d.join("trials.csv")).map_err(|e| e.to_string())?;
    let s = std::fs::read_to_string(d.join("session.json")).map_err(|e| e.to_string())?;
    if now != std::fs::read(d.join("trials.csv.orig")).map_err(|e| e.to_string())? {
        return Err("trials.csv was changed by a refused resume".into());
    }
    if s.matches("\"first_trial\"").count() != 1 {
        return Err("a refused resume added a run to session.json".into());
    }
    Ok(())
}

fn rig_recorded(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let s = std::fs::read_to_string(ctx.dir.join("paper/out/rig_anyway/session.json"))
        .map_err(|e| e.to_string())?;
    if !s.contains("\"resumed_anyway\": \"the time scale (0.02 then, 0.03 now)\"") {
        return Err(format!("session.json does not record the resume: {s}"));
    }
    Ok(())
}

pub(crate) fn paper_fixtures(dir: &Path) {
    let dir = dir.join("paper");
    std::fs::create_dir_all(&dir).unwrap();
    let library = Path::new(env!("CARGO_MANIFEST_DIR")).join("../studies/paper-library.toml");
    let w = |name: &str, body: String| std::fs::write(dir.join(name), body).unwrap();
    let base = format!(
        "name = \"na\"\nlibrary = \"{}\"\nsets = 2\nstimulus = \"lms-5hz-a{{radius}}\"\n\n\
         [timeline]\non_s = 0.5\niti_s = 0.0\ngate = \"untracked\"\n\n\
         [[factor]]\nname = \"radius\"\nlevels = [\"2\", \"3\"]\n\n\
         [[question]]\nid = \"vibration\"\nkind = \"likert\"\npoints = 7\n\
         not_perceived = \"could not perceive\"\n\n\
         [[question]]\nid = \"guess\"\nkind = \"number\"\n",
        library.display()
    );
    w("na.toml", base.clone());
    w("na_ok.txt", "na\n2\n3\n4\nna\n6\n7\n1\n".into());
    w("na_guess.txt", "1\nna\n3\n4\n5\n6\n7\n1\n".into());
    w(
        "empty_label.toml",
        base.replace(
            "not_perceived = \"could not perceive\"",
            "not_perceived = \"\"",
        ),
    );
    w(
        "na_option.toml",
        base.replace(
            "[[question]]\nid = \"guess\"\nkind = \"number\"\n",
            "[[question]]\nid = \"guess\"\nkind = \"choice\"\noptions = [\"yes\", \"NA\"]\n\
             not_perceived = \"could not perceive\"\n",
        ),
    );
    w("alpha.toml", base.clone() + "\n[report]\nalpha = 0.0\n");
    w(
        "friedman2.toml",
        base.clone() + "\n[report]\nfriedman = [\"radius\"]\n",
    );
    w(
        "pairs_factor.toml",
        base.clone() + "\n[[report.pairs]]\nfactor = \"colour\"\n",
    );
    w(
        "pairs_level.toml",
        base.clone() + "\n[[report.pairs]]\nfactor = \"radius\"\npairs = [[\"2\", \"7\"]]\n",
    );
    w("report_key.toml", base.clone() + "\n[report]\ntests = 3\n");
    // One real run (time scale 0.02), copied with its last row torn for
    // the resume cases.
    let o = Command::new(lmhost())
        .args(["study", "run"])
        .arg(dir.join("na.toml"))
        .args(["--port", "autd3:emulator", "--out"])
        .arg(dir.join("out"))
        .arg("--responses")
        .arg(dir.join("na_ok.txt"))
        .args(["--participant", "R1", "--seed", "3", "--time-scale", "0.02"])
        .env_remove("LMHOST_PORT")
        .output()
        .expect("running the paper fixture");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let src = dir.join("out/R1");
    for id in ["rig", "rig_anyway"] {
        let d = dir.join("out").join(id);
        std::fs::create_dir_all(&d).unwrap();
        let session = std::fs::read_to_string(src.join("session.json")).unwrap();
        std::fs::write(
            d.join("session.json"),
            session.replace(
                "\"participant\": \"R1\"",
                &format!("\"participant\": \"{id}\""),
            ),
        )
        .unwrap();
        std::fs::copy(src.join("events.jsonl"), d.join("events.jsonl")).unwrap();
        let t = std::fs::read_to_string(src.join("trials.csv"))
            .unwrap()
            .replace("\nR1,", &format!("\n{id},"));
        // Three whole rows and the start of the fourth.
        let torn = &t[..t.len() - 30];
        std::fs::write(d.join("trials.csv"), torn).unwrap();
        std::fs::write(d.join("trials.csv.orig"), torn).unwrap();
    }
}
