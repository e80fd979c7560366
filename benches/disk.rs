//! One disk calibration (n = 4, m = 100, including the ellipse fits; target <= 50 us) and one
//! analytic trial of the Fig. 15 sweep.

use criterion::{Criterion, criterion_group, criterion_main};
use lasercal::calib::disk::{DiskProblem, DiskScan, solve};
use lasercal::scenario::ScenarioFile;
use lasercal::sim::disk::analytic_scan;
use lasercal::testkit;
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let mut g = testkit::rng(9);
    let (rig, target, plans) = testkit::random_disk_setup(&mut g, 4, 100);
    let scans: Vec<DiskScan> = plans
        .iter()
        .map(|p| analytic_scan(&rig, &target, p, 1e-4, &mut g))
        .collect();
    let problem = DiskProblem::new(target.radius, scans);
    c.bench_function("disk/solve_n4_m100", |b| {
        b.iter(|| black_box(solve(black_box(&problem))))
    });

    let sf = ScenarioFile::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/chen2018-disk.toml"
    )))
    .unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    let mut t = 0u64;
    c.bench_function("disk/trial_chen2018_m100", |b| {
        b.iter(|| {
            t += 1;
            black_box(lasercal::trial::run_trial(&setup, "disk", 1, t))
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
