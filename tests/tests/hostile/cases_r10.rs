//! Round 10: files as other tools and platforms write them. Every text
//! input (JSON phases and foci, TOML protocols, libraries, scenes and
//! camera settings, centroid CSV and JSONL, responses, `trials.csv` on
//! `--resume`, the session's control lines, stdin) is read one way
//! (`lmhost::files::text`) whatever wrote it: Notepad, Excel (also its
//! European-locale and Mac CSVs), PowerShell 5 and 7, MATLAB.
//!
//! - A UTF-8 byte-order mark opening a file or a stream is skipped: a
//!   phases or foci JSON file refused it as "expected value at line 1
//!   column 1", a responses file and `--responses -` as an answer
//!   `\u{feff}1`, a session its first control line; a JSON error's column
//!   on line 1 counts from after it. One opening a later line (two files
//!   joined) is refused as such.
//! - A lone CR ends a line as LF and CRLF do (a TOML protocol was refused
//!   at its first CR, a centroid file read as one line; a JSON error said
//!   line 1 for line 3).
//! - UTF-16 and UTF-32, by their byte-order mark or by the NUL bytes of
//!   their ASCII, are named ("it is UTF-16 (little-endian) text, not UTF-8:
//!   save it as UTF-8"); they were "not UTF-8 text", or without a
//!   byte-order mark a JSON error about a key. A NUL byte is named with
//!   its line (a JSON error at the end of the file, a number `0\u{0}`).
//! - A CSV separated by `;` or tabs (a European-locale spreadsheet, with
//!   decimal commas) is refused naming what was found, never read as
//!   other fields; a number answer `2,5` says to write `2.5`.
//!
//! Fixtures in `{dir}/r10`.

use super::*;

/// `study run` of the round-4 protocol, answers from `{dir}/r10/FILE`.
const STUDY: &str = "study run {dir}/study/mini.toml --port autd3:emulator --time-scale 0.02 \
                     --out {dir}/r10/out --responses";

/// `text` with a UTF-8 byte-order mark before it.
fn bom(text: &str) -> Vec<u8> {
    [b"\xef\xbb\xbf".as_slice(), text.as_bytes()].concat()
}

/// `text` in UTF-16 (with PowerShell 5's byte-order mark when `mark`).
fn utf16(text: &str, little: bool, mark: bool) -> Vec<u8> {
    let units = std::iter::once(0xfeff)
        .filter(|_| mark)
        .chain(text.encode_utf16());
    units
        .flat_map(|u| match little {
            true => u.to_le_bytes(),
            false => u.to_be_bytes(),
        })
        .collect()
}

/// The `.json` fixtures serde cannot read as they are (a byte-order mark,
/// UTF-16, a NUL byte, errors on purpose).
pub(crate) const FIXTURE_JSON: [&str; 8] = [
    "foci_bom.json",
    "foci_bad_bom.json",
    "foci_bad_cr.json",
    "foci_joined.json",
    "foci_u16.json",
    "foci_u16be.json",
    "foci_nul.json",
    "phases_bom.json",
];

pub(crate) fn round10_fixtures(dir: &Path) {
    let r10 = dir.join("r10");
    std::fs::create_dir_all(&r10).unwrap();
    let w = |name: &str, body: &[u8]| std::fs::write(r10.join(name), body).unwrap();
    let foci =
        "{\n  \"foci_mm\": [[[0.0, 0.0, 200.0]], [[3.0, 0.0, 200.0]]],\n  \"dwell_us\": 2000\n}\n";
    let crlf = |t: &str| t.replace('\n', "\r\n");
    let cr = |t: &str| t.replace('\n', "\r");
    w("foci_bom.json", &bom(&crlf(foci)));
    w(
        "foci_bad_bom.json",
        &bom("{\"foci_mm\": [[[0, 0, 200]]], \"dwell_us\": x}"),
    );
    w(
        "foci_bad_cr.json",
        cr(&foci.replace("2000", "x")).as_bytes(),
    );
    w("foci_joined.json", &[bom(foci), bom(foci)].concat());
    w("foci_u16.json", &utf16(foci, true, true));
    w("foci_u16be.json", &utf16(foci, false, false));
    w("foci_nul.json", foci.replace("2000", "2000\0").as_bytes());
    let step = |v: u8| format!("[{}]", vec![v.to_string(); 996].join(","));
    let phases = format!(
        "{{\"phases\": [{}, {}], \"dwell_us\": 2000}}\n",
        step(0),
        step(128)
    );
    w("phases_bom.json", &bom(&crlf(&phases)));
    let mini = std::fs::read_to_string(dir.join("study/mini.toml")).unwrap();
    w("mini_cr.toml", cr(&mini).as_bytes());
    w("mini_u16.toml", &utf16(&mini, true, true));
    let cam =
        "width = 4\nheight = 4\nfx = 2.0\nfy = 2.0\nppx = 1.5\nppy = 1.5\ndepth_scale = 0.001\n";
    let utf32: Vec<u8> = cam.chars().flat_map(|c| (c as u32).to_le_bytes()).collect();
    w("cam_u32.toml", &utf32);
    let answers = "1\n2\n3\n4\n5\n6\n7\n1\n";
    w("ans_bom.txt", &bom(&crlf(answers)));
    w("ans_cr.txt", cr(answers).as_bytes());
    w("ans_u16.txt", &utf16(answers, true, true));
    w("ans_comma.txt", b"1\n2,5\n3\n4\n5\n6\n7\n1\n");
    let rows = "0,0,0,200,1\n0.011,0,0,200,1\n0.022,0,0,200,1\n";
    w("cr.csv", cr(rows).as_bytes());
    w("u16.csv", &utf16(rows, true, true));
    w("nul.csv", b"0,0,0,200,1\n0.011,0,0\0,200,1\n");
    w("semi.csv", b"t;x;y;z;present\n0;3,5;0;200;1\n");
    w("tab.csv", b"0\t0\t0\t200\t1\n");
    w("lib.toml", b"[[stimulus]]\nid = \"a\"\n");
    // trials.csv of a run to resume, saved by a spreadsheet since.
    let semi = |t: &str| t.replace(',', ";").into_bytes();
    let wide = |t: &str| utf16(t, true, true);
    for (id, to) in [
        ("r10_u16", &wide as &dyn Fn(&str) -> Vec<u8>),
        ("r10_semi", &semi),
    ] {
        super::cases_r7_files::resumed_copy(dir, id, 1, "trial", "1");
        let p = dir.join("study/out").join(id).join("trials.csv");
        let text = std::fs::read_to_string(&p).unwrap();
        std::fs::write(&p, to(&text)).unwrap();
    }
}

pub(crate) fn round10_cases() -> Vec<Case> {
    let study =
        |answers: &str, id: &str| format!("{STUDY} {{dir}}/r10/{answers} --participant {id}");
    let resume = |id: &str| {
        format!(
            "study run {{dir}}/study/mini.toml --port autd3:emulator --out {{dir}}/study/out \
             --time-scale 0.02 --responses {{dir}}/study/ans.txt --participant {id} --resume"
        )
    };
    let c = |class: &'static str, args: String| case(class, &args);
    let mut v = table![
        // 1. A byte-order mark opening a file or a stream is skipped.
        TEXT_BOM "upload --port autd3:emulator --foci-file {dir}/r10/foci_bom.json" .ok();
        TEXT_BOM "upload --port autd3:emulator --phases {dir}/r10/phases_bom.json" .ok();
        TEXT_BOM "upload --port autd3:emulator --foci-file {dir}/r10/foci_bad_bom.json"
            .err("foci_bad_bom.json: not a foci JSON object (expected value at line 1 column 42)");
        TEXT_BOM "upload --port autd3:emulator --foci-file {dir}/r10/foci_joined.json"
            .err("line 5 starts with a byte-order mark (U+FEFF), which only the first line may (were two files joined?)");
        TEXT_BOM "session --port autd3:emulator --control - --library {dir}/r10/lib.toml"
            .stdin(b"\xef\xbb\xbf{\"cmd\":\"status\"}\r\n").ok()
            .out("{\"cmd\":\"status\",\"ok\":true");
        // 2. CRLF and a lone CR end a line.
        TEXT_LINE_ENDS "study check {dir}/r10/mini_cr.toml" .ok();
        // Control lines on stdin: a lone CR ends each command.
        TEXT_LINE_ENDS "session --port autd3:emulator --control - --library {dir}/r10/lib.toml"
            .stdin(b"{\"cmd\":\"status\"}\r{\"cmd\":\"quit\"}\r").ok()
            .out("{\"cmd\":\"quit\",\"ok\":true");
        TEXT_LINE_ENDS "stream --port {port} --input {dir}/r10/cr.csv" .ok()
            .out("streamed 3 samples (3 with a finger)");
        TEXT_LINE_ENDS "upload --port autd3:emulator --foci-file {dir}/r10/foci_bad_cr.json"
            .err("foci_bad_cr.json: not a foci JSON object (expected value at line 3 column 15)");
        // 3. UTF-16 and UTF-32 are named, with what to do.
        TEXT_WIDE "upload --port autd3:emulator --foci-file {dir}/r10/foci_u16.json"
            .err("cannot read --foci-file {dir}/r10/foci_u16.json: it is UTF-16 (little-endian) text, not UTF-8: save it as UTF-8");
        TEXT_WIDE "upload --port autd3:emulator --foci-file {dir}/r10/foci_u16be.json"
            .err("it is UTF-16 (big-endian) text, not UTF-8: save it as UTF-8");
        TEXT_WIDE "study check {dir}/r10/mini_u16.toml"
            .err("cannot read study protocol {dir}/r10/mini_u16.toml: it is UTF-16 (little-endian) text");
        TEXT_WIDE "track --synthetic --fast --seconds 0.5 --intrinsics {dir}/r10/cam_u32.toml"
            .err("cam_u32.toml: it is UTF-32 (little-endian) text, not UTF-8");
        TEXT_WIDE "stream --port {port} --input {dir}/r10/u16.csv"
            .err("--input file {dir}/r10/u16.csv: line 1 is UTF-16 (little-endian) text, not UTF-8");
        // 4. A NUL byte is named with its line.
        TEXT_NUL "upload --port autd3:emulator --foci-file {dir}/r10/foci_nul.json"
            .err("foci_nul.json: line 3 holds a NUL byte");
        TEXT_NUL "stream --port {port} --input {dir}/r10/nul.csv"
            .err("nul.csv: line 2 holds a NUL byte");
        // 5. A CSV that is not ours is named, never misread.
        TEXT_CSV "stream --port {port} --input {dir}/r10/semi.csv"
            .err("line 1: fields separated by `;`, not a CSV lmhost reads");
        TEXT_CSV "stream --port {port}" .stdin("0;3,5;0;200;1\n")
            .err("line 1: fields separated by `;` and decimal commas (`3,5`)");
        TEXT_CSV "stream --port {port} --input {dir}/r10/tab.csv"
            .err("line 1: fields separated by tabs");
    ];
    v.extend([
        c(TEXT_BOM, study("ans_bom.txt", "r10_bom"))
            .ok()
            .err("4 of 4 trials done"),
        c(TEXT_BOM, format!("{STUDY} - --participant r10_stdin_bom"))
            .stdin(bom("1\r\n2\r\n3\r\n4\r\n5\r\n6\r\n7\r\n1\r\n"))
            .ok()
            .err("4 of 4 trials done"),
        c(TEXT_LINE_ENDS, study("ans_cr.txt", "r10_cr"))
            .ok()
            .err("4 of 4 trials done"),
        c(TEXT_WIDE, study("ans_u16.txt", "r10_wide")).err(
            "cannot read --responses file {dir}/r10/ans_u16.txt: it is UTF-16 (little-endian) text",
        ),
        c(TEXT_WIDE, resume("r10_u16"))
            .err("trials.csv: it is UTF-16 (little-endian) text, not UTF-8")
            .err("nothing was changed"),
        c(TEXT_CSV, resume("r10_semi"))
            .err("trials.csv line 1: fields separated by `;`, not a CSV lmhost reads")
            .err("nothing was changed"),
        c(TEXT_CSV, study("ans_comma.txt", "r10_comma"))
            .err("line 2: `2,5` is not an answer to `guess`")
            .err("(a decimal comma? write `2.5`)"),
    ]);
    v
}
