//! `--port` syntax for AUTD3 rigs.
//!
//! - `autd3:emulator` — autd3's CPU + FPGA firmware emulator, in-process;
//! - `autd3:soem[:IFNAME]`, `autd3:ethercrab[:IFNAME]` — EtherCAT on a
//!   network interface (all interfaces are scanned when it is left out);
//! - `autd3:remote:HOST:PORT` — an `autd3-link-remote` server (always built: pure Rust TCP).

use crate::error::InputError;

/// Prefix that selects the AUTD3 backend.
pub const PREFIX: &str = "autd3:";

/// A parsed AUTD3 port.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Autd3Port {
    /// In-process firmware emulator (tests, CI, the demo).
    Emulator,
    /// The emulator as a rig of a fixed number of boards, for checking a
    /// scene against a rig it does not match (`autd3:emulator:N`).
    EmulatorRig {
        /// Boards in the rig, 1..=64.
        devices: usize,
    },
    /// EtherCAT through SOEM, on `ifname` or the first interface with devices.
    Soem {
        /// Network interface, e.g. `enp3s0`.
        ifname: Option<String>,
    },
    /// EtherCAT through ethercrab, on `ifname` or the first interface with devices.
    EtherCrab {
        /// Network interface.
        ifname: Option<String>,
    },
    /// A remote server reached over TCP.
    Remote {
        /// Host name or address.
        host: String,
        /// TCP port.
        port: u16,
    },
}

impl Autd3Port {
    /// Whether the rig is autd3's emulator, which lives in this process
    /// (and ends with it).
    pub fn is_emulator(&self) -> bool {
        matches!(self, Self::Emulator | Self::EmulatorRig { .. })
    }

    /// Whether `port` asks for the AUTD3 backend (starts with `autd3:`).
    pub fn is_autd3(port: &str) -> bool {
        port.starts_with(PREFIX)
    }

    /// Parses `autd3:...`; anything else under the prefix is an [`InputError`]
    /// listing the accepted forms.
    pub fn parse(port: &str) -> Result<Self, InputError> {
        const FORMS: &str = "autd3:emulator, autd3:soem[:IFNAME], autd3:ethercrab[:IFNAME] or autd3:remote:HOST:PORT";
        let Some(rest) = port.strip_prefix(PREFIX) else {
            return Err(InputError::new(format!(
                "port `{port}` is not an AUTD3 port; use {FORMS}"
            )));
        };
        let (kind, arg) = match rest.split_once(':') {
            Some((k, a)) => (k, Some(a)),
            None => (rest, None),
        };
        let ifname = |arg: Option<&str>| -> Result<Option<String>, InputError> {
            match arg {
                None => Ok(None),
                Some(a) if valid_ifname(a) => Ok(Some(a.to_string())),
                Some(a) => Err(InputError::new(format!(
                    "port `{port}`: `{a}` is not a network interface name (1-15 characters, no `:`, `/` or spaces)"
                ))),
            }
        };
        match kind {
            "emulator" if arg.is_none() => Ok(Self::Emulator),
            "emulator" => {
                let a = arg.unwrap_or_default();
                match a.parse::<usize>() {
                    Ok(devices) if (1..=64).contains(&devices) => Ok(Self::EmulatorRig { devices }),
                    _ => Err(InputError::new(format!(
                        "port `{port}`: the emulated rig's board count must be 1..=64, got `{a}`"
                    ))),
                }
            }
            "soem" => Ok(Self::Soem {
                ifname: ifname(arg)?,
            }),
            "ethercrab" => Ok(Self::EtherCrab {
                ifname: ifname(arg)?,
            }),
            "remote" => {
                let Some((host, p)) = arg.and_then(|a| a.rsplit_once(':')) else {
                    return Err(InputError::new(format!(
                        "port `{port}`: remote needs HOST:PORT, e.g. autd3:remote:192.168.0.2:8080"
                    )));
                };
                let host = host.trim_start_matches('[').trim_end_matches(']');
                if host.is_empty() || host.contains(char::is_whitespace) {
                    return Err(InputError::new(format!(
                        "port `{port}`: remote host must be a non-empty name or address"
                    )));
                }
                let port_no = p.parse::<u16>().ok().filter(|&n| n != 0).ok_or_else(|| {
                    InputError::new(format!(
                        "port `{port}`: remote TCP port must be 1..=65535, got `{p}`"
                    ))
                })?;
                Ok(Self::Remote {
                    host: host.to_string(),
                    port: port_no,
                })
            }
            _ => Err(InputError::new(format!(
                "port `{port}`: unknown AUTD3 link; use {FORMS}"
            ))),
        }
    }

    /// Cargo feature that enables this link, `None` when always built
    /// (the emulator and the remote link are pure Rust).
    pub fn feature(&self) -> Option<&'static str> {
        match self {
            Self::Emulator | Self::EmulatorRig { .. } => None,
            Self::Soem { .. } => Some("autd3-soem"),
            Self::EtherCrab { .. } => Some("autd3-ethercrab"),
            Self::Remote { .. } => None,
        }
    }
}

impl std::fmt::Display for Autd3Port {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Emulator => write!(f, "autd3:emulator"),
            Self::EmulatorRig { devices } => write!(f, "autd3:emulator:{devices}"),
            Self::Soem { ifname: None } => write!(f, "autd3:soem"),
            Self::Soem { ifname: Some(i) } => write!(f, "autd3:soem:{i}"),
            Self::EtherCrab { ifname: None } => write!(f, "autd3:ethercrab"),
            Self::EtherCrab { ifname: Some(i) } => write!(f, "autd3:ethercrab:{i}"),
            Self::Remote { host, port } if host.contains(':') => {
                write!(f, "autd3:remote:[{host}]:{port}")
            }
            Self::Remote { host, port } => write!(f, "autd3:remote:{host}:{port}"),
        }
    }
}

/// Linux interface names: 1..=15 bytes, no `/`, `:` or whitespace.
fn valid_ifname(s: &str) -> bool {
    !s.is_empty() && s.len() <= 15 && !s.contains(['/', ':']) && !s.contains(char::is_whitespace)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_form() {
        assert_eq!(
            Autd3Port::parse("autd3:emulator").unwrap(),
            Autd3Port::Emulator
        );
        assert_eq!(
            Autd3Port::parse("autd3:soem").unwrap(),
            Autd3Port::Soem { ifname: None }
        );
        assert_eq!(
            Autd3Port::parse("autd3:soem:enp3s0").unwrap(),
            Autd3Port::Soem {
                ifname: Some("enp3s0".into())
            }
        );
        assert_eq!(
            Autd3Port::parse("autd3:ethercrab:eth0").unwrap(),
            Autd3Port::EtherCrab {
                ifname: Some("eth0".into())
            }
        );
        assert_eq!(
            Autd3Port::parse("autd3:remote:10.0.0.2:8080").unwrap(),
            Autd3Port::Remote {
                host: "10.0.0.2".into(),
                port: 8080
            }
        );
        assert_eq!(
            Autd3Port::parse("autd3:remote:[::1]:8080").unwrap(),
            Autd3Port::Remote {
                host: "::1".into(),
                port: 8080
            }
        );
        for s in [
            "autd3:emulator",
            "autd3:emulator:3",
            "autd3:soem:eth0",
            "autd3:ethercrab",
            "autd3:remote:h:1",
            "autd3:remote:[::1]:8080",
        ] {
            assert_eq!(Autd3Port::parse(s).unwrap().to_string(), s);
        }
    }

    #[test]
    fn rejects_malformed_ports_with_one_line() {
        for s in [
            "autd3:",
            "autd3:emulator:x",
            "autd3:emulator:0",
            "autd3:twincat",
            "autd3:soem:",
            "autd3:soem:a/b",
            "autd3:soem:waytoolonginterfacename",
            "autd3:remote",
            "autd3:remote:host",
            "autd3:remote::80",
            "autd3:remote:h:0",
            "autd3:remote:h:70000",
            "/dev/ttyACM0",
        ] {
            let e = Autd3Port::parse(s).unwrap_err().to_string();
            assert!(!e.contains('\n'), "{s}: {e}");
            assert!(e.contains(s), "{s}: {e}");
        }
        assert!(Autd3Port::is_autd3("autd3:emulator"));
        assert!(!Autd3Port::is_autd3("/dev/ttyACM0"));
    }
}
