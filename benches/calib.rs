//! Calibration cost. Issue 4: one disk calibration (n = 4, m = 100, ellipse fits included) within
//! 50 us. Issue 5: an edge calibration with 25 x 10 captures and a ball calibration with 8.

use criterion::{Criterion, criterion_group, criterion_main};
use lasercal::calib::ball::{self, BallProblem};
use lasercal::calib::disk::{DiskProblem, DiskScan, solve};
use lasercal::calib::edge;
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

    let (rig, target, plans) = testkit::random_edge_setup(&mut g, 25, 10);
    let ep = lasercal::sim::edge::analytic_problem(&rig, &target, &plans, 0.05e-3, &mut g).unwrap();
    c.bench_function("edge/solve_25x10", |b| {
        b.iter(|| black_box(edge::solve(black_box(&ep))))
    });

    let (rig, ball_t) = testkit::random_ball_setup(&mut g, 4, 4);
    let plan = testkit::random_ball_plan(&mut g, &rig, &ball_t, 4, 4, 1);
    let bp: BallProblem =
        lasercal::sim::ball::analytic_problem(&rig, &ball_t, &plan, 0.1e-3, 0.1e-3, &mut g)
            .unwrap();
    c.bench_function("ball/solve_8_captures", |b| {
        b.iter(|| black_box(ball::solve(black_box(&bp))))
    });

    let dir = env!("CARGO_MANIFEST_DIR");
    // Issue 8: the joint refinement against the closed form on the same captures (the disk
    // paper's n = 4, m = 100 and the edge paper's 25 x 10, sigma 0.1 and 0.05 mm).
    for (scen, method) in [("chen2018-disk.toml", "disk"), ("xu2021-edge.toml", "edge")] {
        let sf =
            ScenarioFile::load(std::path::Path::new(&format!("{dir}/scenarios/{scen}"))).unwrap();
        let setup = sf.scenario.build(&sf.file).unwrap();
        let caps = lasercal::trial::trial_captures(&setup, method.parse().unwrap(), 1, 0)
            .0
            .unwrap();
        let sensor = &setup.rig.sensor;
        let cal = lasercal::method::calibrate(&caps, sensor).unwrap();
        c.bench_function(&format!("refine/{method}_closed_form"), |b| {
            b.iter(|| black_box(lasercal::method::calibrate(black_box(&caps), sensor)))
        });
        // Issue 27: the verdict's figures of the closed form's result (its rows at the result).
        c.bench_function(&format!("verdict/{method}_closed_form"), |b| {
            b.iter(|| {
                black_box(lasercal::method::verdict::quality(
                    black_box(&cal),
                    None,
                    lasercal::method::Estimator::ClosedForm,
                    &caps,
                    sensor,
                ))
            })
        });
        let opts = lasercal::calib::refine::Options::default();
        let kind = caps.method;
        c.bench_function(&format!("refine/{method}_refinement"), |b| {
            b.iter(|| black_box(black_box(&cal).refine(kind, &opts)))
        });
    }

    // Issue 14: the full-profile refinements from the closed form on the comparison rig's
    // ray-cast captures (the disk: 4 scans x 100 profiles, up to 512 face points each and the
    // wall; the bar: 25 x 10 profiles).
    let sf = ScenarioFile::load(std::path::Path::new(&format!(
        "{dir}/scenarios/comparison.toml"
    )))
    .unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    for method in ["disk-refined", "disk-full", "edge-refined", "edge-full"] {
        let id: lasercal::method::MethodId = method.parse().unwrap();
        let caps = lasercal::trial::trial_captures(&setup, id.kind, 1, 0)
            .0
            .unwrap();
        let sensor = &setup.rig.sensor;
        c.bench_function(&format!("full_profile/{method}_comparison"), |b| {
            b.iter(|| black_box(lasercal::method::estimate(id, black_box(&caps), sensor)))
        });
    }

    for (scen, method) in [
        ("chen2018-disk.toml", "disk"),
        ("chen2018-ball.toml", "ball"),
        ("xu2021-edge.toml", "edge"),
    ] {
        let sf =
            ScenarioFile::load(std::path::Path::new(&format!("{dir}/scenarios/{scen}"))).unwrap();
        let setup = sf.scenario.build(&sf.file).unwrap();
        let id: lasercal::method::MethodId = method.parse().unwrap();
        let mut t = 0u64;
        c.bench_function(&format!("trial/{method}_{}", sf.scenario.name), |b| {
            b.iter(|| {
                t += 1;
                black_box(lasercal::trial::run_trial(&setup, id, 1, t))
            })
        });
    }
}

/// Issue 14's timing case: the ball from 15 free poses of 1,500 arc points each (z noise 0.05 mm),
/// global start + linear solve + joint refinement over all 22,500 points.
fn any_pose(c: &mut Criterion) {
    use lasercal::calib::ball_any::{ArcView, solve};
    use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector2, Vector3};
    let mut g = testkit::rng(14);
    let mut u = |lo: f64, hi: f64| lo + (hi - lo) * rand::RngExt::random::<f64>(&mut g);
    let radius = 0.0254;
    let x = Isometry3::from_parts(
        Translation3::new(0.02, -0.05, 0.3),
        UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1),
    );
    let centre = Point3::new(0.6, 0.1, 0.1);
    let views: Vec<ArcView> = (0..15)
        .map(|_| {
            let rot = UnitQuaternion::from_euler_angles(u(-0.6, 0.6), u(-0.6, 0.6), u(-3.1, 3.1));
            let s = Vector3::new(u(-0.02, 0.02), u(-0.7, 0.7) * radius, u(-0.03, 0.03));
            let sensor = Isometry3::from_parts(Translation3::from(centre.coords - rot * s), rot);
            let r = (radius * radius - s.y * s.y).sqrt();
            let points = (0..1500)
                .map(|k| {
                    let a = -1.0 + 2.0 * k as f64 / 1499.0;
                    Vector2::new(
                        s.x + r * a.sin(),
                        s.z + r * a.cos() + u(-0.087e-3, 0.087e-3),
                    )
                })
                .collect();
            ArcView {
                base_to_flange: sensor * x.inverse(),
                circle_centre: Vector2::new(s.x, s.z),
                circle_radius: r,
                points,
            }
        })
        .collect();
    c.bench_function("any_pose/ball_15_poses_1500_points", |b| {
        b.iter(|| black_box(solve(black_box(&views), radius)))
    });

    // The plane from 48 free poses of the Gocator 2340 (1,280 columns) on the table: line
    // extraction, the normal search, the linear start and the joint refinement.
    let dir = env!("CARGO_MANIFEST_DIR");
    let text = std::fs::read_to_string(format!("{dir}/scenarios/plane.toml"))
        .unwrap()
        .replace("count = 24 ", "count = 48 ");
    let sf = ScenarioFile::parse(&text, "plane.toml").unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    let caps = lasercal::trial::trial_captures(&setup, lasercal::method::Kind::Plane, 1, 0)
        .0
        .unwrap();
    assert_eq!(caps.profiles.len(), 48);
    let id: lasercal::method::MethodId = "plane-any-pose".parse().unwrap();
    c.bench_function("any_pose/plane_48_poses_1280_columns", |b| {
        b.iter(|| {
            black_box(lasercal::method::estimate(
                id,
                black_box(&caps),
                &setup.rig.sensor,
            ))
        })
    });

    // A plate's face and edges from 30 free poses (edge-8-poses.toml with 30): face and edge
    // extraction, the plane's start, the edge clustering and the joint refinement.
    let text = std::fs::read_to_string(format!("{dir}/scenarios/edge-8-poses.toml"))
        .unwrap()
        .replace("count = 8 ", "count = 30 ");
    let sf = ScenarioFile::parse(&text, "edge-8-poses.toml").unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    let caps = lasercal::trial::trial_captures(&setup, lasercal::method::Kind::Edge, 1, 0)
        .0
        .unwrap();
    assert_eq!(caps.profiles.len(), 30);
    let id: lasercal::method::MethodId = "edge-any-pose".parse().unwrap();
    c.bench_function("any_pose/edge_30_poses_1280_columns", |b| {
        b.iter(|| {
            black_box(lasercal::method::estimate(
                id,
                black_box(&caps),
                &setup.rig.sensor,
            ))
        })
    });
}

/// Scanning on the move (the ray-cast disk paper rig at 100 mm/s, the stamps 10 ms late, or on
/// time): each estimator with the clock offset held as stated and estimated with the transform.
fn on_the_move(c: &mut Criterion) {
    for late_ms in [10.0, 0.0] {
        on_the_move_at(c, late_ms);
    }
}

fn on_the_move_at(c: &mut Criterion, late_ms: f64) {
    let dir = env!("CARGO_MANIFEST_DIR");
    let text = std::fs::read_to_string(format!("{dir}/scenarios/chen2018-disk-raycast.toml"))
        .unwrap()
        .replace(
            "[disk]\n",
            &format!("[disk]\nscan_speed_mm_s = 100.0\nclock_offset_ms = {late_ms}\n"),
        );
    let sf = ScenarioFile::parse(&text, "moving.toml").unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    let estimated = lasercal::trial::trial_captures(&setup, lasercal::method::Kind::Disk, 1, 0)
        .0
        .unwrap();
    let mut held = estimated.clone();
    held.timing.as_mut().unwrap().estimate_offset = false;
    let mut g = c.benchmark_group("on_the_move");
    g.sample_size(10);
    for m in ["disk-refined", "disk-full", "disk-any-pose"] {
        let id: lasercal::method::MethodId = m.parse().unwrap();
        for (what, caps) in [("held", &held), ("estimated", &estimated)] {
            g.bench_function(format!("{m}/{late_ms}ms/{what}"), |b| {
                b.iter(|| {
                    black_box(lasercal::method::estimate(
                        id,
                        black_box(caps),
                        &setup.rig.sensor,
                    ))
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench, any_pose, on_the_move);
criterion_main!(benches);
