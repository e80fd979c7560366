//! Issue 5: the ball two-step method.

use lasercal::calib::ball::{self, BallCapture, BallProblem};
use lasercal::calib::{CalibError, PoseError};
use lasercal::math::rot_zyx;
use lasercal::papers::chen2018 as paper;
use lasercal::scenario::ScenarioFile;
use lasercal::sim::ball::analytic_problem;
use lasercal::sweep::{self, Shard, SweepPlan};
use lasercal::testkit;
use nalgebra::{Matrix3, Vector3};

fn table3() -> Vec<BallCapture> {
    paper::TABLE3
        .iter()
        .map(|(t, r, q)| BallCapture {
            r_tcp: rot_zyx(r[0], r[1], r[2]),
            t_tcp: Vector3::from(*t) * 1e-3,
            q_in_sensor: Vector3::from(*q) * 1e-3,
        })
        .collect()
}

#[test]
fn chen2018_table3_reproduces_eq53() {
    let caps = table3();
    let sol = ball::solve(&BallProblem {
        orientation_tolerance_deg: lasercal::calib::ORIENTATION_TOLERANCE_DEG,
        rotation_set: caps[..4].to_vec(),
        translation_set: caps[4..].to_vec(),
    })
    .unwrap();
    let r = sol
        .flange_to_sensor
        .rotation
        .to_rotation_matrix()
        .into_inner();
    let frob = (r - Matrix3::from_fn(|i, j| paper::EQ53[i][j])).norm();
    let t_pub = Vector3::new(paper::EQ53[0][3], paper::EQ53[1][3], paper::EQ53[2][3]);
    let dt = (sol.flange_to_sensor.translation.vector * 1e3 - t_pub).norm();
    eprintln!(
        "Table III -> Frobenius {frob:.5}, translation {dt:.3} mm, spread {:.3} mm (paper 0.208)",
        sol.spread * 1e3
    );
    assert!(frob < 0.005, "Frobenius {frob}");
    assert!(dt < 0.6, "translation off by {dt} mm");
    assert!(
        (sol.spread * 1e3 - paper::EQ56_SPREAD_MM).abs() < 0.05,
        "spread {}",
        sol.spread * 1e3
    );
}

#[test]
fn ball_exact_data_recovers_truth() {
    let mut g = testkit::rng(50);
    let mut worst = (0.0f64, 0.0f64);
    for setup in 0..200 {
        let (rig, target) = testkit::random_ball_setup(&mut g, 4, 4);
        let plan =
            testkit::random_ball_plan(&mut g, &rig, &target, 4 + setup % 3, 3 + setup % 4, 1);
        let p = analytic_problem(&rig, &target, &plan, 0.5e-3, 0.0, &mut g).unwrap();
        let sol = ball::solve(&p).unwrap_or_else(|e| panic!("setup {setup}: {e}"));
        let err = PoseError::between(&sol.flange_to_sensor, &rig.flange_to_sensor);
        worst = (
            worst.0.max(err.rotation_error_deg),
            worst.1.max(err.translation_error_mm),
        );
        assert!(
            err.rotation_error_deg <= 1e-9 && err.translation_error_mm <= 1e-9,
            "setup {setup}: {err:?}"
        );
    }
    eprintln!(
        "worst exact-data error: {:.2e} deg, {:.2e} mm",
        worst.0, worst.1
    );
}

#[test]
fn ball_degenerate_inputs_are_typed_errors() {
    let caps = table3();
    // Fewer than 4 rotation-set captures.
    let e = ball::solve(&BallProblem {
        orientation_tolerance_deg: lasercal::calib::ORIENTATION_TOLERANCE_DEG,
        rotation_set: caps[..3].to_vec(),
        translation_set: caps[4..].to_vec(),
    })
    .unwrap_err();
    assert!(
        matches!(
            e,
            CalibError::TooFewData {
                got: 3,
                need: 4,
                ..
            }
        ),
        "{e}"
    );
    // A rotation set whose orientations differ.
    let e = ball::solve(&BallProblem {
        orientation_tolerance_deg: lasercal::calib::ORIENTATION_TOLERANCE_DEG,
        rotation_set: caps[3..7].to_vec(),
        translation_set: caps[4..].to_vec(),
    })
    .unwrap_err();
    assert!(
        matches!(
            e,
            CalibError::Degenerate {
                part: "rotation",
                ..
            }
        ),
        "{e}"
    );
    // Collinear translations in the rotation set.
    let mut col = caps[..4].to_vec();
    for (k, c) in col.iter_mut().enumerate() {
        c.t_tcp = caps[0].t_tcp + Vector3::new(0.01, 0.02, 0.0) * k as f64;
        c.q_in_sensor = caps[0].q_in_sensor
            - caps[0].r_tcp.inverse() * Vector3::new(0.01, 0.02, 0.0) * k as f64;
    }
    let e = ball::solve(&BallProblem {
        orientation_tolerance_deg: lasercal::calib::ORIENTATION_TOLERANCE_DEG,
        rotation_set: col,
        translation_set: caps[4..].to_vec(),
    })
    .unwrap_err();
    assert!(
        matches!(
            e,
            CalibError::Degenerate {
                part: "rotation",
                ..
            }
        ),
        "{e}"
    );
    // A translation set with one orientation only.
    let e = ball::solve(&BallProblem {
        orientation_tolerance_deg: lasercal::calib::ORIENTATION_TOLERANCE_DEG,
        rotation_set: caps[..4].to_vec(),
        translation_set: caps[..4].to_vec(),
    })
    .unwrap_err();
    assert!(
        matches!(
            e,
            CalibError::Degenerate {
                part: "translation",
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn ball_raycast_recovers_truth() {
    // Noise-free ray-cast profiles: every arc point lies exactly on the sphere, so the only error
    // is the circle fit's rounding.
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/chen2018-ball.toml");
    let text = std::fs::read_to_string(path)
        .unwrap()
        .replace("source = \"analytic\"", "source = \"raycast\"")
        .replace(
            "preset = \"gocator-2340\"",
            "preset = \"gocator-2340\"\nquantise = false",
        );
    let sf = ScenarioFile::parse(&text, "ball-raycast.toml").unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    let out = lasercal::trial::run_trial(&setup, "ball".parse().unwrap(), 1, 0);
    let s = out.result.unwrap();
    eprintln!("ray-cast ball: {:?}", s.error());
    assert!(
        s.error().rotation_error_deg < 1e-6 && s.error().translation_error_mm < 1e-6,
        "{:?}",
        s.error()
    );
}

#[test]
fn reduced_fig17_sweep_more_arcs_do_not_help() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/chen2018-ball.toml");
    let text = format!(
        "{}\n[sweep]\ntrials = 150\ndraws = \"common\"\n[sweep.grid]\n\"ball.sigma_mm\" = [0.2, 0.6]\n\"ball.arcs\" = [1, 4, 16]\n",
        std::fs::read_to_string(path).unwrap()
    );
    let sf = ScenarioFile::parse(&text, "fig17.toml").unwrap();
    let plan = SweepPlan::new(&sf, None, None);
    let summary = sweep::run(&plan, &sf.file, Shard::ALL, |_| Ok(()), &|_| {}).unwrap();
    let e: Vec<f64> = summary
        .iter()
        .map(|r| lasercal::io::csv::summary_value(r, "centre_error_mm_std").unwrap())
        .collect();
    eprintln!(
        "e (sigma 0.2: m = 1, 4, 16) = {:?}; (sigma 0.6) = {:?}",
        &e[..3],
        &e[3..]
    );
    for s in 0..2 {
        let (e1, e16) = (e[3 * s], e[3 * s + 2]);
        // With 1/sqrt(m) behaviour 16 arcs would cut e by 4x; the ball method gains far less.
        assert!(e16 > 0.6 * e1, "sigma row {s}: e fell from {e1} to {e16}");
    }
    // And e grows with sigma.
    assert!(e[3] > 2.0 * e[0]);
}
