//! Round 13, follow-ups.
//!
//! - r13-13 (Python's own, in `python/tests/test_hostile_r13.py`): a
//!   `Session` argument bound for a control line is refused by its own
//!   limit before the line is built; `present(stimulus="x" * 5000)` said
//!   "bad command: longer than 4096 bytes", naming the line, not the
//!   argument.
//! - r13-14: a whole number in a JSON file we read names the field and
//!   its own range: a plan report's header (`"steps": -1`, `2.5`, `1e30`)
//!   said "invalid value: integer `-1`, expected a whole number from 0 to
//!   65535" (its Rust type's range, the field unnamed), a phase `-1` or
//!   `300` "expected u8", a `crc32` of `-1` "expected u32"; a study's
//!   `session.json` with `"seed": -1` or a trial `2.5` "expected u64" or
//!   "invalid type: floating point".
//! - r13-15: a centroid's `present` takes the same values in JSON and
//!   CSV: a CSV line took `1`/`0` and `TRUE` or `False` (any case), a
//!   JSON line only a boolean ("invalid type: integer `1`, expected a
//!   boolean"); both now take `true`, `false`, `1` and `0` (CSV in any
//!   case, as spreadsheets write it), nothing else, refused in the same
//!   words.
//!
//! Fixtures in `{dir}/r13b`.

use super::*;

/// Edits of a plan report: where (a JSON pointer), the value written, and
/// what the refusal must say.
const REPORT_EDITS: [(&str, &str, &str); 12] = [
    (
        "/header/steps",
        "-1",
        "header.steps: -1 is out of range: allowed 1..=65535",
    ),
    (
        "/header/steps",
        "2.5",
        "header.steps: 2.5 is not a whole number: allowed 1..=65535",
    ),
    (
        "/header/steps",
        "1e30",
        "header.steps: 1e30 is out of range: allowed 1..=65535",
    ),
    (
        "/header/transducers",
        "70000",
        "header.transducers: 70000 is out of range: allowed 1..=65535",
    ),
    (
        "/header/period_us",
        "-3",
        "header.period_us: -3 is out of range: allowed 1..=4294967295",
    ),
    (
        "/header/intensity",
        "256",
        "header.intensity: 256 is out of range: allowed 0..=255",
    ),
    (
        "/header/sound_speed_mm_s",
        "5",
        "header.sound_speed_mm_s: 5 is out of range: allowed 100000..=2000000",
    ),
    (
        "/header/center_um/2",
        "-1e12",
        "header.center_um[2]: -1e12 is out of range: allowed -2147483648..=2147483647",
    ),
    (
        "/crc32",
        "-1",
        "crc32: -1 is out of range: allowed 0..=4294967295",
    ),
    (
        "/foci_per_step",
        "99",
        "foci_per_step: 99 is out of range: allowed 1..=32",
    ),
    (
        "/timing/steps",
        "0.5",
        "timing.steps: 0.5 is not a whole number: allowed 1..=65535",
    ),
    (
        "/phases/1/3",
        "-1",
        "phases[1][3]: -1 is out of range: allowed 0..=255",
    ),
];

/// Edits of a study's `session.json`, as [`REPORT_EDITS`].
const SESSION_EDITS: [(&str, &str, &str); 7] = [
    (
        "/seed",
        "-1",
        "field `seed`: -1 is out of range: allowed 0..=",
    ),
    (
        "/index",
        "0",
        "field `index`: 0 is out of range: allowed 1..=1000000",
    ),
    (
        "/trials/0/trial",
        "2.5",
        "field `trials[0].trial`: 2.5 is not a whole number: allowed 1..=10000",
    ),
    (
        "/trials/0/condition",
        "1e30",
        "field `trials[0].condition`: 1e30 is out of range: allowed 0..=999",
    ),
    (
        "/trials/0/orders",
        "[[-1]]",
        "field `trials[0].orders[0][0]`: -1 is out of range: allowed 0..=8",
    ),
    (
        "/runs/0/first_trial",
        "-1",
        "field `runs[0].first_trial`: -1 is out of range: allowed 1..=10000",
    ),
    (
        "/runs/0/started_unix_s",
        "-5",
        "field `runs[0].started_unix_s`: -5 is out of range: allowed 0..=",
    ),
];

/// `from` copied to `to`, its `session.json` edited at `at` to `value`.
fn edited_participant(from: &Path, to: &Path, at: &str, value: &str) {
    std::fs::create_dir_all(to).unwrap();
    for f in ["trials.csv", "events.jsonl"] {
        std::fs::copy(from.join(f), to.join(f)).unwrap();
    }
    let text = std::fs::read_to_string(from.join("session.json")).unwrap();
    let mut session: serde_json::Value = serde_json::from_str(&text).unwrap();
    if at == "/index" {
        session["index"] = serde_json::Value::Null;
    }
    *session
        .pointer_mut(at)
        .expect("session.json's layout moved") = serde_json::from_str(value).unwrap();
    std::fs::write(to.join("session.json"), session.to_string()).unwrap();
}

pub(crate) fn round13b_fixtures(dir: &Path) {
    let r = dir.join("r13b");
    std::fs::create_dir_all(&r).unwrap();
    let planned = r.join("plan.json");
    ok(&["plan", "--out", planned.to_str().unwrap()]);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&planned).unwrap()).unwrap();
    for (i, (at, value, _)) in REPORT_EDITS.iter().enumerate() {
        let mut edited = report.clone();
        *edited.pointer_mut(at).expect("the report's layout moved") =
            serde_json::from_str(value).unwrap();
        std::fs::write(r.join(format!("report_{i}.json")), edited.to_string()).unwrap();
    }
    let rows = vec![vec![0u8; 996]; 2];
    for (name, phase) in [("ph_neg", "-1"), ("ph_big", "300"), ("ph_frac", "2.5")] {
        let body = serde_json::json!({ "phases": rows }).to_string();
        let body = body.replacen("[0,", &format!("[{phase},"), 1);
        std::fs::write(r.join(format!("{name}.json")), body).unwrap();
    }
    let p1 = dir.join("study/out/P1");
    for (i, (at, value, _)) in SESSION_EDITS.iter().enumerate() {
        edited_participant(&p1, &r.join(format!("session_{i}/P1")), at, value);
    }
}

pub(crate) fn round13b_cases() -> Vec<Case> {
    let mut v = Vec::new();
    let upload = "upload --port {port} --hold 0.05 --phases {dir}/r13b";
    for (i, (_, _, said)) in REPORT_EDITS.iter().enumerate() {
        v.push(
            case(R13_JSON_WHOLE, &format!("{upload}/report_{i}.json"))
                .err("not a `lmhost plan --out` JSON report (")
                .err(said),
        );
    }
    for (name, said) in [
        (
            "ph_neg",
            "phases[0][0]: -1 is out of range: allowed 0..=255",
        ),
        (
            "ph_big",
            "phases[0][0]: 300 is out of range: allowed 0..=255",
        ),
        (
            "ph_frac",
            "phases[0][0]: 2.5 is not a whole number: allowed 0..=255",
        ),
    ] {
        v.push(case(R13_JSON_WHOLE, &format!("{upload}/{name}.json")).err(said));
    }
    for (i, (_, _, said)) in SESSION_EDITS.iter().enumerate() {
        v.push(
            case(
                R13_JSON_WHOLE,
                &format!("study report {{dir}}/r13b/session_{i}/P1"),
            )
            .err("session.json: ")
            .err(said),
        );
    }
    let said =
        |v: &str| format!("line 2: `{v}` is not a `present` value: give true, false, 1 or 0");
    let json = |v: &str| {
        format!(
            "{{\"t\":0,\"x\":0,\"y\":0,\"z\":200}}\n{{\"t\":0.01,\"x\":0,\"y\":0,\"z\":200,\"present\":{v}}}\n"
        )
    };
    let csv = |v: &str| format!("0,0,0,200,1\n0.01,0,0,200,{v}\n");
    for w in ["\"true\"", "\"1\"", "1.0", "2", "null"] {
        v.push(
            case(R13_PRESENT, "stream --port {port}")
                .stdin(json(w))
                .err(&said(w)),
        );
    }
    for w in ["yes", "2", "1.0", "truth"] {
        v.push(
            case(R13_PRESENT, "stream --port {port}")
                .stdin(csv(w))
                .err(&said(w)),
        );
    }
    // The four values, alike in both; a spreadsheet's TRUE and False.
    v.push(
        case(R13_PRESENT, "stream --port {port}")
            .stdin(csv("TRUE"))
            .ok(),
    );
    v.push(
        case(R13_PRESENT, "stream --port {port}")
            .stdin(csv("False"))
            .ok(),
    );
    for p in ["true", "false", "1", "0"] {
        v.push(
            case(R13_PRESENT, "stream --port {port}")
                .stdin(json(p))
                .ok(),
        );
        v.push(case(R13_PRESENT, "stream --port {port}").stdin(csv(p)).ok());
    }
    // The report as plan wrote it still uploads.
    v.push(case(R13_JSON_WHOLE, &format!("{upload}/plan.json")).ok());
    v
}
