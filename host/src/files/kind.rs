//! What kind of lmhost file a text is, by the top-level keys only that
//! kind has, so that a file given where another kind goes says what it is
//! and what takes it: a stimulus library given as `--scene` failed on
//! "unknown field `stimulus`, expected one of `name`, `directivity`, …".
//!
//! Pure data over key names: each reader asks [`other_kind`] on its error
//! path with the kind it expected and the keys it found.

/// A kind of file lmhost reads.
#[derive(Debug, PartialEq, Eq)]
pub struct Kind {
    /// What it is called (`stimulus library`).
    pub name: &'static str,
    /// What it is for (`--library`).
    pub taken_by: &'static str,
    /// Top-level keys only this kind has, separated by spaces; `[[name]]`
    /// is an array of tables.
    keys: &'static str,
}

impl Kind {
    const fn new(name: &'static str, taken_by: &'static str, keys: &'static str) -> Self {
        Self {
            name,
            taken_by,
            keys,
        }
    }
}

/// A scene (`--scene`).
pub const SCENE: Kind = Kind::new(
    "scene file",
    "--scene",
    "[[device]] rig lm_plane medium reflector directivity camera tracking calibration min_dwell_ms",
);
/// A stimulus library (`--library`).
pub const LIBRARY: Kind = Kind::new("stimulus library", "--library", "[[stimulus]]");
/// A study protocol (`lmhost study run` and `study check`).
pub const PROTOCOL: Kind = Kind::new(
    "study protocol",
    "`lmhost study run` and `study check`",
    "library sets order timeline [[factor]] [[question]] adjustment staircase quest report [[block]]",
);
/// A depth camera's intrinsics (`--intrinsics`).
pub const INTRINSICS: Kind = Kind::new("camera intrinsics file", "--intrinsics", "depth_scale");
/// A colour camera's settings, read beside a colour recording.
pub const COLOUR_CAMERA: Kind = Kind::new(
    "colour camera file",
    "a colour recording, beside it as `REC.colour.toml`",
    "model coeffs rotation translation_m",
);
/// The points of a camera calibration (`lmhost calibrate camera`).
pub const POINTS: Kind = Kind::new(
    "calibration points file",
    "`lmhost calibrate camera`",
    "ball_diameter_mm background [[point]]",
);

/// The TOML files lmhost reads.
pub const TOML: [&Kind; 6] = [
    &SCENE,
    &LIBRARY,
    &PROTOCOL,
    &INTRINSICS,
    &COLOUR_CAMERA,
    &POINTS,
];

/// Phases as JSON (`--phases`).
pub const PHASES: Kind = Kind::new("phases file", "--phases", "phases");
/// Foci as JSON (`--foci-file`).
pub const FOCI: Kind = Kind::new("foci file", "--foci-file", "foci_mm");
/// The report `lmhost plan --out F.json` writes (`--phases` replays it).
pub const PLAN_REPORT: Kind = Kind::new(
    "`lmhost plan` report",
    "--phases",
    "crc32 header target transducers index_offset",
);

/// The JSON files a stimulus is read from.
pub const JSON: [&Kind; 3] = [&PHASES, &FOCI, &PLAN_REPORT];

/// The kind of `kinds` whose own keys `top` (a text's top-level keys,
/// arrays of tables as `[[name]]`) holds most of, if one holds more than
/// every other.
pub fn recognise<'k, S: AsRef<str>>(kinds: &[&'k Kind], top: &[S]) -> Option<&'k Kind> {
    let score = |k: &Kind| {
        k.keys
            .split(' ')
            .filter(|key| top.iter().any(|t| t.as_ref() == *key))
            .count()
    };
    let mut ranked: Vec<(usize, &'k Kind)> = kinds.iter().map(|k| (score(k), *k)).collect();
    ranked.sort_by_key(|r| std::cmp::Reverse(r.0));
    match ranked.as_slice() {
        [(best, k), rest @ ..] if *best > 0 && rest.first().is_none_or(|r| r.0 < *best) => Some(k),
        _ => None,
    }
}

/// `it is a stimulus library, not a scene file (for --library)`
/// when `top` is recognised as another kind of `kinds` than `expected`.
pub fn other_kind<S: AsRef<str>>(expected: &Kind, kinds: &[&Kind], top: &[S]) -> Option<String> {
    let k = recognise(kinds, top)?;
    (k != expected).then(|| {
        format!(
            "it is a {}, not a {} (for {})",
            k.name, expected.name, k.taken_by
        )
    })
}

/// The top-level keys of a TOML text, arrays of tables as `[[name]]`;
/// none when it does not parse.
pub fn toml_keys(text: &str) -> Vec<String> {
    let Ok(doc) = toml_edit::Document::parse(text) else {
        return Vec::new();
    };
    doc.as_table()
        .iter()
        .map(|(k, item)| match item {
            toml_edit::Item::ArrayOfTables(_) => format!("[[{k}]]"),
            _ => k.to_owned(),
        })
        .collect()
}

/// The top-level keys of a JSON object; none when it is not one.
pub fn json_keys(text: &str) -> Vec<String> {
    serde_json::from_str::<std::collections::BTreeMap<String, serde::de::IgnoredAny>>(text)
        .map(|m| m.into_keys().collect())
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_kind_is_told_from_the_others_by_its_keys() {
        let repo = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        for (file, kind) in [
            ("scenes/paper.toml", &SCENE),
            ("studies/paper-library.toml", &LIBRARY),
            ("studies/paper-exp1.toml", &PROTOCOL),
            ("studies/quest-detection.toml", &PROTOCOL),
        ] {
            let text = std::fs::read_to_string(repo.join(file)).unwrap();
            assert_eq!(recognise(&TOML, &toml_keys(&text)), Some(kind), "{file}");
            assert_eq!(other_kind(kind, &TOML, &toml_keys(&text)), None, "{file}");
        }
        let intrinsics = "width = 848\nheight = 480\nfx = 1.0\nfy = 1.0\nppx = 1.0\nppy = 1.0\ndepth_scale = 0.001\n";
        assert_eq!(recognise(&TOML, &toml_keys(intrinsics)), Some(&INTRINSICS));
        assert_eq!(
            other_kind(&SCENE, &TOML, &toml_keys("[[stimulus]]\nid = \"a\"\n")).unwrap(),
            "it is a stimulus library, not a scene file (for --library)"
        );
        // JSON: a report names its phases and foci too, and is still one.
        let report = r#"{"crc32": 1, "header": {}, "target": "lm", "phases": [], "foci_mm": []}"#;
        assert_eq!(recognise(&JSON, &json_keys(report)), Some(&PLAN_REPORT));
        assert_eq!(
            recognise(&JSON, &json_keys(r#"{"phases": []}"#)),
            Some(&PHASES)
        );
        assert_eq!(
            other_kind(
                &PHASES,
                &JSON,
                &json_keys(r#"{"foci_mm": [], "dwell_us": 1}"#)
            )
            .unwrap(),
            "it is a foci file, not a phases file (for --foci-file)"
        );
        // Nothing known, a tie, or no object: no kind.
        assert_eq!(recognise(&TOML, &toml_keys("x = 1\n")), None);
        assert_eq!(
            recognise(&JSON, &json_keys(r#"{"phases": [], "foci_mm": []}"#)),
            None
        );
        assert_eq!(recognise(&JSON, &json_keys("[1, 2]")), None);
        assert_eq!(recognise(&TOML, &toml_keys("not toml [")), None);
    }
}
