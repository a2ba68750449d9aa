//! JSON read from the outside at run time (control lines, centroid lines
//! and datagrams): parsed as `serde_json` does, except that an object that
//! names a key twice is refused. `serde_json` keeps the last one without a
//! word, so `{"cmd":"stop","cmd":"quit"}` would quit and
//! `{"x":0,"x":500}` would be a centroid at 500 mm.

use std::fmt;

use serde::Deserialize;
use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use serde_json::{Map, Value};

/// One JSON value from `s` (the whole of it), refusing a duplicate key at
/// any depth with an error naming it.
pub fn from_str(s: &str) -> Result<Value, serde_json::Error> {
    let mut de = serde_json::Deserializer::from_str(s);
    let Strict(v) = Strict::deserialize(&mut de)?;
    de.end()?;
    Ok(v)
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
}
