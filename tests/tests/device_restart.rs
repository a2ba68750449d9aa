//! A device that restarts while a command holds it (a power glitch, a
//! watchdog) has lost the sequences lmhost uploaded: the command ends
//! naming the port (exit 1) rather than holding nothing.

use std::io::BufRead as _;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

#[allow(dead_code)]
mod gated_device;
mod link_support;
use link_support::{lmhost, one_line_error};

/// `lmhost upload --hold 30` on `dev`, its stderr piped.
fn holding(dev: &gated_device::Gated) -> Child {
    Command::new(lmhost())
        .args(["upload", "--radius", "3", "--untracked", "--hold", "30"])
        .args(["--port", &dev.port])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

#[test]
fn a_device_that_restarts_during_an_upload_hold_ends_it_naming_the_port() {
    let dev = gated_device::Gated::start(0);
    let mut child = holding(&dev);
    let (tx, rx) = std::sync::mpsc::channel::<String>();
    let stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        for l in std::io::BufReader::new(stderr).lines() {
            let _ = tx.send(l.unwrap());
        }
    });
    let mut err = String::new();
    while !err.contains("holding ") {
        let l = rx
            .recv_timeout(Duration::from_secs(60))
            .unwrap_or_else(|e| panic!("no hold ({e}): {err}"));
        err.push_str(&l);
        err.push('\n');
    }
    // The device resets while it plays: its library is gone.
    dev.restart();
    let st = child.wait().unwrap();
    reader.join().unwrap();
    err.extend(rx.try_iter().map(|l| l + "\n"));
    assert_eq!(st.code(), Some(1), "{err}");
    assert!(
        err.contains(&format!("the device on {} restarted", dev.port)),
        "{err}"
    );
}

/// A restart that leaves nothing to tell but the clock: the device reset
/// before it ever played and before it counted anything (every since-reset
/// counter 0, Idle before and after). Held at the `BeginUpload`, it loses
/// the rig lmhost sent; lmhost sends it again on `NoRig` and plays, and
/// its next `Status` says the device's uptime went back.
#[test]
fn a_restart_with_every_counter_at_0_before_any_play_is_seen() {
    let dev = gated_device::Gated::start(1);
    let child = holding(&dev);
    dev.wait_held(Duration::from_secs(60));
    dev.restart();
    dev.release();
    let err = one_line_error(&child.wait_with_output().unwrap(), 1);
    assert!(
        err.contains(&format!("the device on {} restarted", dev.port)),
        "{err}"
    );
    assert!(err.contains("its uptime went back from 36"), "{err}");
}
