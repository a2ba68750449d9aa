//! `lmhost info`: what the device is and what it can hold.

use anyhow::Context as _;

use crate::link::PortArgs;

/// Print the device's info.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    port: PortArgs,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        let mut client = self.port.connect()?;
        let where_ = client.transport_mut().describe();
        let i = client
            .info()
            .with_context(|| format!("asking {where_} for its info"))?;
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
