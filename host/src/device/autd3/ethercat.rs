//! Before an EtherCAT link opens (`autd3:soem[:IF]`, `autd3:ethercrab[:IF]`):
//! the interface exists and this process may open raw sockets, each said
//! in one line (exit 1) instead of the link's own "timeout" or "no socket
//! connection", which mean either. Built in every configuration (it needs
//! no link crate), so it is tested without an adapter.

use std::path::Path;

/// Network interfaces by name, sorted (from `sys_class_net`, Linux's
/// `/sys/class/net`).
pub fn interfaces(sys_class_net: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(sys_class_net)
        .map(|d| {
            d.filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Interfaces an EtherCAT search may try: every one but loopback, with a
/// name the kernel's 16-byte `ifreq` can hold.
pub fn candidates(sys_class_net: &Path) -> Vec<String> {
    interfaces(sys_class_net)
        .into_iter()
        .filter(|i| i != "lo" && i.len() < 16)
        .collect()
}

/// Refuses an interface `sys_class_net` does not list, naming the ones it
/// does.
pub fn check_interface(port: &str, ifname: &str, sys_class_net: &Path) -> anyhow::Result<()> {
    let have = interfaces(sys_class_net);
    if have.is_empty() || have.iter().any(|i| i == ifname) {
        // No sysfs (not Linux): let the link say what it finds.
        return Ok(());
    }
    anyhow::bail!(
        "{port}: there is no network interface `{ifname}` (this machine has: {})",
        have.join(", ")
    )
}

/// Whether this process may open a raw packet socket (root or
/// CAP_NET_RAW): `Err` with the reason when it may not.
pub fn raw_socket_allowed() -> Result<(), std::io::Error> {
    #[cfg(target_os = "linux")]
    {
        // SAFETY: socket(2) takes plain integers and touches no memory of ours.
        let fd = unsafe {
            libc::socket(
                libc::AF_PACKET,
                libc::SOCK_RAW,
                i32::from((libc::ETH_P_ALL as u16).to_be()),
            )
        };
        if fd < 0 {
            return Err(std::io::Error::last_os_error());
        }
        // SAFETY: `fd` is the descriptor just opened above, closed once.
        unsafe { libc::close(fd) };
    }
    Ok(())
}

/// Whether a thread of this process may run at the real-time priority the
/// EtherCAT links ask for their send/receive thread (`SCHED_FIFO`, its
/// highest level: root, `CAP_SYS_NICE` or an `RLIMIT_RTPRIO` that allows
/// it). Tried on a thread of its own that ends at once.
pub fn realtime_allowed() -> bool {
    std::thread::spawn(|| {
        #[cfg(target_os = "linux")]
        {
            // SAFETY: plain FFI calls on the current thread with a valid parameter.
            unsafe {
                let param = libc::sched_param {
                    sched_priority: libc::sched_get_priority_max(libc::SCHED_FIFO),
                };
                libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) == 0
            }
        }
        #[cfg(not(target_os = "linux"))]
        true
    })
    .join()
    .unwrap_or(false)
}

/// The one warning when the EtherCAT thread cannot get real-time priority:
/// the links ask for it and run on at normal priority without a word, with
/// more jitter on a loaded machine.
pub fn realtime_warning() -> String {
    format!(
        "warning: the EtherCAT thread runs without real-time priority (it needs CAP_SYS_NICE: \
         `sudo setcap cap_net_raw,cap_net_admin,cap_sys_nice+ep {}`); frames may be late on a busy machine",
        std::env::current_exe().map_or_else(|_| "lmhost".into(), |p| p.display().to_string())
    )
}

/// The checks before `port` (an EtherCAT port on `ifname`, if given)
/// opens; warns once per process, when the link may open, that its thread
/// will not get real-time priority.
pub fn preflight(port: &str, ifname: Option<&str>) -> anyhow::Result<()> {
    static WARNED: std::sync::Once = std::sync::Once::new();
    if let Some(i) = ifname {
        check_interface(port, i, Path::new("/sys/class/net"))?;
    }
    raw_socket_allowed().map_err(|e| {
        let denied = matches!(e.raw_os_error(), Some(libc::EPERM) | Some(libc::EACCES));
        if denied {
            anyhow::anyhow!(
                "{port}: EtherCAT needs raw-socket privileges: run as root, or once `sudo setcap cap_net_raw,cap_net_admin,cap_sys_nice+ep {}`",
                std::env::current_exe().map_or_else(|_| "lmhost".into(), |p| p.display().to_string())
            )
        } else {
            anyhow::anyhow!("{port}: cannot open a raw socket: {}", crate::files::reason(&e))
        }
    })?;
    // Only for a link that can open at all: a refusal above is the one
    // line (its setcap already names cap_sys_nice).
    if !realtime_allowed() {
        WARNED.call_once(|| crate::errln!("lmhost: {}", realtime_warning()));
    }
    Ok(())
}

/// The link's own error made specific: its "timeout" means no EtherCAT
/// device answered on the interface.
pub fn explain(port: &str, e: &dyn std::fmt::Display) -> String {
    let m = e.to_string();
    let first = m.lines().next().unwrap_or("").trim();
    if first.eq_ignore_ascii_case("timeout") || first.starts_with("timeout:") {
        format!(
            "{port}: no EtherCAT device answered ({first}): is the AUTD3 chain connected to this interface and powered?"
        )
    } else {
        format!("{port}: {first}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_interface_is_named_with_the_ones_there_are() {
        let d = crate::files::scratch("sysnet");
        for i in ["lo", "eth0", "enp3s0"] {
            std::fs::create_dir_all(d.join(i)).unwrap();
        }
        check_interface("autd3:soem:eth0", "eth0", &d).unwrap();
        let e = check_interface("autd3:soem:eth9", "eth9", &d)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "autd3:soem:eth9: there is no network interface `eth9` (this machine has: enp3s0, eth0, lo)"
        );
        assert_eq!(candidates(&d), ["enp3s0", "eth0"]);
        // No sysfs: nothing to check against.
        check_interface("autd3:soem:x", "x", &d.join("none")).unwrap();
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn the_realtime_probe_agrees_with_the_system_and_the_warning_names_the_capability() {
        // Whatever this machine allows, the probe must say the same as a
        // direct try on a thread of the test's own.
        let direct = std::thread::spawn(|| {
            // SAFETY: as in `realtime_allowed`.
            unsafe {
                let param = libc::sched_param {
                    sched_priority: libc::sched_get_priority_max(libc::SCHED_FIFO),
                };
                libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) == 0
            }
        })
        .join()
        .unwrap();
        assert_eq!(realtime_allowed(), direct);
        let w = realtime_warning();
        assert!(w.contains("cap_sys_nice") && !w.contains('\n'), "{w}");
    }

    #[test]
    fn link_errors_become_one_specific_line() {
        let e = explain("autd3:ethercrab:eth0", &"timeout: PDU");
        assert!(
            e.contains("no EtherCAT device answered") && !e.contains('\n'),
            "{e}"
        );
        assert_eq!(
            explain("autd3:soem", &"No AUTD device was found\nmore"),
            "autd3:soem: No AUTD device was found"
        );
    }
}
