//! Which port to talk to: `--port`, else `LMHOST_PORT`, else a board found
//! by USB vendor/product id in sysfs (no libudev), else an error that lists
//! the ports found. Never the simulator unless asked for by path.

use std::path::{Path, PathBuf};

use crate::InputError;

/// The environment variable naming the default port.
pub const PORT_ENV: &str = "LMHOST_PORT";
/// The environment variable holding a response timeout for every LM
/// device (ms), which `--timeout-ms` overrides.
pub const TIMEOUT_ENV: &str = "LMHOST_TIMEOUT_MS";

/// USB ids of the Nucleo's on-board ST-LINK probes, each with a name for
/// messages: the one list `lmhost doctor` looks for a probe in and port
/// discovery names a virtual COM port by (BRINGUP.md's udev rules list
/// the same ids). UM1974/UM2407 name 374b (NUCLEO-H743ZI) and 374e/374f
/// (NUCLEO-H743ZI2); an ST-LINK firmware update can change the setup
/// the probe shows (without mass storage: 3752 on a V2-1, 3754 on a V3;
/// 3753: a V3 with two virtual COM ports).
pub const ST_LINKS: &[(u16, u16, &str)] = &[
    (0x0483, 0x374b, "ST-LINK/V2-1 (Nucleo-H743ZI)"),
    (0x0483, 0x3752, "ST-LINK/V2-1 (Nucleo-H743ZI)"),
    (0x0483, 0x374e, "STLINK-V3E (Nucleo-H743ZI2)"),
    (0x0483, 0x374f, "STLINK-V3E (Nucleo-H743ZI2)"),
    (0x0483, 0x3753, "STLINK-V3"),
    (0x0483, 0x3754, "STLINK-V3"),
];

/// The name of the USB device `(vid, pid)` among the boards the firmware
/// runs on: the firmware's own CDC-ACM port on the Nucleo's user USB
/// connector (firmware/nucleo-h743/src/usb.rs: ST's VCP id; preferred when
/// the board's ST-LINK port shows up too, it is the faster link) or an
/// ST-LINK's virtual COM port.
pub fn known_board(usb: (u16, u16)) -> Option<&'static str> {
    if usb == FIRMWARE_USB {
        return Some("Nucleo-H743 user USB (LM firmware)");
    }
    ST_LINKS.iter().find(|b| (b.0, b.1) == usb).map(|b| b.2)
}

/// The USB id of the firmware's own CDC-ACM port.
pub const FIRMWARE_USB: (u16, u16) = (0x0483, 0x5740);

/// A tty found in sysfs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PortInfo {
    /// Device node, e.g. `/dev/ttyACM0`.
    pub path: String,
    /// USB vendor and product id, if the tty hangs off a USB device.
    pub usb: Option<(u16, u16)>,
}

impl PortInfo {
    /// The known board this port belongs to, if any.
    pub fn board(&self) -> Option<&'static str> {
        known_board(self.usb?)
    }
}

fn read_hex(path: &Path) -> Option<u16> {
    u16::from_str_radix(std::fs::read_to_string(path).ok()?.trim(), 16).ok()
}

/// USB ids for a tty's sysfs directory: walk up from `device` until a
/// directory with `idVendor` appears (interface → device).
fn usb_ids(tty_dir: &Path) -> Option<(u16, u16)> {
    let mut dir: PathBuf = std::fs::canonicalize(tty_dir.join("device")).ok()?;
    for _ in 0..4 {
        if let (Some(v), Some(p)) = (
            read_hex(&dir.join("idVendor")),
            read_hex(&dir.join("idProduct")),
        ) {
            return Some((v, p));
        }
        dir = dir.parent()?.to_path_buf();
    }
    None
}

/// Serial ports under a sysfs class root (normally `/sys/class/tty`):
/// only ttys backed by a device (so not the hundreds of virtual consoles).
pub fn scan(sys_class_tty: &Path) -> Vec<PortInfo> {
    let Ok(entries) = std::fs::read_dir(sys_class_tty) else {
        return Vec::new();
    };
    let mut ports: Vec<PortInfo> = entries
        .flatten()
        .filter(|e| e.path().join("device").exists())
        .filter_map(|e| {
            let name = e.file_name().into_string().ok()?;
            // Legacy 8250 ports without hardware still have a device link;
            // keep them only if they are USB or ACM/USB-serial by name.
            let usb = usb_ids(&e.path());
            let plausible =
                usb.is_some() || name.starts_with("ttyACM") || name.starts_with("ttyUSB");
            plausible.then(|| PortInfo {
                path: format!("/dev/{name}"),
                usb,
            })
        })
        .collect();
    ports.sort_by(|a, b| a.path.cmp(&b.path));
    ports
}

/// Choose the port: `flag`, else `env`, else the one known board among
/// `found`. The error lists what was found and how to choose.
pub fn choose(
    flag: Option<&str>,
    env: Option<&str>,
    found: &[PortInfo],
) -> Result<String, InputError> {
    // An empty flag is refused, not taken for no flag: `--port "$PORT"`
    // with PORT unset picked whatever board discovery found.
    if flag == Some("") {
        return Err(InputError::new(format!(
            "--port is empty: give a serial port path, tcp:HOST:PORT or autd3:…, \
             or leave --port out for ${PORT_ENV} or the one LM board found"
        )));
    }
    if let Some(p) = flag {
        return Ok(p.to_owned());
    }
    if let Some(p) = env {
        return empty_env(p).map(|()| p.to_owned());
    }
    let boards: Vec<&PortInfo> = found.iter().filter(|p| p.board().is_some()).collect();
    let own: Vec<&PortInfo> = boards
        .iter()
        .copied()
        .filter(|p| p.usb == Some(FIRMWARE_USB))
        .collect();
    if let [one] = own.as_slice() {
        return Ok(one.path.clone());
    }
    match boards.as_slice() {
        [one] => Ok(one.path.clone()),
        [] => {
            let list = if found.is_empty() {
                "none".to_owned()
            } else {
                crate::error::some_of(
                    found.iter().map(|p| match p.usb {
                        Some((v, d)) => format!("{} ({v:04x}:{d:04x})", p.path),
                        None => p.path.clone(),
                    }),
                    ", ",
                )
            };
            Err(InputError::new(format!(
                "no LM board found (serial ports: {list}); pass --port PATH or set {PORT_ENV} \
                 (for the simulated device, run `lmhost sim` and use the path it prints)"
            )))
        }
        many => Err(InputError::new(format!(
            "several LM boards found ({}); choose one with --port PATH or {PORT_ENV}",
            crate::error::some_of(many.iter().map(|p| p.path.as_str()), ", ")
        ))),
    }
}

/// Refuses `$LMHOST_PORT` set empty, when it is read (no `--port`): it
/// was taken for an unset variable, so `LMHOST_PORT=$PORT` with PORT
/// unset picked whatever board discovery found, as an empty `--port` did.
pub fn empty_env(value: &str) -> Result<(), InputError> {
    match value {
        "" => Err(InputError::new(format!(
            "${PORT_ENV} is empty: give a serial port path, tcp:HOST:PORT or autd3:…, \
             or unset it for the one LM board found"
        ))),
        _ => Ok(()),
    }
}

/// [`choose`] against the live system.
pub fn resolve(flag: Option<&str>) -> Result<String, InputError> {
    let env = env_port()?;
    choose(flag, env.as_deref(), &scan(Path::new("/sys/class/tty")))
}

/// `$LMHOST_PORT`, if set. A value that is not UTF-8 is refused, not
/// taken for an unset variable (that picked whatever board discovery
/// found).
pub fn env_port() -> Result<Option<String>, InputError> {
    match std::env::var(PORT_ENV) {
        Ok(p) => Ok(Some(p)),
        Err(std::env::VarError::NotPresent) => Ok(None),
        Err(std::env::VarError::NotUnicode(raw)) => {
            Err(crate::error::env_not_utf8(PORT_ENV, &raw, "a port name"))
        }
    }
}

/// Refuses a port name (`named`: the flag or variable that gave it) of a
/// form no port has: spaces at an end, or a line break or other control
/// character (a name pasted with its line end). Each was opened as it
/// was and failed as "no such file" (exit 1), the trouble unseen.
pub fn check_name(named: &str, port: &str) -> Result<(), InputError> {
    let echo = || crate::error::short_echo(&port.escape_debug().to_string());
    if port.chars().any(char::is_control) {
        return Err(InputError::new(format!(
            "{named} `{}` holds a line break or control character: give the port's name alone",
            echo()
        )));
    }
    if port.trim() != port {
        return Err(InputError::new(format!(
            "{named} `{}` has spaces at an end: give the port's name without them",
            echo()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fake_sysfs() -> PathBuf {
        let root = std::env::temp_dir().join(format!("lmhost-sysfs-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let usb = root.join("devices/usb1/1-1");
        let intf = usb.join("1-1:1.2");
        std::fs::create_dir_all(&intf).unwrap();
        std::fs::write(usb.join("idVendor"), "0483\n").unwrap();
        std::fs::write(usb.join("idProduct"), "374e\n").unwrap();
        let class = root.join("class/tty");
        std::fs::create_dir_all(class.join("ttyACM0")).unwrap();
        std::os::unix::fs::symlink(&intf, class.join("ttyACM0/device")).unwrap();
        // A virtual console: no device link, must be ignored.
        std::fs::create_dir_all(class.join("tty7")).unwrap();
        root
    }

    #[test]
    fn finds_board_by_usb_id() {
        let root = fake_sysfs();
        let found = scan(&root.join("class/tty"));
        assert_eq!(
            found,
            vec![PortInfo {
                path: "/dev/ttyACM0".into(),
                usb: Some((0x0483, 0x374e))
            }]
        );
        assert_eq!(choose(None, None, &found).unwrap(), "/dev/ttyACM0");
        let _ = std::fs::remove_dir_all(root);
    }

    #[test]
    fn the_firmwares_usb_port_is_preferred_to_the_st_link_of_the_same_board() {
        let port = |path: &str, usb| PortInfo {
            path: path.into(),
            usb: Some(usb),
        };
        let both = vec![
            port("/dev/ttyACM0", (0x0483, 0x374e)),
            port("/dev/ttyACM1", FIRMWARE_USB),
        ];
        assert_eq!(choose(None, None, &both).unwrap(), "/dev/ttyACM1");
        assert_eq!(
            PortInfo::board(&both[1]),
            Some("Nucleo-H743 user USB (LM firmware)")
        );
        // The id the firmware enumerates with is this one.
        let fw = include_str!("../../../../firmware/nucleo-h743/src/usb.rs");
        let want = format!(
            "pub const VID_PID: (u16, u16) = (0x{:04x}, 0x{:04x});",
            FIRMWARE_USB.0, FIRMWARE_USB.1
        );
        assert!(
            fw.contains(&want),
            "firmware/nucleo-h743/src/usb.rs: {want}"
        );
        // Two boards' USB ports: ambiguous, as before.
        let two = vec![
            port("/dev/ttyACM1", FIRMWARE_USB),
            port("/dev/ttyACM2", FIRMWARE_USB),
        ];
        assert!(
            choose(None, None, &two)
                .unwrap_err()
                .to_string()
                .contains("several")
        );
    }

    #[test]
    fn flag_beats_env_beats_autodetect() {
        let found = vec![PortInfo {
            path: "/dev/ttyACM0".into(),
            usb: Some((0x0483, 0x374e)),
        }];
        assert_eq!(
            choose(Some("/dev/a"), Some("/dev/b"), &found).unwrap(),
            "/dev/a"
        );
        assert_eq!(choose(None, Some("/dev/b"), &found).unwrap(), "/dev/b");
    }

    #[test]
    fn a_port_name_with_spaces_at_an_end_or_a_control_character_is_refused() {
        for (port, said) in [
            (" /dev/ttyACM0", "` /dev/ttyACM0` has spaces at an end"),
            ("/dev/ttyACM0 ", "`/dev/ttyACM0 ` has spaces at an end"),
            (
                "/dev/ttyACM0\n",
                "`/dev/ttyACM0\\n` holds a line break or control",
            ),
            (
                "tcp:\thost:1",
                "`tcp:\\thost:1` holds a line break or control",
            ),
        ] {
            let e = check_name("--port", port).unwrap_err().to_string();
            assert!(e.starts_with(&format!("--port {said}")), "{e}");
        }
        for fine in [
            "/dev/ttyACM0",
            "tcp:127.0.0.1:9000",
            "autd3:emulator",
            "/tmp/a b",
        ] {
            check_name("--port", fine).unwrap();
        }
    }

    #[test]
    fn no_board_lists_ports_and_never_picks_the_simulator() {
        let found = vec![PortInfo {
            path: "/dev/ttyUSB0".into(),
            usb: Some((0x1a86, 0x7523)),
        }];
        let e = choose(None, None, &found).unwrap_err().to_string();
        assert!(
            e.contains("/dev/ttyUSB0 (1a86:7523)") && e.contains("--port"),
            "{e}"
        );
        let e = choose(None, None, &[]).unwrap_err().to_string();
        assert!(e.contains("serial ports: none"), "{e}");
    }

    /// The udev rules BRINGUP.md tells a rig builder to install grant
    /// exactly the probes doctor and discovery know, and the firmware's
    /// own port.
    #[test]
    fn bringup_udev_rules_list_every_st_link_we_know() {
        let doc = include_str!("../../../../BRINGUP.md");
        let mut ruled: Vec<u16> = doc
            .lines()
            .filter(|l| l.starts_with("ATTRS{idVendor}==\"0483\""))
            .filter_map(|l| l.split("idProduct}==\"").nth(1))
            .map(|r| u16::from_str_radix(&r[..4], 16).unwrap())
            .collect();
        ruled.sort_unstable();
        let firmware = ruled.iter().position(|&p| p == FIRMWARE_USB.1);
        ruled.remove(firmware.expect("the firmware's own port is ruled too"));
        let mut known: Vec<u16> = ST_LINKS.iter().map(|s| s.1).collect();
        known.sort_unstable();
        assert_eq!(ruled, known);
        assert!(ST_LINKS.iter().all(|s| s.0 == 0x0483));
        assert_eq!(
            known_board((0x0483, 0x3752)),
            Some("ST-LINK/V2-1 (Nucleo-H743ZI)")
        );
        assert_eq!(known_board((0x0483, 0x5741)), None);
    }
}
