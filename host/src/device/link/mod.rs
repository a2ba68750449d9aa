//! The host side of the link: byte transports ([`transport`]), which port
//! to open ([`discover`]), the request/response client with retries and
//! chunked upload ([`client`]) of a sequence in wire form ([`spec`]) and
//! how its requests fail ([`error`]), the
//! checks every device `Info` and `Status` passes before use
//! ([`reply`]), and a fault-injecting wrapper for tests ([`proxy`]).
//!
//! The link carries what it is given: wire values (micrometres,
//! microseconds) are built from the library's millimetres and seconds by
//! [`crate::units`], where every host → wire conversion lives, before they
//! reach a client call.

pub mod client;
pub mod discover;
pub mod error;
pub mod proxy;
pub mod reply;
pub mod spec;
pub mod transport;

pub use client::{Client, Heard, LinkError, LinkStats, Reply, UploadReport, UploadSpec};
pub use transport::Transport;

/// Which device port to open and how (the CLI's `--port`, `--baud`,
/// `--timeout-ms`, `--tries`, `--lease`). The serial link's settings are
/// `None` where not given: the LM firmware's link takes its default, and an
/// AUTD3 port, which has no such link, refuses one given
/// ([`PortSpec::device`](crate::device::connect)).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PortSpec {
    /// Serial port or pty path, `tcp:HOST:PORT`, or an AUTD3 rig
    /// (`autd3:...`); `None`: `$LMHOST_PORT`, else the one LM board found
    /// by USB id.
    pub port: Option<String>,
    /// Baud rate for real serial ports (ptys ignore it) [default:
    /// [`DEFAULT_BAUD`]].
    pub baud: Option<u32>,
    /// Response timeout per attempt, ms; `None`: 100 + twice the time a
    /// full chunk takes at the baud rate.
    pub timeout_ms: Option<u64>,
    /// Attempts per request before giving up [default: [`DEFAULT_TRIES`]].
    pub tries: Option<u32>,
    /// The LM firmware's host lease, ms: a play ends this long after the
    /// device last heard from lmhost (within [`lm_proto::LEASE_MS`])
    /// [default: [`lm_proto::DEFAULT_LEASE_MS`]].
    pub lease_ms: Option<u16>,
}

/// The serial link's baud rate when none is given.
pub const DEFAULT_BAUD: u32 = 115_200;
/// Attempts per request when none is given.
pub const DEFAULT_TRIES: u32 = 8;

impl PortSpec {
    /// `port` with every link setting at its default.
    pub fn new(port: Option<String>) -> Self {
        Self {
            port,
            baud: None,
            timeout_ms: None,
            tries: None,
            lease_ms: None,
        }
    }

    /// The serial link's settings given (by flag name), which only the
    /// LM firmware's link takes. The timeout is not among them: it may
    /// come from `$LMHOST_TIMEOUT_MS`, set once for every device.
    pub fn link_settings_given(&self) -> Vec<&'static str> {
        crate::limits::given(&[
            ("--baud", self.baud.is_some()),
            ("--tries", self.tries.is_some()),
            ("--lease", self.lease_ms.is_some()),
        ])
    }

    /// Resolve the port and open a client on it (the LM firmware; every
    /// command opens its device through [`crate::device::connect::open`], which
    /// sends AUTD3 ports elsewhere).
    pub fn connect(&self) -> anyhow::Result<Client<Box<dyn Transport>>> {
        let baud = self.baud.unwrap_or(DEFAULT_BAUD);
        let tries = self.tries.unwrap_or(DEFAULT_TRIES);
        let lease_ms = self.lease_ms.unwrap_or(lm_proto::DEFAULT_LEASE_MS);
        if baud == 0 {
            return Err(crate::InputError::new("--baud must be above 0").into());
        }
        if tries == 0 {
            return Err(crate::InputError::new("--tries must be at least 1").into());
        }
        if !lm_proto::LEASE_MS.contains(&lease_ms) {
            return Err(crate::InputError::new(format!(
                "--lease {} s is out of range: allowed {}..={} s",
                f64::from(lease_ms) / 1000.0,
                f64::from(*lm_proto::LEASE_MS.start()) / 1000.0,
                f64::from(*lm_proto::LEASE_MS.end()) / 1000.0
            ))
            .into());
        }
        let path = discover::resolve(self.port.as_deref())?;
        // A port from the environment is named as such: the user may not
        // remember a `LMHOST_PORT` a shell profile set.
        let from_env = self.port.is_none() && std::env::var_os(discover::PORT_ENV).is_some();
        let transport = transport::open(&path, baud).map_err(|e| {
            if from_env {
                e.context(format!("${}", discover::PORT_ENV))
            } else {
                e
            }
        })?;
        let mut client = Client::new(transport);
        // Requests are matched to replies by seq: a client that started
        // where the last one did (a killed lmhost, its replies still in the
        // port's buffer) would take those for its own.
        client.start_seq(fresh_seq());
        let chunk_ms = (lm_proto::MAX_ENCODED_FRAME as u64 * 10 * 1000).div_ceil(u64::from(baud));
        client.timeout =
            std::time::Duration::from_millis(self.timeout_ms.unwrap_or(100 + 2 * chunk_ms));
        client.tries = tries;
        client.lease_ms = lease_ms;
        Ok(client)
    }
}

/// A seq to start from that differs from one run to the next.
fn fresh_seq() -> u16 {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    let mixed =
        u64::from(std::process::id()).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ u64::from(nanos);
    (mixed >> 16) as u16
}
