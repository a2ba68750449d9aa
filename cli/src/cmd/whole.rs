//! The parser of every whole-number flag: one range, the flag's own,
//! named whatever is wrong with the value.
//!
//! clap's own integer parsers said `invalid digit found in string` for
//! `--timeout-ms -1` and `number too large to fit in target type` for
//! `--tries 99999999999999999999`, and a flag the library bounds later
//! (`--enter-frames`, 1 to 90) named its type's range for a value its type
//! cannot hold (`-1 is not in 0..=4294967295`), never its own.

/// A whole-number flag's parser: a value in `lo..=hi` (the flag's own
/// range, which [`T`] holds), else `VALUE is not in LO..=HI` (`VALUE is
/// not a whole number in LO..=HI` when it is not one: a fraction, a word,
/// an exponent).
pub fn whole<T>(lo: u64, hi: u64) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync
where
    T: TryFrom<u64> + Clone + Send + Sync + 'static,
{
    debug_assert!(
        lo <= hi && T::try_from(hi).is_ok(),
        "a range the type holds"
    );
    move |s: &str| {
        let range = range(lo, hi);
        // Digits alone (a sign is the one thing besides them a whole
        // number may carry): out of range, however many there are.
        let digits = s.strip_prefix(['-', '+']).unwrap_or(s);
        if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
            return Err(format!("{s} is not a whole number in {range}"));
        }
        match s.parse::<u64>() {
            Ok(v) if (lo..=hi).contains(&v) => {
                T::try_from(v).map_err(|_| format!("{s} is not in {range}"))
            }
            _ => Err(format!("{s} is not in {range}")),
        }
    }
}

/// `lo..=hi`, the largest `u64` written as what it is.
fn range(lo: u64, hi: u64) -> String {
    match hi {
        u64::MAX => format!("{lo}..=2^64-1"),
        _ => format!("{lo}..={hi}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_value_is_refused_naming_the_flags_own_range() {
        let p = whole::<u32>(1, 90);
        assert_eq!(p("1"), Ok(1));
        assert_eq!(p("+90"), Ok(90));
        for (v, want) in [
            ("0", "0 is not in 1..=90"),
            ("91", "91 is not in 1..=90"),
            ("-1", "-1 is not in 1..=90"),
            ("4294967296", "4294967296 is not in 1..=90"),
            (
                "99999999999999999999999",
                "99999999999999999999999 is not in 1..=90",
            ),
            ("1.5", "1.5 is not a whole number in 1..=90"),
            ("1e3", "1e3 is not a whole number in 1..=90"),
            ("", " is not a whole number in 1..=90"),
            (" 5", " 5 is not a whole number in 1..=90"),
            ("-", "- is not a whole number in 1..=90"),
            ("٣", "٣ is not a whole number in 1..=90"),
        ] {
            assert_eq!(p(v), Err(want.to_owned()), "{v}");
        }
        let seed = whole::<u64>(0, u64::MAX);
        assert_eq!(seed("18446744073709551615"), Ok(u64::MAX));
        assert_eq!(
            seed("18446744073709551616"),
            Err("18446744073709551616 is not in 0..=2^64-1".to_owned())
        );
        assert_eq!(
            whole::<u8>(0, 255)("256"),
            Err("256 is not in 0..=255".into())
        );
    }
}
