//! The real `lmhost` binary against the firmware under QEMU (`mps2-an500`,
//! UART0 on a TCP socket): info, upload, play, stream, status, stop; what
//! lmhost plays lasts while it holds the port.
//!
//! The firmware ELF comes from `LM_FW_QEMU_ELF` (set by `cargo xtask ci`);
//! without it the test builds it for `thumbv7em-none-eabihf` into its own
//! target dir. Skipped, with a message, when `qemu-system-arm` is missing.

use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

mod link_support;
mod qemu_support;
use link_support::{assert_fields, json, stream_stdin, upload_json};
use qemu_support::{firmware_elf, free_port, qemu_command, qemu_installed};

/// QEMU with UART0 on a TCP server that accepts one lmhost after another.
struct Qemu {
    child: Child,
    port: String,
}

impl Qemu {
    fn start(elf: &Path) -> Qemu {
        let port = free_port();
        let child = qemu_command(elf, port, false)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("start qemu-system-arm");
        let deadline = Instant::now() + Duration::from_secs(20);
        while TcpStream::connect(("127.0.0.1", port)).is_err() {
            assert!(
                Instant::now() < deadline,
                "QEMU's UART never listened on {port}"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        Qemu {
            child,
            port: format!("tcp:127.0.0.1:{port}"),
        }
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[test]
fn lmhost_drives_the_firmware_under_qemu() {
    if !qemu_installed() {
        eprintln!("skipped: qemu-system-arm is not installed");
        return;
    }
    let q = Qemu::start(&firmware_elf());
    let p = q.port.as_str();
    let info = json(&["info", "--port", p, "--json"]);
    assert_eq!(info["max_transducers"], 996, "{info}");
    // QEMU's timer follows the host machine's clock, and says so.
    assert_eq!(info["clock"], "Emulated", "{info}");
    let up = upload_json(p, &["--foci", "4"]);
    assert_eq!(up["steps"], 82, "{up}");
    assert_eq!(up["playing"], true);
    assert_eq!(up["state"], "Muted", "{up}");
    // The upload held it briefly and left it silent.
    assert_eq!(json(&["status", "--port", p, "--json"])["state"], "Stopped");
    // The stream plays it again, tracked, and leaves it silent too.
    let out = stream_stdin(p, &["--json"], "0,0.5,0,200,1\n");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["device_state"], "Playing", "{v}");
    assert_eq!(v["device_last_seq"], 1, "{v}");
    let st = json(&["status", "--port", p, "--json"]);
    assert_fields(
        &st,
        &["state", "mute_reason"],
        serde_json::json!(["Stopped", "stopped"]),
    );
    assert_eq!(st["last_centroid_seq"], 1);
    assert_eq!(st["crc_errors"], 0);
    assert_eq!(st["lease_ms"], 1000);
    link_support::ok(&["stop", "--port", p]);
    assert_eq!(json(&["status", "--port", p, "--json"])["state"], "Stopped");
}
