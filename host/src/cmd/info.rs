//! `lmhost info`: what the device is and what it can hold.

use super::QueryArgs;

/// Prints the device's info.
pub fn run(q: &QueryArgs) -> anyhow::Result<()> {
    let (mut dev, where_) = q.open()?;
    let bi = dev.info()?;
    match &bi.lm {
        None => q.print(&bi, |bi| {
            lmhost::outln!("device:          {where_} ({})", bi.backend)?;
            lmhost::outln!("boards:          {}", bi.devices)?;
            lmhost::outln!("transducers:     {}", bi.transducers)?;
            lmhost::outln!("slots:           {} (STM segments)", bi.slots)?;
            lmhost::outln!("firmware:        {}", bi.firmware.join(", "))?;
            if let Some(g) = bi.dwell_grid_us {
                lmhost::outln!("dwell grid:      {g} µs (≥ 1000 µs with the silencer)")?;
            }
            Ok(())
        }),
        Some(i) => q.print(i, |i| {
            let [a, b, c] = i.fw_version;
            lmhost::outln!("device:          {where_}")?;
            lmhost::outln!("protocol:        {}", i.proto_version)?;
            lmhost::outln!("firmware:        {a}.{b}.{c}")?;
            lmhost::outln!("transducers:     up to {}", i.max_transducers)?;
            lmhost::outln!("slots:           {} × {} bytes", i.slots, i.slot_bytes)?;
            lmhost::outln!("timer:           {} Hz", i.timer_hz)?;
            lmhost::outln!("minimum dwell:   {} µs", i.min_dwell_us)?;
            lmhost::outln!("largest chunk:   {} bytes", i.max_chunk)?;
            Ok(())
        }),
    }
}
