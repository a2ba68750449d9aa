//! A streamed finger through the plausibility gate as the driver (so
//! `lmhost session` and `lmhost study run`) reads it: live arrivals on
//! the session's manual clock, the filter fed only what the gate passes.

use std::collections::VecDeque;
use std::sync::Arc;

use super::*;
use crate::sense::stream::Sample;
use crate::sense::stream::intake::{Intake, SharedCounts, Timing};
use crate::sense::stream::run::{Feed, Next};

/// A tracker sending `samples` one every 11 ms of `clock` from its start.
struct Tracker {
    clock: Clock,
    t0_us: u64,
    samples: VecDeque<Sample>,
    sent: u64,
}

impl Feed for Tracker {
    fn next_within(&mut self, _wait: Duration) -> Next<anyhow::Result<Sample>> {
        if self.samples.is_empty() {
            return Next::End;
        }
        if self.clock.now_us() < self.t0_us + self.sent * 11_111 {
            return Next::Idle;
        }
        self.sent += 1;
        Next::Ready(Ok(self.samples.pop_front().unwrap()))
    }
}

#[test]
fn a_wild_stamp_and_a_far_centroid_never_reach_the_session() {
    let clock = Clock::manual_at_us(1_000_000);
    // A finger resting at the centre, moving 0.01 mm a sample; sample 3
    // is stamped years ahead, sample 6 lies metres away, sample 9 is
    // stamped a minute back.
    let mut samples: VecDeque<Sample> = (0..90)
        .map(|i| Sample::at(100.0 + f64::from(i) / 90.0, f64::from(i) * 0.01))
        .collect();
    samples[3].t_s = 1e9;
    samples[6].pos_mm[0] = 5000.0;
    samples[9].t_s = 40.0;
    let last = *samples.back().unwrap();
    let counts = Arc::new(SharedCounts::default());
    let feed = Tracker {
        clock: clock.clone(),
        t0_us: clock.now_us(),
        samples,
        sent: 0,
    };
    let intake = Intake::new(Timing::Live, counts.clone());
    let mut d = driver(
        LIB,
        &Target::Lm,
        lm(&clock),
        &clock,
        Finger::Samples(Box::new(feed), intake),
    );
    d.session().drain_events();
    d.session()
        .present(&present("a", Some(Gate::Tracked), None, None, None))
        .unwrap();
    let mut sent = Vec::new();
    let mut events = Vec::new();
    let end = clock.now_us() + 3_000_000;
    while !d.feed_ended() && clock.now_us() < end {
        events.extend(d.turn().unwrap());
        sent.extend(d.take_finger());
        clock.advance(
            d.wait_time(Duration::from_secs(1))
                .max(Duration::from_micros(50)),
        );
    }
    assert!(d.feed_ended(), "the tracker's samples were not all read");
    // Every centroid the session got is the finger's; the last is the
    // last sample (the good ones after the wild ones were all taken).
    assert!(!sent.is_empty());
    for p in &sent {
        let p = p.expect("the finger stays present");
        assert!(p[0].abs() < 1.0, "{p:?}");
    }
    assert_eq!(sent.last().copied().flatten(), Some(last.pos_mm));
    // Present from the first sample on, never steered out of range.
    assert!(
        !has(&events, |k| matches!(k, EventKind::Mute { .. })),
        "{events:?}"
    );
    assert_eq!(counts.read(), 90);
    let dropped = counts.dropped();
    // Out of order (back), a time jump (ahead), out of range, jumps.
    assert_eq!(
        (
            dropped.out_of_order,
            dropped.time_jumps,
            dropped.out_of_range,
            dropped.jumps
        ),
        (1, 1, 1, 0)
    );
    // The `closed` event carries the same counts, by the end line's
    // classes.
    let last = d.close(OffsetReason::Quit);
    let closed = serde_json::to_value(last.last().unwrap()).unwrap();
    assert_eq!(closed["event"], "closed", "{closed}");
    assert_eq!(
        closed["finger"],
        serde_json::json!({
            "samples": 90, "dropped": 3, "out_of_order": 1, "time_jumps": 1,
            "out_of_range": 1, "jumps": 0
        }),
        "{closed}"
    );
}
