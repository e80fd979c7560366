//! Arm dynamics: one move and 0.5 s of settling (dt 1 ms) per arm; robot seconds per wall second =
//! simulated time / measured time.

use criterion::{Criterion, criterion_group, criterion_main};
use lasercal::sim::dynamics::{ArmDynamics, ServoGains};
use lasercal::testkit;
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    for robot in [testkit::irb120(), testkit::irb2600()] {
        let mut arm = ArmDynamics::new(&robot, ServoGains::default(), 1e-3).unwrap();
        let poses = [
            [0.5, 0.3, -0.2, 0.4, 0.8, 0.2],
            [0.45, 0.32, -0.22, 0.42, 0.78, 0.22],
        ];
        let mut k = 0;
        let simulated = arm.move_to(&poses[1], 0.5, 0.5, 100.0).simulated;
        c.bench_function(&format!("dynamics/move_settle_0.5s/{}", robot.name), |b| {
            b.iter(|| {
                k = (k + 1) % 2;
                black_box(arm.move_to(&poses[k], 0.5, 0.5, 100.0))
            })
        });
        eprintln!(
            "({} simulates about {simulated:.2} s per iteration)",
            robot.name
        );
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
