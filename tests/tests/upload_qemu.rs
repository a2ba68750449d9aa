//! The real `lmhost` binary against the firmware under QEMU (`mps2-an386`,
//! UART0 on a TCP socket): info, upload, play, stream, status, stop.
//!
//! The firmware ELF comes from `LM_FW_QEMU_ELF` (set by `cargo xtask ci`);
//! without it the test builds it for `thumbv7em-none-eabihf` into its own
//! target dir. Skipped, with a message, when `qemu-system-arm` is missing.

use std::io::Write as _;
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

mod link_support;
use link_support::{json, lmhost};

const THUMB: &str = "thumbv7em-none-eabihf";

fn qemu_installed() -> bool {
    Command::new("qemu-system-arm")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

fn firmware_elf() -> PathBuf {
    if let Some(p) = std::env::var_os("LM_FW_QEMU_ELF") {
        return PathBuf::from(p);
    }
    let target_dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("lm-fw-qemu");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let status = Command::new(cargo)
        .current_dir(root)
        .args([
            "build",
            "--release",
            "-p",
            "lm-fw-qemu",
            "--bin",
            "lm-fw-qemu",
            "--target",
            THUMB,
        ])
        .arg("--target-dir")
        .arg(&target_dir)
        .status()
        .expect("run cargo to build the QEMU firmware");
    assert!(
        status.success(),
        "building the QEMU firmware failed (`rustup target add {THUMB}`?)"
    );
    target_dir.join(THUMB).join("release/lm-fw-qemu")
}

/// QEMU with UART0 on a TCP server that accepts one lmhost after another.
struct Qemu {
    child: Child,
    port: String,
}

impl Qemu {
    fn start(elf: &Path) -> Qemu {
        let port = TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let child = Command::new("qemu-system-arm")
            .args(["-M", "mps2-an386", "-display", "none", "-monitor", "none"])
            .args([
                "-semihosting-config",
                "enable=on,target=native",
                "-icount",
                "shift=0",
            ])
            .arg("-serial")
            .arg(format!("tcp:127.0.0.1:{port},server=on,wait=off"))
            .arg("-kernel")
            .arg(elf)
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
    let up = json(&["upload", "--port", p, "--foci", "4", "--json"]);
    assert_eq!(up["steps"], 82, "{up}");
    assert_eq!(up["playing"], true);
    assert_eq!(json(&["status", "--port", p, "--json"])["state"], "Muted");
    let mut child = Command::new(lmhost())
        .args(["stream", "--port", p])
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(b"0,0.5,0,200,1\n")
        .unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let st = json(&["status", "--port", p, "--json"]);
    assert_eq!(st["state"], "Playing", "{st}");
    assert_eq!(st["last_centroid_seq"], 1);
    assert_eq!(st["crc_errors"], 0);
    link_support::ok(&["stop", "--port", p]);
    assert_eq!(json(&["status", "--port", p, "--json"])["state"], "Stopped");
}
