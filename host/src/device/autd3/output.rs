//! The array's output level, through autd3's modulation, under a lease.
//!
//! The GainSTM segments hold full-intensity phases; what sounds is their
//! product with the modulation, so the level (mute, a stimulus's
//! intensity) is set here and nowhere else. Muted is `Static(0)` looping
//! forever: silent with or without a host.
//!
//! **Lease.** Sounding is never an endless loop. It is a finite
//! modulation, `[level; 100] + [0]` played once, whose sample period makes
//! the level last until the lease ends; at the end of a finite loop
//! autd3's FPGA holds the last sample, 0, so the array falls silent by
//! itself when the host stops renewing (dies, hangs, is killed). While
//! sounding, [`Output::set`] re-arms it once half the lease has passed: the
//! same buffer goes into the other modulation segment with a `SysTime`
//! switch [`SWITCH_MARGIN_US`] ahead, before the playing one reaches its
//! 0, and since both hold the same level the switch is seamless (no
//! glitch, whatever the STM does). A lease runs from its arming:
//! `armed + lease` is when the array is silent without a renewal.
//!
//! Unmuting is immediate, which autd3 firmware allows only into an endless
//! loop, so it goes out as one frame of two operations: `Static(level)`
//! forever with an `Immediate` switch, and the first lease armed behind it
//! (the frame arrives whole or not at all, so no endless level is ever
//! left without a lease).
//!
//! **Amplitude modulation.** A stimulus with an [`Am`] sounds as the same
//! kind of lease, its samples the envelope at the level
//! ([`Am::sample`], at 4 kHz: divide 10, the silencer's strict minimum)
//! for the lease, then 0. Such a buffer spans several frames, so it never
//! rides with an endless operation: an AM stimulus starts through the
//! `SysTime` switch alone, [`SWITCH_MARGIN_US`] after it is asked for
//! (from a level whose switch is still pending it mutes first), and each
//! renewal starts its buffer at the envelope's phase at its switch, so the
//! envelope runs on across renewals (within a sample; a retried switch,
//! later by its doubled margin, restarts it).

use std::num::NonZeroU16;
use std::time::Duration;

use anyhow::Context as _;
use autd3::Controller;
use autd3::core::ethercat::DcSysTime;
use autd3::core::firmware::transition_mode::{Immediate, SysTime};
use autd3::core::link::Link;
use autd3::modulation::Custom;
use autd3::prelude::{
    AUTDDriverError, SamplingConfig, Segment, Static, WithFiniteLoop, WithSegment,
};

use crate::error::InputError;
use crate::plan::modulation::{Am, SAMPLE_DIVIDE};

/// How far ahead a renewal's `SysTime` switch is set: autd3 firmware
/// refuses one less than 10 ms ahead of its clock when the frame arrives,
/// and a real link takes a few milliseconds.
pub const SWITCH_MARGIN_US: u64 = 50_000;
/// Times a `SysTime` switch is tried, each on a fresh reading of the
/// devices' clock and twice the margin of the one before: a host stalled
/// past the margin (a loaded machine, a slow link) gets autd3 firmware's
/// `MissTransitionTime` and tries again rather than failing the command.
const SWITCH_TRIES: u32 = 3;
/// Shortest and longest lease (µs): at least four margins, so a renewal
/// fits well inside one; at most 10 s.
pub const LEASE_US: std::ops::RangeInclusive<u64> = 200_000..=10_000_000;
/// Samples at the level in a lease's modulation. The FPGA steps a
/// modulation on its clock's sample boundaries, not from the switch, so a
/// lease's level lasts within one sample period of its length; a hundred
/// keep that within 1 %, and the buffer small enough to go out with the
/// unmute in one frame.
const LEASE_SAMPLES: u64 = 100;
/// The output level and its lease.
#[derive(Debug, Clone)]
pub struct Output {
    lease_us: u64,
    /// The modulation segment last switched to (autd3 firmware's current one).
    seg: Segment,
    /// What sounds: 0 = muted (forever).
    level: u8,
    /// Its amplitude modulation, if any.
    am: Option<Am>,
    /// When the modulation's sample 0 played (host µs): the envelope's
    /// phase at a renewal.
    am_t0_us: u64,
    /// When the lease in force was armed (host µs).
    armed_us: u64,
    /// When its switch happens; no renewal goes out before (a write into a
    /// segment the FPGA still plays would make it loop forever).
    switch_us: u64,
}

fn other(s: Segment) -> Segment {
    match s {
        Segment::S0 => Segment::S1,
        Segment::S1 => Segment::S0,
    }
}

/// A lease's modulation for `level`: [`LEASE_SAMPLES`] samples at the
/// level, then 0, sampled so the level lasts at most
/// `lease_us - SWITCH_MARGIN_US` from the switch (and at least one sample
/// period less); returns it with that longest duration.
fn lease_buffer(level: u8, lease_us: u64) -> (Custom<SamplingConfig>, u64) {
    let sounding_us = lease_us - SWITCH_MARGIN_US;
    // ≥ 60 in the lease range, ≤ 3980: a valid divide of the 40 kHz clock.
    let divide = (sounding_us / LEASE_SAMPLES / 25).clamp(1, u64::from(u16::MAX)) as u16;
    let mut buffer = vec![level; LEASE_SAMPLES as usize];
    buffer.push(0);
    let config = SamplingConfig::new(NonZeroU16::new(divide).unwrap_or(NonZeroU16::MIN));
    (
        Custom::new(buffer, config),
        LEASE_SAMPLES * u64::from(divide) * 25,
    )
}

/// An AM lease's modulation at `level`: the envelope's samples from
/// sample `first` for at most `lease_us - SWITCH_MARGIN_US` (and within
/// autd3's buffer), then 0; returns it with how long it sounds.
fn am_lease_buffer(level: u8, am: &Am, first: u64, lease_us: u64) -> (Custom<SamplingConfig>, u64) {
    let sample_us = u64::from(SAMPLE_DIVIDE) * 25;
    let n = ((lease_us - SWITCH_MARGIN_US) / sample_us)
        .min(autd3::core::firmware::MOD_BUF_SIZE_MAX as u64 - 1);
    let mut buffer: Vec<u8> = (0..n).map(|k| am.sample(level, first + k)).collect();
    buffer.push(0);
    let config = SamplingConfig::new(NonZeroU16::new(SAMPLE_DIVIDE).unwrap_or(NonZeroU16::MIN));
    (Custom::new(buffer, config), n * sample_us)
}

impl Output {
    /// An output whose sounding lasts `lease` past each renewal; muted
    /// once [`Output::mute`] has gone out.
    pub fn new(lease: Duration) -> Result<Self, InputError> {
        let lease_us = check_lease(lease)?;
        Ok(Self {
            lease_us,
            seg: Segment::S0,
            level: 0,
            am: None,
            am_t0_us: 0,
            armed_us: 0,
            switch_us: 0,
        })
    }

    /// The lease.
    pub fn lease(&self) -> Duration {
        Duration::from_micros(self.lease_us)
    }

    /// Changes the lease; it applies from the next arming.
    pub fn set_lease(&mut self, lease: Duration) -> Result<(), InputError> {
        self.lease_us = check_lease(lease)?;
        Ok(())
    }

    /// The level sounding now (0: muted).
    pub fn level(&self) -> u8 {
        self.level
    }

    /// When the array falls silent unless renewed (host µs); `None` while
    /// muted.
    pub fn lease_end_us(&self) -> Option<u64> {
        (self.level != 0).then(|| self.armed_us + self.lease_us)
    }

    /// Whether the lease ran out before it was renewed: the array is
    /// silent though the level says otherwise.
    pub fn lapsed(&self, now_us: u64) -> bool {
        self.lease_end_us().is_some_and(|end| now_us >= end)
    }

    /// Silences the array at once and for good (`Static(0)` looping, in
    /// the current segment; a pending renewal is dropped with it).
    pub fn mute(&mut self, ctl: &mut Controller<Box<dyn Link>>) -> anyhow::Result<()> {
        ctl.send(WithSegment::new(Static::new(0), self.seg, Immediate))
            .context("muting the output")?;
        self.level = 0;
        Ok(())
    }

    /// The amplitude modulation sounding (`None` while muted or unmodulated).
    pub fn am(&self) -> Option<Am> {
        self.am.filter(|_| self.level != 0)
    }

    /// Brings the output to `level` (modulated by `am`) at `now_us` (host
    /// clock; `dc` the devices' clock): mutes, sounds with a fresh lease,
    /// or renews the lease when half of it has passed.
    pub fn set(
        &mut self,
        ctl: &mut Controller<Box<dyn Link>>,
        level: u8,
        am: Option<Am>,
        now_us: u64,
        dc: &dyn Fn() -> DcSysTime,
    ) -> anyhow::Result<()> {
        if level == 0 {
            if self.level != 0 {
                self.mute(ctl)?;
            }
            return Ok(());
        }
        if level != self.level || am != self.am || self.lapsed(now_us) {
            return match am {
                Some(am) => self.sound_am(ctl, level, am, now_us, dc),
                None => self.sound(ctl, level, now_us, dc),
            };
        }
        if now_us >= self.armed_us + self.lease_us / 2 && now_us >= self.switch_us {
            self.renew(ctl, now_us, dc)?;
        }
        Ok(())
    }

    /// Arms a fresh lease now if sounding and no switch is pending (before
    /// work that sends nothing else for a while, such as an upload).
    pub fn refresh(
        &mut self,
        ctl: &mut Controller<Box<dyn Link>>,
        now_us: u64,
        dc: &dyn Fn() -> DcSysTime,
    ) -> anyhow::Result<()> {
        if self.level != 0 && !self.lapsed(now_us) && now_us >= self.switch_us {
            self.renew(ctl, now_us, dc)?;
        }
        Ok(())
    }

    /// `Static(level)` forever at once, and the first lease behind it, in
    /// one frame.
    fn sound(
        &mut self,
        ctl: &mut Controller<Box<dyn Link>>,
        level: u8,
        now_us: u64,
        dc: &dyn Fn() -> DcSysTime,
    ) -> anyhow::Result<()> {
        let (buffer, _) = lease_buffer(level, self.lease_us);
        let lease_seg = other(self.seg);
        let seg = self.seg;
        let sent = switch_at(dc, |at| {
            ctl.send((
                WithSegment::new(Static::new(level), seg, Immediate),
                WithFiniteLoop::new(buffer.clone(), NonZeroU16::MIN, lease_seg, at),
            ))
        });
        if let Err(e) = sent {
            // The endless level may have gone out without its lease:
            // never leave it so.
            let _ = ctl.send(WithSegment::new(Static::new(0), seg, Immediate));
            self.level = 0;
            return Err(anyhow::Error::from(e).context("setting the output level"));
        }
        self.am = None;
        self.arm(lease_seg, level, now_us);
        Ok(())
    }

    /// An AM lease into the other segment, switched to a margin ahead
    /// (after a mute when a switch is still pending: a write into the
    /// segment the FPGA plays would make it loop forever).
    fn sound_am(
        &mut self,
        ctl: &mut Controller<Box<dyn Link>>,
        level: u8,
        am: Am,
        now_us: u64,
        dc: &dyn Fn() -> DcSysTime,
    ) -> anyhow::Result<()> {
        if self.level != 0 && (now_us < self.switch_us || self.lapsed(now_us)) {
            self.mute(ctl)?;
        }
        let (buffer, _) = am_lease_buffer(level, &am, 0, self.lease_us);
        self.send_lease(ctl, buffer, level, now_us, dc)
            .context("setting the modulated output")?;
        self.am = Some(am);
        self.am_t0_us = now_us + SWITCH_MARGIN_US;
        Ok(())
    }

    /// The same level again in the other segment, switched to before the
    /// playing lease reaches its 0.
    fn renew(
        &mut self,
        ctl: &mut Controller<Box<dyn Link>>,
        now_us: u64,
        dc: &dyn Fn() -> DcSysTime,
    ) -> anyhow::Result<()> {
        let (buffer, _) = match &self.am {
            Some(am) => {
                // The envelope's sample at the switch, a margin from now.
                let since = (now_us + SWITCH_MARGIN_US).saturating_sub(self.am_t0_us);
                let first = since / (u64::from(SAMPLE_DIVIDE) * 25);
                am_lease_buffer(self.level, am, first, self.lease_us)
            }
            None => lease_buffer(self.level, self.lease_us),
        };
        self.send_lease(ctl, buffer, self.level, now_us, dc)
            .context("renewing the output's lease")
    }

    /// `buffer` once into the other segment, switched to a margin ahead,
    /// then armed as playing `level`.
    fn send_lease(
        &mut self,
        ctl: &mut Controller<Box<dyn Link>>,
        buffer: Custom<SamplingConfig>,
        level: u8,
        now_us: u64,
        dc: &dyn Fn() -> DcSysTime,
    ) -> Result<(), AUTDDriverError> {
        let lease_seg = other(self.seg);
        switch_at(dc, |at| {
            ctl.send(WithFiniteLoop::new(
                buffer.clone(),
                NonZeroU16::MIN,
                lease_seg,
                at,
            ))
        })?;
        self.arm(lease_seg, level, now_us);
        Ok(())
    }

    fn arm(&mut self, seg: Segment, level: u8, now_us: u64) {
        self.seg = seg;
        self.level = level;
        self.armed_us = now_us;
        self.switch_us = now_us + SWITCH_MARGIN_US;
    }
}

/// Sends what `send` builds for a `SysTime` switch [`SWITCH_MARGIN_US`]
/// ahead of the devices' clock, read anew for each of [`SWITCH_TRIES`]
/// tries (the margin doubling) while the devices say the time was missed.
fn switch_at(
    dc: &dyn Fn() -> DcSysTime,
    mut send: impl FnMut(SysTime) -> Result<(), AUTDDriverError>,
) -> Result<(), AUTDDriverError> {
    let mut margin = SWITCH_MARGIN_US;
    let mut tries = 1;
    loop {
        match send(SysTime(dc() + Duration::from_micros(margin))) {
            Err(AUTDDriverError::MissTransitionTime) if tries < SWITCH_TRIES => {
                tries += 1;
                margin *= 2;
            }
            r => return r,
        }
    }
}

/// `lease` in µs, if within [`LEASE_US`].
fn check_lease(lease: Duration) -> Result<u64, InputError> {
    let us = u64::try_from(lease.as_micros()).unwrap_or(u64::MAX);
    if !LEASE_US.contains(&us) {
        return Err(InputError::new(format!(
            "lease {} s is out of range: an AUTD3 takes {}..={} s",
            crate::limits::show(lease.as_secs_f64()),
            *LEASE_US.start() as f64 / 1e6,
            *LEASE_US.end() as f64 / 1e6
        )));
    }
    Ok(us)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lease_sounds_until_its_end_then_holds_zero() {
        for lease_us in [*LEASE_US.start(), 1_000_000, 1_700_000, *LEASE_US.end()] {
            let (m, sounding_us) = lease_buffer(200, lease_us);
            let k = m.buffer.len() - 1;
            assert!(m.buffer[..k].iter().all(|&v| v == 200), "{lease_us}");
            assert_eq!(m.buffer[k], 0, "the held last sample is silent");
            // Silent by the lease's end (the switch comes a margin after
            // arming), and within a sample period and a 25 µs tick of it.
            let period = sounding_us / k as u64;
            assert!(SWITCH_MARGIN_US + sounding_us <= lease_us, "{lease_us}");
            assert!(SWITCH_MARGIN_US + sounding_us + 25 * k as u64 >= lease_us);
            assert!(period * 50 <= lease_us, "{lease_us}: {period} µs samples");
        }
        // The default lease: 100 samples of 9.5 ms.
        let (m, us) = lease_buffer(255, 1_000_000);
        assert_eq!((m.buffer.len(), us), (101, 950_000));
    }

    #[test]
    fn an_am_lease_is_the_envelope_until_its_end_then_zero() {
        let am = Am {
            shape: crate::plan::modulation::AmShape::Square,
            freq_hz: 100.0,
            depth: 0.5,
        };
        for lease_us in [*LEASE_US.start(), 1_000_000, *LEASE_US.end()] {
            let (m, sounding_us) = am_lease_buffer(200, &am, 7, lease_us);
            let k = m.buffer.len() - 1;
            assert_eq!(m.buffer[k], 0, "the held last sample is silent");
            assert!(SWITCH_MARGIN_US + sounding_us <= lease_us, "{lease_us}");
            assert!(
                SWITCH_MARGIN_US + sounding_us + 250 > lease_us,
                "{lease_us}"
            );
            // 40 samples per period, from sample 7: 13 high, 20 low, 20 high.
            assert!(m.buffer[..13].iter().all(|&v| v == 200));
            assert!(m.buffer[13..33].iter().all(|&v| v == 100));
            assert_eq!(m.buffer[33], 200);
        }
    }

    #[test]
    fn leases_out_of_range_are_bad_input() {
        assert!(Output::new(Duration::from_secs(1)).is_ok());
        for bad in [
            Duration::ZERO,
            Duration::from_millis(199),
            Duration::from_secs(11),
        ] {
            let e = Output::new(bad).unwrap_err();
            assert!(e.to_string().contains("0.2..=10 s"), "{e}");
        }
    }
}
