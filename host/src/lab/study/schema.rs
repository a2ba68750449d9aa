//! The protocol and library files' JSON Schemas, generated from the types
//! serde reads them into (`protocol::file`, `plan::library`), and the
//! reference page generated from those schemas. Editors complete and check
//! a file with a schema (Taplo's `#:schema` line, as in `studies/`); CI
//! validates every shipped file against the committed copies in
//! `docs/schema/` with an independent validator (python/tests), and a test
//! here regenerates the copies and the page and fails on any difference,
//! so neither is kept by hand.

use schemars::generate::{SchemaGenerator, SchemaSettings};
use serde_json::Value;

/// A file format lmhost reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// A study protocol (`lmhost study check|run PROTOCOL`).
    Protocol,
    /// A stimulus library (a protocol's `library`, `lmhost session --library`).
    Library,
}

impl Format {
    /// Both, in the reference page's order.
    pub const ALL: [Format; 2] = [Format::Protocol, Format::Library];

    /// Its name: `protocol` or `library`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Protocol => "protocol",
            Self::Library => "library",
        }
    }

    /// Its committed schema's file name in `docs/schema/`.
    pub fn file_name(self) -> String {
        format!("{}.schema.json", self.name())
    }

    /// Its JSON Schema (draft 2020-12), every subschema inline.
    pub fn schema(self) -> Value {
        let g = generator();
        let mut v = match self {
            Self::Protocol => crate::lab::study::protocol::file_schema(g),
            Self::Library => g.into_root_schema_for::<crate::plan::library::LibraryFile>(),
        }
        .to_value();
        toml_only(&mut v);
        v
    }
}

/// The protocol file's JSON Schema.
pub fn protocol() -> Value {
    Format::Protocol.schema()
}

/// The stimulus library file's JSON Schema.
pub fn library() -> Value {
    Format::Library.schema()
}

/// A schema as it is committed and printed: keys sorted (whatever map
/// serde_json was built with), indented, one final newline.
pub fn to_text(schema: &Value) -> String {
    fn sorted(v: &Value) -> Value {
        match v {
            Value::Object(o) => {
                let mut keys: Vec<&String> = o.keys().collect();
                keys.sort();
                Value::Object(
                    keys.into_iter()
                        .map(|k| (k.clone(), sorted(&o[k])))
                        .collect(),
                )
            }
            Value::Array(a) => Value::Array(a.iter().map(sorted).collect()),
            x => x.clone(),
        }
    }
    let mut s = serde_json::to_string_pretty(&sorted(schema)).unwrap_or_default();
    s.push('\n');
    s
}

// Inline: the reference page reads each field where it is, and an editor's
// hover shows the whole field without following `$ref`s.
fn generator() -> SchemaGenerator {
    SchemaSettings::draft2020_12()
        .with(|s| s.inline_subschemas = true)
        .into_generator()
}

/// TOML has no null: an absent key is what `Option` means, so the `null`
/// schemars allows for an `Option` is dropped (`"type": [T, "null"]` → T,
/// `anyOf: [S, null]` → S).
fn toml_only(v: &mut Value) {
    match v {
        Value::Object(o) => {
            if let Some(Value::Array(types)) = o.get_mut("type") {
                types.retain(|t| t != "null");
                if types.len() == 1 {
                    let t = types.remove(0);
                    o.insert("type".into(), t);
                }
            }
            if let Some(Value::Array(e)) = o.get_mut("enum") {
                e.retain(|x| !x.is_null());
            }
            // A number's storage ("double", "uint32") says nothing to a TOML
            // file's author; its range does.
            if o.get("type")
                .is_some_and(|t| t == "number" || t == "integer")
            {
                o.remove("format");
            }
            if let Some(Value::Array(any)) = o.get("anyOf") {
                let rest: Vec<&Value> = any.iter().filter(|s| s["type"] != "null").collect();
                if let [Value::Object(only)] = rest[..] {
                    let only = only.clone();
                    o.remove("anyOf");
                    for (k, x) in only {
                        o.entry(k).or_insert(x);
                    }
                }
            }
            o.values_mut().for_each(toml_only);
        }
        Value::Array(a) => a.iter_mut().for_each(toml_only),
        _ => {}
    }
}

/// The reference page of both formats (`docs/schema/README.md`): every
/// field's type, unit, range, default and description, table by table.
pub fn reference() -> String {
    let mut out = String::from(
        "# Protocol and library files\n\n\
         Generated from the JSON Schemas beside this page, which are generated from\n\
         the Rust types the files are read into: do not edit either by hand. After a\n\
         change to those types, rewrite all three with\n\
         `LMHOST_WRITE_SCHEMA=1 cargo test -p lmhost --lib schema` (the test fails\n\
         until they match). `lmhost study schema protocol|library` prints a schema;\n\
         a file names its schema for editors (Taplo, Even Better TOML) with a first\n\
         line `#:schema ../docs/schema/protocol.schema.json`.\n\n\
         A field with no default and not required is simply absent when not given.\n\
         `lmhost study check PROTOCOL` checks what a schema cannot (fields that\n\
         depend on each other, the library's entries, the trial plan).\n",
    );
    for f in Format::ALL {
        let s = f.schema();
        out.push_str(&format!(
            "\n## {} (`{}`)\n\n{}\n",
            text(&s["title"]),
            f.file_name(),
            text(&s["description"])
        ));
        let mut tables = Vec::new();
        collect(&s, "", false, &mut tables);
        for (name, t) in tables {
            out.push_str(&format!("\n### {name}\n\n"));
            if !name.starts_with("Top") {
                out.push_str(&format!("{}\n\n", cell(&t["description"])));
            }
            out.push_str("| field | type | unit | range | default | description |\n");
            out.push_str("|---|---|---|---|---|---|\n");
            let required = |k: &str| {
                t["required"]
                    .as_array()
                    .is_some_and(|r| r.iter().any(|x| x == k))
            };
            for (k, p) in t["properties"].as_object().into_iter().flatten() {
                let default = match p.get("default") {
                    Some(d) => format!("`{d}`"),
                    None if required(k) => "required".into(),
                    None => "—".into(),
                };
                out.push_str(&format!(
                    "| `{k}` | {} | {} | {} | {default} | {} |\n",
                    type_of(p),
                    unit(p),
                    range(p),
                    cell(&p["description"])
                ));
            }
        }
    }
    out
}

/// The tables of `s` (an object schema) as TOML names them: `[a]`, `[[b]]`,
/// `[b.c]`, each after its parent.
fn collect<'a>(s: &'a Value, path: &str, array: bool, out: &mut Vec<(String, &'a Value)>) {
    out.push((
        match (path, array) {
            ("", _) => "Top level".to_string(),
            (p, true) => format!("`[[{p}]]`"),
            (p, false) => format!("`[{p}]`"),
        },
        s,
    ));
    for (k, p) in s["properties"].as_object().into_iter().flatten() {
        let name = if path.is_empty() {
            k.clone()
        } else {
            format!("{path}.{k}")
        };
        if is_table(p) {
            collect(p, &name, false, out);
        } else if is_table(&p["items"]) {
            collect(&p["items"], &name, true, out);
        }
    }
}

fn is_table(s: &Value) -> bool {
    s.get("properties").is_some()
}

fn type_of(s: &Value) -> String {
    let consts = |v: &Value| -> Option<Vec<String>> {
        v.as_array()?
            .iter()
            .map(|x| x.get("const").map(|c| format!("`{c}`")))
            .collect()
    };
    if let Some(c) = consts(&s["oneOf"]) {
        return c.join(" \\| ");
    }
    if let Some(e) = s["enum"].as_array() {
        let e: Vec<String> = e.iter().map(|x| format!("`{x}`")).collect();
        return e.join(" \\| ");
    }
    match s["type"].as_str() {
        Some("array") if s.get("prefixItems").is_some() => {
            let v: Vec<String> = s["prefixItems"]
                .as_array()
                .into_iter()
                .flatten()
                .map(type_of)
                .collect();
            format!("[{}]", v.join(", "))
        }
        Some("array") if is_table(&s["items"]) => "array of tables".into(),
        Some("array") => format!("array of {}", type_of(&s["items"])),
        Some("object") => "table".into(),
        Some(t) => t.into(),
        None => "any".into(),
    }
}

fn unit(s: &Value) -> String {
    match s.get("x-unit").or_else(|| s["items"].get("x-unit")) {
        Some(u) => text(u),
        None => String::new(),
    }
}

fn range(s: &Value) -> String {
    let mut parts = Vec::new();
    let (lo, hi) = (&s["minimum"], &s["maximum"]);
    match (lo.is_null(), hi.is_null()) {
        (false, false) => parts.push(format!("{lo}..={hi}")),
        (false, true) => parts.push(format!("≥ {lo}")),
        (true, false) if s.get("exclusiveMinimum").is_none() => parts.push(format!("≤ {hi}")),
        _ => {}
    }
    if let Some(x) = s.get("exclusiveMinimum") {
        parts.push(match hi.is_null() {
            true => format!("> {x}"),
            false => format!("> {x}, ≤ {hi}"),
        });
    }
    if let Some(x) = s.get("exclusiveMaximum") {
        parts.push(format!("< {x}"));
    }
    let count = |min: &str, max: &str, what: &str| match (s.get(min), s.get(max)) {
        (Some(a), Some(b)) if a == b => Some(format!("{a} {what}")),
        (Some(a), Some(b)) => Some(format!("{a}..={b} {what}")),
        (Some(a), None) => Some(format!("≥ {a} {what}")),
        (None, Some(b)) => Some(format!("≤ {b} {what}")),
        (None, None) => None,
    };
    parts.extend(count("minLength", "maxLength", "characters"));
    parts.extend(count("minItems", "maxItems", "items"));
    if let Some(p) = s["pattern"].as_str() {
        parts.push(format!("pattern `{}`", p.replace('|', "\\|")));
    }
    if !is_table(&s["items"]) && s["items"].is_object() {
        let each = range(&s["items"]);
        if !each.is_empty() {
            parts.push(format!("each {each}"));
        }
    }
    parts.join("; ")
}

fn text(v: &Value) -> String {
    v.as_str().unwrap_or_default().to_string()
}

/// A description as one table cell.
fn cell(v: &Value) -> String {
    text(v)
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .replace('|', "\\|")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::library::Library;

    fn docs() -> std::path::PathBuf {
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/schema")
    }

    /// Every object schema of `s` with its path.
    fn tables<'a>(s: &'a Value, path: &str, out: &mut Vec<(String, &'a Value)>) {
        if is_table(s) {
            out.push((path.to_string(), s));
        }
        for (k, p) in s["properties"].as_object().into_iter().flatten() {
            tables(p, &format!("{path}.{k}"), out);
            tables(&p["items"], &format!("{path}.{k}[]"), out);
        }
    }

    /// Every table of both schemas: its format's name, its path, its
    /// schema.
    fn all_tables() -> Vec<(&'static str, String, Value)> {
        let mut out = Vec::new();
        for f in Format::ALL {
            let s = f.schema();
            let mut all = Vec::new();
            tables(&s, f.name(), &mut all);
            out.extend(all.into_iter().map(|(path, t)| (f.name(), path, t.clone())));
        }
        out
    }

    #[test]
    fn the_committed_schemas_and_reference_are_generated_from_the_types() {
        let mut files: Vec<(String, String)> = Format::ALL
            .iter()
            .map(|f| (f.file_name(), to_text(&f.schema())))
            .collect();
        files.push(("README.md".into(), reference()));
        let write = std::env::var_os("LMHOST_WRITE_SCHEMA").is_some_and(|v| v == "1");
        for (name, want) in files {
            let path = docs().join(&name);
            if write {
                std::fs::create_dir_all(docs()).unwrap();
                crate::files::write_whole(&path, want.as_bytes()).unwrap();
            }
            let have = std::fs::read_to_string(&path).unwrap_or_default();
            assert!(
                have == want,
                "docs/schema/{name} differs from the types: rewrite it with \
                 `LMHOST_WRITE_SCHEMA=1 cargo test -p lmhost --lib schema`"
            );
        }
    }

    #[test]
    fn every_field_has_a_description_and_every_number_a_range() {
        let all = all_tables();
        for f in Format::ALL {
            let n = all.iter().filter(|t| t.0 == f.name()).count();
            assert!(n >= 2, "{}: {n} tables", f.name());
        }
        for (_, path, t) in &all {
            for (k, p) in t["properties"].as_object().unwrap() {
                assert!(
                    p["description"].as_str().is_some_and(|d| !d.is_empty()),
                    "{path}.{k} has no description"
                );
                let number = |x: &Value| matches!(x["type"].as_str(), Some("number" | "integer"));
                for n in [p, &p["items"]].into_iter().filter(|x| number(x)) {
                    let bounded = |a: &str, b: &str| n.get(a).or(n.get(b)).is_some();
                    assert!(
                        bounded("minimum", "exclusiveMinimum")
                            && bounded("maximum", "exclusiveMaximum"),
                        "{path}.{k} has no range: {n}"
                    );
                }
            }
        }
    }

    #[test]
    fn the_schemas_refuse_unknown_keys_and_require_what_serde_requires() {
        for (_, path, t) in all_tables() {
            assert_eq!(t["additionalProperties"], false, "{path}");
        }
        let p = protocol();
        assert_eq!(
            p["required"],
            serde_json::json!(["name", "library", "stimulus", "timeline", "factor"])
        );
        let l = library();
        assert_eq!(l["required"], serde_json::json!(["stimulus"]));
        let entry = &l["properties"]["stimulus"]["items"];
        assert_eq!(entry["required"], serde_json::json!(["id"]));
        assert_eq!(
            entry["properties"]["am"]["required"],
            serde_json::json!(["shape", "freq"])
        );
    }

    #[test]
    fn the_defaults_the_schemas_show_are_the_loaders() {
        let entry = library()["properties"]["stimulus"]["items"]["properties"].clone();
        let d = |k: &str| entry[k]["default"].as_f64().unwrap_or(f64::NAN);
        let lib = Library::from_toml("[[stimulus]]\nid = \"x\"\n", "t").unwrap();
        let s = &lib.entries[0].stimulus;
        assert_eq!(d("radius"), s.cycle.radius_mm);
        assert_eq!(d("foci"), s.cycle.foci as f64);
        assert_eq!(d("spacing"), s.cycle.spacing_mm);
        assert_eq!(d("freq"), s.cycle.freq_hz);
        assert_eq!(
            s.cycle.steps,
            crate::plan::trajectory::Steps::Width(d("step"))
        );
        assert_eq!(d("intensity"), s.intensity);
        assert_eq!(entry["untracked"]["default"], lib.entries[0].untracked);
        let lib = Library::from_toml(
            "[[stimulus]]\nid = \"x\"\nam = { shape = \"sine\", freq = 100 }\n\
             path = { shape = \"lissajous\", a = 1, b = 1 }\n",
            "t",
        )
        .unwrap();
        let s = &lib.entries[0].stimulus;
        assert_eq!(
            s.am.unwrap().depth,
            entry["am"]["properties"]["depth"]["default"]
        );
        let path = &entry["path"]["properties"];
        let crate::plan::path::Path::Lissajous(crate::plan::path::Lissajous {
            n_a,
            n_b,
            phase_deg,
            ..
        }) = s.cycle.path
        else {
            panic!("{:?}", s.cycle.path)
        };
        assert_eq!(path["ratio"]["default"], serde_json::json!([n_a, n_b]));
        assert_eq!(path["phase"]["default"], phase_deg);

        let p = protocol();
        let exp1 =
            std::fs::read_to_string(crate::lab::study::test_files::studies("paper-exp1.toml"))
                .unwrap()
                .replace("sets = 2\n", "")
                .replace("iti_s = 1.0\n", "")
                .replace("touch_s = 3.0\n", "");
        let u = crate::lab::study::protocol::Unlinked::from_toml(&exp1, "t").unwrap();
        assert_eq!(p["properties"]["sets"]["default"], u.sets);
        let t = &p["properties"]["timeline"]["properties"];
        assert_eq!(t["iti_s"]["default"], u.timeline.iti_s);
        assert_eq!(t["off_s"]["default"], u.timeline.off_s);
        assert_eq!(t["touch_s"]["default"], u.timeline.touch_s);
        assert_eq!(
            p["properties"]["report"]["properties"]["alpha"]["default"],
            u.report.alpha
        );
    }
}
