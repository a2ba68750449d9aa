//! `lmhost status`: what the device is doing, and its error counters.

use anyhow::Context as _;

use super::QueryArgs;

/// Prints the device's status.
pub fn run(q: &QueryArgs) -> anyhow::Result<()> {
    let (mut dev, where_) = q.open()?;
    let s = dev
        .status()
        .with_context(|| format!("asking {where_} for its status"))?;
    q.print(&s, print_status)
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
