//! A library larger than the device's memory: preloaded as far as it
//! goes, loaded on demand in place of idle entries.

use std::sync::{Arc, Mutex};

use super::*;
use crate::device::connect::LmBackend;
use crate::device::link::Client;
use crate::device::simdev::{FwCore, InProcess, SimConfig};

/// The simulated firmware with a library of `steps` raw steps of 996
/// transducers, uploading Raw (so every entry takes its raw size).
fn small_lm(clock: &Clock, steps: u32) -> Box<dyn Backend> {
    let core = Arc::new(Mutex::new(
        FwCore::new(SimConfig {
            slot_steps: steps / 2,
            ..SimConfig::default()
        })
        .unwrap(),
    ));
    let mut dev = LmBackend::new(
        Client::new(InProcess::new(core, clock.clone())),
        lm_proto::Encoding::Raw,
    );
    dev.progress = false;
    Box::new(dev)
}

/// Six untracked 10 Hz LM-S entries `r3` to `r8` at radii 3 to 8 mm, of
/// 19 to 50 steps (207 in all).
fn big() -> String {
    (3..=8)
        .map(|r| {
            format!("[[stimulus]]\nid = \"r{r}\"\nradius = {r}\nfreq = 10\nstep = 1.0\nuntracked = true\n")
        })
        .collect()
}

/// A session over [`big`] on the simulated firmware with room for `steps`
/// raw steps, no finger.
fn big_on(clock: &Clock, steps: u32) -> Driver {
    driver(
        &big(),
        &Target::Lm,
        small_lm(clock, steps),
        clock,
        Finger::None,
    )
}

#[test]
fn a_library_larger_than_the_devices_memory_loads_on_demand_in_place_of_idle_entries() {
    let clock = Clock::manual_at_us(1_000_000);
    // Room for 120 steps: the first four entries (113 steps), not all six.
    let mut d = big_on(&clock, 120);
    let ev = d.session().drain_events();
    let resident = ev.iter().find_map(|e| match e.kind {
        EventKind::Ready { resident, .. } => Some(resident),
        _ => None,
    });
    assert_eq!(resident, Some(4), "{:?}", kinds(&ev));
    let ids = ["r3", "r4", "r5", "r6", "r7", "r8"];
    let mut evicted = Vec::new();
    // Three rounds through the library, each entry presented over the
    // one before: never refused.
    for round in 0..3 {
        for id in ids {
            d.session()
                .present(&untracked(id))
                .unwrap_or_else(|e| panic!("round {round}, {id}: {e:#}"));
            let ev = run_until(&mut d, &clock, Duration::from_secs(1), |e| {
                has(
                    e,
                    |k| matches!(k, EventKind::Onset { stimulus, .. } if stimulus == id),
                )
            });
            assert!(
                has(
                    &ev,
                    |k| matches!(k, EventKind::Onset { stimulus, .. } if stimulus == id)
                ),
                "{id}: {:?}",
                kinds(&ev)
            );
            for e in &ev {
                if let EventKind::Preloaded {
                    evicted: x,
                    stimulus,
                    ..
                } = &e.kind
                {
                    assert!(!x.contains(stimulus));
                    evicted.extend(x.iter().cloned());
                }
                assert!(!matches!(e.kind, EventKind::Refused { .. }));
            }
        }
    }
    assert!(!evicted.is_empty());
    // Only idle entries make room: never the one playing when it loaded.
    let st = d.session().status().unwrap();
    assert_eq!(st.stimulus.as_deref(), Some("r8"));
    let resident = d
        .session()
        .library()
        .iter()
        .filter(|i| i.slot.is_some())
        .count();
    assert!(resident < 6, "{resident}");
    // An entry that cannot fit beside the playing one, even alone, is
    // refused with the reason and nothing changes.
    let mut tiny = big_on(&clock, 60);
    tiny.session().present(&untracked("r5")).unwrap();
    let r = tiny.session().handle(&Command::Present(untracked("r8")), 1);
    let msg = r.0["error"].as_str().unwrap_or_default();
    assert!(
        msg.contains("does not fit the device's library memory"),
        "{msg}"
    );
    assert_eq!(
        tiny.session().status().unwrap().stimulus.as_deref(),
        Some("r5")
    );
}
