//! Round 4, the study's data (issues 31.5, 31.6, 30): `study run --resume`
//! checks before it changes anything, labels and answers are told apart as
//! they are matched, `study report` summarises only values its columns
//! accept and names every folder it skips, every study file is read
//! bounded and regular-only, counts are checked, and number errors name
//! their field.
//!
//! The fixtures are one real 4-trial run of a small protocol on autd3's
//! emulator (`{dir}/study/out/P1`), copied per case under another
//! participant id, then cut, edited or replaced by a FIFO.

use super::*;

/// `study run` of the small protocol: 4 trials, a Likert and a number
/// question each (8 answers).
const RUN: &str = "study run {dir}/study/mini.toml --port autd3:emulator --out {dir}/study/out \
                   --time-scale 0.02 --responses";

pub(crate) fn study_cases() -> Vec<Case> {
    let run = |answers: &str, id: &str| format!("{RUN} {{dir}}/study/{answers} --participant {id}");
    let resume = |id: &str| format!("{} --resume", run("ans.txt", id));
    let c = |class: &'static str, args: String| case(class, &args);
    let proto = |name: &str| {
        format!(
            "study run {{dir}}/study/{name}.toml --port autd3:emulator --out {{dir}}/study/out \
             --responses {{dir}}/study/ans.txt --participant {name}"
        )
    };
    let report = |d: &str| format!("study report {{dir}}/study/{d}");
    vec![
        // 1. --resume validates first, cuts only a provably torn tail, and
        //    counts answers from their own column.
        c(STUDY_RESUME, resume("torn"))
            .ok()
            .err("resuming at trial 4")
            .check(torn_resumed),
        c(STUDY_RESUME, resume("torn_seed") + " --seed 9")
            .err("--seed 9")
            .check(unchanged),
        c(STUDY_RESUME, resume("garbage"))
            .err("not the start of this protocol's header")
            .err("nothing was changed")
            .check(unchanged),
        c(STUDY_RESUME, resume("garbage_tail"))
            .err("is neither a whole row nor the start of trial 3")
            .check(unchanged),
        c(STUDY_RESUME, resume("swapped"))
            .err("line 2: column `trial` is `2`")
            .check(unchanged),
        c(STUDY_RESUME, resume("count"))
            .err("column `answers` is `3`, but the row holds 2 answers")
            .check(unchanged),
        c(STUDY_RESUME, resume("no_header"))
            .ok()
            .err("4 trials")
            .check(header_rewritten),
        c(
            STUDY_RESUME,
            "study run {dir}/study/adjust.toml --port autd3:emulator --out {dir}/study/out \
             --time-scale 0.02 --responses {dir}/study/adjust.txt --participant adj --resume"
                .to_owned(),
        )
        .ok()
        .err("resuming at trial 2")
        .check(adjust_resumed),
        // 2. Labels are checked as answers are matched; no answer is left over.
        c(STUDY_LABELS, proto("same_case"))
            .err("`same` and `Same`")
            .err("field `adjustment.same`"),
        c(STUDY_LABELS, proto("numeric_label"))
            .err("`3` is a number")
            .err("field `adjustment.same`"),
        c(STUDY_LABELS, proto("pipe_label")).err("holds `|`"),
        c(STUDY_LABELS, proto("choice_case")).err("`same` and `Same` are the same answer"),
        c(STUDY_LABELS, proto("choice_number")).err("`2` is a number"),
        c(STUDY_LABELS, run("extra.txt", "extra"))
            .err("extra.txt line 9: `9` is left over")
            .check(no_extra_folder),
        c(STUDY_LABELS, run("extra.txt", "torn_extra") + " --resume")
            .err("line 9: `9` is left over")
            .check(unchanged),
        c(STUDY_LABELS, run("few.txt", "torn_few") + " --resume")
            .err("ended at line 8")
            .check(unchanged),
        // 3. study report: finite, in-range values; every skipped folder named.
        c(STUDY_REPORT, report("rep_inf")).err("column `guess`: `inf`"),
        c(STUDY_REPORT, report("rep_huge")).err("`1e308`: give a number from -1e12 to 1e12"),
        c(STUDY_REPORT, report("rep_99")).err("column `vibration`: `99`: give 1 to 7"),
        c(STUDY_REPORT, report("rep_x")).err("column `guess`: `x`"),
        c(STUDY_REPORT, report("rep_skips"))
            .ok()
            .err("skipped")
            .err("no_session")
            .err("FIFO")
            .err("1 participants")
            .out("summary.csv"),
        c(STUDY_REPORT, report("rep_none"))
            .err("no participant folder")
            .err("no_session"),
        c(STUDY_REPORT, report("rep_torn"))
            .ok()
            .err("torn row")
            .err("3 trials"),
        // 4. Every study file is read bounded and regular-only.
        c(STUDY_READS, resume("fifo_session"))
            .err("session.json")
            .err("FIFO"),
        c(STUDY_READS, resume("zero_session")).err("device node"),
        c(STUDY_READS, resume("fifo_trials"))
            .err("trials.csv")
            .err("FIFO"),
        c(STUDY_READS, resume("zero_trials")).err("device node"),
        c(STUDY_READS, resume("fifo_events"))
            .err("events.jsonl")
            .err("FIFO"),
        c(STUDY_READS, resume("huge_trials")).err("larger than"),
        c(STUDY_READS, report("rep_fifo/A")).err("FIFO"),
        c(STUDY_READS, run("fifo", "fifo_answers")).err("FIFO"),
        // 5. Counts are checked, not wrapped.
        c(STUDY_COUNTS, proto("factors64")).err("conditions; a protocol has 1 to 1000"),
        c(STUDY_COUNTS, proto("factors2000")).err("2 factors give 2000 conditions"),
        c(STUDY_COUNTS, proto("sets0")).err("field `sets`: 0 is out of range"),
        // 6. Number errors name their field (and line).
        c(STUDY_NUMBERS, proto("sets_float")).err("line 3, field `sets`"),
        c(STUDY_NUMBERS, proto("iti_huge")).err("field `timeline.iti_s`: -1e308 is out of range"),
        c(STUDY_NUMBERS, proto("points_float")).err("field `question[0].points`"),
        c(STUDY_NUMBERS, resume("seed_text")).err("field `seed`"),
        c(STUDY_NUMBERS, resume("trial_float")).err("column `trial` is `1e3`"),
        c(STUDY_NUMBERS, run("huge_number.txt", "huge_number"))
            .err("huge_number.txt line 2")
            .err("`guess`"),
    ]
}

/// A check does not know its case's participant, so each fixture a resume
/// must refuse keeps its original beside it ([`keep`]): every
/// `NAME/trials.csv` must still equal `NAME/trials.csv.orig`.
fn unchanged(ctx: &Ctx, _: &Run) -> Result<(), String> {
    for e in std::fs::read_dir(ctx.dir.join("study/out")).map_err(|e| e.to_string())? {
        let d = e.map_err(|e| e.to_string())?.path();
        let orig = d.join("trials.csv.orig");
        if !orig.exists() {
            continue;
        }
        let now = std::fs::read(d.join("trials.csv")).map_err(|e| e.to_string())?;
        if now != std::fs::read(&orig).map_err(|e| e.to_string())? {
            return Err(format!("{} was changed by a refused resume", d.display()));
        }
    }
    Ok(())
}

fn rows(path: &Path) -> Result<Vec<Vec<String>>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| e.to_string())?;
    if !text.ends_with('\n') {
        return Err(format!("{} does not end in a whole row", path.display()));
    }
    Ok(text
        .lines()
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect())
}

/// The torn fourth row was cut and trial 4 ran again with the 7th and 8th
/// answers (6 skipped: the `answers` column of three rows).
fn torn_resumed(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let r = rows(&ctx.dir.join("study/out/torn/trials.csv"))?;
    let last = r.last().ok_or("no rows")?;
    let at = |c: &str| r[0].iter().position(|h| h == c).unwrap_or(0);
    if r.len() != 5
        || last[1] != "4"
        || (&*last[at("vibration")], &*last[at("guess")]) != ("7", "1")
    {
        return Err(format!("after the resume: {r:?}"));
    }
    Ok(())
}

/// A header cut short starts the file again: four whole rows.
fn header_rewritten(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let r = rows(&ctx.dir.join("study/out/no_header/trials.csv"))?;
    if r.len() != 5 || r[0][0] != "participant" {
        return Err(format!("after the resume: {r:?}"));
    }
    Ok(())
}

/// Trial 1 took two adjustment answers (`stronger`, `same`): trial 2
/// starts at the third line, `weaker`.
fn adjust_resumed(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let text = std::fs::read_to_string(ctx.dir.join("study/out/adj/trials.csv"))
        .map_err(|e| e.to_string())?;
    // The adjustment's columns, then its response times and force_n.
    let last = text.lines().last().unwrap_or_default();
    if !last.contains(",weaker|same,4.00|4.25,4.25,") || text.lines().count() != 3 {
        return Err(format!("after the resume: {text}"));
    }
    Ok(())
}

fn no_extra_folder(ctx: &Ctx, _: &Run) -> Result<(), String> {
    if ctx.dir.join("study/out/extra").exists() {
        return Err("a refused run left a folder".into());
    }
    Ok(())
}

/// The small protocol (2 radii in 2 sets: 4 trials), passed through `edit`.
fn mini(library: &Path, edit: &dyn Fn(String) -> String) -> String {
    edit(format!(
        "name = \"mini\"\nlibrary = \"{}\"\nsets = 2\nstimulus = \"lms-5hz-a{{radius}}\"\n\n\
         [timeline]\non_s = 0.5\niti_s = 0.0\ngate = \"untracked\"\n\n\
         [[factor]]\nname = \"radius\"\nlevels = [\"2\", \"3\"]\n\n\
         [[question]]\nid = \"vibration\"\nkind = \"likert\"\npoints = 7\n\n\
         [[question]]\nid = \"guess\"\nkind = \"number\"\n",
        library.display()
    ))
}

fn adjust(library: &Path, labels: &str) -> String {
    format!(
        "name = \"adjust\"\nlibrary = \"{}\"\nsets = 1\nstimulus = \"lms-5hz-a{{radius}}\"\n\n\
         [timeline]\non_s = 0.5\noff_s = 0.5\niti_s = 0.0\ngate = \"untracked\"\n\n\
         [[factor]]\nname = \"radius\"\nlevels = [\"2\", \"3\"]\n\n\
         [adjustment]\nstart_mm = 4.0\n{labels}",
        library.display()
    )
}

fn study_run(dir: &Path, protocol: &str, answers: &str, id: &str) {
    let o = Command::new(lmhost())
        .args(["study", "run"])
        .arg(dir.join(protocol))
        .args(["--port", "autd3:emulator", "--out"])
        .arg(dir.join("out"))
        .arg("--responses")
        .arg(dir.join(answers))
        .args(["--participant", id, "--seed", "3", "--time-scale", "0.02"])
        .env_remove("LMHOST_PORT")
        .output()
        .expect("running the study fixture");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// A copy of participant folder `src` as participant `id` in `out` (its id
/// in both files), its `trials.csv` passed through `edit`.
fn variant(src: &Path, out: &Path, id: &str, edit: impl Fn(String) -> String) -> PathBuf {
    let d = out.join(id);
    std::fs::create_dir_all(&d).unwrap();
    let from = src.file_name().unwrap().to_str().unwrap();
    let session = std::fs::read_to_string(src.join("session.json")).unwrap();
    std::fs::write(
        d.join("session.json"),
        session.replace(
            &format!("\"participant\": \"{from}\""),
            &format!("\"participant\": \"{id}\""),
        ),
    )
    .unwrap();
    std::fs::copy(src.join("events.jsonl"), d.join("events.jsonl")).unwrap();
    let trials = std::fs::read_to_string(src.join("trials.csv"))
        .unwrap()
        .replace(&format!("\n{from},"), &format!("\n{id},"));
    let trials = edit(trials);
    std::fs::write(d.join("trials.csv"), trials).unwrap();
    d
}

/// Keeps `d`'s `trials.csv` as it is now, for [`unchanged`].
fn keep(d: PathBuf) {
    std::fs::copy(d.join("trials.csv"), d.join("trials.csv.orig")).unwrap();
}

fn fifo(path: &Path) {
    let _ = std::fs::remove_file(path);
    assert!(Command::new("mkfifo").arg(path).status().unwrap().success());
}

/// Cuts the last `n` bytes (a row's write cut short by `kill -9`).
fn cut(n: usize) -> impl Fn(String) -> String {
    move |s: String| s[..s.len() - n].to_owned()
}

/// Replaces the answers `from` (`vibration,guess`) of data line `line` by
/// `to` (each answer is followed by its response time in the row).
fn value(line: usize, from: &'static str, to: &'static str) -> impl Fn(String) -> String {
    move |s: String| {
        let (from, to): (Vec<&str>, Vec<&str>) =
            (from.split(',').collect(), to.split(',').collect());
        let mut s = s;
        for (column, (f, t)) in ["vibration", "guess"].iter().zip(from.iter().zip(&to)) {
            s = field(line, column, f, t)(s);
        }
        s
    }
}

/// Replaces the value `from` of column `column` in data line `line` by `to`.
pub(crate) fn field<'a>(
    line: usize,
    column: &'a str,
    from: &'a str,
    to: &'a str,
) -> impl Fn(String) -> String + 'a {
    move |s: String| {
        let mut l: Vec<String> = s.lines().map(str::to_owned).collect();
        let at = l[0].split(',').position(|h| h == column).unwrap();
        let mut f: Vec<&str> = l[line].split(',').collect();
        assert_eq!(f[at], from, "{column} in {}", l[line]);
        f[at] = to;
        l[line] = f.join(",");
        l.join("\n") + "\n"
    }
}

pub(crate) fn study_fixtures(dir: &Path) {
    let dir = dir.join("study");
    std::fs::create_dir_all(&dir).unwrap();
    let library = Path::new(env!("CARGO_MANIFEST_DIR")).join("../studies/paper-library.toml");
    let w = |name: &str, body: String| std::fs::write(dir.join(name), body).unwrap();
    let same = |s: String| s;
    w("mini.toml", mini(&library, &same));
    // Likert, number: trial answers 1 2 | 3 4 | 5 6 | 7 1.
    w("ans.txt", "1\n2\n3\n4\n5\n6\n7\n1\n".into());
    w("extra.txt", "1\n2\n3\n4\n5\n6\n7\n1\n9\n\n".into());
    w("few.txt", "1\n2\n3\n4\n5\n6\n7\n".into());
    w("huge_number.txt", "1\n1e999\n".into());
    fifo(&dir.join("fifo"));
    let out = dir.join("out");
    study_run(&dir, "mini.toml", "ans.txt", "P1");
    let p1 = out.join("P1");
    // --resume: a torn fourth row; garbage; a refused resume; rows wrong.
    let row4 = 30;
    variant(&p1, &out, "torn", cut(row4));
    for id in ["torn_seed", "torn_extra", "torn_few"] {
        keep(variant(&p1, &out, id, cut(row4)));
    }
    keep(variant(&p1, &out, "garbage", |_| "garbage".into()));
    keep(variant(&p1, &out, "garbage_tail", |s| {
        let l: Vec<&str> = s.lines().collect();
        l[..3].join("\n") + "\n#garbage"
    }));
    keep(variant(&p1, &out, "swapped", |s| {
        let l: Vec<&str> = s.lines().collect();
        [l[0], l[2], l[1]].join("\n") + "\n"
    }));
    keep(variant(&p1, &out, "count", field(1, "answers", "2", "3")));
    variant(&p1, &out, "no_header", |s| s[..20].to_owned());
    // Number errors in session.json and trials.csv.
    let d = variant(&p1, &out, "seed_text", same);
    let s = std::fs::read_to_string(d.join("session.json")).unwrap();
    std::fs::write(
        d.join("session.json"),
        s.replace("\"seed\": 3", "\"seed\": -3"),
    )
    .unwrap();
    keep(d);
    keep(variant(&p1, &out, "trial_float", |s| {
        s.replacen("\ntrial_float,1,", "\ntrial_float,1e3,", 1)
    }));
    // Reads: FIFOs, device nodes, a file larger than the session wrote.
    let d = variant(&p1, &out, "fifo_session", same);
    fifo(&d.join("session.json"));
    let d = variant(&p1, &out, "zero_session", same);
    std::fs::remove_file(d.join("session.json")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", d.join("session.json")).unwrap();
    let d = variant(&p1, &out, "fifo_trials", same);
    fifo(&d.join("trials.csv"));
    let d = variant(&p1, &out, "zero_trials", same);
    std::fs::remove_file(d.join("trials.csv")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", d.join("trials.csv")).unwrap();
    let d = variant(&p1, &out, "fifo_events", cut(row4));
    fifo(&d.join("events.jsonl"));
    keep(d);
    let d = variant(&p1, &out, "huge_trials", same);
    let f = std::fs::OpenOptions::new()
        .write(true)
        .open(d.join("trials.csv"))
        .unwrap();
    f.set_len(2 << 30).unwrap();
    // study report: values out of range, skipped folders, a torn row.
    for (name, edit) in [
        ("rep_inf", value(1, "1,2", "1,inf")),
        ("rep_huge", value(1, "1,2", "1,1e308")),
        ("rep_99", value(1, "1,2", "99,2")),
        ("rep_x", value(1, "1,2", "1,x")),
    ] {
        variant(&p1, &dir.join(name), "A", edit);
    }
    for name in ["rep_skips", "rep_none", "rep_fifo", "rep_torn"] {
        std::fs::create_dir_all(dir.join(name).join("no_session")).unwrap();
        let d = variant(&p1, &dir.join(name), "fifo", same);
        fifo(&d.join("trials.csv"));
    }
    variant(&p1, &dir.join("rep_skips"), "A", same);
    let d = variant(&p1, &dir.join("rep_fifo"), "A", same);
    fifo(&d.join("session.json"));
    variant(&p1, &dir.join("rep_torn"), "A", cut(row4));
    // Protocols: labels, counts, numbers.
    let labels = |s: &str| "stronger = \"stronger\"\nweaker = \"weaker\"\n".to_owned() + s;
    w(
        "same_case.toml",
        adjust(
            &library,
            "stronger = \"Same\"\nweaker = \"weaker\"\nsame = \"same\"\n",
        ),
    );
    w(
        "numeric_label.toml",
        adjust(&library, &labels("same = \"3\"\n")),
    );
    w(
        "pipe_label.toml",
        adjust(&library, &labels("same = \"a|b\"\n")),
    );
    let choice = |opts: &str| {
        let o = opts.to_owned();
        move |s: String| {
            format!("{s}\n[[question]]\nid = \"pick\"\nkind = \"choice\"\noptions = {o}\n")
        }
    };
    w(
        "choice_case.toml",
        mini(&library, &choice("[\"Same\", \"same\"]")),
    );
    w(
        "choice_number.toml",
        mini(&library, &choice("[\"flat\", \"2\"]")),
    );
    w(
        "factors64.toml",
        mini(&library, &|s: String| {
            let mut s = s.replace("{radius}", "2");
            for i in 0..64 {
                s += &format!("\n[[factor]]\nname = \"f{i}\"\nlevels = [\"a\", \"b\"]\n");
            }
            s
        }),
    );
    let levels: Vec<String> = (0..1000).map(|i| format!("\"l{i}\"")).collect();
    w(
        "factors2000.toml",
        mini(&library, &|s: String| {
            s.replace("[\"2\", \"3\"]", &format!("[{}]", levels.join(", ")))
                + "\n[[factor]]\nname = \"g\"\nlevels = [\"a\", \"b\"]\n"
        }),
    );
    w(
        "sets0.toml",
        mini(&library, &|s: String| s.replace("sets = 2", "sets = 0")),
    );
    w(
        "sets_float.toml",
        mini(&library, &|s: String| s.replace("sets = 2", "sets = 2.5")),
    );
    w(
        "iti_huge.toml",
        mini(&library, &|s: String| {
            s.replace("iti_s = 0.0", "iti_s = -1e308")
        }),
    );
    w(
        "points_float.toml",
        mini(&library, &|s: String| {
            s.replace("points = 7", "points = 7.5")
        }),
    );
    // An adjustment session of 2 trials killed in its second row; trial 1
    // took `stronger`, `same`: the resume must skip exactly two answers.
    w("adjust.toml", adjust(&library, ""));
    w("adjust.txt", "stronger\nsame\nweaker\nsame\n".into());
    study_run(&dir, "adjust.toml", "adjust.txt", "adj");
    let t = out.join("adj/trials.csv");
    let text = std::fs::read_to_string(&t).unwrap();
    std::fs::write(&t, &text[..text.len() - 10]).unwrap();
}
