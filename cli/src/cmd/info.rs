//! `lmhost info`: what the device is and what it can hold.

use super::QueryArgs;
use lmhost::device::backend::Kind;

/// Prints the device's info.
pub fn run(q: &QueryArgs) -> anyhow::Result<()> {
    let (mut dev, where_) = q.open()?;
    let bi = dev.info()?;
    match &bi.kind {
        Kind::Autd3 { dwell_grid_us } => q.print(&bi, |bi| {
            lmhost::outln!("device:          {where_} ({})", bi.backend)?;
            lmhost::outln!("boards:          {}", bi.devices)?;
            lmhost::outln!("transducers:     {}", bi.transducers)?;
            lmhost::outln!("slots:           {} (STM segments)", bi.slots)?;
            lmhost::outln!("firmware:        {}", bi.firmware.join(", "))?;
            lmhost::outln!("dwell grid:      {dwell_grid_us} µs (≥ 1000 µs with the silencer)")?;
            Ok(())
        }),
        Kind::LmFirmware(i) => q.print(i, |i| {
            let [a, b, c] = i.fw_version;
            lmhost::outln!("device:          {where_}")?;
            lmhost::outln!("protocol:        {}", i.proto_version)?;
            lmhost::outln!("firmware:        {a}.{b}.{c}")?;
            lmhost::outln!("transducers:     up to {}", i.max_transducers)?;
            lmhost::outln!(
                "library:         {} entries in {} bytes ({} free; an entry is stored raw or as its Delta stream)",
                i.slots,
                i.slot_bytes,
                i.library_free
            )?;
            if i.rig_transducers > 0 {
                lmhost::outln!(
                    "rig:             {} transducers (positions CRC-32 {:08x})",
                    i.rig_transducers,
                    i.rig_crc32
                )?;
            } else {
                lmhost::outln!("rig:             none yet (the first upload sends it)")?;
            }
            lmhost::outln!(
                "timer:           {} Hz, from {}",
                i.timer_hz,
                match i.clock {
                    lm_proto::ClockSource::Crystal => "a crystal (±50 ppm or better)",
                    lm_proto::ClockSource::InternalRc =>
                        "the internal RC oscillator (~1 %: the crystal clock did not start)",
                    lm_proto::ClockSource::Emulated => "the host machine's clock (emulated)",
                    _ => "an unknown oscillator",
                }
            )?;
            lmhost::outln!("minimum dwell:   {} µs", i.min_dwell_us)?;
            lmhost::outln!("largest chunk:   {} bytes", i.max_chunk)?;
            let lease = q.lease_ms();
            lmhost::outln!(
                "host lease:      {} s: what lmhost plays stops by itself this long after the device last heard from it (renewed every {} s while lmhost holds the port; --lease {}-{} s)",
                f64::from(lease) / 1000.0,
                f64::from(lease / 4) / 1000.0,
                f64::from(*lm_proto::LEASE_MS.start()) / 1000.0,
                f64::from(*lm_proto::LEASE_MS.end()) / 1000.0
            )?;
            Ok(())
        }),
    }
}
