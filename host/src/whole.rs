//! A whole-number field of a file (a scene, a protocol, a library, an
//! intrinsics or stimulus file), read as whatever number the file wrote
//! and judged by the field's own range.
//!
//! Read straight into its Rust type, `repeat = -1` said "expected a whole
//! number from 0 to 4294967295" (the type's range, not the field's
//! 1..=10000), `2.5` and `1e30` "invalid type: floating point", and only a
//! value the type held reached the field's own check. [`Whole`] takes any
//! number and refuses it in the field's words: `-1 is out of range:
//! allowed 1..=10000`, `2.5 is not a whole number: allowed 1..=10000` (the
//! words of a whole-number flag and of a control line's `repeat` too).

use std::fmt;

use serde::de::{self, Deserializer, Visitor};
use serde::{Deserialize, Serialize};

use crate::limits::show;

/// A number as a file wrote it, before any range is checked: a whole
/// number (however large the file's format lets it be) or a float.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FileNumber {
    /// Written without a fraction or exponent.
    Int(i128),
    /// Written with one (`2.5`, `3.0`, `1e30`), or NaN / infinite.
    Float(f64),
}

impl FileNumber {
    /// The whole number in `lo..=hi` this is, or one line naming the
    /// range: `VALUE is out of range: allowed LO..=HI` for a whole number
    /// outside it (however large), `VALUE is not a whole number: allowed
    /// LO..=HI` for a fraction (`3.0` too: the file wrote a float).
    pub fn whole_in(self, lo: u64, hi: u64) -> Result<u64, String> {
        // In range, so it is a u64.
        self.within(lo.into(), hi.into()).map(|v| v as u64)
    }

    /// The whole number in `lo..=hi` (either sign) this is, in the words
    /// of [`FileNumber::whole_in`].
    pub fn signed_in(self, lo: i64, hi: i64) -> Result<i64, String> {
        // In range, so it is an i64.
        self.within(lo.into(), hi.into()).map(|v| v as i64)
    }

    /// Both of them: every u64 and i64 range is one of i128.
    fn within(self, lo: i128, hi: i128) -> Result<i128, String> {
        let range = range(lo, hi);
        match self {
            FileNumber::Int(i) if (lo..=hi).contains(&i) => Ok(i),
            FileNumber::Int(i) => Err(format!("{i} is out of range: allowed {range}")),
            FileNumber::Float(f) => {
                let whole = f.is_finite() && f.fract() == 0.0;
                let inside = f >= lo as f64 && f <= hi as f64;
                match (whole, inside) {
                    (true, false) => Err(format!("{} is out of range: allowed {range}", show(f))),
                    // `3.0`, not `3`: the number as written, not an integer.
                    (true, true) => Err(format!("{f:.1} is not a whole number: allowed {range}")),
                    (false, _) if f.is_infinite() => {
                        Err(format!("{} is out of range: allowed {range}", show(f)))
                    }
                    (false, _) => Err(format!(
                        "{} is not a whole number: allowed {range}",
                        show(f)
                    )),
                }
            }
        }
    }
}

/// `lo..=hi` as every whole-number refusal names it (a file's field, a
/// flag, a control line's `repeat`), the largest `u64` written as what it
/// is (`2^64-1`), not as a float the message tidier would round.
pub fn range(lo: i128, hi: i128) -> String {
    match hi {
        h if h == i128::from(u64::MAX) => format!("{lo}..=2^64-1"),
        _ => format!("{lo}..={hi}"),
    }
}

impl<'de> Deserialize<'de> for FileNumber {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(NumberVisitor(None))
    }
}

/// Reads any number; a value of another kind is refused as not "a whole
/// number" (in the range, when one is given).
struct NumberVisitor(Option<(u64, u64)>);

impl Visitor<'_> for NumberVisitor {
    type Value = FileNumber;
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match self.0 {
            Some((lo, hi)) => write!(f, "a whole number in {}", range(lo.into(), hi.into())),
            None => f.write_str("a whole number"),
        }
    }
    fn visit_i64<E>(self, v: i64) -> Result<FileNumber, E> {
        Ok(FileNumber::Int(v.into()))
    }
    fn visit_u64<E>(self, v: u64) -> Result<FileNumber, E> {
        Ok(FileNumber::Int(v.into()))
    }
    fn visit_i128<E>(self, v: i128) -> Result<FileNumber, E> {
        Ok(FileNumber::Int(v))
    }
    fn visit_u128<E>(self, v: u128) -> Result<FileNumber, E> {
        Ok(i128::try_from(v).map_or(FileNumber::Float(v as f64), FileNumber::Int))
    }
    fn visit_f64<E>(self, v: f64) -> Result<FileNumber, E> {
        Ok(FileNumber::Float(v))
    }
}

/// A whole number in `LO..=HI` (the field's own range) read from a file
/// as [`FileNumber::whole_in`] judges it. Give the range the library
/// checks the field against, so every value outside it is refused here,
/// where the file's line is known, in the same words.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(transparent)]
pub struct Whole<const LO: u64, const HI: u64>(pub u64);

impl<const LO: u64, const HI: u64> Whole<LO, HI> {
    /// The number, as a `u32` (every range a file uses fits one).
    pub fn get(self) -> u32 {
        u32::try_from(self.0).unwrap_or(u32::MAX)
    }

    /// The number, as a `usize`.
    pub fn get_usize(self) -> usize {
        usize::try_from(self.0).unwrap_or(usize::MAX)
    }

    /// The number as a `T`, refused in the field's words when `T` cannot
    /// hold it (a range wider than the type a struct keeps).
    fn held<T: TryFrom<u64>, E: de::Error>(self) -> Result<T, E> {
        T::try_from(self.0).map_err(|_| {
            E::custom(format!(
                "{} is out of range: allowed {}",
                self.0,
                range(LO.into(), HI.into())
            ))
        })
    }
}

impl<'de, const LO: u64, const HI: u64> Deserialize<'de> for Whole<LO, HI> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let n = d.deserialize_any(NumberVisitor(Some((LO, HI))))?;
        n.whole_in(LO, HI).map(Self).map_err(de::Error::custom)
    }
}

/// A whole number in `LO..=HI` of either sign (a centre in µm), judged as
/// [`Whole`] judges one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(transparent)]
pub struct Signed<const LO: i64, const HI: i64>(pub i64);

impl<'de, const LO: i64, const HI: i64> Deserialize<'de> for Signed<LO, HI> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let n = d.deserialize_any(NumberVisitor(None))?;
        n.signed_in(LO, HI).map(Self).map_err(de::Error::custom)
    }
}

/// A whole number in `0..=255` kept in one byte (a phase, a level of an
/// intensity table): as [`Whole<0, 255>`] judges it, an eighth its size
/// for the millions a phases file holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(transparent)]
pub struct Byte(pub u8);

impl<'de> Deserialize<'de> for Byte {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let n = d.deserialize_any(NumberVisitor(Some((0, 255))))?;
        n.whole_in(0, 255)
            .map(|v| Self(u8::try_from(v).unwrap_or(u8::MAX)))
            .map_err(de::Error::custom)
    }
}

/// Rows of [`Byte`]s as rows of bytes.
pub fn bytes(rows: Vec<Vec<Byte>>) -> Vec<Vec<u8>> {
    rows.into_iter()
        .map(|r| r.into_iter().map(|b| b.0).collect())
        .collect()
}

/// An integer field of type `T` read as [`Whole<LO, HI>`] judges it, for
/// a struct that keeps its plain type:
/// `#[serde(deserialize_with = "crate::whole::field::<_, _, 1, 100>")]`.
pub fn field<'de, D, T, const LO: u64, const HI: u64>(d: D) -> Result<T, D::Error>
where
    D: Deserializer<'de>,
    T: TryFrom<u64>,
{
    Whole::<LO, HI>::deserialize(d)?.held()
}

/// As [`field`], for an optional field (`null` is none).
pub fn opt_field<'de, D, T, const LO: u64, const HI: u64>(d: D) -> Result<Option<T>, D::Error>
where
    D: Deserializer<'de>,
    T: TryFrom<u64>,
{
    Option::<Whole<LO, HI>>::deserialize(d)?
        .map(Whole::held)
        .transpose()
}

/// As [`field`], for rows of whole numbers.
pub fn rows<'de, D, T, const LO: u64, const HI: u64>(d: D) -> Result<Vec<Vec<T>>, D::Error>
where
    D: Deserializer<'de>,
    T: TryFrom<u64>,
{
    let rows = Vec::<Vec<Whole<LO, HI>>>::deserialize(d)?;
    rows.into_iter()
        .map(|r| r.into_iter().map(Whole::held).collect())
        .collect()
}

impl<const LO: u64, const HI: u64> schemars::JsonSchema for Whole<LO, HI> {
    fn inline_schema() -> bool {
        true
    }
    fn schema_name() -> std::borrow::Cow<'static, str> {
        format!("Whole_{LO}_{HI}").into()
    }
    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        schemars::json_schema!({ "type": "integer", "minimum": LO, "maximum": HI })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Deserialize)]
    struct T {
        n: Whole<1, 100>,
    }

    fn said(v: &str) -> Result<u64, String> {
        toml::from_str::<T>(&format!("n = {v}\n"))
            .map(|t| t.n.0)
            .map_err(|e| e.message().to_owned())
    }

    #[test]
    fn every_number_is_judged_by_the_fields_range_not_its_type() {
        assert_eq!(said("1"), Ok(1));
        assert_eq!(said("100"), Ok(100));
        for (v, msg) in [
            ("0", "0 is out of range: allowed 1..=100"),
            ("-1", "-1 is out of range: allowed 1..=100"),
            ("101", "101 is out of range: allowed 1..=100"),
            ("4294967296", "4294967296 is out of range: allowed 1..=100"),
            (
                "9223372036854775807",
                "9223372036854775807 is out of range: allowed 1..=100",
            ),
            ("2.5", "2.5 is not a whole number: allowed 1..=100"),
            ("3.0", "3.0 is not a whole number: allowed 1..=100"),
            ("1e30", "1e30 is out of range: allowed 1..=100"),
            ("-1e300", "-1e300 is out of range: allowed 1..=100"),
            ("inf", "inf is out of range: allowed 1..=100"),
            ("nan", "NaN is not a whole number: allowed 1..=100"),
        ] {
            assert_eq!(said(v), Err(msg.to_owned()), "{v}");
        }
        // A seed's range: its top written as what it is, not rounded.
        assert_eq!(
            FileNumber::Int(-1).whole_in(0, u64::MAX),
            Err("-1 is out of range: allowed 0..=2^64-1".to_owned())
        );
        let s = said("\"3\"").unwrap_err();
        assert!(s.contains("expected a whole number in 1..=100"), "{s}");
    }

    #[test]
    fn signed_numbers_and_bytes_are_judged_by_their_range() {
        let s = |v: &str| {
            serde_json::from_str::<Signed<-5, 5>>(v)
                .map(|w| w.0)
                .map_err(|e| e.to_string())
        };
        assert_eq!(s("-5"), Ok(-5));
        assert_eq!(s("5"), Ok(5));
        for (v, msg) in [
            ("-6", "-6 is out of range: allowed -5..=5"),
            ("6", "6 is out of range: allowed -5..=5"),
            ("-2.5", "-2.5 is not a whole number: allowed -5..=5"),
            ("-3.0", "-3.0 is not a whole number: allowed -5..=5"),
            ("1e30", "1e30 is out of range: allowed -5..=5"),
            (
                "18446744073709551615",
                "18446744073709551615 is out of range: allowed -5..=5",
            ),
        ] {
            let e = s(v).unwrap_err();
            assert!(e.starts_with(msg), "{v}: {e}");
        }
        let b = |v: &str| {
            serde_json::from_str::<Vec<Byte>>(v)
                .map(|w| w.iter().map(|b| b.0).collect::<Vec<_>>())
                .map_err(|e| e.to_string())
        };
        assert_eq!(b("[0, 255]"), Ok(vec![0, 255]));
        for (v, msg) in [
            ("[-1]", "-1 is out of range: allowed 0..=255"),
            ("[256]", "256 is out of range: allowed 0..=255"),
            ("[2.5]", "2.5 is not a whole number: allowed 0..=255"),
        ] {
            let e = b(v).unwrap_err();
            assert!(e.starts_with(msg), "{v}: {e}");
        }
        assert!(
            b("[\"7\"]")
                .unwrap_err()
                .contains("expected a whole number in 0..=255")
        );
    }

    #[test]
    fn json_numbers_beyond_64_bits_are_judged_too() {
        let j = |v: &str| {
            serde_json::from_str::<Whole<0, 255>>(v)
                .map(|w| w.0)
                .map_err(|e| e.to_string())
        };
        assert_eq!(j("255"), Ok(255));
        assert!(
            j("256")
                .unwrap_err()
                .starts_with("256 is out of range: allowed 0..=255")
        );
        let huge = j("18446744073709551616").unwrap_err();
        assert!(huge.contains("is out of range: allowed 0..=255"), "{huge}");
        let text = j("\"7\"").unwrap_err();
        assert!(
            text.contains("expected a whole number in 0..=255"),
            "{text}"
        );
        assert!(
            j("-5")
                .unwrap_err()
                .starts_with("-5 is out of range: allowed 0..=255")
        );
    }
}
