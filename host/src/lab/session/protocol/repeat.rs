//! A control line's `repeat`: a whole number of on-phases in
//! 1..=[`MAX_REPEAT`], refused in those words whatever number came (`-1`,
//! `0`, `2.5`, `1e21`, `3.0`), never as the Rust type the field is read
//! into ("expected a whole number from 0 to 4294967295" named a range that
//! is not the rule) or by the JSON type of a number too large for it.

use crate::lab::session::MAX_REPEAT;
use crate::whole::FileNumber;

/// `repeat` as `Present` reads it: absent is None (with
/// `serde(default)`), `null` refused as every optional key's is
/// ([`crate::json::no_null`]).
pub fn opt<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<u32>, D::Error> {
    let v = crate::json::no_null::<_, serde_json::Value>(d)?;
    v.map(|v| check(&v).map_err(serde::de::Error::custom))
        .transpose()
}

/// The on-phases `v` asks for, or what is wrong with it (one line): a
/// number judged as a file's whole-number field is ([`crate::whole`]).
pub fn check(v: &serde_json::Value) -> Result<u32, String> {
    let range = crate::whole::range(1, MAX_REPEAT.into());
    let kind = match v {
        serde_json::Value::Number(_) => "",
        serde_json::Value::String(_) => "a string",
        serde_json::Value::Bool(_) => "a boolean",
        serde_json::Value::Array(_) => "a list",
        _ => "an object",
    };
    let serde_json::Value::Number(n) = v else {
        return Err(format!("`repeat` is {kind}, not a number: allowed {range}"));
    };
    let n = match (n.as_i64(), n.as_u64()) {
        (Some(i), _) => FileNumber::Int(i.into()),
        (None, Some(u)) => FileNumber::Int(u.into()),
        (None, None) => FileNumber::Float(n.as_f64().unwrap_or(f64::NAN)),
    };
    n.whole_in(1, MAX_REPEAT.into())
        .map(|r| r as u32)
        .map_err(|e| format!("repeat {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_number_is_judged_by_the_rule_not_the_type() {
        let said = |s: &str| check(&serde_json::from_str(s).unwrap());
        assert_eq!(said("3"), Ok(3));
        assert_eq!(said("10000"), Ok(10_000));
        for (text, msg) in [
            ("0", "repeat 0 is out of range: allowed 1..=10000"),
            ("-1", "repeat -1 is out of range: allowed 1..=10000"),
            ("10001", "repeat 10001 is out of range: allowed 1..=10000"),
            (
                "4294967296",
                "repeat 4294967296 is out of range: allowed 1..=10000",
            ),
            (
                "18446744073709551615",
                "repeat 18446744073709551615 is out of range: allowed 1..=10000",
            ),
            (
                "1180591620717411303424",
                "repeat 1.18059e21 is out of range: allowed 1..=10000",
            ),
            ("-1e300", "repeat -1e300 is out of range: allowed 1..=10000"),
            ("2.5", "repeat 2.5 is not a whole number: allowed 1..=10000"),
            ("3.0", "repeat 3.0 is not a whole number: allowed 1..=10000"),
            (
                "\"3\"",
                "`repeat` is a string, not a number: allowed 1..=10000",
            ),
            (
                "true",
                "`repeat` is a boolean, not a number: allowed 1..=10000",
            ),
            ("[3]", "`repeat` is a list, not a number: allowed 1..=10000"),
        ] {
            assert_eq!(said(text), Err(msg.to_owned()), "{text}");
        }
    }
}
