//! Tests of `connect`: opening a port by its spec, the LM backend over
//! the simulated firmware, and holding a play.

use std::sync::{Arc, Mutex};

use lm_proto::DeviceState;

use super::*;
use crate::clock::Clock;
use crate::plan::stimulus::Stimulus;

/// The simulated firmware in process on a manual clock, keeping its
/// output frames.
fn sim() -> (LmBackend<InProcess<FwCore>>, Arc<Mutex<FwCore>>, Clock) {
    let clock = Clock::manual_at_us(1_000_000);
    let (dev, core) = simulated(clock.clone()).unwrap();
    core.lock().unwrap().set_capture(true);
    (dev, core, clock)
}

fn plan() -> Plan {
    Stimulus::default()
        .plan_for(&Target::Lm, Scene::default())
        .unwrap()
        .plan
}

/// Where the firmware's schedule puts boundary `g` after a start at `t0`.
fn boundary(plan: &Plan, t0: u64, g: u64) -> u64 {
    let h = &plan.sequence.header;
    t0 + g * u64::from(h.period_us) / u64::from(h.steps)
}

/// Moves the device's clock to `us`, polling it at every deadline on
/// the way (as a board's timer would).
fn to(dev: &mut LmBackend<InProcess<FwCore>>, us: u64) {
    dev.client.transport_mut().advance_to(us);
}

fn count(st: &Status, n: u16) -> u64 {
    u64::from(st.cycles) * u64::from(n) + u64::from(st.step)
}

#[test]
fn the_device_kind_says_what_lives_in_this_process() {
    let kind = |p: &str| PortSpec::new(Some(p.into())).device().unwrap();
    assert!(kind("autd3:emulator").in_process());
    assert!(kind("autd3:emulator:4").in_process());
    for p in ["autd3:soem", "autd3:remote:h:1", "/dev/ttyACM0", "tcp:h:1"] {
        assert!(!kind(p).in_process(), "{p}");
    }
    assert_eq!(kind("autd3:emulator").target(), Target::Autd3);
    assert_eq!(kind("/dev/ttyACM0").target(), Target::Lm);
}

/// An AUTD3 has no serial link: a setting of one is refused, naming
/// the flag, where the LM firmware's link takes it.
#[test]
fn serial_link_settings_are_refused_for_an_autd3() {
    for (spec, flag) in [
        (
            PortSpec {
                baud: Some(9600),
                ..PortSpec::new(None)
            },
            "--baud",
        ),
        (
            PortSpec {
                tries: Some(2),
                ..PortSpec::new(None)
            },
            "--tries",
        ),
        (
            PortSpec {
                lease_ms: Some(500),
                ..PortSpec::new(None)
            },
            "--lease",
        ),
    ] {
        let lm = PortSpec {
            port: Some("/dev/ttyACM0".into()),
            ..spec.clone()
        };
        assert_eq!(lm.device().unwrap(), DeviceKind::Lm);
        let autd3 = PortSpec {
            port: Some("autd3:emulator".into()),
            ..spec
        };
        let e = autd3.device().unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("{flag} applies to the LM firmware's serial link")),
            "{e}"
        );
    }
    // A timeout given for the AUTD3 is refused; one that is
    // $LMHOST_TIMEOUT_MS's, set for every device, is not.
    let timeout = PortSpec {
        timeout_ms: Some(300),
        ..PortSpec::new(Some("autd3:emulator".into()))
    };
    if timeout_from_env() == Some(300) {
        assert!(timeout.device().is_ok());
    } else {
        let e = timeout.device().unwrap_err().to_string();
        assert!(
            e.starts_with("--timeout-ms applies to the LM firmware's serial link"),
            "{e}"
        );
    }
}

#[test]
fn play_for_stops_on_the_devices_timer_at_the_step_boundary() {
    let (mut dev, core, clock) = sim();
    let plan = plan();
    let n = plan.sequence.header.steps;
    let steps = 2 * u32::from(n) + 3;
    let slot = dev.upload(&plan, None).unwrap().slot;
    core.lock().unwrap().take_captured();
    let t0 = clock.now_us();
    dev.play_for(slot, true, steps).unwrap();
    let end = boundary(&plan, t0, u64::from(steps));
    to(&mut dev, end - 1);
    let st = dev.status().unwrap();
    assert_eq!(st.state, DeviceState::Playing);
    assert_eq!(count(&st, n), u64::from(steps) - 1);
    to(&mut dev, end);
    let st = dev.status().unwrap();
    assert_eq!(
        (st.state, st.slot, st.queued_slot),
        (DeviceState::Stopped, Some(slot), None)
    );
    assert_eq!(count(&st, n), u64::from(steps));
    assert_eq!(st.missed_deadlines, 0);
    // Frozen afterwards.
    to(&mut dev, end + 10_000_000);
    let later = dev.status().unwrap();
    assert_eq!(
        lm_proto::Status {
            uptime_ms: st.uptime_ms,
            ..later
        },
        st
    );
    assert_eq!(later.uptime_ms, st.uptime_ms + 10_000, "its uptime goes on");
    let frames = core.lock().unwrap().take_captured();
    let sounding = frames.iter().filter(|f| f.amplitude > 0).count();
    assert_eq!(sounding, steps as usize);
    assert_eq!(frames.last().map(|f| f.amplitude), Some(0));
}

/// An AM stimulus on the simulated firmware: the plan's intensity
/// table goes up with the phases and every step's frame carries the
/// entry's intensity times that step's level.
#[test]
fn an_am_plan_plays_its_intensity_table_frame_by_frame() {
    use crate::plan::modulation::{Am, AmShape};
    let (mut dev, core, clock) = sim();
    let stimulus = Stimulus {
        am: Some(Am {
            shape: AmShape::Sine,
            freq_hz: 20.0,
            depth: 0.8,
        }),
        intensity: 0.8,
        ..Stimulus::default()
    };
    let plan = stimulus
        .plan_for(&Target::Lm, Scene::default())
        .unwrap()
        .plan;
    let table = plan.sequence.intensity_table.clone().unwrap();
    let n = plan.sequence.header.steps;
    let report = dev.upload(&plan, None).unwrap();
    let wire = report.wire().unwrap();
    assert_eq!(wire.crc32, plan.sequence.crc32());
    core.lock().unwrap().take_captured();
    let t0 = clock.now_us();
    dev.play_for(report.slot, true, u32::from(n)).unwrap();
    to(&mut dev, boundary(&plan, t0, u64::from(n)));
    let frames = core.lock().unwrap().take_captured();
    let sounding: Vec<_> = frames.iter().filter(|f| f.amplitude > 0).collect();
    assert_eq!(sounding.len(), usize::from(n));
    for f in sounding {
        let level = u32::from(table[usize::from(f.step)]);
        // 0.8 → 204; 204 × level / 255, rounded to nearest.
        assert_eq!(
            u32::from(f.intensity),
            (204 * level + 127) / 255,
            "step {}",
            f.step
        );
    }
    let levels: std::collections::BTreeSet<u8> = frames.iter().map(|f| f.intensity).collect();
    assert!(levels.len() > 10, "the envelope varies: {levels:?}");
    // A plan for the simulation (no table) is refused, not played flat.
    let flat = stimulus.plan(Scene::default()).unwrap().plan;
    let e = dev.upload(&flat, None).unwrap_err();
    assert!(e.to_string().contains("no intensity table"), "{e}");
}

#[test]
fn a_queued_play_for_counts_from_the_takeover() {
    let (mut dev, core, clock) = sim();
    let plan = plan();
    let n = plan.sequence.header.steps;
    let a = dev.upload(&plan, Some(0)).unwrap().slot;
    let b = dev.upload(&plan, Some(1)).unwrap().slot;
    let t0 = clock.now_us();
    dev.play(a, true).unwrap();
    to(&mut dev, boundary(&plan, t0, 2));
    core.lock().unwrap().take_captured();
    dev.play_for(b, true, u32::from(n) + 2).unwrap();
    assert_eq!(dev.status().unwrap().queued_slot, Some(b));
    // Slot b takes over at the end of a's first cycle.
    let takeover = boundary(&plan, t0, u64::from(n));
    to(&mut dev, boundary(&plan, takeover, u64::from(n) + 2) - 1);
    assert_eq!(dev.status().unwrap().state, DeviceState::Playing);
    to(&mut dev, boundary(&plan, takeover, u64::from(n) + 2));
    let st = dev.status().unwrap();
    assert_eq!((st.state, st.slot), (DeviceState::Stopped, Some(b)));
    assert_eq!(count(&st, n), u64::from(n) + 2);
    let frames = core.lock().unwrap().take_captured();
    let from_b = frames
        .iter()
        .filter(|f| f.slot == b && f.amplitude > 0)
        .count();
    assert_eq!(from_b, usize::from(n) + 2);
}

/// The LM backend holds what it plays by its host lease: `tick` renews
/// it (so a holding lmhost keeps it playing however long), and a host
/// that stops ticking loses it within the lease (real clock).
#[test]
fn tick_renews_the_lease_and_a_quiet_host_loses_the_play() {
    let (mut dev, _core) = simulated(Clock::real()).unwrap();
    dev.client.lease_ms = 200;
    let slot = dev.upload(&plan(), None).unwrap().slot;
    assert!(!dev.needs_host(), "nothing plays yet");
    dev.play(slot, true).unwrap();
    assert!(dev.needs_host());
    let t0 = std::time::Instant::now();
    while t0.elapsed() < std::time::Duration::from_millis(700) {
        dev.tick().unwrap();
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    let st = dev.status().unwrap();
    assert_eq!(st.state, DeviceState::Playing, "{st:?}");
    assert_eq!(st.lease_ms, 200);
    // The host goes quiet for more than a lease.
    std::thread::sleep(std::time::Duration::from_millis(400));
    let st = dev.status().unwrap();
    assert_eq!(
        (st.state, st.mute_reason, st.lease_expiries),
        (DeviceState::Stopped, lm_proto::MuteReason::LeaseExpired, 1)
    );
    assert!(!dev.needs_host(), "nothing of this host plays any more");
    dev.tick().unwrap();
    // A stop ends the hold without an expiry.
    dev.play(slot, true).unwrap();
    dev.stop().unwrap();
    assert!(!dev.needs_host());
    assert_eq!(
        dev.status().unwrap().mute_reason,
        lm_proto::MuteReason::Stopped
    );
}

/// `SelfTest` through the backend: the simulated board's loopback, or
/// none.
#[test]
fn self_test_reaches_the_simulated_loopback() {
    use crate::device::simdev::Loopback;
    for (loopback, want) in [
        (None, "Unsupported"),
        (Some(Loopback::Ok), "Passed"),
        (Some(Loopback::Broken), "Failed"),
    ] {
        let core = Arc::new(Mutex::new(
            FwCore::new(SimConfig {
                loopback,
                ..SimConfig::default()
            })
            .unwrap(),
        ));
        let mut dev = LmBackend::new(
            Client::new(InProcess::new(core, Clock::manual())),
            Encoding::Delta,
        );
        let t = dev.self_test().unwrap();
        assert!(format!("{t:?}").starts_with(want), "{t:?}");
    }
}
