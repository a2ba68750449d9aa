//! `lmhost play`: play a committed slot, holding the link while it plays.

use std::time::Duration;

use anyhow::Context as _;
use lm_proto::{DeviceState, PlayAt};

use super::args::DeviceArgs;
use crate::cmd::upload::{HoldArgs, UNTRACKED_WARNING, hold_saying, play_outcome};

/// Play a slot that holds a committed sequence.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    device: DeviceArgs,
    /// Slot to play (checked against the device's slot count).
    #[arg(long, default_value_t = 0, value_parser = super::whole::whole::<u8>(0, u8::MAX.into()))]
    slot: u8,
    /// Switch at once instead of at the end of the current cycle.
    #[arg(long, conflicts_with = "steps")]
    immediate: bool,
    /// Play without tracking: the device sounds without a finger (no
    /// gating, no correction) while lmhost holds it.
    #[arg(long)]
    untracked: bool,
    #[command(flatten)]
    hold: HoldArgs,
    /// Play this many steps (1 to 4294967295), then stop: a presentation
    /// of N dwells timed by the device's own clock, not the link's. The LM
    /// firmware stops itself (lmhost holds the link, renewing its lease,
    /// until then); on an AUTD3 lmhost holds the link and stops it when
    /// the devices' clock says the steps have played. From silence
    /// it starts at once; while another slot plays it takes over at the
    /// end of that cycle and counts from there.
    #[arg(
        long,
        value_name = "N",
        conflicts_with = "hold",
        allow_negative_numbers = true,
        value_parser = super::whole::whole::<u32>(1, u32::MAX.into())
    )]
    steps: Option<u32>,
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        let hold = self.hold.duration()?;
        let mut dev = self.device.open()?;
        let at = if self.immediate {
            PlayAt::Immediate
        } else {
            PlayAt::NextCycle
        };
        // What plays lasts only while lmhost holds the link (an AUTD3; the
        // LM firmware by its host lease): Ctrl-C / SIGTERM end the hold
        // below and leave the array silent.
        lmhost::stop::graceful();
        match self.steps {
            Some(n) => dev.play_for(self.slot, self.untracked, n)?,
            None => dev.play_at(self.slot, at, self.untracked)?,
        }
        let st = dev.status().context("reading the device status")?;
        if self.untracked {
            lmhost::errln!("{UNTRACKED_WARNING}");
        }
        let outcome = play_outcome(self.slot, &st);
        let where_ = dev.describe();
        let Some(n) = self.steps else {
            lmhost::outln!("{outcome}")?;
            if !dev.needs_host() {
                return Ok(());
            }
            lmhost::out::flush_stdout()?;
            hold_saying(dev.as_mut(), &where_, hold)?;
            return Ok(dev.stop()?);
        };
        // The LM firmware counts the steps and stops itself; an AUTD3 cannot
        // and lmhost stops it when the devices' clock says they have
        // played. Either way lmhost holds the link until then.
        lmhost::outln!(
            "{outcome}, for {n} steps ({})",
            if dev.counters_source() == "device" {
                "the device stops itself"
            } else {
                "lmhost stops it"
            }
        )?;
        lmhost::out::flush_stdout()?;
        // An AUTD3 is stopped by `tick` (on time to a millisecond); the LM
        // firmware's status goes over the link, so ask it less often.
        let every = if dev.counters_source() == "device" {
            Duration::from_millis(20)
        } else {
            Duration::from_millis(1)
        };
        loop {
            if lmhost::stop::requested() {
                dev.stop()?;
                break;
            }
            dev.tick()?;
            if dev.status()?.state == DeviceState::Stopped {
                break;
            }
            std::thread::sleep(every);
        }
        let st = dev.status()?;
        lmhost::outln!("stopped after cycle {} step {}", st.cycles, st.step)?;
        Ok(())
    }
}
