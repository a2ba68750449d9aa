//! Mark-10 digital force gauges (Series 5, Series 7; Series 4 answers the
//! same request) over RS-232 or USB, as a [`ForceGauge`](super::ForceGauge).
//!
//! Request `?` CR ("request the displayed reading", Gauge Control
//! Language 2); the reply is the value, a space and the unit, ended by
//! CR LF, e.g. `4.285 N` (compression) or `-18.78 lbF` (tension); the
//! number of decimals depends on capacity; errors come back as `*10`
//! (illegal command), `*11` (not applicable), `*12` (invalid specifier),
//! `*22` (value too large). Source: Mark-10's Series 4 and Series 5
//! user's guides (sections "Data Communication" / "Command Set / Gauge
//! Control Language 2"). Baud rate, data bits and stop bits are set on the
//! gauge (Series 5 ships at 115200, 8N1); the reply carries a unit only
//! when the gauge's Serial/USB "Data format" includes it, which this
//! driver needs, since a bare number could be in any of the gauge's units.
//!
//! The space before the unit is parsed as any run of spaces (or none);
//! the unit is matched without regard to case (`lbF`, `kgF`, `N`, `mN`,
//! `gF`, `ozF`, `kN`, `klbF`); nothing else may follow.

use std::time::Duration;

use super::error::{InstrumentError, quote};
use super::serial_gauge::{Dialect, SerialGauge};
use super::unit::ForceUnit;

/// The Series 5 factory baud rate.
pub const MARK10_BAUD: u32 = 115_200;
/// How long a reply may take.
pub const MARK10_REPLY_TIMEOUT: Duration = Duration::from_millis(500);

/// What a reply line says.
#[derive(Debug, Clone, PartialEq)]
pub enum Mark10Reply {
    /// A reading.
    Value(f64, ForceUnit),
    /// A number without a unit (the data format leaves it out).
    NoUnit(f64),
    /// A number with a unit we do not know.
    UnknownUnit(f64, String),
    /// An error code (`*10`).
    Error(String),
}

/// Parse a reply line (without CR LF); `None` if it is none of the above.
pub fn parse_reply(line: &str) -> Option<Mark10Reply> {
    let line = line.trim();
    if let Some(code) = line.strip_prefix('*') {
        if !code.is_empty() && code.len() <= 3 && code.bytes().all(|c| c.is_ascii_digit()) {
            return Some(Mark10Reply::Error(line.to_owned()));
        }
        return None;
    }
    let num_len = line
        .bytes()
        .position(|c| !(c.is_ascii_digit() || c == b'.' || c == b'-' || c == b'+'))
        .unwrap_or(line.len());
    let (num, unit) = line.split_at(num_len);
    let digits = num.bytes().filter(u8::is_ascii_digit).count();
    let signs = num.bytes().filter(|&c| c == b'-' || c == b'+').count();
    let sign_first = signs == 0 || (signs == 1 && matches!(num.as_bytes()[0], b'-' | b'+'));
    if digits == 0 || digits > 9 || !sign_first {
        return None;
    }
    let value: f64 = num.parse().ok()?;
    let unit = unit.trim_start_matches(' ');
    if unit.is_empty() {
        return Some(Mark10Reply::NoUnit(value));
    }
    if !unit.bytes().all(|c| c.is_ascii_alphabetic()) || unit.len() > 5 {
        return None;
    }
    Some(match ForceUnit::from_symbol(unit) {
        Some(u) => Mark10Reply::Value(value, u),
        None => Mark10Reply::UnknownUnit(value, unit.to_owned()),
    })
}

/// A Mark-10 gauge over port `P` ([`SerialGauge::open`] it at the baud set
/// on the gauge, [`MARK10_BAUD`] from the factory).
pub type Mark10<P> = SerialGauge<P, Mark10Dialect>;

/// Mark-10's `?` request and its reply.
pub struct Mark10Dialect;

impl Dialect for Mark10Dialect {
    const REQUEST: &'static str = "?";
    const REPLY_TIMEOUT: Duration = MARK10_REPLY_TIMEOUT;

    fn reading(name: &str, line: &str) -> Result<(f64, ForceUnit), InstrumentError> {
        match parse_reply(line) {
            Some(Mark10Reply::Value(value, unit)) => Ok((value, unit)),
            Some(Mark10Reply::NoUnit(_)) => Err(InstrumentError::protocol(
                name,
                format!(
                    "reply {} has no unit; include units in the gauge's Serial/USB data format",
                    quote(line.as_bytes())
                ),
            )),
            Some(Mark10Reply::UnknownUnit(_, u)) => Err(InstrumentError::protocol(
                name,
                format!(
                    "reply {} is in unit '{u}', which is not a force unit lmhost knows",
                    quote(line.as_bytes())
                ),
            )),
            Some(Mark10Reply::Error(code)) => Err(InstrumentError::refused(
                name,
                format!("gauge answered ? with error {code} (*10: illegal command)"),
            )),
            None => Err(InstrumentError::protocol(
                name,
                format!(
                    "reply to ? is not a value and a unit: {}",
                    quote(line.as_bytes())
                ),
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn documented_replies_parse() {
        assert_eq!(
            parse_reply("4.285 N"),
            Some(Mark10Reply::Value(4.285, ForceUnit::N))
        );
        assert_eq!(
            parse_reply("-18.78 lbF"),
            Some(Mark10Reply::Value(-18.78, ForceUnit::Lbf))
        );
        assert_eq!(
            parse_reply("  0.512  kgF "),
            Some(Mark10Reply::Value(0.512, ForceUnit::Kgf))
        );
        assert_eq!(
            parse_reply("12.3mN"),
            Some(Mark10Reply::Value(12.3, ForceUnit::MilliN))
        );
        assert_eq!(parse_reply("12.34"), Some(Mark10Reply::NoUnit(12.34)));
        assert_eq!(
            parse_reply("1.5 psi"),
            Some(Mark10Reply::UnknownUnit(1.5, "psi".into()))
        );
        assert_eq!(parse_reply("*10"), Some(Mark10Reply::Error("*10".into())));
    }

    #[test]
    fn garbage_is_refused() {
        for bad in [
            "",
            "N",
            "abc",
            "1-2 N",
            "--1 N",
            "1.2.3 N",
            "1 N x",
            "1 N2",
            "*",
            "*abc",
            "1 Newtons",
        ] {
            assert_eq!(parse_reply(bad), None, "{bad:?} parsed");
        }
    }
}
