//! Flag parsers the subcommands share: library enums offered as clap
//! values without the library knowing clap.

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};

use lmhost::device::backend::Backend;
use lmhost::device::link::PortSpec;
use lmhost::plan::scene::Scene;
use lmhost::sense::stream::filter::FilterKind;

/// Port flags shared by every command that talks to a device.
#[derive(Debug, Clone, clap::Args)]
pub struct PortArgs {
    /// Serial port or pty path, `tcp:HOST:PORT`, or an AUTD3 rig
    /// (`autd3:emulator`, `autd3:soem[:IFNAME]`, `autd3:ethercrab[:IFNAME]`,
    /// `autd3:remote:HOST:PORT`) [default: $LMHOST_PORT, else the one LM
    /// board found by USB id].
    #[arg(long, value_name = "PATH")]
    pub port: Option<String>,
    /// Baud rate for real serial ports (ptys ignore it).
    #[arg(long, value_name = "BAUD", default_value_t = 115_200)]
    pub baud: u32,
    /// Response timeout per attempt, ms, 1..=60000 [default: 100 + twice
    /// the time a full chunk takes at --baud].
    #[arg(long, value_name = "MS", value_parser = clap::value_parser!(u64).range(1..=lmhost::limits::MAX_TIMEOUT_MS))]
    pub timeout_ms: Option<u64>,
    /// Attempts per request before giving up, 1..=100.
    #[arg(long, value_name = "N", default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=i64::from(lmhost::limits::MAX_TRIES)))]
    pub tries: u32,
    /// LM firmware: the host lease, 0.1 to 60 s. What lmhost plays stops
    /// by itself this long after the device last heard from it (lmhost
    /// renews it every quarter lease while it holds the port), so the
    /// array falls silent when lmhost dies.
    #[arg(long, value_name = "S", default_value = "1", value_parser = lease_ms, allow_negative_numbers = true)]
    pub lease: u16,
}

/// `--lease S` as milliseconds, within the device's bounds.
fn lease_ms(s: &str) -> Result<u16, String> {
    let (lo, hi) = (*lm_proto::LEASE_MS.start(), *lm_proto::LEASE_MS.end());
    let bad = || {
        format!(
            "{s} is not a lease: {} to {} s (there is no \"forever\")",
            f64::from(lo) / 1000.0,
            f64::from(hi) / 1000.0
        )
    };
    let secs: f64 = s.trim().parse().map_err(|_| bad())?;
    let ms = (secs * 1000.0).round();
    if !(f64::from(lo)..=f64::from(hi)).contains(&ms) {
        return Err(bad());
    }
    Ok(ms as u16)
}

impl PortArgs {
    /// The library's port description.
    pub fn spec(&self) -> PortSpec {
        PortSpec {
            port: self.port.clone(),
            baud: self.baud,
            timeout_ms: self.timeout_ms,
            tries: self.tries,
            lease_ms: self.lease,
        }
    }
}

/// The device a command talks to: its port and, for AUTD3 ports, the
/// scene whose devices the rig has (`info`, `status`, `play`, `stop`).
#[derive(Debug, clap::Args)]
pub struct DeviceArgs {
    #[command(flatten)]
    port: PortArgs,
    /// AUTD3 ports: scene file whose devices the rig has [default: the
    /// built-in array].
    #[arg(long, value_name = "FILE")]
    scene: Option<std::path::PathBuf>,
}

impl DeviceArgs {
    /// The host lease `--lease` asks for, ms.
    pub fn lease_ms(&self) -> u16 {
        self.port.lease
    }

    /// Loads the scene and opens the device ([`lmhost::device::connect::open`]).
    pub fn open(&self) -> anyhow::Result<Box<dyn Backend>> {
        let scene = Scene::load_or_default(self.scene.as_deref())?;
        lmhost::device::connect::open(&self.port.spec(), &scene)
    }
}

/// `--filter`: one of [`FilterKind::ALL`] by name, with each one's help.
pub fn filter() -> impl TypedValueParser<Value = FilterKind> {
    PossibleValuesParser::new(
        FilterKind::ALL.map(|k| PossibleValue::new(k.name()).help(k.describe())),
    )
    .map(|name: String| {
        FilterKind::ALL
            .into_iter()
            .find(|k| k.name() == name)
            .unwrap_or(FilterKind::Kalman)
    })
}

/// Tracked finger centroids on a reader thread, for `session` and `study
/// run`: UDP datagrams on 127.0.0.1:`udp`, else JSON or CSV lines from
/// `stream` (`-`: stdin; `lmhost track --json` lines included); `None`
/// when neither is given.
pub fn centroid_feed(
    udp: Option<u16>,
    stream: Option<&std::path::Path>,
) -> anyhow::Result<Option<lmhost::sense::stream::run::Threaded>> {
    use lmhost::sense::stream::run::on_thread;
    use lmhost::sense::stream::source;
    if let Some(port) = udp {
        let max = lmhost::limits::MAX_SECONDS;
        let idle = lmhost::limits::duration_s("--udp idle time", max, max)?;
        let udp = source::udp(port, idle, std::sync::Arc::default())?;
        return Ok(Some(on_thread(move || udp)?));
    }
    let Some(p) = stream else {
        return Ok(None);
    };
    Ok(Some(if p.as_os_str() == "-" {
        on_thread(|| source::read_lines(std::io::stdin().lock()))?
    } else {
        let reader = std::io::BufReader::new(lmhost::files::open_input("--stream file", p)?);
        on_thread(move || source::read_lines(reader))?
    }))
}

/// `--view ADDR`: a port (on 127.0.0.1, local only) or HOST:PORT.
pub fn view_addr(s: &str) -> Result<std::net::SocketAddr, String> {
    if let Ok(port) = s.parse::<u16>() {
        return Ok(std::net::SocketAddr::from(([127, 0, 0, 1], port)));
    }
    if !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()) {
        return Err(format!(
            "port {s} is out of range: give 0..=65535 (0: any free port)"
        ));
    }
    s.parse()
        .map_err(|_| format!("`{s}` is neither a port nor HOST:PORT (e.g. 8000 or 127.0.0.1:8000)"))
}
