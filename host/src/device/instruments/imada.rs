//! IMADA digital force gauges (ZTS, ZTA; the DS2 and DST/DPS commands they
//! share) over RS-232 or their USB virtual COM port, as a [`ForceGauge`](super::ForceGauge).
//!
//! Request `D` CR ("transmit the displayed value"); the reply is one line
//! ended by CR: a sign, the value with its decimal point, a unit letter
//! (`N` newton, `K` kilogram-force, `O` pound-force), a mode letter (`T`
//! real time, `P` peak) and a judgement letter (`L` below the low set
//! point, `O` between, `H` above, `E` overload), e.g. `+12.34NTO`. Factory
//! setting 19200 baud, 8N1. IMADA's instruction manuals are the authority
//! on this command set; the details here are as two open drivers that read
//! these gauges use them: `sktometometo/imada_forcegauge` (a DS2: `D` CR,
//! a 10-byte reply its comment shows as `+XX.XXKT0`, 19200 baud) and a
//! DST-44A driver (reply pattern `(\+|-)(\d+\.?\d*)([OKN])([TP])([LOHE])`,
//! the letters as above). Newer ZTS firmware also has `XAR`-style commands
//! whose unit is an index into a list (`XFC`); they are not used, since
//! `D` carries the unit itself.
//!
//! The number of digits depends on the capacity and unit (a ZTS-50N shows
//! 0.01 N), so the value is parsed as digits with at most one point; the
//! mode and judgement letters are optional (older models omit them), but
//! nothing else may follow. A peak-mode reading is refused: a series of
//! held peaks has no median worth logging. An overload is refused too.

use std::time::Duration;

use super::error::{InstrumentError, quote};
use super::serial_gauge::{Dialect, SerialGauge};
use super::unit::ForceUnit;

/// The ZTS/ZTA factory baud rate.
pub const IMADA_BAUD: u32 = 19_200;
/// How long a reply may take.
pub const IMADA_REPLY_TIMEOUT: Duration = Duration::from_millis(500);

/// What a reply line says.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImadaReply {
    /// The signed value.
    pub value: f64,
    /// Its unit.
    pub unit: ForceUnit,
    /// `T` (real time), `P` (peak) or absent.
    pub mode: Option<u8>,
    /// `L`, `O`, `H`, `E` or absent.
    pub judgement: Option<u8>,
}

/// Parse a reply line (without its CR); `None` if it is not one.
pub fn parse_reply(line: &str) -> Option<ImadaReply> {
    let b = line.trim_end_matches(' ').as_bytes();
    let (&sign, rest) = b.split_first()?;
    let negative = match sign {
        b'+' => false,
        b'-' => true,
        _ => return None,
    };
    let num_len = rest
        .iter()
        .position(|c| !(c.is_ascii_digit() || *c == b'.'))
        .unwrap_or(rest.len());
    let (num, tail) = rest.split_at(num_len);
    let digits = num.iter().filter(|c| c.is_ascii_digit()).count();
    if digits == 0 || digits > 7 || num.iter().filter(|&&c| c == b'.').count() > 1 {
        return None;
    }
    let value: f64 = std::str::from_utf8(num).ok()?.parse().ok()?;
    let (&unit, tail) = tail.split_first()?;
    let unit = match unit {
        b'N' => ForceUnit::N,
        b'K' => ForceUnit::Kgf,
        b'O' => ForceUnit::Lbf,
        _ => return None,
    };
    let (mode, tail) = match tail.split_first() {
        Some((&m @ (b'T' | b'P'), t)) => (Some(m), t),
        _ => (None, tail),
    };
    let (judgement, tail) = match tail.split_first() {
        Some((&j @ (b'L' | b'O' | b'H' | b'E'), t)) => (Some(j), t),
        _ => (None, tail),
    };
    if !tail.is_empty() {
        return None;
    }
    Some(ImadaReply {
        value: if negative { -value } else { value },
        unit,
        mode,
        judgement,
    })
}

/// An IMADA gauge over port `P` ([`SerialGauge::open`] it at [`IMADA_BAUD`]
/// unless the gauge was set otherwise).
pub type Imada<P> = SerialGauge<P, ImadaDialect>;

/// IMADA's `D` request and its reply.
pub struct ImadaDialect;

impl Dialect for ImadaDialect {
    const REQUEST: &'static str = "D";
    const REPLY_TIMEOUT: Duration = IMADA_REPLY_TIMEOUT;

    fn reading(port: &str, line: &str) -> Result<(f64, ForceUnit), InstrumentError> {
        let r = parse_reply(line).ok_or_else(|| {
            InstrumentError::protocol(
                port,
                format!(
                    "reply to D is not sign, value, unit N/K/O (mode, judgement): {}",
                    quote(line.as_bytes())
                ),
            )
        })?;
        if r.judgement == Some(b'E') {
            return Err(InstrumentError::refused(
                port,
                format!("gauge reports an overload ({line}); unload it"),
            ));
        }
        if r.mode == Some(b'P') {
            return Err(InstrumentError::refused(
                port,
                format!("gauge is in peak mode ({line}); set it to real time (T)"),
            ));
        }
        Ok((r.value, r.unit))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replies_of_every_documented_shape_parse() {
        let r = parse_reply("+12.34NTO").unwrap();
        assert_eq!(
            (r.value, r.unit, r.mode, r.judgement),
            (12.34, ForceUnit::N, Some(b'T'), Some(b'O'))
        );
        let r = parse_reply("-1.234KTL").unwrap();
        assert_eq!((r.value, r.unit), (-1.234, ForceUnit::Kgf));
        let r = parse_reply("+11.24OTH").unwrap();
        assert_eq!(
            (r.value, r.unit, r.judgement),
            (11.24, ForceUnit::Lbf, Some(b'H'))
        );
        // Lbf with judgement O: the unit letter comes first, so no clash.
        assert_eq!(parse_reply("+0.50OTO").unwrap().unit, ForceUnit::Lbf);
        // Models that send no mode or judgement.
        assert_eq!(parse_reply("+0.05N").unwrap().value, 0.05);
        assert_eq!(parse_reply("+0.05NT").unwrap().mode, Some(b'T'));
        assert_eq!(parse_reply("+0012N").unwrap().value, 12.0);
    }

    #[test]
    fn garbage_is_refused() {
        for bad in [
            "",
            "+",
            "12.34NTO",
            "+12.34",
            "+12.34XTO",
            "+1.2.3NTO",
            "+.NTO",
            "+12.34NTOX",
            "+12.34NTZ",
            "++12NTO",
            "+12345678NTO",
            "+12.34 NTO",
            "-N",
        ] {
            assert!(parse_reply(bad).is_none(), "{bad:?} parsed");
        }
    }
}
