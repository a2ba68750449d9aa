//! `lmhost selftest`: the board's output self-test (its SPI loopback: one
//! jumper from MOSI to MISO), in one line.

use lm_proto::SelfTest;

use super::args::DeviceArgs;

/// Run the board's SPI loopback self-test (a jumper from MOSI to MISO).
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Prints one line: `spi loopback: passed (1024 bytes)` (exit 0), or \
    `spi loopback: failed: ...` / `spi loopback: not supported by this board` as the \
    error (exit 1). The device refuses it while a slot plays (stop first)."
)]
pub struct Args {
    #[command(flatten)]
    device: DeviceArgs,
    /// Print the result as JSON (then exit as above).
    #[arg(long)]
    json: bool,
}

/// The result in words: `passed (1024 bytes)`, `failed: ...`, `not
/// supported by this board`.
pub fn describe(t: &SelfTest) -> String {
    match *t {
        SelfTest::Passed { bytes } => format!("passed ({bytes} bytes)"),
        SelfTest::Failed {
            bytes,
            mismatches,
            first_mismatch,
            sent,
            got,
        } => format!(
            "failed: {mismatches} of {bytes} bytes came back wrong, the first at byte \
             {first_mismatch} (sent {sent:02x}, got {got:02x}); is the jumper from MOSI to \
             MISO in place?"
        ),
        _ => "not supported by this board".to_owned(),
    }
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        self.device.plays_nothing("selftest")?;
        let mut dev = self.device.open()?;
        let t = dev.self_test()?;
        if self.json {
            lmhost::outln!("{}", serde_json::to_string(&t)?)?;
        }
        let line = format!("spi loopback: {}", describe(&t));
        match t {
            SelfTest::Passed { .. } if !self.json => lmhost::outln!("{line}"),
            SelfTest::Passed { .. } => Ok(()),
            _ => Err(anyhow::anyhow!("{line}")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_outcome_reads_as_one_line() {
        assert_eq!(
            describe(&SelfTest::Passed { bytes: 1024 }),
            "passed (1024 bytes)"
        );
        assert_eq!(
            describe(&SelfTest::Unsupported),
            "not supported by this board"
        );
        let f = describe(&SelfTest::Failed {
            bytes: 1024,
            mismatches: 1020,
            first_mismatch: 0,
            sent: 0,
            got: 0xFF,
        });
        assert!(f.starts_with("failed: 1020 of 1024 bytes"), "{f}");
        assert!(f.contains("sent 00, got ff") && !f.contains('\n'), "{f}");
    }
}
