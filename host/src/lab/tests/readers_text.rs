//! The text readers under the fuzz run: the TOML files (scene, stimulus
//! library, study protocol, camera settings), the text decoder, the
//! centroid stream's lines, the session's control lines and a study's
//! responses file. Each reads bytes as its file or stream would be read
//! (through [`crate::files::text`]) and checks what it accepts.

use super::harness::{Outcome, Reader, Verdict, finite, refused};
use crate::error::InputError;
use crate::files::text;
use crate::lab::session::Command;
use crate::lab::study::answers::{Accepts, Answers as _, Asked, Lines};
use crate::lab::study::protocol::{Protocol, Unlinked};
use crate::limits::MAX_TIME_STAMP_S;
use crate::plan::library::{Library, MAX_ENTRIES, MAX_ID_LEN};
use crate::plan::scene::Scene;
use crate::sense::stream::source::parse_line;
use crate::sense::track::colour::ColourCamera;
use crate::sense::track::intrinsics::Intrinsics;
use crate::sense::track::settings_file::SettingsFile;

/// A file of the repository, by its path from the workspace root.
pub fn repo_file(rel: &str) -> Vec<u8> {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(rel);
    std::fs::read(&p).unwrap_or_else(|e| panic!("seed {}: {e}", p.display()))
}

/// The text a file reader reads from `bytes`, or its refusal (as
/// [`crate::limits::read_text_file`] words it).
fn decoded(what: &str, bytes: &[u8]) -> Result<String, Verdict> {
    text::decode(bytes.to_vec())
        .map_err(|why| Verdict::Refused(format!("cannot read {what} fuzz.toml: {why}")))
}

/// A TOML reader: decoded, then `parse`d (its error is the refusal), and
/// what it accepts checked by `check`.
fn toml_reader<T: 'static, E: std::fmt::Display + 'static>(
    name: &'static str,
    seeds: Vec<Vec<u8>>,
    cases: usize,
    parse: fn(&str) -> Result<T, E>,
    check: fn(&T) -> Result<(), String>,
) -> Reader {
    Reader {
        name,
        seeds,
        cases,
        read: Box::new(move |b| match decoded(name, b) {
            Ok(t) => match parse(&t) {
                Ok(v) => check(&v).map(|()| Verdict::Accepted),
                Err(e) => refused(e),
            },
            Err(v) => Ok(v),
        }),
    }
}

const SCENE_EXTRAS: &str = r#"name = "flat, tracked"
directivity = "t4010a1"
center_mm = [0.0, 0.0, 200.0]
min_dwell_ms = 0.5

[medium]
temperature_c = 20.5
attenuation_np_per_m = 0.1

[lm_plane]
a = [1.0, 0.0, 0.0]
b = [0.0, 1.0, 0.0]

[[device]]
center_mm = [-96.0, 0.0, 0.0]

[[device]]
center_mm = [96.0, 0.0, 0.0]
rotation_deg = [0.0, 0.0, 90.0]

[camera]
position_mm = [0, 276.2, 73.4]
x_axis = [-1, 0, 0]
y_axis = [0, 0, -1]
z_axis = [0, -1, 0]

[tracking]
box_center_mm = [0, 36.43, 22.34]
box_axes = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
box_size_mm = [10, 10, 20]
min_points = 20

[calibration]
pressure_scale = 0.8
measured_n = 0.01
simulated_n = 0.0125
disk_mm = 10.0
"#;

fn scene(s: &Scene) -> Result<(), String> {
    if s.devices.is_empty() {
        return Err("no devices".into());
    }
    for d in &s.devices {
        finite("a device centre", &d.center_mm)?;
    }
    finite("the centre", &s.center_mm)?;
    let medium = [s.sound_speed_m_s, s.attenuation_np_per_m, s.min_dwell_s];
    finite("the medium and dwell", &medium)?;
    if !(s.sound_speed_m_s > 0.0 && s.min_dwell_s > 0.0 && s.attenuation_np_per_m >= 0.0) {
        return Err(format!("medium and dwell {medium:?} out of range"));
    }
    if let Some(c) = s.calibration
        && !(crate::plan::scene::MIN_PRESSURE_SCALE..=crate::plan::scene::MAX_PRESSURE_SCALE)
            .contains(&c.pressure_scale)
    {
        return Err(format!("pressure_scale {} out of range", c.pressure_scale));
    }
    for t in s.transducers() {
        finite("a transducer", &t.pos_mm)?;
    }
    Ok(())
}

const LIBRARY_EXTRAS: &str = r#"[[stimulus]]
id = "lms-5hz-a3"
radius = 3.0
foci = 2
spacing = 3.0
freq = 5.0
step = 0.23
center = [0, 0, 200]
intensity = 1.0
untracked = false

[[stimulus]]
id = "liss-am"
freq = 2.0
path = { shape = "lissajous", a = 5.0, b = 3.0, ratio = [3, 2], phase = 90.0 }
am = { shape = "square", freq = 200.0, depth = 0.5 }
z = [0.5]
method = "gspat"
iterations = 20

[[stimulus]]
id = "line.e"
freq = 4.0
steps = 40
path = { shape = "ellipse", a = 5.0, b = 3.0 }
z = [0.0, 1.0, 2.0, 3.0]

[[stimulus]]
id = "from-file"
phases_file = "circle.npy"
freq = 5.0
"#;

fn library(lib: &Library) -> Result<(), String> {
    if !(1..=MAX_ENTRIES).contains(&lib.entries.len()) {
        return Err(format!("{} entries", lib.entries.len()));
    }
    let mut ids = std::collections::HashSet::new();
    for e in &lib.entries {
        if e.id.is_empty() || e.id.len() > MAX_ID_LEN || !ids.insert(e.id.as_str()) {
            return Err(format!("entry id `{}` empty, long or repeated", e.id));
        }
        let s = &e.stimulus;
        if !(0.0..=1.0).contains(&s.intensity) {
            return Err(format!("`{}`'s intensity {}", e.id, s.intensity));
        }
        finite("a centre", &s.center_mm.unwrap_or_default())?;
        if e.file.is_none()
            && let Err(why) = s.cycle.check()
        {
            return Err(format!("`{}`'s cycle fails its own check: {why}", e.id));
        }
    }
    Ok(())
}

fn protocol(p: &Unlinked) -> Result<(), String> {
    if p.conditions.is_empty() || p.trials() == 0 {
        return Err(format!(
            "{} conditions, {} trials",
            p.conditions.len(),
            p.trials()
        ));
    }
    Ok(())
}

/// A protocol in `studies/`, linked to its library there.
fn read_linked(t: &str) -> Result<Protocol, InputError> {
    let at = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../studies/fuzz.toml");
    Protocol::from_toml(t, &at)
}

/// Every condition's stimulus and every grid's level is an entry of the
/// linked library.
fn linked(p: &Protocol) -> Result<(), String> {
    let grids = p
        .staircase
        .iter()
        .map(|s| &s.grid)
        .chain(p.quest.iter().map(|q| &q.grid));
    let ids = p
        .conditions
        .iter()
        .map(|c| &c.stimulus)
        .chain(grids.flat_map(|g| g.entries.iter().flatten()));
    for id in ids {
        if p.library.find(id).is_none() {
            return Err(format!("stimulus `{id}` is not in the library"));
        }
    }
    Ok(())
}

fn intrinsics(i: &Intrinsics) -> Result<(), String> {
    let p = &i.pinhole;
    finite("a number", &[p.fx, p.fy, p.ppx, p.ppy, i.depth_scale])?;
    if !(1..=8192).contains(&p.width) || !(1..=8192).contains(&p.height) {
        return Err(format!("{}×{} pixels", p.width, p.height));
    }
    Ok(())
}

fn colour(c: &ColourCamera) -> Result<(), String> {
    let p = &c.pinhole;
    finite("a number", &[p.fx, p.fy, p.ppx, p.ppy])?;
    finite("a coefficient", &c.coeffs)?;
    finite("the rotation", &c.rotation)?;
    finite("the translation", &c.translation_m)?;
    if c.image_bytes() > 3 * 8192 * 8192 {
        return Err(format!("{} bytes an image", c.image_bytes()));
    }
    Ok(())
}

/// Lines as a stream reads them: cut at LF, then [`text::stream_line`].
fn stream_lines(b: &[u8]) -> impl Iterator<Item = (usize, Result<&str, String>)> {
    b.split(|&c| c == b'\n')
        .enumerate()
        .map(|(i, l)| (i + 1, text::stream_line(l, i + 1)))
}

fn centroids(b: &[u8]) -> Outcome {
    for (n, line) in stream_lines(b) {
        let line = match line {
            Ok(l) => l,
            Err(e) => return refused(e),
        };
        match parse_line(line, n) {
            Ok(None) => {}
            Ok(Some(s)) => {
                finite("a sample", &[s.t_s, s.pos_mm[0], s.pos_mm[1], s.pos_mm[2]])?;
                if !(0.0..=MAX_TIME_STAMP_S).contains(&s.t_s) {
                    return Err(format!("time stamp {}", s.t_s));
                }
            }
            Err(e) => return refused(e),
        }
    }
    Ok(Verdict::Accepted)
}

fn decode(b: &[u8]) -> Outcome {
    match text::decode(b.to_vec()) {
        Ok(t) if t.contains(['\r', '\0']) || t.starts_with('\u{feff}') => {
            Err("a CR, a NUL or a byte-order mark left in the text".into())
        }
        Ok(_) => Ok(Verdict::Accepted),
        Err(why) => refused(format!("cannot read scene file fuzz.toml: {why}")),
    }
}

fn control(b: &[u8]) -> Outcome {
    // Lines as a connection's reader thread hands them to the loop.
    let mut out = Ok(Verdict::Accepted);
    crate::lab::session::conn::read_lines(b, |line| {
        let line = match line {
            Ok(l) => l,
            Err(e) => {
                out = refused(e);
                return false;
            }
        };
        out = match Command::parse(&line) {
            Ok(Command::Present(p)) => {
                finite("a phase", &[p.on_s.unwrap_or(0.0), p.off_s.unwrap_or(0.0)])
                    .map(|()| Verdict::Accepted)
            }
            Ok(_) => Ok(Verdict::Accepted),
            Err(e) => refused(e),
        };
        matches!(out, Ok(Verdict::Accepted))
    });
    out
}

/// What the paper's protocols ask, every kind of question.
fn asked() -> Vec<Asked> {
    let mut out = Vec::new();
    for f in [
        "studies/paper-exp1.toml",
        "studies/staircase-detection.toml",
    ] {
        let t = String::from_utf8(repo_file(f)).unwrap();
        let p = Unlinked::from_toml(&t, f).unwrap();
        for q in &p.questions {
            let order: Vec<usize> = (0..q.shuffled_len()).collect();
            out.extend(Asked::of(q, &order));
        }
    }
    out.push(Asked {
        column: "force".into(),
        prompt: "force".into(),
        accepts: Accepts::Number(-1.5, 10.0),
        not_perceived: Some("nothing".into()),
        perceived_at: None,
    });
    out
}

fn responses(asked: &[Asked], b: &[u8]) -> Outcome {
    let t = match decoded("--responses file", b) {
        Ok(t) => t,
        Err(v) => return Ok(v),
    };
    let mut lines = Lines::from_text("--responses fuzz.txt".into(), &t);
    for q in asked.iter().cycle().take(t.lines().count()) {
        let got = match lines.poll(q) {
            Ok(Some(v)) => v,
            Ok(None) => return Err("a file's answer was not ready".into()),
            Err(e) => return refused(format!("{e:#}")),
        };
        let fits = match &q.accepts {
            _ if q.not_perceived.is_some() && got == "na" => true,
            Accepts::Likert(p) => got.parse::<u32>().is_ok_and(|v| (1..=*p).contains(&v)),
            Accepts::Choice(o) => o.contains(&got),
            Accepts::Number(lo, hi) => got
                .parse::<f64>()
                .is_ok_and(|v| v.is_finite() && (*lo..=*hi).contains(&v)),
        };
        if !fits {
            return Err(format!("`{got}` recorded as an answer to `{}`", q.column));
        }
    }
    match lines.check_used_up() {
        Ok(()) => Ok(Verdict::Accepted),
        Err(e) => refused(e),
    }
}

/// The text readers with their seeds.
pub fn readers() -> Vec<Reader> {
    let studies = [
        "studies/exp1-with-practice.toml",
        "studies/paper-exp1.toml",
        "studies/paper-exp2.toml",
        "studies/paper-exp3.toml",
        "studies/quest-detection.toml",
        "studies/staircase-detection.toml",
        "tests/tests/study_support/kinds.toml",
        "tests/tests/study_support/two.toml",
    ];
    let libraries = [
        "studies/paper-library.toml",
        "studies/staircase-library.toml",
        "tests/tests/study_support/kinds-library.toml",
    ];
    let files = |names: &[&str]| names.iter().map(|f| repo_file(f)).collect::<Vec<_>>();
    let mut libs = files(&libraries);
    libs.push(LIBRARY_EXTRAS.into());
    let csv = b"t,x,y,z,present\n0.0,1.5,-2.0,200.0,1\n0.011,1.6,-2.0,200.5,true\n\
        # a comment\n\n0.02,0,0,0,0\n"
        .to_vec();
    let json = br#"{"t": 0.5, "x": 1.0, "y": -2.0, "z": 201.0}
{"t": 0.6, "x": 1.0, "y": -2.0, "z": 201.0, "present": false}
{"t_s": 0.7, "present": true, "centroid_mm": [1.0, 2.0, 3.0], "gated_present": true, "filtered_mm": [1.1, 2.1, 3.1], "points": 40, "z_profile_mm": [0.1], "replan": false, "truth_present": true, "truth_mm": [1, 2, 3]}
{"t_s": 0.8, "present": false, "centroid_mm": null}
"#
    .to_vec();
    let control_lines = br#"{"cmd":"present","stimulus":"lms-5hz-a3","gate":"untracked","on_s":1.5,"off_s":0.5,"repeat":3}
{"cmd":"prepare","stimulus":"liss-am"}
{"cmd":"auth","token":"0123abcd"}
{"cmd":"status"}
{"cmd":"library"}
{"cmd":"subscribe"}
{"cmd":"stop"}
{"cmd":"quit"}
"#
    .to_vec();
    let asked = asked();
    let answers: Vec<u8> = asked
        .iter()
        .map(|q| match &q.accepts {
            Accepts::Likert(p) => p.to_string(),
            Accepts::Choice(o) => o[0].clone(),
            Accepts::Number(..) => "2.5".into(),
        })
        .collect::<Vec<_>>()
        .join("\n")
        .into_bytes();
    let mut every = files(&studies);
    every.extend(libs.iter().cloned());
    every.push(repo_file("scenes/paper.toml"));
    every.extend([csv.clone(), json.clone(), control_lines.clone()]);
    let mut texts = every.clone();
    texts.push(b"\xef\xbb\xbfname = \"bom\"\r\nx = 1\r\n".to_vec());
    vec![
        toml_reader(
            "scene TOML",
            vec![repo_file("scenes/paper.toml"), SCENE_EXTRAS.into()],
            20_000,
            |t| Scene::from_toml(t, "fuzz.toml"),
            scene,
        ),
        toml_reader(
            "stimulus library TOML",
            libs,
            20_000,
            |t| Library::from_toml(t, "fuzz.toml"),
            library,
        ),
        toml_reader(
            "study protocol TOML",
            files(&studies),
            20_000,
            |t| Unlinked::from_toml(t, "fuzz.toml"),
            protocol,
        ),
        toml_reader(
            "study protocol + library",
            files(&studies[..6]),
            10_000,
            read_linked,
            linked,
        ),
        toml_reader(
            "intrinsics TOML",
            vec![Intrinsics::D435_848X480.to_toml().into_bytes()],
            20_000,
            |t| Intrinsics::from_toml(t, "fuzz.toml"),
            intrinsics,
        ),
        toml_reader(
            "colour camera TOML",
            vec![ColourCamera::D435_848X480.to_toml().into_bytes()],
            20_000,
            |t| ColourCamera::from_toml(t, "fuzz.toml"),
            colour,
        ),
        Reader {
            name: "text decoder",
            seeds: texts,
            cases: 50_000,
            read: Box::new(decode),
        },
        Reader {
            name: "centroid lines",
            seeds: vec![csv, json],
            cases: 50_000,
            read: Box::new(centroids),
        },
        Reader {
            name: "session control lines",
            seeds: vec![control_lines],
            cases: 50_000,
            read: Box::new(control),
        },
        Reader {
            name: "study responses file",
            seeds: vec![answers],
            cases: 20_000,
            read: Box::new(move |b| responses(&asked, b)),
        },
    ]
}
