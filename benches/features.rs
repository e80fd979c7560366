//! Feature extraction per profile (issue 13): a disk chord, a ball arc and an edge point from one
//! noisy ray-cast profile of each scenario.

use criterion::{Criterion, criterion_group, criterion_main};
use lasercal::captures::ProfileData;
use lasercal::features::{self, SplitMerge};
use lasercal::method::Kind;
use lasercal::scenario::ScenarioFile;
use std::hint::black_box;

fn middle_profile(
    scenario: &str,
    kind: Kind,
) -> (lasercal::sensor::Profile, lasercal::scenario::Setup) {
    let path = format!("{}/scenarios/{scenario}", env!("CARGO_MANIFEST_DIR"));
    let sf = ScenarioFile::load(std::path::Path::new(&path)).unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    let caps = lasercal::trial::trial_captures(&setup, kind, 1, 0)
        .0
        .unwrap();
    let p = &caps.profiles[caps.profiles.len() / 2];
    let ProfileData::Raw(prof) = &p.data else {
        panic!("{scenario}: a ray-cast scenario gives raw profiles")
    };
    (prof.clone(), setup)
}

fn bench(c: &mut Criterion) {
    let (disk, s) = middle_profile("chen2018-disk-raycast.toml", Kind::Disk);
    let cfg = SplitMerge::for_sensor(&s.rig.sensor);
    c.bench_function("features/disk_chord_step", |b| {
        b.iter(|| features::disk_chord_step(black_box(&disk), &s.rig.sensor, 0.05, &cfg))
    });
    let (ball, s) = middle_profile("comparison.toml", Kind::Ball);
    let cfg = SplitMerge::for_sensor(&s.rig.sensor);
    c.bench_function("features/ball_arc", |b| {
        b.iter(|| features::ball_arc(black_box(&ball), 0.0695, &cfg))
    });
    let (edge, s) = middle_profile("xu2021-rotations.toml", Kind::Edge);
    let cfg = SplitMerge::for_sensor(&s.rig.sensor);
    c.bench_function("features/edge_point", |b| {
        b.iter(|| {
            features::edge_point(
                black_box(&edge),
                &s.rig.sensor,
                features::EdgeSense::Falling,
                &cfg,
            )
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
