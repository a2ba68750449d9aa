//! `lmhost status`: what the device is doing, and its error counters.

use anyhow::Context as _;

use crate::backend::DeviceArgs;

/// Print the device's status.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    device: DeviceArgs,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        let mut dev = self.device.open()?;
        let where_ = dev.describe();
        let s = dev
            .status()
            .with_context(|| format!("asking {where_} for its status"))?;
        if self.json {
            println!("{}", serde_json::to_string(&s)?);
            return Ok(());
        }
        print_status(&s);
        Ok(())
    }
}

/// The text form of a status.
pub fn print_status(s: &lm_proto::Status) {
    let slot = s.slot.map_or("none".to_owned(), |s| s.to_string());
    let queued = s.queued_slot.map_or("none".to_owned(), |s| {
        format!("{s} (takes over at the next cycle boundary)")
    });
    println!("state:            {:?}", s.state);
    println!("mute reason:      {}", s.mute_reason.describe());
    println!("slot:             {slot}");
    println!("queued slot:      {queued}");
    println!("step:             {}", s.step);
    println!("cycles:           {}", s.cycles);
    println!("missed deadlines: {}", s.missed_deadlines);
    println!("last centroid:    #{}", s.last_centroid_seq);
    println!("correction:       {:?} µm", s.correction_um);
    println!("bad frames:       {}", s.bad_frames);
    println!("CRC errors:       {}", s.crc_errors);
    println!("nacks sent:       {}", s.nacks);
}
