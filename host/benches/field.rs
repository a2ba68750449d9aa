//! Field simulation speed: the batched f32 fast path on the target
//! size (101 × 101 points × 996 transducers × 82 steps) and the plain f64
//! loop on a smaller grid (it scales linearly with points).
//!
//! Run: `cargo bench -p lmhost --bench field`.

use std::f64::consts::PI;

use criterion::{Criterion, criterion_group, criterion_main};
use lmhost::field::{
    Directivity, FieldModel, Medium, ObservationPlane, Radiation, simulate, simulate_reference,
};
use lmhost::plan::array::{Transducer, autd3_local_center_mm, autd3_local_positions_mm};

/// Four AUTD3 in a flat 2 × 2 array centred on the origin, facing +z.
fn four_autd3() -> Vec<Transducer> {
    let c = autd3_local_center_mm();
    let (w, h) = (192.0, 151.4);
    let mut out = Vec::new();
    for (ox, oy) in [
        (-w / 2.0, -h / 2.0),
        (w / 2.0, -h / 2.0),
        (-w / 2.0, h / 2.0),
        (w / 2.0, h / 2.0),
    ] {
        out.extend(autd3_local_positions_mm().map(|p| Transducer {
            pos_mm: [p[0] - c[0] + ox, p[1] - c[1] + oy, 0.0],
            normal: [0.0, 0.0, 1.0],
        }));
    }
    out
}

/// LM-M-like sequence: 4 foci 3 mm apart on a 3 mm circle, 82 steps.
fn lm_m(tr: &[Transducer], k: f64, center: [f64; 3], steps: usize) -> Vec<u8> {
    let mut ph = Vec::with_capacity(steps * tr.len());
    for s in 0..steps {
        for t in tr {
            let (mut re, mut im) = (0.0, 0.0);
            for f in 0..4 {
                let a = 2.0 * PI * (s + 13 * f) as f64 / steps as f64;
                let p = [
                    center[0] + 3.0 * a.cos(),
                    center[1] + 3.0 * a.sin(),
                    center[2],
                ];
                let d = [p[0] - t.pos_mm[0], p[1] - t.pos_mm[1], p[2] - t.pos_mm[2]];
                let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                re += (-k * r).cos();
                im += (-k * r).sin();
            }
            ph.push(
                (im.atan2(re) / (2.0 * PI) * 256.0)
                    .round()
                    .rem_euclid(256.0) as u8,
            );
        }
    }
    ph
}

fn bench(c: &mut Criterion) {
    let tr = four_autd3();
    let model = FieldModel::new(&tr, Directivity::T4010A1, Medium::default(), None).unwrap();
    let center = [0.0, 0.0, 220.0];
    let ph = lm_m(&tr, model.wavenumber_rad_per_mm(), center, 82);
    let plane = ObservationPlane::lm_default(center, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
    let small = ObservationPlane {
        width_mm: 2.0,
        height_mm: 2.0,
        ..plane
    };
    let rad = Radiation::default();
    let mut g = c.benchmark_group("field");
    g.sample_size(10);
    g.bench_function("fast 101x101 pts x 996 tr x 82 steps", |b| {
        b.iter(|| simulate(&model, &plane, &ph, 82, rad).unwrap())
    });
    g.bench_function("f64 reference 11x11 pts x 996 tr x 82 steps", |b| {
        b.iter(|| simulate_reference(&model, &small, &ph, 82, rad).unwrap())
    });
    g.bench_function("fast 11x11 pts x 996 tr x 82 steps", |b| {
        b.iter(|| simulate(&model, &small, &ph, 82, rad).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
