//! lmhost's device layer against the firmware under QEMU (UART0 on a TCP
//! socket, opened as `tcp:127.0.0.1:PORT`): the device policy's
//! conformance table, a timed play the firmware stops itself, and
//! `lmhost session` switching and timing from its events. The raw protocol
//! and the stimulus library are `qemu.rs`'s. Skipped, with a message, when
//! `qemu-system-arm` is not installed (`cargo xtask ci` installs it).

use std::io::Write;
use std::net::TcpStream;
use std::path::Path;
use std::time::{Duration, Instant};

use lm_proto::{DeviceState, Status};

mod link_support;
mod qemu_support;
use qemu_support::{
    Qemu, device_or_skip, firmware_or_skip, free_port, qemu_command_icount, serving, until_stopped,
    wait_on_device, within_20_s,
};

/// The default stimulus (LM-S, 5 Hz) planned for the paper's scene.
fn default_plan() -> lmhost::plan::sequence::Plan {
    use lmhost::plan::scene::Scene;
    use lmhost::plan::stimulus::Stimulus;
    use lmhost::plan::target::Target;
    Stimulus::default()
        .plan_for(&Target::Lm, Scene::default())
        .unwrap()
        .plan
}

/// The device policy's conformance table (`lmhost::device::conformance`), the
/// same one the simulated device and the AUTD3 emulator pass, against the
/// firmware under QEMU: a fresh QEMU per scenario.
#[test]
fn firmware_under_qemu_conforms_to_the_device_policy() {
    use lmhost::device::conformance::{Dut, run};
    use lmhost::plan::scene::Scene;
    let Some(elf) = firmware_or_skip() else {
        return;
    };
    let wide = default_plan();
    let mut narrow = wide.clone();
    narrow.sequence.set_max_offset_mm(2.0).unwrap();
    let steps = u64::from(wide.sequence.header.steps);
    let dwell_us = wide.sequence.dwell_us();
    let mut held: Vec<Qemu> = Vec::new();
    let failures = run(
        &mut || {
            held.clear();
            let (qemu, spec) = serving(&elf)?;
            held.push(qemu);
            let dev = within_20_s(|| lmhost::device::connect::open(&spec, &Scene::default()))?;
            Ok(Dut {
                dev,
                wait: Box::new(move |dev, d| wait_on_device(dev, d, steps, dwell_us)),
            })
        },
        &wide,
        &narrow,
    )
    .unwrap();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// `lmhost session` against the firmware under QEMU: the paper's library
/// resident, two switches at the cycle end and a timed on-phase, read from
/// the session's events; the figures are printed for BENCHMARKS.md (no
/// timing is asserted: under `-icount` the guest's time is its own).
#[test]
fn a_session_on_the_firmware_under_qemu_switches_and_times_from_events() {
    let Some(elf) = firmware_or_skip() else {
        return;
    };
    let port = free_port();
    // `-icount shift=auto`: the guest's clock follows the host's, so what
    // the device counts and what the host times can be compared (with
    // `shift=0` a busy guest's second lasts as long as QEMU takes to run
    // 10^9 instructions).
    let _qemu = Qemu::spawn(
        qemu_command_icount(&elf, port, false, "shift=auto,sleep=on"),
        port,
    )
    .expect("start qemu-system-arm");
    let deadline = Instant::now() + Duration::from_secs(20);
    while TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(Instant::now() < deadline, "QEMU's UART never listened");
        std::thread::sleep(Duration::from_millis(50));
    }
    // QEMU's UART takes one client: the probe above was it until it closed.
    std::thread::sleep(Duration::from_millis(200));
    // Three of the paper's stimuli (the whole set preloads in the QEMU
    // library test above; a loaded machine makes QEMU's UART slow).
    let library = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("session-lib-{port}.toml"));
    std::fs::write(
        &library,
        "[[stimulus]]\nid = \"lms-5hz-a3\"\n\n[[stimulus]]\nid = \"lmm-5hz-a3\"\nfoci = 4\n\n\
         [[stimulus]]\nid = \"lms-5hz-a5\"\nradius = 5\n",
    )
    .unwrap();
    let tcp = format!("tcp:127.0.0.1:{port}");
    let script = [
        r#"{"cmd":"present","stimulus":"lms-5hz-a3","gate":"untracked"}"#,
        r#"{"cmd":"present","stimulus":"lmm-5hz-a3","gate":"untracked"}"#,
        r#"{"cmd":"present","stimulus":"lms-5hz-a5","gate":"untracked"}"#,
        r#"{"cmd":"stop"}"#,
        r#"{"cmd":"present","stimulus":"lms-5hz-a3","gate":"untracked","on_s":2}"#,
    ];
    let mut child = std::process::Command::new(link_support::lmhost())
        .args([
            "session",
            "--library",
            library.to_str().unwrap(),
            "--port",
            &tcp,
            // A lease far beyond the slow link's reply timeout: QEMU's
            // UART on a loaded machine must not end a play (a host late
            // renewing it is `lease_expired`, not what this test times).
            "--lease",
            "30",
            "--control",
            "-",
        ])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let (tx, rx) = std::sync::mpsc::channel::<serde_json::Value>();
    let stdout = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || {
        use std::io::BufRead as _;
        for line in std::io::BufReader::new(stdout).lines() {
            let v: serde_json::Value = serde_json::from_str(&line.unwrap()).unwrap();
            if tx.send(v).is_err() {
                break;
            }
        }
    });
    let mut events = Vec::new();
    // Commands go in once the library is on the device.
    let wait_ready = Instant::now() + Duration::from_secs(120);
    loop {
        let v = rx
            .recv_timeout(wait_ready.saturating_duration_since(Instant::now()))
            .expect("the session never got ready");
        let ready = v["event"] == "ready";
        events.push(v);
        if ready {
            break;
        }
    }
    {
        let mut stdin = child.stdin.take().unwrap();
        for line in script {
            writeln!(stdin, "{line}").unwrap();
            // Each stimulus plays a few cycles before the next.
            std::thread::sleep(Duration::from_millis(700));
        }
    }
    let out = child.wait_with_output().unwrap();
    reader.join().unwrap();
    events.extend(rx.try_iter());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let ready = events.iter().find(|e| e["event"] == "ready").unwrap();
    assert_eq!(ready["resident"], 3, "{ready}");
    let switches: Vec<(f64, f64)> = events
        .iter()
        .filter(|e| e["event"] == "switch")
        .map(|e| {
            let (l, d) = (
                e["latency_ms"].as_f64().unwrap(),
                e["detected_ms"].as_f64().unwrap(),
            );
            assert!(l <= d, "{e}");
            (l, d)
        })
        .collect();
    assert_eq!(switches.len(), 2, "{events:?}");
    let timed = events
        .iter()
        .find(|e| e["event"] == "offset" && e["reason"] == "timer")
        .unwrap_or_else(|| panic!("no timed offset: {events:?}"));
    let device = timed["device_presented_s"].as_f64().unwrap();
    // The firmware timed the on-phase itself: 2 s to half a dwell (5 Hz,
    // 82 steps: 2.439 ms).
    assert!(
        (device - 2.0).abs() <= 0.5 * 200.0 / 82.0 / 1e3 + 1e-9,
        "{timed}"
    );
    println!(
        "QEMU session: switch (latency, detected) {switches:?} ms (5 Hz: one cycle is 200 ms); 2 s untracked on-phase: device {device} s, host {} s",
        timed["presented_s"]
    );
}

/// `play_for` on the firmware under QEMU: the device counts the steps of a
/// 5 Hz stimulus on its own timer and stops itself at the boundary, with
/// no deadline missed; its status shows the count at the limit, frozen.
#[test]
fn a_timed_play_on_the_firmware_under_qemu_stops_itself_after_its_steps() {
    let Some((_qemu, mut dev)) = device_or_skip() else {
        return;
    };
    let plan = default_plan();
    let h = plan.sequence.header;
    assert_eq!(h.period_us, 200_000, "a 5 Hz stimulus");
    let n = u64::from(h.steps);
    let steps = 2 * h.steps as u32 + 7;
    let slot = dev.upload(&plan, None).unwrap().slot;
    dev.play_for(slot, true, steps).unwrap();
    let count = |st: &Status| u64::from(st.cycles) * n + u64::from(st.step);
    let st = until_stopped(dev.as_mut(), |st| {
        assert_eq!(st.state, DeviceState::Playing, "{st:?}");
        assert!(count(st) < u64::from(steps), "{st:?}");
    });
    assert_eq!(count(&st), u64::from(steps), "{st:?}");
    assert_eq!(
        (st.slot, st.queued_slot, st.mute_reason),
        (Some(slot), None, lm_proto::MuteReason::Stopped)
    );
    assert_eq!(st.missed_deadlines, 0);
    std::thread::sleep(Duration::from_millis(300));
    let later = dev.status().unwrap();
    assert_eq!(
        (later.state, count(&later)),
        (DeviceState::Stopped, u64::from(steps))
    );
}

/// An amplitude-modulated stimulus on the firmware under QEMU (protocol
/// v6): the plan's intensity table goes up with the phases, the firmware
/// acknowledges the commit (its CRC over the phases and levels it stored)
/// and plays it for its steps without a missed deadline; the same phases
/// without the table are another entry (another CRC).
#[test]
fn an_am_stimulus_plays_on_the_firmware_under_qemu() {
    use lmhost::plan::modulation::{Am, AmShape};
    use lmhost::plan::scene::Scene;
    use lmhost::plan::stimulus::Stimulus;
    use lmhost::plan::target::Target;
    let Some((_qemu, mut dev)) = device_or_skip() else {
        return;
    };
    let am = Stimulus {
        am: Some(Am {
            shape: AmShape::Sine,
            freq_hz: 20.0,
            depth: 1.0,
        }),
        ..Stimulus::default()
    }
    .plan_for(&Target::Lm, Scene::default())
    .unwrap();
    assert_eq!(am.timing.am_freq_hz, Some(20.0));
    let plan = am.plan;
    let flat = default_plan();
    let up = dev.upload(&plan, Some(0)).unwrap();
    assert_eq!(up.wire().unwrap().crc32, plan.sequence.crc32());
    let up_flat = dev.upload(&flat, Some(1)).unwrap();
    assert_ne!(up_flat.wire().unwrap().crc32, up.wire().unwrap().crc32);
    let n = u32::from(plan.sequence.header.steps);
    dev.play_for(0, true, n).unwrap();
    let st = until_stopped(dev.as_mut(), |_| {});
    assert_eq!(
        (st.slot, st.cycles, st.missed_deadlines),
        (Some(0), 1, 0),
        "{st:?}"
    );
}
