//! JSON read from the outside at run time (control lines, centroid lines
//! and datagrams): parsed as `serde_json` does, except that an object that
//! names a key twice is refused. `serde_json` keeps the last one without a
//! word, so `{"cmd":"stop","cmd":"quit"}` would quit and
//! `{"x":0,"x":500}` would be a centroid at 500 mm. A number that
//! underflows (`1e-400`, read as 0 by `serde_json`) is refused too,
//! naming its key ([`crate::limits::exact_literal`]).
//!
//! `null`, in every JSON input lmhost reads (control lines, centroid lines
//! and datagrams, foci and phases files, `plan --out` reports,
//! `session.json`, `events.jsonl`), is one rule: it is never read as a key
//! left out. A key that may be left out for its default and is given
//! `null` is refused, naming it ([`no_null`], [`NULL_REFUSED`]): the
//! default is a choice the file did not make (`"present": null` a finger,
//! `"on_s": null` a play until stopped). `null` is read only where it is
//! the value lmhost itself writes for "none", each such key listed in its
//! format's docs (a track line's `centroid_mm` and `filtered_mm`, a plan
//! report's `timing.am_freq_hz` and `timing.divide`, `session.json`'s
//! `index` and `scene.path`/`scene.crc32`, an event's `answer`).

use std::fmt;

use serde::Deserialize;
use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use serde_json::{Map, Value};

/// One JSON value from `s` (the whole of it), refusing a duplicate key at
/// any depth with an error naming it.
///
/// Its number literals are checked first: `serde_json` stops at one
/// beyond a float with "number out of range", naming neither the
/// literal nor its key (`{"x":1e999}`); the check names both.
pub fn from_str(s: &str) -> Result<Value, serde_json::Error> {
    exact_numbers(s).map_err(<serde_json::Error as de::Error>::custom)?;
    let mut de = serde_json::Deserializer::from_str(s);
    let Strict(v) = Strict::deserialize(&mut de)?;
    de.end()?;
    Ok(v)
}

/// Checks every number literal of the valid JSON text `s` with
/// [`crate::limits::exact_literal`]; the error names the key the number
/// belongs to (the innermost one before it). The parsed value has lost the
/// literal, so this reads the text: one pass, no allocation but the error.
/// Also for JSON files typed straight from their text; on text that is
/// not JSON it finds nothing to refuse, and the parse says what is wrong.
pub(crate) fn exact_numbers(s: &str) -> Result<(), String> {
    let b = s.as_bytes();
    let (mut i, mut key) = (0, None);
    while i < b.len() {
        match b[i] {
            b'"' => {
                let start = i + 1;
                i += 1;
                while i < b.len() && b[i] != b'"' {
                    i += if b[i] == b'\\' { 2 } else { 1 };
                }
                let end = i.min(b.len());
                i += 1;
                // A string followed by `:` is a key.
                let rest = s[i.min(s.len())..].trim_start();
                if rest.starts_with(':') {
                    key = Some(&s[start..end]);
                }
            }
            b'-' | b'0'..=b'9' => {
                let start = i;
                while i < b.len() && matches!(b[i], b'0'..=b'9' | b'-' | b'+' | b'.' | b'e' | b'E')
                {
                    i += 1;
                }
                let lit = &s[start..i];
                let v: f64 = lit.parse().unwrap_or(f64::NAN);
                crate::limits::exact_literal(lit, v).map_err(|m| match key {
                    Some(k) => format!("`{k}`: {m}"),
                    None => m,
                })?;
            }
            _ => i += 1,
        }
    }
    Ok(())
}

/// Why a `null` is refused where a key may be left out: one message for
/// every reader (the reader names the key).
pub const NULL_REFUSED: &str = "null is not a value here: leave the key out for its default";

/// An optional key of a JSON input (with `#[serde(default, deserialize_with
/// = "crate::json::no_null")]`): absent is `None`, a value is `Some`, and
/// `null` is refused ([`NULL_REFUSED`]) rather than taken for absent.
/// Readers through `serde_path_to_error` name the key.
pub fn no_null<'de, D, T>(d: D) -> Result<Option<T>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    struct NoNull<T>(std::marker::PhantomData<T>);
    impl<'de, T: Deserialize<'de>> Visitor<'de> for NoNull<T> {
        type Value = Option<T>;

        fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str("a value (not null)")
        }

        fn visit_none<E: de::Error>(self) -> Result<Self::Value, E> {
            Err(E::custom(NULL_REFUSED))
        }

        fn visit_unit<E: de::Error>(self) -> Result<Self::Value, E> {
            Err(E::custom(NULL_REFUSED))
        }

        fn visit_some<D2: Deserializer<'de>>(self, d: D2) -> Result<Self::Value, D2::Error> {
            T::deserialize(d).map(Some)
        }
    }
    d.deserialize_option(NoNull(std::marker::PhantomData))
}

/// `v` read as a `T`: serde's message as it is, but a refused `null`
/// names its key (`` `on_s`: null is not a value here: … ``).
pub fn from_value<T: de::DeserializeOwned>(v: Value) -> Result<T, String> {
    serde_path_to_error::deserialize(v).map_err(|e| {
        let inner = e.inner().to_string();
        if inner == NULL_REFUSED {
            format!("`{}`: {inner}", e.path())
        } else {
            inner
        }
    })
}

/// A [`Value`] built by [`StrictVisitor`].
struct Strict(Value);

impl<'de> Deserialize<'de> for Strict {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(StrictVisitor).map(Strict)
    }
}

/// `serde_json::Value`'s own visitor, but for duplicate keys.
struct StrictVisitor;

impl<'de> Visitor<'de> for StrictVisitor {
    type Value = Value;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a JSON value")
    }

    fn visit_bool<E>(self, v: bool) -> Result<Value, E> {
        Ok(Value::Bool(v))
    }

    fn visit_i64<E>(self, v: i64) -> Result<Value, E> {
        Ok(v.into())
    }

    fn visit_u64<E>(self, v: u64) -> Result<Value, E> {
        Ok(v.into())
    }

    fn visit_f64<E>(self, v: f64) -> Result<Value, E> {
        // serde_json never yields a non-finite number; null as its Value does.
        Ok(serde_json::Number::from_f64(v).map_or(Value::Null, Value::Number))
    }

    fn visit_str<E>(self, v: &str) -> Result<Value, E> {
        Ok(Value::String(v.to_owned()))
    }

    fn visit_string<E>(self, v: String) -> Result<Value, E> {
        Ok(Value::String(v))
    }

    fn visit_unit<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }

    fn visit_none<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }

    fn visit_some<D: Deserializer<'de>>(self, d: D) -> Result<Value, D::Error> {
        Strict::deserialize(d).map(|s| s.0)
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut a: A) -> Result<Value, A::Error> {
        let mut v = Vec::new();
        while let Some(Strict(x)) = a.next_element()? {
            v.push(x);
        }
        Ok(Value::Array(v))
    }

    fn visit_map<A: MapAccess<'de>>(self, mut a: A) -> Result<Value, A::Error> {
        let mut m = Map::new();
        while let Some(k) = a.next_key::<String>()? {
            if m.contains_key(&k) {
                return Err(de::Error::custom(format_args!("duplicate key `{k}`")));
            }
            let Strict(v) = a.next_value()?;
            m.insert(k, v);
        }
        Ok(Value::Object(m))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_parse_as_serde_json_parses_them() {
        for s in [
            r#"{"cmd":"present","on_s":2.5,"repeat":3,"gate":null,"a":[1,-2,{"b":true}]}"#,
            "[]",
            "18446744073709551615",
            "-1e300",
            r#""é\n""#,
        ] {
            assert_eq!(
                from_str(s).unwrap(),
                serde_json::from_str::<Value>(s).unwrap(),
                "{s}"
            );
        }
    }

    #[test]
    fn a_key_given_twice_is_refused_at_any_depth() {
        for s in [
            r#"{"cmd":"stop","cmd":"quit"}"#,
            r#"{"t":0,"x":0,"x":500,"y":0,"z":200}"#,
            r#"{"a":[{"k":1,"k":1}]}"#,
        ] {
            let e = from_str(s).unwrap_err().to_string();
            assert!(e.starts_with("duplicate key `"), "{s}: {e}");
            // serde_json alone takes the last.
            assert!(serde_json::from_str::<Value>(s).is_ok());
        }
        for s in ["", "{", r#"{"a":1} x"#, &"[".repeat(200)] {
            assert!(from_str(s).is_err(), "{s}");
        }
    }

    #[test]
    fn a_number_beyond_a_float_is_refused_as_itself_naming_its_key() {
        for (s, said) in [
            (
                r#"{"t":0,"x":1e999,"y":0,"z":200}"#,
                "`x`: 1e999 is too large to represent (it would be read as inf): \
                 give a magnitude of at most 1.79769e308",
            ),
            (
                r#"{"cmd":"present","on_s":-2E400}"#,
                "`on_s`: -2E400 is too large to represent (it would be read as -inf)",
            ),
        ] {
            let e = from_str(s).unwrap_err().to_string();
            assert!(e.starts_with(said), "{s}: {e}");
            // serde_json alone says only "number out of range".
            let plain = serde_json::from_str::<Value>(s).unwrap_err().to_string();
            assert!(plain.starts_with("number out of range"), "{plain}");
        }
    }

    #[test]
    fn a_number_that_underflows_is_refused_naming_its_key() {
        for (s, key) in [
            (r#"{"t":1e-400,"x":0,"y":0,"z":200}"#, "`t`"),
            (
                r#"{"cmd":"present","stimulus":"a\"b","on_s":-2.5e-320}"#,
                "`on_s`",
            ),
            (r#"{"centroid_mm":[0, 1e-330, 0]}"#, "`centroid_mm`"),
        ] {
            let e = from_str(s).unwrap_err().to_string();
            assert!(
                e.starts_with(key) && e.contains("too small to represent"),
                "{s}: {e}"
            );
            // serde_json alone reads it as 0 (or a subnormal).
            assert!(serde_json::from_str::<Value>(s).is_ok());
        }
        // Zero in any spelling, and the smallest normal number, are exact.
        for s in [
            "0.0e-400",
            "-0",
            "0e5",
            "2.2250738585072014e-308",
            "[1e-300]",
        ] {
            assert!(from_str(s).is_ok(), "{s}");
        }
    }

    #[test]
    fn a_key_left_out_is_none_and_a_null_is_refused_by_name() {
        #[derive(Debug, serde::Deserialize)]
        struct Opt {
            #[serde(default, deserialize_with = "no_null")]
            a: Option<f64>,
            /// A key whose `null` is its value for "none".
            #[serde(default)]
            b: Option<f64>,
        }
        let read = |s: &str| from_value::<Opt>(from_str(s).unwrap());
        let o = read(r#"{}"#).unwrap();
        assert_eq!((o.a, o.b), (None, None));
        let o = read(r#"{"a":2.5,"b":null}"#).unwrap();
        assert_eq!((o.a, o.b), (Some(2.5), None));
        assert_eq!(
            read(r#"{"a":null}"#).unwrap_err(),
            format!("`a`: {NULL_REFUSED}")
        );
        // Any other error is serde's, as it is.
        let e = read(r#"{"a":"x"}"#).unwrap_err();
        assert!(e.starts_with("invalid type: string"), "{e}");
        // From text too (the readers of whole files).
        let e = serde_json::from_str::<Opt>(r#"{"a":null}"#).unwrap_err();
        assert!(e.to_string().starts_with(NULL_REFUSED), "{e}");
    }
}
