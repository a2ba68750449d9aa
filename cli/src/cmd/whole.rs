//! The parser of every whole-number flag: one range, the flag's own,
//! named whatever is wrong with the value.
//!
//! clap's own integer parsers said `invalid digit found in string` for
//! `--timeout-ms -1` and `number too large to fit in target type` for
//! `--tries 99999999999999999999`, and a flag the library bounds later
//! (`--enter-frames`, 1 to 90) named its type's range for a value its type
//! cannot hold (`-1 is not in 0..=4294967295`), never its own.

/// A whole-number flag's parser: a value in `lo..=hi` (the flag's own
/// range, which [`T`] holds), else `VALUE is out of range: allowed LO..=HI`
/// (`VALUE is not a whole number: allowed LO..=HI` when it is not one: a
/// fraction, a word, an exponent), in the words of a file's whole-number
/// field ([`lmhost::whole`]).
pub fn whole<T>(lo: u64, hi: u64) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync
where
    T: TryFrom<u64> + Clone + Send + Sync + 'static,
{
    debug_assert!(
        lo <= hi && T::try_from(hi).is_ok(),
        "a range the type holds"
    );
    move |s: &str| {
        let range = lmhost::whole::range(lo.into(), hi.into());
        // Digits alone (a sign is the one thing besides them a whole
        // number may carry): out of range, however many there are.
        let digits = s.strip_prefix(['-', '+']).unwrap_or(s);
        if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
            // An empty value or one with spaces shown as one (` 5` read
            // as "5 is not" named a value that would have been taken).
            // What it looks like as a number written another way (`0x10`,
            // `1_000`, `30ms`), in a number flag's words; a comma in a
            // whole number is no decimal comma (`1,000`).
            let hint = match s.contains(',') {
                true => String::new(),
                false => lmhost::files::text::number_hint(s),
            };
            return Err(match s {
                "" => format!("an empty value is not a whole number: allowed {range}"),
                _ if s.trim() != s => format!("`{s}` is not a whole number: allowed {range}"),
                _ => format!("{s} is not a whole number{hint}: allowed {range}"),
            });
        }
        s.parse::<u64>()
            .ok()
            .filter(|v| (lo..=hi).contains(v))
            .and_then(|v| T::try_from(v).ok())
            .ok_or_else(|| format!("{s} is out of range: allowed {range}"))
    }
}

/// For a flag whose range the library checks in its own words, the words
/// Python's `plan()` says too (`--foci`, `--steps`, `--iterations`): a
/// value that is not a whole number or that `T` cannot hold is refused as
/// [`whole`] refuses it, naming `lo..=hi`; any other whole number is the
/// library's to take or refuse (`foci must be 1..=32, got 0`).
pub fn whole_for_library<T>(
    lo: u64,
    hi: u64,
) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync
where
    T: TryFrom<u64> + Clone + Send + Sync + 'static,
{
    let own = whole::<T>(lo, hi);
    move |s: &str| {
        let digits = s.strip_prefix('+').unwrap_or(s);
        let held = digits
            .bytes()
            .all(|b| b.is_ascii_digit())
            .then(|| digits.parse::<u64>().ok())
            .flatten()
            .and_then(|v| T::try_from(v).ok());
        match held {
            Some(v) => Ok(v),
            None => own(s),
        }
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
            ("0", "0 is out of range: allowed 1..=90"),
            ("91", "91 is out of range: allowed 1..=90"),
            ("-1", "-1 is out of range: allowed 1..=90"),
            ("4294967296", "4294967296 is out of range: allowed 1..=90"),
            (
                "99999999999999999999999",
                "99999999999999999999999 is out of range: allowed 1..=90",
            ),
            ("1.5", "1.5 is not a whole number: allowed 1..=90"),
            ("1e3", "1e3 is not a whole number: allowed 1..=90"),
            ("", "an empty value is not a whole number: allowed 1..=90"),
            (" 5", "` 5` is not a whole number: allowed 1..=90"),
            ("-", "- is not a whole number: allowed 1..=90"),
            (
                "٣",
                "٣ is not a whole number (digits other than 0-9: write it with 0-9): allowed 1..=90",
            ),
            (
                "0x10",
                "0x10 is not a whole number (a hexadecimal number? write it in decimal): allowed 1..=90",
            ),
            (
                "1_0",
                "1_0 is not a whole number (digit separators? write `10`): allowed 1..=90",
            ),
            (
                "30ms",
                "30ms is not a whole number (a unit after it? give the number alone: `30`): allowed 1..=90",
            ),
            ("1,000", "1,000 is not a whole number: allowed 1..=90"),
        ] {
            assert_eq!(p(v), Err(want.to_owned()), "{v}");
        }
        let seed = whole::<u64>(0, u64::MAX);
        assert_eq!(seed("18446744073709551615"), Ok(u64::MAX));
        assert_eq!(
            seed("18446744073709551616"),
            Err("18446744073709551616 is out of range: allowed 0..=2^64-1".to_owned())
        );
        assert_eq!(
            whole::<u8>(0, 255)("256"),
            Err("256 is out of range: allowed 0..=255".into())
        );
    }

    #[test]
    fn a_value_the_library_rules_on_passes_to_it() {
        let p = whole_for_library::<u8>(1, 32);
        // The library's rule says these.
        assert_eq!(p("0"), Ok(0));
        assert_eq!(p("+33"), Ok(33));
        assert_eq!(p("255"), Ok(255));
        // What no rule of the library sees: named by the flag's range.
        for (v, want) in [
            ("-1", "-1 is out of range: allowed 1..=32"),
            ("256", "256 is out of range: allowed 1..=32"),
            (
                "99999999999999999999999",
                "99999999999999999999999 is out of range: allowed 1..=32",
            ),
            ("1.5", "1.5 is not a whole number: allowed 1..=32"),
            ("", "an empty value is not a whole number: allowed 1..=32"),
            ("+", "+ is not a whole number: allowed 1..=32"),
        ] {
            assert_eq!(p(v), Err(want.to_owned()), "{v}");
        }
    }
}
