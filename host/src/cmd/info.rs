//! `lmhost info`: what the device is and what it can hold.

use super::QueryArgs;

/// Prints the device's info.
pub fn run(q: &QueryArgs) -> anyhow::Result<()> {
    let (mut dev, where_) = q.open()?;
    let bi = dev.info()?;
    match &bi.lm {
        None => q.print(&bi, |bi| {
            crate::outln!("device:          {where_} ({})", bi.backend)?;
            crate::outln!("boards:          {}", bi.devices)?;
            crate::outln!("transducers:     {}", bi.transducers)?;
            crate::outln!("slots:           {} (STM segments)", bi.slots)?;
            crate::outln!("firmware:        {}", bi.firmware.join(", "))?;
            if let Some(g) = bi.dwell_grid_us {
                crate::outln!("dwell grid:      {g} µs (≥ 1000 µs with the silencer)")?;
            }
            Ok(())
        }),
        Some(i) => q.print(i, |i| {
            let [a, b, c] = i.fw_version;
            crate::outln!("device:          {where_}")?;
            crate::outln!("protocol:        {}", i.proto_version)?;
            crate::outln!("firmware:        {a}.{b}.{c}")?;
            crate::outln!("transducers:     up to {}", i.max_transducers)?;
            crate::outln!("slots:           {} × {} bytes", i.slots, i.slot_bytes)?;
            crate::outln!("timer:           {} Hz", i.timer_hz)?;
            crate::outln!("minimum dwell:   {} µs", i.min_dwell_us)?;
            crate::outln!("largest chunk:   {} bytes", i.max_chunk)?;
            Ok(())
        }),
    }
}
