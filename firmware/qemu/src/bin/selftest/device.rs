//! The device core on target: the store's commit check, the player on the
//! timer, the centroid correction and the tracking gate.

use lm_fw_core::Device;
use lm_fw_qemu::{PCLK_HZ, Timer, hprint, hprintln};
use lm_proto::{Message, NackCode};

use crate::support::*;
use crate::{Ctx, Failed, INSTR_PER_COUNT, TestResult};

pub fn store_commit_checks_crc(_: &mut Ctx, mem: &mut [u8]) -> TestResult {
    let mut dev = device(mem);
    let r = upload(&mut dev, 0, 20, 996, 200_000, true);
    check!(
        r == Message::Nack(NackCode::CrcMismatch),
        "corrupt commit answered {:?}",
        r
    );
    let r = dev.handle(&play_now(0), 0);
    check!(
        r == Message::Nack(NackCode::NotCommitted),
        "play of a refused slot answered {:?}",
        r
    );
    let r = upload(&mut dev, 0, 20, 996, 200_000, false);
    check!(r == Message::Ack, "good commit answered {:?}", r);
    // Larger than the whole library: refused at BeginUpload.
    let r = upload(&mut dev, 1, 470, 996, 470_000, false);
    check!(
        r == Message::Nack(NackCode::TooLarge),
        "oversized upload answered {:?}",
        r
    );
    let r = dev.handle(&play_now(0), 0);
    check!(r == Message::Ack, "play answered {:?}", r);
    Ok(())
}

pub fn player_follows_timer_schedule(c: &mut Ctx, mem: &mut [u8]) -> TestResult {
    // 7 steps in 10 ms: 250,000 counts per cycle, 35,714.28 per step, so the
    // floor(k·P/N) rounding is exercised. 996 transducers: real frames.
    let (steps, period_us) = (7usize, 10_000u32);
    let p = u64::from(period_us) * u64::from(PCLK_HZ) / 1_000_000;
    let mut dev = device(mem);
    check!(upload(&mut dev, 0, steps, 996, period_us, false) == Message::Ack);
    let timer = Timer::clone_of(&c.timer);
    let mut rec = Recorder::new(&timer);
    let start = c.now();
    let r = dev.handle(&play_now(0), start);
    check!(r == Message::Ack, "play answered {:?}", r);
    let frames = 3 * steps + 1;
    while rec.n < frames {
        let now = c.now();
        dev.poll(now, &mut rec);
    }
    let t0 = rec.due[0];
    check!(
        t0 >= start && t0 - start < p / steps as u64,
        "first step due {} for play at {}",
        t0,
        start
    );
    let mut worst = 0;
    for g in 0..frames {
        let ideal = t0 + g as u64 * p / steps as u64;
        check!(
            rec.due[g] == ideal,
            "step {} due {} != ideal {}",
            g,
            rec.due[g],
            ideal
        );
        check!(
            usize::from(rec.step[g]) == g % steps,
            "frame {} is step {}",
            g,
            rec.step[g]
        );
        let late = rec.written[g].wrapping_sub(rec.due[g] as u32);
        worst = worst.max(late);
    }
    // Written within 1/20 of a step (about 70 µs) of the boundary.
    check!(
        u64::from(worst) < p / steps as u64 / 20,
        "a frame went out {} counts late",
        worst
    );
    let st = dev.status(c.now());
    check!(
        st.missed_deadlines == 0,
        "{} missed deadlines",
        st.missed_deadlines
    );
    check!(st.cycles >= 3, "{} cycles", st.cycles);
    hprint!(
        "(worst output latency {} counts = {} instructions) ",
        worst,
        worst * INSTR_PER_COUNT
    );
    Ok(())
}

/// The correction the core must apply to transducer `i` for a centroid at
/// `c`, in phase LSB, from a plain f64 formula.
pub fn reference_offset(i: usize, c: [i32; 3]) -> f64 {
    let x = position_um(i);
    let dist = |a: [i32; 3]| {
        let d = [0, 1, 2].map(|k| f64::from(x[k]) - f64::from(a[k]));
        libm::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    };
    (dist(CENTER_UM) - dist(c)) * 40_000.0 * 256.0 / (f64::from(SOUND_SPEED_MM_S) * 1e3)
}

pub fn correction_applied_to_frames(c: &mut Ctx, mem: &mut [u8]) -> TestResult {
    let mut dev = device(mem);
    check!(upload(&mut dev, 0, 4, 996, 8_000, false) == Message::Ack);
    let timer = Timer::clone_of(&c.timer);
    let mut rec = Recorder::new(&timer);
    let now = c.now();
    check!(dev.handle(&play_now(0), now) == Message::Ack);
    for (seq, moved) in [
        (1, [5_000, -3_000, 152_000]),
        (2, [-10_000, 1_000, 145_000]),
    ] {
        check!(dev.handle(&centroid(seq, moved, true), c.now()) == Message::Ack);
        let before = rec.n;
        while rec.n == before {
            let now = c.now();
            dev.poll(now, &mut rec);
        }
        let step = usize::from(rec.step[(rec.n - 1).min(63)]);
        check!(
            rec.amplitude[(rec.n - 1).min(63)] == 255,
            "frame after a fresh centroid is muted"
        );
        let mut worst = 0.0f64;
        for i in 0..996 {
            let got = rec.phases[i].wrapping_sub(phase(step, i)) as i8;
            let want = reference_offset(i, moved);
            let err = libm::fabs(f64::from(got) - libm::remainder(want, 256.0));
            let err = err.min(256.0 - err);
            worst = worst.max(err);
        }
        check!(
            worst <= 1.0,
            "offset error {} LSB at centroid {:?}",
            worst,
            moved
        );
    }
    Ok(())
}

pub fn gate_mutes_within_one_step(c: &mut Ctx, mem: &mut [u8]) -> TestResult {
    let mut dev = device(mem);
    dev.set_centroid_timeout_us(3_000);
    check!(upload(&mut dev, 0, 8, 996, 8_000, false) == Message::Ack);
    let timer = Timer::clone_of(&c.timer);
    let mut rec = Recorder::new(&timer);
    let now = c.now();
    check!(dev.handle(&play_now(0), now) == Message::Ack);
    // Returns the amplitude of the next frame written.
    let next_amplitude = |dev: &mut Device<'_>, c: &mut Ctx, rec: &mut Recorder<'_>| {
        let before = rec.n;
        while rec.n == before {
            let now = c.now();
            dev.poll(now, rec);
        }
        rec.amplitude[(rec.n - 1).min(63)]
    };
    check!(
        next_amplitude(&mut dev, c, &mut rec) == 0,
        "sounds before any centroid"
    );
    check!(dev.handle(&centroid(1, CENTER_UM, true), c.now()) == Message::Ack);
    check!(
        next_amplitude(&mut dev, c, &mut rec) == 255,
        "muted after a fresh centroid"
    );
    check!(dev.handle(&centroid(2, CENTER_UM, false), c.now()) == Message::Ack);
    check!(
        next_amplitude(&mut dev, c, &mut rec) == 0,
        "sounds after presence = false"
    );
    let r = dev.handle(&centroid(2, CENTER_UM, true), c.now());
    check!(
        r == Message::Nack(NackCode::OutOfOrder),
        "a repeated seq answered {:?}",
        r
    );
    check!(dev.handle(&centroid(3, CENTER_UM, true), c.now()) == Message::Ack);
    check!(
        next_amplitude(&mut dev, c, &mut rec) == 255,
        "muted after presence came back"
    );
    // No update for longer than the 3 ms timeout: muted by the step after it.
    let last_update = c.now();
    let mut amp = 255;
    while c.now() - last_update < 3 * u64::from(PCLK_HZ) / 1000 + 25_000 {
        amp = next_amplitude(&mut dev, c, &mut rec);
    }
    check!(amp == 0, "still sounding 4 ms after the last centroid");
    check!(dev.handle(&Message::Stop, c.now()) == Message::Ack);
    Ok(())
}

/// Counts frames by sound and notes when (TIMER0) they were written.
struct LeaseWatch<'t> {
    timer: &'t Timer,
    sounding: u32,
    muted: u32,
    /// The last sounding frame's step: when it was due and when it was
    /// written.
    last_sounding_due: u64,
    last_sounding_at: u32,
    /// Written time of the first muted frame.
    first_muted_at: Option<u32>,
}

impl lm_fw_core::OutputDriver for LeaseWatch<'_> {
    type Error = core::convert::Infallible;
    fn write_frame(&mut self, f: &lm_fw_core::OutputFrame<'_>) -> Result<(), Self::Error> {
        let t = self.timer.now();
        if f.amplitude == 0 {
            self.muted += 1;
            self.first_muted_at.get_or_insert(t);
        } else {
            self.sounding += 1;
            self.last_sounding_due = f.due;
            self.last_sounding_at = t;
        }
        Ok(())
    }
}

/// The host lease on the firmware: renewed, an untracked play keeps
/// sounding; once the host goes quiet it ends one lease after the last
/// renewal, within a poll of the expiry (the serve loop's timing), muted,
/// with no step due after it sounding, and `Status` says why.
pub fn lease_silences_a_quiet_host(c: &mut Ctx, mem: &mut [u8]) -> TestResult {
    const LEASE_MS: u16 = 100;
    let lease = u64::from(LEASE_MS) * u64::from(PCLK_HZ) / 1000;
    let step = u64::from(PCLK_HZ) / 1000;
    let mut dev = device(mem);
    // 8 steps of 1 ms, 996 transducers.
    check!(upload(&mut dev, 0, 8, 996, 8_000, false) == Message::Ack);
    let timer = Timer::clone_of(&c.timer);
    let mut w = LeaseWatch {
        timer: &timer,
        sounding: 0,
        muted: 0,
        last_sounding_due: 0,
        last_sounding_at: 0,
        first_muted_at: None,
    };
    let t0 = c.now();
    check!(dev.handle(&play_leased(0, LEASE_MS), t0) == Message::Ack);
    // A host renewing every half lease for 2.5 leases.
    let mut renewed = t0;
    while c.now() - t0 < 5 * lease / 2 {
        let now = c.now();
        if now - renewed >= lease / 2 {
            check!(dev.handle(&Message::Renew, now) == Message::Ack);
            renewed = now;
        }
        dev.poll(now, &mut w);
    }
    check!(
        w.muted == 0 && dev.is_sounding(c.now()),
        "renewed play stopped ({} muted frames)",
        w.muted
    );
    // The host goes quiet: the serve loop polls on.
    let expiry = renewed + lease;
    while dev.next_deadline().is_some() && c.now() < expiry + 10 * step {
        let now = c.now();
        dev.poll(now, &mut w);
    }
    check!(
        dev.next_deadline().is_none(),
        "still playing 10 ms after the lease"
    );
    let Some(muted_at) = w.first_muted_at else {
        hprintln!("    no muted frame at the expiry");
        return Err(Failed);
    };
    // Written time is TIMER0's low 32 bits; the run is far from a wrap.
    let late = muted_at.wrapping_sub(expiry as u32);
    check!(
        u64::from(late) < step,
        "silent {} counts after the expiry (a step is {})",
        late,
        step
    );
    // No step due at or after the expiry sounds. A step due just before
    // it is written a poll's latency later, which may be past it (where
    // the renewals put the expiry against the 1 ms step grid decides).
    check!(
        w.last_sounding_due < expiry,
        "a step due {} counts after the expiry sounded",
        w.last_sounding_due - expiry
    );
    check!(
        u64::from(w.last_sounding_at.wrapping_sub(w.last_sounding_due as u32)) < step,
        "the last sounding frame went out {} counts after its step was due",
        w.last_sounding_at.wrapping_sub(w.last_sounding_due as u32)
    );
    check!(w.muted == 1, "{} muted frames", w.muted);
    let st = dev.status(c.now());
    check!(
        st.state == lm_proto::DeviceState::Stopped
            && st.mute_reason == lm_proto::MuteReason::LeaseExpired
            && st.lease_ms == LEASE_MS
            && st.lease_expiries == 1,
        "{:?}",
        st
    );
    hprint!(
        "({} frames sounded; muted {} counts = {} instructions after the expiry) ",
        w.sounding,
        late,
        late * INSTR_PER_COUNT
    );
    Ok(())
}

/// `SelfTest` on this board (QEMU has no SPI loopback): `Unsupported`
/// through the byte path, `Busy` while a slot plays.
pub fn self_test_is_unsupported_here(c: &mut Ctx, mem: &mut [u8]) -> TestResult {
    let mut dev = device(mem);
    let mut out = lm_fw_qemu::FrameCounter::default();
    let mut ask = |dev: &mut Device<'_>, now: u64| -> Option<Message<'static>> {
        let mut wire = [0u8; lm_proto::MAX_ENCODED_FRAME];
        let n = lm_proto::encode_frame(5, &Message::SelfTest, &mut wire).ok()?;
        let mut reply = [0u8; lm_proto::MAX_ENCODED_FRAME];
        let mut len = 0;
        dev.feed(&wire[..n], now, &mut out, &mut |r| {
            len = r.len();
            reply[..len].copy_from_slice(r);
        });
        match lm_proto::FrameDecoder::new().feed(&reply[..len]) {
            lm_proto::FeedResult::Frame { frame, .. } => match frame.message {
                Message::SelfTestResult(t) => Some(Message::SelfTestResult(t)),
                Message::Nack(code) => Some(Message::Nack(code)),
                _ => None,
            },
            _ => None,
        }
    };
    let r = ask(&mut dev, c.now());
    check!(
        r == Some(Message::SelfTestResult(lm_proto::SelfTest::Unsupported)),
        "{:?}",
        r
    );
    check!(upload(&mut dev, 0, 4, 996, 8_000, false) == Message::Ack);
    check!(dev.handle(&play_leased(0, 1000), c.now()) == Message::Ack);
    let r = ask(&mut dev, c.now());
    check!(r == Some(Message::Nack(NackCode::Busy)), "{:?}", r);
    check!(dev.handle(&Message::Stop, c.now()) == Message::Ack);
    Ok(())
}
