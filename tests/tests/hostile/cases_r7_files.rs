//! Round 7a, a sweep of every field of every input file (scene, stimulus
//! library, study protocol, camera intrinsics, points file, phases and
//! foci, centroid streams, depth recordings, `trials.csv` on `--resume`):
//! each field in turn given NaN, ±inf, -1, 0, ±1e300, 2^64, 2^63, 2^32,
//! empty, 100 000 characters, the wrong type, an empty or 100 000-element
//! array, a duplicate, an unknown key beside it, or deleted. One row per
//! class of what it found and per file kind the class hit.
//!
//! - A fixed-size vector is exactly its length: the TOML reader dropped
//!   what followed the third number of `center_mm = [0, 30, 30, 99]`.
//! - A file's value meets the rule its flag or its device has, where the
//!   file is named: a library's `radius = -1` passed `study check`, a scene's
//!   1e300 m/s sound speed `lmhost scene`, a camera 1e300 mm away
//!   everything; the AUTD3's dwell grid clamped a step wider than the
//!   circle (a flag's value, the same rule).
//! - An error names the line and the key, and what is wrong: intrinsics
//!   read through `serde(flatten)` lost both, an `.npy` header's wrong
//!   value was reported as a missing key, a 1000-dimension shape echoed.
//! - A key no reader reads is refused (an `.npy` header's fourth key).
//! - `--resume` keeps only rows a run could have written: a measured -1,
//!   a count of 1e300, an answer emptied after the run were kept.
//!
//! Fixtures in `{dir}/r7`.

use super::*;

/// The repository's file `rel` (from `tests/`).
fn repo(rel: &str) -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)).unwrap()
}

/// `text` with `from` replaced once by `to` (which must be there).
fn edit(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "fixture edit: `{from}` not found");
    text.replacen(from, to, 1)
}

/// An `.npy` of two 4 × 4 uint16 frames under header dict `dict` (the
/// broken ones named `.depth`: the suite checks every `.npy` is whole).
pub(super) fn npy(dict: &str) -> Vec<u8> {
    let mut h = dict.as_bytes().to_vec();
    while !(10 + h.len() + 1).is_multiple_of(64) {
        h.push(b' ');
    }
    h.push(b'\n');
    let mut b = b"\x93NUMPY\x01\x00".to_vec();
    b.extend((h.len() as u16).to_le_bytes());
    b.extend(&h);
    b.extend([0u8; 64]);
    b
}

/// Participant `P1` of the study fixtures as participant `id`, its
/// `trials.csv` cell (data line `line`, column `column`) set to `to`.
pub(super) fn resumed_copy(dir: &Path, id: &str, line: usize, column: &str, to: &str) {
    let out = dir.join("study/out");
    let d = out.join(id);
    std::fs::create_dir_all(&d).unwrap();
    let session = std::fs::read_to_string(out.join("P1/session.json")).unwrap();
    let session = edit(
        &session,
        "\"participant\": \"P1\"",
        &format!("\"participant\": \"{id}\""),
    );
    std::fs::write(d.join("session.json"), session).unwrap();
    std::fs::copy(out.join("P1/events.jsonl"), d.join("events.jsonl")).unwrap();
    let trials = std::fs::read_to_string(out.join("P1/trials.csv")).unwrap();
    let mut rows: Vec<Vec<String>> = trials
        .lines()
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect();
    let at = rows[0].iter().position(|h| h == column).unwrap();
    for r in rows.iter_mut().skip(1) {
        r[0] = id.to_owned();
    }
    rows[line][at] = to.to_owned();
    // The last trial cut away: there is something left to resume.
    rows.pop();
    let text: String = rows.iter().map(|r| r.join(",") + "\n").collect();
    std::fs::write(d.join("trials.csv"), text).unwrap();
}

pub(crate) fn files_fixtures(dir: &Path) {
    let r7 = dir.join("r7");
    std::fs::create_dir_all(&r7).unwrap();
    let w = |name: &str, body: &[u8]| std::fs::write(r7.join(name), body).unwrap();
    let paper = repo("../scenes/paper.toml");
    let dev = "[[device]]\ncenter_mm = [0.0, 0.0, 0.0]\n";
    // 1. Vectors of four numbers where three belong.
    let center = "center_mm = [0.0, 30.0, 30.0]";
    w(
        "center4.toml",
        edit(&paper, center, "center_mm = [0.0, 30.0, 30.0, 99.0]").as_bytes(),
    );
    w(
        "axes4.toml",
        edit(
            &paper,
            "box_axes = [[1.0, 0.0, 0.0],",
            "box_axes = [[1.0, 0.0, 0.0, 7.0],",
        )
        .as_bytes(),
    );
    w(
        "rotation4.toml",
        format!("{dev}rotation_deg = [0.0, 0.0, 0.0, 90.0]\n").as_bytes(),
    );
    w(
        "points4.toml",
        b"ball_diameter_mm = 40.0\n\n[[point]]\nat_mm = [0.0, 30.0, 30.0, 5.0]\ndepth = \"p1.npy\"\n\n\
          [[point]]\nat_mm = [40.0, 30.0, 30.0]\ndepth = \"p2.npy\"\n\n\
          [[point]]\nat_mm = [0.0, 70.0, 30.0]\ndepth = \"p3.npy\"\n",
    );
    // 2. Values the flags' or the device's rule refuses.
    w(
        "sound.toml",
        format!("{dev}[medium]\nsound_speed_m_s = 1e300\n").as_bytes(),
    );
    w(
        "hot.toml",
        format!("{dev}[medium]\ntemperature_c = 1e6\n").as_bytes(),
    );
    w(
        "camera_far.toml",
        edit(
            &paper,
            "position_mm = [0.0, 276.",
            "position_mm = [1e300, 276.",
        )
        .as_bytes(),
    );
    w(
        "box_far.toml",
        edit(&paper, "box_center_mm = [0.0,", "box_center_mm = [-1e9,").as_bytes(),
    );
    let library = repo("../studies/paper-library.toml");
    let protocol = repo("../studies/paper-exp1.toml");
    for (name, from, to) in [
        ("radius", "radius = 2.0", "radius = -1.0"),
        ("step", "step = 0.23", "step = 1e300"),
        ("foci", "foci = 1", "foci = 0"),
    ] {
        let lib = r7.join(format!("lib_{name}.toml"));
        std::fs::write(&lib, edit(&library, from, to)).unwrap();
        let p = edit(
            &protocol,
            "library = \"paper-library.toml\"",
            &format!("library = \"{}\"", lib.display()),
        );
        w(&format!("exp1_{name}.toml"), p.as_bytes());
    }
    // 3. Errors that lose their place or misname the trouble.
    w(
        "cam_height.toml",
        b"width = 4\nheight = \"4\"\nfx = 2.0\nfy = 2.0\nppx = 1.5\nppy = 1.5\ndepth_scale = 0.001\n",
    );
    let dict = |descr: &str, order: &str, shape: &str, extra: &str| {
        format!("{{'descr': {descr}, 'fortran_order': {order}, 'shape': {shape}, {extra}}}")
    };
    let dims: Vec<String> = (0..1000).map(|i| i.to_string()).collect();
    for (name, d) in [
        ("descr_nan.depth", dict("nan", "False", "(2, 4, 4)", "")),
        ("order_7.depth", dict("'<u2'", "7", "(2, 4, 4)", "")),
        (
            "dims.depth",
            dict("'<u2'", "False", &format!("({})", dims.join(", ")), ""),
        ),
        // 4. A fourth key numpy would refuse.
        (
            "extra_key.depth",
            dict("'<u2'", "False", "(2, 4, 4)", "'scale': 1000, "),
        ),
    ] {
        w(name, &npy(&d));
    }
    // 5. Rows of trials.csv a run cannot have written.
    resumed_copy(dir, "r7_dwell", 1, "dwell_us", "-1");
    resumed_copy(dir, "r7_mutes", 1, "mutes", "1e300");
    resumed_copy(dir, "r7_rt", 2, "guess_rt_s", "-0.5");
    resumed_copy(dir, "r7_answer", 2, "vibration", "");
}

/// A short error: the value is not echoed whole.
fn short_error(_: &Ctx, r: &Run) -> Result<(), String> {
    match r.stderr.len() {
        n if n < 400 => Ok(()),
        n => Err(format!("stderr is {n} bytes")),
    }
}

pub(crate) fn files_cases() -> Vec<Case> {
    let resume = |id: &str| {
        format!(
            "study run {{dir}}/study/mini.toml --port autd3:emulator --out {{dir}}/study/out \
             --time-scale 0.02 --responses {{dir}}/study/ans.txt --participant {id} --resume"
        )
    };
    let mut cases = table! {
        // 1. Exactly three numbers: scene, plan, points file.
        FILES_EXACT "scene --scene {dir}/r7/center4.toml"
                    .err("line 8, field `center_mm`: invalid length 4, expected 3 numbers");
        FILES_EXACT "scene --scene {dir}/r7/axes4.toml"
                    .err("field `tracking.box_axes`").err("invalid length 4");
        FILES_EXACT "plan --scene {dir}/r7/rotation4.toml"
                    .err("field `device[0].rotation_deg`: invalid length 4");
        FILES_EXACT "calibrate camera {dir}/r7/points4.toml --scene {scenes}/paper.toml"
                    .err("points file {dir}/r7/points4.toml: line 4, field `point[0].at_mm`");
        // 2. The rule of the flag or the device, where the file is named.
        FILES_ONE_RULE "scene --scene {dir}/r7/sound.toml"
                       .err("field `medium.sound_speed_m_s`: speed of sound 1e300 m/s is outside");
        FILES_ONE_RULE "scene --scene {dir}/r7/hot.toml"
                       .err("field `medium.temperature_c`").err("outside the 100-2000 m/s");
        FILES_ONE_RULE "scene --scene {dir}/r7/camera_far.toml"
                       .err("field `camera.position_mm` [1e300, ");
        FILES_ONE_RULE "track --synthetic --seconds 0.3 --fast --scene {dir}/r7/box_far.toml"
                       .err("field `tracking.box_center_mm` [").err("is out of range");
        FILES_ONE_RULE "study check {dir}/r7/exp1_radius.toml"
                       .err("stimulus 1 (`lms-5hz-a2`): radius must be a finite number ≥ 0 mm, got -1");
        FILES_ONE_RULE "study check {dir}/r7/exp1_step.toml"
                       .err("step 1e300 mm is out of range: allowed above 0 and at most 1000 mm");
        FILES_ONE_RULE "study check {dir}/r7/exp1_foci.toml"
                       .err("field `stimulus[0].foci`: 0 is out of range: allowed 1..=32");
        FILES_ONE_RULE "session --library {dir}/r7/lib_radius.toml --port autd3:emulator --control -"
                       .err("stimulus library {dir}/r7/lib_radius.toml: stimulus 1");
        // The AUTD3's grid planner takes the rule the firmware's does.
        FILES_ONE_RULE "upload --port autd3:emulator --step 100"
                       .err("step 100 mm is wider than the circumference");
        FILES_ONE_RULE "upload --port autd3:emulator --step 1e300"
                       .err("step 1e300 mm is out of range");
        // 3. The line and the key, and what is wrong with a value.
        FILES_PLACE "track" .depth("ok.npy", "r7/cam_height.toml")
                    .err("line 2, field `height`: \"4\" is text, not a whole number in 1..=8192: write `4` without quotes");
        FILES_PLACE "track" .depth("r7/descr_nan.depth", "cam.toml")
                    .err(".npy header's 'descr' must be a quoted type such as '<u2', got `nan`");
        FILES_PLACE "track" .depth("r7/order_7.depth", "cam.toml")
                    .err(".npy header's 'fortran_order' must be False or True, got `7`");
        FILES_PLACE "track" .depth("r7/dims.depth", "cam.toml")
                    .err("shape has 1000 dimensions; numpy writes at most 64")
                    .check(short_error);
        // 4. A key nothing reads.
        FILES_IGNORED "track" .depth("r7/extra_key.depth", "cam.toml")
                      .err(".npy header has key 'scale'");
    };
    for (id, want) in [
        (
            "r7_dwell",
            "line 2: column `dwell_us`: `-1`: give a number from 0",
        ),
        (
            "r7_mutes",
            "column `mutes`: `1e300`: give a whole number from 0",
        ),
        ("r7_rt", "column `guess_rt_s`: `-0.5`: give a number from 0"),
        (
            "r7_answer",
            "column `answers` is `2`, but the row holds 1 answers",
        ),
    ] {
        cases.push(
            case(FILES_RESUME, &resume(id))
                .err(want)
                .err("nothing was changed"),
        );
    }
    cases
}
