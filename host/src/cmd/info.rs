//! `lmhost info`: what the device is and what it can hold.

use crate::backend::DeviceArgs;

/// Print the device's info.
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
        let bi = dev.info()?;
        let Some(i) = bi.lm else {
            if self.json {
                println!("{}", serde_json::to_string(&bi)?);
                return Ok(());
            }
            println!("device:          {where_} ({})", bi.backend);
            println!("boards:          {}", bi.devices);
            println!("transducers:     {}", bi.transducers);
            println!("slots:           {} (STM segments)", bi.slots);
            println!("firmware:        {}", bi.firmware.join(", "));
            if let Some(g) = bi.dwell_grid_us {
                println!("dwell grid:      {g} µs (≥ 1000 µs with the silencer)");
            }
            return Ok(());
        };
        if self.json {
            println!("{}", serde_json::to_string(&i)?);
            return Ok(());
        }
        let [a, b, c] = i.fw_version;
        println!("device:          {where_}");
        println!("protocol:        {}", i.proto_version);
        println!("firmware:        {a}.{b}.{c}");
        println!("transducers:     up to {}", i.max_transducers);
        println!("slots:           {} × {} bytes", i.slots, i.slot_bytes);
        println!("timer:           {} Hz", i.timer_hz);
        println!("minimum dwell:   {} µs", i.min_dwell_us);
        println!("largest chunk:   {} bytes", i.max_chunk);
        Ok(())
    }
}
