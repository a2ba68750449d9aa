//! Fault injection between host and device: flips bits, drops, duplicates
//! and truncates bytes at set rates, and cuts the link after a byte count.
//!
//! [`Faulty`] wraps any [`Transport`] and damages both directions with
//! independent seeded generators, so a failing run can be replayed. Rates
//! are per bit (`ber`) or per byte (the rest); events are drawn as
//! geometric gaps, so a clean stretch costs nothing per byte.

use std::str::FromStr;
use std::time::Duration;

use super::transport::Transport;
use crate::rng::SplitMix64;

/// Fault rates. All zero is a clean link.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Faults {
    /// Bit error rate: probability that each bit is flipped.
    pub ber: f64,
    /// Probability that a byte is lost.
    pub drop: f64,
    /// Probability that a byte is sent twice.
    pub dup: f64,
    /// Probability per byte that the rest of the write it is in is lost
    /// (a truncated frame).
    pub truncate: f64,
    /// After this many bytes (both directions together) the link goes dead:
    /// writes vanish and nothing arrives, like a pulled cable.
    pub cut_after: Option<u64>,
}

impl FromStr for Faults {
    type Err = String;
    /// `ber=1e-4,drop=1e-5,dup=1e-5,truncate=1e-6,cut=50000` (any subset).
    fn from_str(s: &str) -> Result<Self, String> {
        let mut f = Faults::default();
        let mut seen: Vec<&str> = Vec::new();
        for part in s.split(',').filter(|p| !p.is_empty()) {
            let (k, v) = part
                .split_once('=')
                .ok_or_else(|| format!("fault `{part}` must look like name=value"))?;
            // Spaces at an end refused, as in every flag's list (a value's
            // by `exact_number`, in a lone number flag's words).
            if k.trim() != k {
                return Err(format!(
                    "fault name `{k}` has spaces at an end: give name=value without them"
                ));
            }
            if seen.contains(&k) {
                return Err(format!("fault `{k}` is given twice"));
            }
            seen.push(k);
            if k == "cut" {
                f.cut_after = Some(
                    v.parse()
                        .map_err(|_| format!("cut `{v}` is not a byte count"))?,
                );
                continue;
            }
            let rate = crate::limits::exact_number(v).map_err(|m| format!("{k}: {m}"))?;
            if !(0.0..=1.0).contains(&rate) {
                return Err(format!("{k} = {rate} is not a probability in [0, 1]"));
            }
            match k {
                "ber" => f.ber = rate,
                "drop" => f.drop = rate,
                "dup" => f.dup = rate,
                "truncate" => f.truncate = rate,
                _ => {
                    return Err(format!(
                        "unknown fault `{k}` (known: ber, drop, dup, truncate, cut)"
                    ));
                }
            }
        }
        Ok(f)
    }
}

/// Counts of what was done to the bytes.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FaultStats {
    /// Bits flipped.
    pub flipped_bits: u64,
    /// Bytes dropped.
    pub dropped: u64,
    /// Bytes duplicated.
    pub duplicated: u64,
    /// Writes truncated.
    pub truncated: u64,
    /// Bytes that passed (before damage).
    pub bytes: u64,
}

/// Events at rate `p` drawn as gaps: how many trials until the next one.
#[derive(Debug, Clone)]
struct Gap {
    log_q: f64,
    left: u64,
}

impl Gap {
    fn new(p: f64, rng: &mut SplitMix64) -> Self {
        let mut g = Self {
            log_q: (1.0 - p).ln(),
            left: u64::MAX,
        };
        g.draw(rng);
        g
    }

    fn draw(&mut self, rng: &mut SplitMix64) {
        self.left = if self.log_q == 0.0 {
            u64::MAX
        } else if self.log_q.is_infinite() {
            0
        } else {
            let u = rng.next_f64().max(f64::MIN_POSITIVE);
            (u.ln() / self.log_q).min(u64::MAX as f64 / 2.0) as u64
        };
    }

    /// Advance over `n` trials; the offsets (within them) where events fall.
    fn events(&mut self, n: u64, rng: &mut SplitMix64, mut hit: impl FnMut(u64)) {
        let mut pos = 0u64;
        while self.left < n - pos {
            pos += self.left;
            hit(pos);
            pos += 1;
            self.draw(rng);
        }
        self.left -= n - pos;
    }
}

/// One direction's damage.
#[derive(Debug, Clone)]
struct Damage {
    rng: SplitMix64,
    bit: Gap,
    drop: Gap,
    dup: Gap,
    truncate: Gap,
}

impl Damage {
    fn new(f: &Faults, seed: u64) -> Self {
        let mut rng = SplitMix64::new(seed);
        Self {
            bit: Gap::new(f.ber, &mut rng),
            drop: Gap::new(f.drop, &mut rng),
            dup: Gap::new(f.dup, &mut rng),
            truncate: Gap::new(f.truncate, &mut rng),
            rng,
        }
    }

    fn apply(&mut self, input: &[u8], stats: &mut FaultStats) -> Vec<u8> {
        let n = input.len() as u64;
        stats.bytes += n;
        let mut bytes = input.to_vec();
        let rng = &mut self.rng;
        self.bit.events(n * 8, rng, |bit| {
            bytes[(bit / 8) as usize] ^= 1 << (bit % 8);
            stats.flipped_bits += 1;
        });
        let mut cut = bytes.len();
        self.truncate.events(n, rng, |i| cut = cut.min(i as usize));
        if cut < bytes.len() {
            bytes.truncate(cut);
            stats.truncated += 1;
        }
        let mut dropped = vec![false; bytes.len()];
        let mut dup = vec![false; bytes.len()];
        self.drop
            .events(bytes.len() as u64, rng, |i| dropped[i as usize] = true);
        self.dup
            .events(bytes.len() as u64, rng, |i| dup[i as usize] = true);
        let mut out = Vec::with_capacity(bytes.len() + 4);
        for (i, b) in bytes.into_iter().enumerate() {
            if dropped[i] {
                stats.dropped += 1;
                continue;
            }
            out.push(b);
            if dup[i] {
                stats.duplicated += 1;
                out.push(b);
            }
        }
        out
    }
}

/// A transport that damages what passes through it.
pub struct Faulty<T> {
    inner: T,
    faults: Faults,
    tx: Damage,
    rx: Damage,
    rx_buf: Vec<u8>,
    /// What was done so far.
    pub stats: FaultStats,
}

impl<T: Transport> Faulty<T> {
    /// Wrap `inner`; `seed` makes the damage reproducible.
    pub fn new(inner: T, faults: Faults, seed: u64) -> Self {
        Self {
            inner,
            tx: Damage::new(&faults, seed),
            rx: Damage::new(&faults, seed ^ 0x5EED_F00D),
            faults,
            rx_buf: Vec::new(),
            stats: FaultStats::default(),
        }
    }

    /// The wrapped transport.
    pub fn inner_mut(&mut self) -> &mut T {
        &mut self.inner
    }

    fn cut(&self) -> bool {
        self.faults.cut_after.is_some_and(|c| self.stats.bytes >= c)
    }
}

impl<T: Transport> Transport for Faulty<T> {
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        if self.cut() {
            return Ok(());
        }
        let out = self.tx.apply(bytes, &mut self.stats);
        self.inner.send(&out)
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> std::io::Result<usize> {
        // Ok(0) must mean "the timeout passed": when every byte read was
        // lost, read again rather than return early.
        let mut tmp = vec![0u8; buf.len().max(1)];
        while self.rx_buf.is_empty() {
            let n = self.inner.recv(&mut tmp, timeout)?;
            if n == 0 {
                return Ok(0);
            }
            if self.cut() {
                // A dead link: the bytes were never delivered.
                continue;
            }
            self.rx_buf = self.rx.apply(&tmp[..n], &mut self.stats);
        }
        let n = self.rx_buf.len().min(buf.len());
        buf[..n].copy_from_slice(&self.rx_buf[..n]);
        self.rx_buf.drain(..n);
        Ok(n)
    }

    fn describe(&self) -> String {
        format!("{} (with injected faults)", self.inner.describe())
    }

    fn discard_input(&mut self) -> std::io::Result<()> {
        self.rx_buf.clear();
        self.inner.discard_input()
    }

    fn now(&self) -> Duration {
        self.inner.now()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_fault_specs() {
        let f: Faults = "ber=1e-4,drop=0.01,cut=500".parse().unwrap();
        assert_eq!(f.ber, 1e-4);
        assert_eq!(f.drop, 0.01);
        assert_eq!(f.cut_after, Some(500));
        // Spaces at an item's end refused, as in every flag's list.
        assert_eq!(
            "ber=1e-4, drop=0.01".parse::<Faults>().unwrap_err(),
            "fault name ` drop` has spaces at an end: give name=value without them"
        );
        assert!(
            "ber= 1e-4"
                .parse::<Faults>()
                .unwrap_err()
                .contains("` 1e-4` is not a number (white space around it)")
        );
        assert!(
            "ber=2"
                .parse::<Faults>()
                .unwrap_err()
                .contains("probability")
        );
        assert!(
            "noise=0.1"
                .parse::<Faults>()
                .unwrap_err()
                .contains("unknown fault")
        );
        assert!("ber".parse::<Faults>().is_err());
    }

    #[test]
    fn damage_rates_match_settings() {
        let f = Faults {
            ber: 1e-3,
            drop: 1e-3,
            dup: 1e-3,
            ..Default::default()
        };
        let mut d = Damage::new(&f, 42);
        let mut stats = FaultStats::default();
        let input = vec![0x55u8; 1_000_000];
        let out = d.apply(&input, &mut stats);
        // Expect ~8000 flips and ~1000 drops/dups; allow 4 σ.
        assert!(
            (stats.flipped_bits as f64 - 8000.0).abs() < 4.0 * 8000f64.sqrt(),
            "{stats:?}"
        );
        assert!((stats.dropped as f64 - 1000.0).abs() < 130.0, "{stats:?}");
        assert!(
            (stats.duplicated as f64 - 1000.0).abs() < 130.0,
            "{stats:?}"
        );
        assert_eq!(
            out.len() as u64,
            1_000_000 - stats.dropped + stats.duplicated
        );
    }

    #[test]
    fn clean_link_is_untouched() {
        let mut d = Damage::new(&Faults::default(), 1);
        let mut stats = FaultStats::default();
        let input: Vec<u8> = (0..=255).collect();
        assert_eq!(d.apply(&input, &mut stats), input);
    }
}
