//! `lmhost info`: what the device is and what it can hold.

use super::QueryArgs;

/// Prints the device's info.
pub fn run(q: &QueryArgs) -> anyhow::Result<()> {
    let (mut dev, where_) = q.open()?;
    let bi = dev.info()?;
    match &bi.lm {
        None => q.print(&bi, |bi| {
            println!("device:          {where_} ({})", bi.backend);
            println!("boards:          {}", bi.devices);
            println!("transducers:     {}", bi.transducers);
            println!("slots:           {} (STM segments)", bi.slots);
            println!("firmware:        {}", bi.firmware.join(", "));
            if let Some(g) = bi.dwell_grid_us {
                println!("dwell grid:      {g} µs (≥ 1000 µs with the silencer)");
            }
        }),
        Some(i) => q.print(i, |i| {
            let [a, b, c] = i.fw_version;
            println!("device:          {where_}");
            println!("protocol:        {}", i.proto_version);
            println!("firmware:        {a}.{b}.{c}");
            println!("transducers:     up to {}", i.max_transducers);
            println!("slots:           {} × {} bytes", i.slots, i.slot_bytes);
            println!("timer:           {} Hz", i.timer_hz);
            println!("minimum dwell:   {} µs", i.min_dwell_us);
            println!("largest chunk:   {} bytes", i.max_chunk);
        }),
    }
}
