//! `lmhost play`: play a committed slot.

use std::time::Duration;

use anyhow::Context as _;
use lm_proto::{DeviceState, PlayAt};

use super::args::DeviceArgs;
use crate::cmd::upload::{UNTRACKED_WARNING, play_outcome};

/// Play a slot that holds a committed sequence.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    device: DeviceArgs,
    /// Slot to play (checked against the device's slot count).
    #[arg(long, default_value_t = 0)]
    slot: u8,
    /// Switch at once instead of at the end of the current cycle.
    #[arg(long, conflicts_with = "steps")]
    immediate: bool,
    /// Play without tracking: the device sounds without a finger (no
    /// gating, no correction) until `lmhost stop`.
    #[arg(long)]
    untracked: bool,
    /// Play this many steps (1 to 4294967295), then stop: a presentation
    /// of N dwells timed by the device's own clock, not the link's. The LM
    /// firmware stops itself; on an AUTD3 lmhost holds the link and stops
    /// it when the devices' clock says the steps have played. From silence
    /// it starts at once; while another slot plays it takes over at the
    /// end of that cycle and counts from there.
    #[arg(
        long,
        value_name = "N",
        allow_negative_numbers = true,
        value_parser = clap::value_parser!(u32).range(1..)
    )]
    steps: Option<u32>,
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        let mut dev = self.device.open()?;
        let at = if self.immediate {
            PlayAt::Immediate
        } else {
            PlayAt::NextCycle
        };
        match self.steps {
            Some(n) => dev.play_for(self.slot, self.untracked, n)?,
            None => dev.play_at(self.slot, at, self.untracked)?,
        }
        let st = dev.status().context("reading the device status")?;
        if self.untracked {
            lmhost::errln!("{UNTRACKED_WARNING}");
        }
        let outcome = play_outcome(self.slot, &st);
        let Some(n) = self.steps else {
            lmhost::outln!("{outcome}")?;
            return Ok(());
        };
        if !dev.needs_host() {
            lmhost::outln!("{outcome}, for {n} steps (the device stops itself)")?;
            return Ok(());
        }
        // An AUTD3 plays only while lmhost holds the link, and cannot stop
        // itself: tick until its clock says the steps have played.
        lmhost::outln!("{outcome}, for {n} steps (lmhost stops it)")?;
        lmhost::stop::graceful();
        loop {
            if lmhost::stop::requested() {
                dev.stop()?;
                break;
            }
            dev.tick()?;
            if dev.status()?.state == DeviceState::Stopped {
                break;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        let st = dev.status()?;
        lmhost::outln!("stopped after cycle {} step {}", st.cycles, st.step)?;
        Ok(())
    }
}
