//! Timer counts and the drift-free step schedule.
//!
//! Time in the core is a `u64` count of a free-running timer at
//! [`Config::timer_hz`](crate::Config::timer_hz). Boards with a 32-bit
//! counter widen it with [`TimeExtender`].

/// Widens a wrapping 32-bit timer count to a monotonic `u64`.
///
/// Call [`extend`](Self::extend) at least once per wrap period
/// (2^32 counts: 71 min at 1 MHz, 17 s at 250 MHz).
#[derive(Debug, Clone, Copy, Default)]
pub struct TimeExtender {
    last: u32,
    high: u64,
}

impl TimeExtender {
    /// Starts at count 0.
    pub const fn new() -> Self {
        Self { last: 0, high: 0 }
    }

    /// Returns the 64-bit count for a raw 32-bit reading.
    pub fn extend(&mut self, raw: u32) -> u64 {
        if raw < self.last {
            self.high += 1 << 32;
        }
        self.last = raw;
        self.high | u64::from(raw)
    }
}

/// Step boundaries of one sequence: boundary `g` (global step index, counting
/// across cycles) is at `start + floor(g · num / den)` counts, where
/// `num / den` is the exact step length `period_us · timer_hz / (steps · 10^6)`.
///
/// Within a cycle this is `floor(k · P / N)` after the cycle start, P the
/// cycle period in counts; when P is an integer every cycle lasts exactly P
/// counts and nothing accumulates. Stepping is incremental (no division per
/// step); jumps after a long stall use one 128-bit division.
#[derive(Debug, Clone, Copy)]
pub struct Schedule {
    start: u64,
    num: u64,
    den: u64,
    q: u64,
    r: u64,
    /// Global index of the current step.
    g: u64,
    /// Offset (counts from `start`) of boundary `g`.
    off: u64,
    /// Remainder of `g · num` modulo `den`.
    rem: u64,
}

impl Schedule {
    /// A schedule starting (step 0) at `start`. `None` if a step would be
    /// shorter than one count or the numbers overflow.
    pub fn new(start: u64, period_us: u32, steps: u16, timer_hz: u32) -> Option<Self> {
        let num = u64::from(period_us).checked_mul(u64::from(timer_hz))?;
        let den = u64::from(steps).checked_mul(1_000_000)?;
        if steps == 0 || num < den {
            return None;
        }
        Some(Self {
            start,
            num,
            den,
            q: num / den,
            r: num % den,
            g: 0,
            off: 0,
            rem: 0,
        })
    }

    /// Time of step 0.
    pub fn start_time(&self) -> u64 {
        self.start
    }

    /// Global index of the current step.
    pub fn index(&self) -> u64 {
        self.g
    }

    /// Start time of the current step.
    pub fn current(&self) -> u64 {
        self.start + self.off
    }

    /// Start time of the next step.
    pub fn next(&self) -> u64 {
        let mut off = self.off + self.q;
        if self.rem + self.r >= self.den {
            off += 1;
        }
        self.start + off
    }

    /// Moves to the next step.
    pub fn advance(&mut self) {
        self.off += self.q;
        self.rem += self.r;
        if self.rem >= self.den {
            self.rem -= self.den;
            self.off += 1;
        }
        self.g += 1;
    }

    /// Exact offset of boundary `g` from the start (reference formula).
    pub fn offset_of(&self, g: u64) -> u64 {
        (u128::from(g) * u128::from(self.num) / u128::from(self.den)) as u64
    }

    /// Jumps to the last step whose boundary is at or before `now`
    /// (`now` must be ≥ the current step's start). Returns how many steps
    /// were passed over without being entered.
    pub fn catch_up(&mut self, now: u64) -> u64 {
        let elapsed = now.saturating_sub(self.start);
        let target = (u128::from(elapsed) * u128::from(self.den) / u128::from(self.num)) as u64;
        // floor(target·num/den) ≤ elapsed by construction; at most one more fits.
        let mut g = target.max(self.g);
        while self.offset_of(g + 1) <= elapsed {
            g += 1;
        }
        let skipped = g.saturating_sub(self.g + 1);
        if g != self.g {
            self.g = g;
            let prod = u128::from(g) * u128::from(self.num);
            self.off = (prod / u128::from(self.den)) as u64;
            self.rem = (prod % u128::from(self.den)) as u64;
        }
        skipped
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extender_widens_across_wraps() {
        let mut t = TimeExtender::new();
        assert_eq!(t.extend(10), 10);
        assert_eq!(t.extend(u32::MAX), u64::from(u32::MAX));
        assert_eq!(t.extend(5), (1 << 32) + 5);
        assert_eq!(t.extend(7), (1 << 32) + 7);
        assert_eq!(t.extend(3), (2 << 32) + 3);
    }

    #[test]
    fn incremental_matches_formula_with_fractional_steps() {
        // 200 ms over 7 steps at 1 MHz: 28571.43 counts per step.
        let mut s = Schedule::new(1000, 200_000, 7, 1_000_000).unwrap();
        for g in 0..10_000u64 {
            assert_eq!(s.current(), 1000 + g * 200_000 / 7);
            assert_eq!(s.next(), 1000 + (g + 1) * 200_000 / 7);
            s.advance();
        }
    }

    #[test]
    fn catch_up_lands_on_last_passed_boundary() {
        let mut s = Schedule::new(0, 1000, 3, 1_000_000).unwrap(); // 333.33
        // boundaries 0, 333, 666, 1000, 1333, 1666, 2000
        assert_eq!(s.catch_up(1665), 3); // to g = 4 (1333), passing 1, 2, 3
        assert_eq!(s.index(), 4);
        assert_eq!(s.current(), 1333);
        assert_eq!(s.next(), 1666);
        assert_eq!(s.catch_up(1666), 0);
        assert_eq!(s.index(), 5);
        assert_eq!(s.catch_up(1700), 0);
        assert_eq!(s.index(), 5);
    }

    #[test]
    fn rejects_sub_count_steps() {
        assert!(Schedule::new(0, 10, 20, 1_000_000).is_none());
        assert!(Schedule::new(0, 10, 0, 1_000_000).is_none());
        assert!(Schedule::new(0, 20, 20, 1_000_000).is_some());
    }
}
