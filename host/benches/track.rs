//! Tracking one 848 × 480 depth frame: the contact-area centroid on the box's
//! pixel rectangle, against the full-frame f64 reference (budget: 11.1 ms
//! per frame at 90 fps).
//!
//! `cargo bench -p lmhost --bench track`

use criterion::{Criterion, criterion_group, criterion_main};
use lmhost::sense::track::contact::reference;
use lmhost::sense::track::report::bench_frame;

fn track(c: &mut Criterion) {
    let (tracker, frame, sim) = bench_frame();
    let mut g = c.benchmark_group("track 848x480");
    g.bench_function("contact-area centroid (box rectangle)", |b| {
        b.iter(|| tracker.track(std::hint::black_box(&frame)))
    });
    g.sample_size(20);
    g.bench_function("full-frame f64 reference", |b| {
        b.iter(|| {
            reference(
                tracker.intrinsics(),
                tracker.setup(),
                std::hint::black_box(&frame),
            )
        })
    });
    let mut out = Vec::new();
    g.bench_function("render one synthetic frame", |b| {
        b.iter(|| sim.render(180, &tracker, &mut out))
    });
    g.finish();
}

criterion_group!(benches, track);
criterion_main!(benches);
