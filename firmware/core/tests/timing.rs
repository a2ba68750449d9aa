//! Scheduling accuracy over 10^6 simulated steps, through the whole
//! device, with a wrapping 32-bit timer and random poll latency.
//!
//! `cargo test -p lm-fw-core --test timing -- --nocapture` prints the figures.

mod common;

use common::*;
use lm_fw_core::{OutputDriver, OutputFrame, TimeExtender};
use lm_proto::codec::Encoding;
use lm_proto::{Message, PlayAt};

struct Check {
    t0: u64,
    p: u64,
    n: u64,
    g: u64,
    prev_due: Option<u64>,
    prev_cycle_start: Option<u64>,
    max_drift: u64,
    min_step: u64,
    max_step: u64,
    min_cycle: u64,
    max_cycle: u64,
}

impl OutputDriver for Check {
    type Error = ();
    fn write_frame(&mut self, f: &OutputFrame<'_>) -> Result<(), ()> {
        // Ideal: step k of cycle c at t0 + c·P + floor(k·P/N), computed independently.
        let (c, k) = (self.g / self.n, self.g % self.n);
        let ideal =
            self.t0 + c * self.p + (u128::from(k) * u128::from(self.p) / u128::from(self.n)) as u64;
        assert_eq!(u64::from(f.step), k, "step order");
        self.max_drift = self.max_drift.max(f.due.abs_diff(ideal));
        if let Some(prev) = self.prev_due {
            let d = f.due - prev;
            self.min_step = self.min_step.min(d);
            self.max_step = self.max_step.max(d);
        }
        if k == 0 {
            if let Some(prev) = self.prev_cycle_start {
                let d = f.due - prev;
                self.min_cycle = self.min_cycle.min(d);
                self.max_cycle = self.max_cycle.max(d);
            }
            self.prev_cycle_start = Some(f.due);
        }
        self.prev_due = Some(f.due);
        self.g += 1;
        Ok(())
    }
}

fn run(timer_hz: u32, steps: u16, period_us: u32, total: u64) -> Check {
    let mut cfg = config(4);
    cfg.timer_hz = timer_hz;
    let mut dev = device(cfg, usize::from(steps) * 4);
    Seq::pattern(steps, 4, period_us, 1).upload(&mut dev, 0, Encoding::Raw, 0);
    // The board's 32-bit counter starts 1 s before it wraps.
    let raw0 = u32::MAX - timer_hz;
    let mut ext = TimeExtender::new();
    let now = ext.extend(raw0);
    assert_eq!(
        request(&mut dev, 1, &play(0, PlayAt::Immediate), now),
        Reply::Ack
    );
    let p = u64::from(period_us) * u64::from(timer_hz) / 1_000_000;
    let mut chk = Check {
        t0: now,
        p,
        n: u64::from(steps),
        g: 0,
        prev_due: None,
        prev_cycle_start: None,
        max_drift: 0,
        min_step: u64::MAX,
        max_step: 0,
        min_cycle: u64::MAX,
        max_cycle: 0,
    };
    let mut rng = Rng(timer_hz as u64 ^ u64::from(steps));
    let min_step = p / u64::from(steps);
    let mut deadline = dev.poll(now, &mut chk).unwrap();
    // The host renews its lease (1 s) twice a second, as lmhost does.
    let mut renewed = now;
    while chk.g < total {
        // Poll late by up to half a step (interrupt latency, busy loop).
        let t = deadline + rng.below(min_step / 2);
        let now = ext.extend(t as u32);
        assert_eq!(now, t, "extender follows the 64-bit time across wraps");
        if now - renewed >= u64::from(timer_hz) / 2 {
            assert_eq!(request(&mut dev, 2, &Message::Renew, now), Reply::Ack);
            renewed = now;
        }
        deadline = dev.poll(now, &mut chk).unwrap();
    }
    assert_eq!(dev.status(deadline).missed_deadlines, 0);
    chk
}

#[test]
fn million_steps_no_drift_no_jitter_exact_cycle() {
    for (hz, steps, period_us) in [
        (1_000_000, 7, 200_000),
        (25_000_000, 82, 200_000),
        (1_000_000, 200, 200_000),
    ] {
        let c = run(hz, steps, period_us, 1_000_000);
        let p = u64::from(period_us) * u64::from(hz) / 1_000_000;
        let n = u64::from(steps);
        println!(
            "timing: {hz} Hz, N = {steps}, P = {p} counts: 10^6 steps, max |drift| = {} counts, \
             step length {}..={} counts (ideal {:.3}), cycle period {}..={} counts, missed 0",
            c.max_drift,
            c.min_step,
            c.max_step,
            p as f64 / n as f64,
            c.min_cycle,
            c.max_cycle
        );
        assert_eq!(c.max_drift, 0, "zero accumulated drift");
        assert!(c.max_step - c.min_step <= 1, "≤ 1 count jitter");
        assert_eq!(c.min_step, p / n);
        assert_eq!((c.min_cycle, c.max_cycle), (p, p), "exact cycle period");
    }
}
