//! The SPI loopback self-test's pattern and comparison.
//!
//! With one wire from MOSI to MISO (see [`crate::pins::LOOPBACK_WIRE`]) and
//! the driver's chip select held high, SPI1 sends [`LOOPBACK_BYTES`] bytes
//! and reads the same number back; every byte must come back unchanged.
//!
//! The pattern ([`Pattern`]) starts with bytes that isolate the usual wiring
//! faults: 0x00 and 0xFF (a line stuck high or low), 0x55 and 0xAA
//! (neighbouring bits shorted), a walking one and a walking zero (each bit
//! alone: a stuck, missing or swapped bit shows at the byte naming it);
//! then bytes of a maximal-length 16-bit LFSR, so that data-dependent
//! faults (a slow edge, crosstalk, a byte slipping by one) show too and no
//! short period hides them. [`LoopbackReport`] counts the bytes compared
//! and the mismatches and keeps the first one (index, sent, got).

/// Bytes one self-test sends and compares: four passes of [`CHUNK`]
/// through the DMA buffers, one continuous pattern.
pub const LOOPBACK_BYTES: usize = 4 * CHUNK;
/// Bytes per pass (the DMA buffers' size).
pub const CHUNK: usize = 1024;

/// The fixed start of the pattern.
const PREFIX: [u8; 20] = [
    0x00, 0xFF, 0x55, 0xAA, // all low, all high, alternate bits both ways
    0x01, 0x02, 0x04, 0x08, 0x10, 0x20, 0x40, 0x80, // walking one
    0xFE, 0xFD, 0xFB, 0xF7, 0xEF, 0xDF, 0xBF, 0x7F, // walking zero
];

/// Galois LFSR taps for x^16 + x^14 + x^13 + x^11 + 1 (maximal length:
/// every non-zero 16-bit state once per 65 535 steps).
const TAPS: u16 = 0xB400;
/// The LFSR's first state (any non-zero value).
const SEED: u16 = 0xACE1;

/// The loopback pattern: the fixed bytes, then LFSR bytes, as an endless
/// iterator. Two `Pattern::new()` give the same bytes.
#[derive(Debug, Clone)]
pub struct Pattern {
    index: usize,
    lfsr: u16,
}

impl Default for Pattern {
    fn default() -> Self {
        Self::new()
    }
}

impl Pattern {
    /// The pattern from its first byte.
    pub const fn new() -> Self {
        Self {
            index: 0,
            lfsr: SEED,
        }
    }

    /// Fills `buf` with the next `buf.len()` bytes.
    pub fn fill(&mut self, buf: &mut [u8]) {
        for b in buf {
            *b = self.next_byte();
        }
    }

    fn next_byte(&mut self) -> u8 {
        let b = match PREFIX.get(self.index) {
            Some(&b) => b,
            None => {
                // Eight LFSR steps per byte: consecutive bytes share no bits.
                for _ in 0..8 {
                    let out = self.lfsr & 1;
                    self.lfsr >>= 1;
                    if out != 0 {
                        self.lfsr ^= TAPS;
                    }
                }
                self.lfsr as u8
            }
        };
        self.index = self.index.saturating_add(1);
        b
    }
}

impl Iterator for Pattern {
    type Item = u8;
    fn next(&mut self) -> Option<u8> {
        Some(self.next_byte())
    }
}

/// The first byte that came back different.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Mismatch {
    /// Its position in the whole test (0 = the first byte sent).
    pub index: u32,
    /// What MOSI sent.
    pub sent: u8,
    /// What MISO read.
    pub got: u8,
}

/// A loopback run's result: what the board reports (and, once the
/// protocol carries it, what `lmhost` shows).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LoopbackReport {
    /// Bytes sent and compared.
    pub bytes: u32,
    /// Bytes that came back different.
    pub mismatches: u32,
    /// The first of them.
    pub first: Option<Mismatch>,
}

impl LoopbackReport {
    /// Nothing compared yet.
    pub const fn new() -> Self {
        Self {
            bytes: 0,
            mismatches: 0,
            first: None,
        }
    }

    /// Compares one pass: `sent[i]` against `got[i]`, continuing the
    /// count. Bytes beyond the shorter slice count as mismatches against
    /// nothing read (got 0): a short read is a failure, not a pass.
    pub fn check(&mut self, sent: &[u8], got: &[u8]) {
        for (i, &s) in sent.iter().enumerate() {
            let g = got.get(i).copied();
            if g != Some(s) {
                self.mismatches = self.mismatches.saturating_add(1);
                if self.first.is_none() {
                    self.first = Some(Mismatch {
                        index: self.bytes.saturating_add(i as u32),
                        sent: s,
                        got: g.unwrap_or(0),
                    });
                }
            }
        }
        self.bytes = self.bytes.saturating_add(sent.len() as u32);
    }

    /// True when bytes were compared and all came back.
    pub const fn passed(&self) -> bool {
        self.bytes > 0 && self.mismatches == 0
    }
}

impl From<LoopbackReport> for lm_proto::SelfTest {
    /// What `SelfTest` answers `lmhost selftest`: passed when bytes were
    /// compared and all came back, else the count and the first mismatch
    /// (nothing compared at all, a stuck bus, is a failure at byte 0).
    fn from(r: LoopbackReport) -> Self {
        match (r.passed(), r.first) {
            (true, _) => Self::Passed { bytes: r.bytes },
            (false, Some(m)) => Self::Failed {
                bytes: r.bytes,
                mismatches: r.mismatches,
                first_mismatch: m.index,
                sent: m.sent,
                got: m.got,
            },
            (false, None) => Self::Failed {
                bytes: r.bytes,
                mismatches: 0,
                first_mismatch: 0,
                sent: 0,
                got: 0,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    fn pattern() -> Vec<u8> {
        Pattern::new().take(LOOPBACK_BYTES).collect()
    }

    /// Runs the pattern through `fault` in passes of CHUNK, as the board does.
    fn run(fault: impl Fn(&[u8]) -> Vec<u8>) -> LoopbackReport {
        let mut p = Pattern::new();
        let mut r = LoopbackReport::new();
        let mut sent = [0u8; CHUNK];
        for _ in 0..LOOPBACK_BYTES / CHUNK {
            p.fill(&mut sent);
            r.check(&sent, &fault(&sent));
        }
        r
    }

    #[test]
    fn reports_answer_the_protocols_self_test() {
        use lm_proto::SelfTest;
        let sent = pattern();
        let mut ok = LoopbackReport::new();
        ok.check(&sent, &sent);
        assert_eq!(
            SelfTest::from(ok),
            SelfTest::Passed {
                bytes: LOOPBACK_BYTES as u32
            }
        );
        let mut bad = sent.clone();
        bad[300] ^= 0x10;
        bad[301] ^= 0x01;
        let mut r = LoopbackReport::new();
        r.check(&sent, &bad);
        assert_eq!(
            SelfTest::from(r),
            SelfTest::Failed {
                bytes: LOOPBACK_BYTES as u32,
                mismatches: 2,
                first_mismatch: 300,
                sent: sent[300],
                got: bad[300],
            }
        );
        // A bus that never moved compared nothing: not a pass.
        assert!(matches!(
            SelfTest::from(LoopbackReport::new()),
            SelfTest::Failed { bytes: 0, .. }
        ));
    }

    #[test]
    fn a_good_loop_passes() {
        let r = run(|s| s.to_vec());
        assert_eq!(r.bytes as usize, LOOPBACK_BYTES);
        const { assert!(LOOPBACK_BYTES >= 1024) };
        assert_eq!(r.mismatches, 0);
        assert_eq!(r.first, None);
        assert!(r.passed());
        assert!(!LoopbackReport::new().passed());
    }

    #[test]
    fn the_pattern_is_repeatable_and_fills_in_passes() {
        let whole = pattern();
        let mut p = Pattern::new();
        let mut parts = Vec::new();
        let mut buf = [0u8; 100];
        while parts.len() < whole.len() {
            p.fill(&mut buf);
            parts.extend_from_slice(&buf);
        }
        assert_eq!(&parts[..whole.len()], &whole[..]);
        assert_eq!(&whole[..PREFIX.len()], &PREFIX[..]);
    }

    #[test]
    fn every_bit_takes_both_values_and_no_two_bits_move_together() {
        let p = pattern();
        for bit in 0..8 {
            assert!(p.iter().any(|b| b & (1 << bit) != 0), "bit {bit} never 1");
            assert!(p.iter().any(|b| b & (1 << bit) == 0), "bit {bit} never 0");
            for other in 0..bit {
                let differ = p.iter().any(|b| ((b >> bit) & 1) != ((b >> other) & 1));
                assert!(differ, "bits {bit} and {other} always equal");
            }
        }
    }

    #[test]
    fn the_lfsr_part_has_no_short_period() {
        let p = pattern();
        let body = &p[PREFIX.len()..];
        for period in 1..body.len() / 2 {
            assert!(
                body.iter().zip(&body[period..]).any(|(a, b)| a != b),
                "repeats with period {period}"
            );
        }
        // Maximal length: the state visits every non-zero value once.
        let mut state = SEED;
        let mut steps = 0u32;
        loop {
            let out = state & 1;
            state >>= 1;
            if out != 0 {
                state ^= TAPS;
            }
            steps += 1;
            if state == SEED {
                break;
            }
        }
        assert_eq!(steps, 65_535);
    }

    #[test]
    fn stuck_bits_are_caught_at_the_first_byte_that_shows_them() {
        for bit in 0..8 {
            let mask = 1u8 << bit;
            let low = run(|s| s.iter().map(|b| b & !mask).collect());
            assert!(!low.passed(), "bit {bit} stuck low passed");
            let first = low.first.unwrap();
            assert_eq!(first.got, first.sent & !mask);
            assert_eq!(first.index, 1, "0xFF is the first byte with bit {bit} set");
            let high = run(|s| s.iter().map(|b| b | mask).collect());
            assert!(!high.passed(), "bit {bit} stuck high passed");
            assert_eq!(high.first.unwrap().index, 0, "0x00 shows a stuck-high bit");
        }
    }

    #[test]
    fn swapped_bits_are_caught() {
        for a in 0..8 {
            for b in 0..a {
                let r = run(|s| {
                    s.iter()
                        .map(|&x| {
                            let (xa, xb) = ((x >> a) & 1, (x >> b) & 1);
                            (x & !(1 << a) & !(1 << b)) | (xa << b) | (xb << a)
                        })
                        .collect()
                });
                assert!(!r.passed(), "bits {a} and {b} swapped passed");
                let f = r.first.unwrap();
                if (a - b) % 2 == 1 {
                    // One odd and one even bit: 0x55 already differs.
                    assert_eq!((f.index, f.sent), (2, 0x55), "bits {a}/{b}");
                } else {
                    // Same parity: the walking one names the lower bit.
                    assert_eq!((f.sent, f.got), (1 << b, 1 << a), "bits {a}/{b}");
                }
            }
        }
    }

    #[test]
    fn a_byte_slip_an_open_wire_and_a_short_read_fail() {
        // Each byte arrives one late (a missing SCK edge at the start).
        let slip = run(|s| {
            let mut v = Vec::with_capacity(s.len());
            v.push(0);
            v.extend_from_slice(&s[..s.len() - 1]);
            v
        });
        assert!(!slip.passed());
        assert!(slip.mismatches as usize > LOOPBACK_BYTES / 2);
        // No wire: MISO pulled down reads zeros; floating high reads 0xFF.
        let open = run(|s| std::vec![0; s.len()]);
        assert_eq!(open.first.unwrap().index, 1);
        let high = run(|s| std::vec![0xFF; s.len()]);
        assert_eq!(high.first.unwrap().index, 0);
        // Fewer bytes back than sent.
        let mut r = LoopbackReport::new();
        r.check(&[1, 2, 3], &[1, 2]);
        assert_eq!((r.bytes, r.mismatches), (3, 1));
        assert_eq!(
            r.first,
            Some(Mismatch {
                index: 2,
                sent: 3,
                got: 0
            })
        );
    }

    #[test]
    fn the_first_mismatch_counts_across_passes() {
        let mut r = LoopbackReport::new();
        r.check(&[1; CHUNK], &[1; CHUNK]);
        let mut got = [2u8; CHUNK];
        got[5] = 9;
        r.check(&[2; CHUNK], &got);
        assert_eq!(r.bytes as usize, 2 * CHUNK);
        assert_eq!(r.mismatches, 1);
        assert_eq!(
            r.first,
            Some(Mismatch {
                index: CHUNK as u32 + 5,
                sent: 2,
                got: 9
            })
        );
    }
}
