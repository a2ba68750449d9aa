//! AUTD3 backend timing on autd3's firmware emulator (in-process, real
//! clock): LM-M uploads at A = 3 and 6 mm into the idle segment, one
//! centroid update (lm-fw-core offsets → PhaseCorrection → applied in the
//! emulated FPGA, acknowledged), and a start from silence (stop, then play
//! the other segment untracked). The frame count per upload and per start
//! is printed for the EtherCAT estimate in BENCHMARKS.md.
//!
//! `cargo bench -p lmhost --bench autd3`

use criterion::{Criterion, criterion_group, criterion_main};
use lm_proto::Centroid;
use lmhost::clock::Clock;
use lmhost::device::autd3::Autd3Backend;
use lmhost::device::backend::Backend;
use lmhost::plan::grid as timing;
use lmhost::plan::scene::Scene;
use lmhost::plan::sequence::Synthesis;
use lmhost::plan::trajectory::LmParams;

fn emulator(c: &mut Criterion) {
    let scene = Scene::default();
    let (mut b, h) = Autd3Backend::open_emulator(&scene, Clock::real(), None).expect("emulator");
    let mut g = c.benchmark_group("autd3 emulator");
    g.sample_size(20);
    for a in [3.0, 6.0] {
        let mut p = LmParams::paper(scene.center_mm);
        p.cycle.radius_mm = a;
        p.cycle.foci = 4;
        let (plan, t) = timing::plan(&p, &scene, &Synthesis::Linear).expect("plan");
        let r = b.upload(&plan, Some(0)).expect("upload");
        eprintln!(
            "LM-M A = {a} mm: N = {}, dwell {} us, {:.3} Hz, {:?} frames, read-back mismatches {:?}",
            t.steps,
            t.dwell_us,
            t.freq_hz,
            r.frames(),
            r.readback_mismatches()
        );
        g.bench_function(
            format!("upload LM-M A = {a} mm ({} x 996)", t.steps),
            |bch| bch.iter(|| b.upload(&plan, Some(0)).expect("upload")),
        );
    }
    let mut p = LmParams::paper(scene.center_mm);
    p.cycle.foci = 4;
    let (plan, _) = timing::plan(&p, &scene, &Synthesis::Linear).expect("plan");
    b.upload(&plan, Some(1)).expect("upload");
    b.play(1, false).expect("play");
    let c0 = plan.sequence.header.center_um;
    let mut seq = 0u32;
    g.sample_size(100);
    g.bench_function(
        "centroid update (offsets + PhaseCorrection, acked)",
        |bch| {
            bch.iter(|| {
                seq += 1;
                let d = (seq % 2000) as i32;
                b.centroid(&Centroid {
                    host_time_us: 0,
                    seq,
                    present: true,
                    pos_um: [c0[0] + d, c0[1] - d, c0[2]],
                })
                .expect("centroid")
            })
        },
    );
    // A start from silence in the other segment: what an onset costs.
    b.stop().expect("stop");
    let f0 = h.frames();
    b.play(0, true).expect("play");
    b.stop().expect("stop");
    let f1 = h.frames();
    b.play(1, true).expect("play");
    eprintln!(
        "start from silence: {} frames (segment and correction, output and lease); stop: {} frame",
        h.frames() - f1,
        f1 - f0 - (h.frames() - f1)
    );
    let mut slot = 0;
    g.bench_function("stop + play from silence in the other segment", |bch| {
        bch.iter(|| {
            slot ^= 1;
            b.stop().expect("stop");
            b.play(slot, true).expect("play")
        })
    });
    g.finish();
}

criterion_group!(benches, emulator);
criterion_main!(benches);
