//! FK and IK per call. Targets (issue 2): FK < 1 us, all IK solutions < 5 us.

use criterion::{Criterion, criterion_group, criterion_main};
use lasercal::testkit;
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    for robot in [testkit::irb120(), testkit::irb2600()] {
        let mut g = testkit::rng(5);
        let qs: Vec<_> = (0..64)
            .map(|_| testkit::random_joints(&robot, &mut g, 0.05))
            .collect();
        let poses: Vec<_> = qs.iter().map(|q| robot.fk(q)).collect();
        let mut i = 0;
        c.bench_function(&format!("fk/{}", robot.name), |b| {
            b.iter(|| {
                i = (i + 1) % qs.len();
                black_box(robot.fk(black_box(&qs[i])))
            })
        });
        c.bench_function(&format!("ik_all/{}", robot.name), |b| {
            b.iter(|| {
                i = (i + 1) % poses.len();
                black_box(robot.ik(black_box(&poses[i]), None))
            })
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
