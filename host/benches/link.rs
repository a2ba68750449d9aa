//! Link timing: LM-M upload and centroid round trips over the simulated
//! device's pty (the real serial path), and the cost of each filter.
//!
//! `cargo bench -p lmhost --bench link`

use criterion::{Criterion, criterion_group, criterion_main};
use lm_proto::{Centroid, Encoding, PlayAt};
use lmhost::clock::monotonic_us;
use lmhost::device::link::transport::Serial;
use lmhost::device::link::{Client, UploadSpec};
use lmhost::device::simdev::{SimConfig, SimThread};
use lmhost::plan::sequence::Plan;
use lmhost::sense::stream::filter::FilterKind;
use lmhost::sense::stream::synthetic::FingerTrack;

fn pty(c: &mut Criterion) {
    let sim = SimThread::start(SimConfig::default()).expect("simulated device");
    let mut client = Client::new(Serial::open(&sim.path, 115_200).expect("pty"));
    let plan = Plan::paper_lm_m().expect("LM-M plan");
    let spec = UploadSpec::from_plan(&plan, Encoding::Delta).expect("encoded");
    let mut g = c.benchmark_group("pty");
    g.sample_size(20);
    g.bench_function("upload LM-M (Delta, 82 x 996)", |b| {
        b.iter(|| client.upload(&spec, 0, 1024, |_, _| {}).expect("upload"))
    });
    client.play(0, PlayAt::Immediate, false).expect("play");
    let mut seq = client.status().expect("status").last_centroid_seq;
    g.sample_size(100);
    g.bench_function("centroid update round trip", |b| {
        b.iter(|| {
            seq += 1;
            let c = Centroid {
                seq,
                pos_um: [0, 0, 200_000],
                present: true,
                host_time_us: monotonic_us(),
            };
            client.centroid(c).expect("centroid")
        })
    });
    g.finish();
}

fn filters(c: &mut Criterion) {
    let samples: Vec<_> = FingerTrack::default().samples().take(900).collect();
    let mut g = c.benchmark_group("filter 900 updates");
    for kind in FilterKind::ALL {
        g.bench_function(kind.name(), |b| {
            b.iter(|| {
                let mut f = kind.build();
                samples.iter().filter_map(|s| f.update(s)).count()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, pty, filters);
criterion_main!(benches);
