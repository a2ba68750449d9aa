//! `lmhost status`: what the device is doing, and its error counters.

use lmhost::device::backend::port_context;

use super::QueryArgs;

/// Prints the device's status.
pub fn run(q: &QueryArgs) -> anyhow::Result<()> {
    q.device.plays_nothing("status")?;
    let (mut dev, where_) = q.open()?;
    let s = dev.status().map_err(|e| {
        port_context(e, &where_, "asking the device for its status", || {
            format!("asking {where_} for its status")
        })
    })?;
    q.print(&s, print_status)
}

/// The text form of a status.
pub fn print_status(s: &lm_proto::Status) -> anyhow::Result<()> {
    let slot = s.slot.map_or("none".to_owned(), |s| s.to_string());
    let queued = s.queued_slot.map_or("none".to_owned(), |s| {
        format!("{s} (takes over at the next cycle boundary)")
    });
    if s.mute_reason == lm_proto::MuteReason::LeaseExpired {
        lmhost::outln!(
            "state:            {:?} (stopped: {})",
            s.state,
            s.mute_reason.describe()
        )?;
    } else {
        lmhost::outln!("state:            {:?}", s.state)?;
    }
    lmhost::outln!("mute reason:      {}", s.mute_reason.describe())?;
    lmhost::outln!("slot:             {slot}")?;
    lmhost::outln!("queued slot:      {queued}")?;
    lmhost::outln!("step:             {}", s.step)?;
    lmhost::outln!("cycles:           {}", s.cycles)?;
    lmhost::outln!("missed deadlines: {}", s.missed_deadlines)?;
    lmhost::outln!("last centroid:    #{}", s.last_centroid_seq)?;
    lmhost::outln!("correction:       {:?} µm", s.correction_um)?;
    lmhost::outln!("bad frames:       {}", s.bad_frames)?;
    lmhost::outln!("CRC errors:       {}", s.crc_errors)?;
    lmhost::outln!("nacks sent:       {}", s.nacks)?;
    lmhost::outln!("uptime:           {:.3} s", f64::from(s.uptime_ms) / 1000.0)?;
    match s.lease_ms {
        0 => lmhost::outln!(
            "host lease:       none ({} plays ended by one)",
            s.lease_expiries
        )?,
        ms => lmhost::outln!(
            "host lease:       {} s ({} plays ended by one since reset)",
            f64::from(ms) / 1000.0,
            s.lease_expiries
        )?,
    }
    Ok(())
}
