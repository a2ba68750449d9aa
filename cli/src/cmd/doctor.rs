//! `lmhost doctor`: what is connected, and what to do about what is not.

use lmhost::lab::doctor::{self, Env, Options};

/// Check the rig: LM boards on USB (or --port), the debug probe, AUTD3 over
/// EtherCAT (links, interface, privileges), the depth camera and its
/// bridge. One line per check; exit 1 when something connected does not
/// work, 0 otherwise (missing pieces are listed with what to do).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Also check this device (a serial port or pty, `tcp:HOST:PORT`, or
    /// `autd3:...`); repeatable, each port once [default: $LMHOST_PORT,
    /// when set: the device every other command uses].
    #[arg(long, value_name = "PORT")]
    pub port: Vec<String>,
    /// Response timeout per request to an LM board (ms), 1..=60000
    /// [default: $LMHOST_TIMEOUT_MS, else 300].
    #[arg(long, value_name = "MS", env = "LMHOST_TIMEOUT_MS", default_value_t = 300,
          hide_default_value = true, hide_env = true,
          value_parser = super::whole::whole::<u64>(1, lmhost::limits::MAX_TIMEOUT_MS))]
    pub timeout_ms: u64,
    /// Print JSON (one array of checks) instead of lines.
    #[arg(long)]
    pub json: bool,
}

impl Args {
    /// Checks and prints.
    pub fn run(self) -> anyhow::Result<()> {
        let options = Options::given(self.port, self.timeout_ms)?;
        let checks = doctor::run(&Env::live(), &options);
        if self.json {
            lmhost::outln!("{}", serde_json::to_string(&checks)?)?;
        } else {
            for c in &checks {
                lmhost::outln!("{}", c.line())?;
            }
        }
        if doctor::healthy(&checks) {
            Ok(())
        } else {
            anyhow::bail!(
                "{} of {} checks failed",
                checks
                    .iter()
                    .filter(|c| c.outcome == doctor::Outcome::Fail)
                    .count(),
                checks.len()
            )
        }
    }
}
