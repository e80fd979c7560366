//! Issue 7 (part): robot pose error and the cheap vibration model.

use lasercal::rng;
use lasercal::scenario::ScenarioFile;
use lasercal::sim::disturb::{Disturbance, RobotError, Vibration};
use lasercal::testkit::{self, irb120};
use lasercal::trial::run_trial;

fn base() -> String {
    std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/chen2018-disk.toml"
    ))
    .unwrap()
}

#[test]
fn every_cause_off_equals_the_ideal_simulator() {
    let ideal = ScenarioFile::parse(&base(), "a.toml").unwrap();
    let off = format!(
        "{}\n[robot_error]\nrepeatability_mm = 0.0\njoint_noise_deg = 0.0\nlink_error_mm = 0.0\njoint_offset_error_deg = 0.0\n[vibration]\namplitude_mm = 0.0\nband_low_hz = 5.0\nband_high_hz = 20.0\nprofile_rate_hz = 170.0\n",
        base()
    );
    let off = ScenarioFile::parse(&off, "b.toml").unwrap();
    let (a, b) = (
        ideal.scenario.build("a").unwrap(),
        off.scenario.build("b").unwrap(),
    );
    for t in 0..5 {
        assert_eq!(
            run_trial(&a, "disk".parse().unwrap(), 3, t),
            run_trial(&b, "disk".parse().unwrap(), 3, t),
            "trial {t}"
        );
    }
    // And a cause switched on changes the result, the same way for the same seed.
    let on = ScenarioFile::parse(
        &format!("{}\n[robot_error]\nrepeatability_mm = 0.05\n", base()),
        "c.toml",
    )
    .unwrap();
    let c = on.scenario.build("c").unwrap();
    assert_ne!(
        run_trial(&a, "disk".parse().unwrap(), 3, 0),
        run_trial(&c, "disk".parse().unwrap(), 3, 0)
    );
    assert_eq!(
        run_trial(&c, "disk".parse().unwrap(), 3, 0),
        run_trial(&c, "disk".parse().unwrap(), 3, 0)
    );
}

#[test]
fn repeatability_statistics_match_iso_9283_figure() {
    let robot = irb120();
    let rp = 0.01e-3;
    let mut d = Disturbance::new(
        &robot,
        RobotError {
            repeatability: rp,
            ..Default::default()
        },
        Vibration::default(),
        rng::stream(1, &[2]),
    );
    let mut g = testkit::rng(70);
    let mut dev = Vec::new();
    for k in 0..6000 {
        let q = testkit::random_joints(&robot, &mut g, 0.2);
        let nominal = robot.fk(&q);
        let a = d.actual(&robot, &nominal, k);
        dev.extend(
            (a.translation.vector - nominal.translation.vector)
                .iter()
                .copied(),
        );
        assert!(a.rotation.angle_to(&nominal.rotation) < 1e-9);
    }
    let sigma = (dev.iter().map(|x| x * x).sum::<f64>() / dev.len() as f64).sqrt();
    let want = rp / (3.0 * 3f64.sqrt());
    assert!((sigma / want - 1.0).abs() < 0.03, "sigma {sigma} vs {want}");
}

#[test]
fn joint_noise_statistics_match_parameter() {
    let robot = irb120();
    let s = 0.01f64.to_radians();
    let mut d = Disturbance::new(
        &robot,
        RobotError {
            joint_noise: s,
            ..Default::default()
        },
        Vibration::default(),
        rng::stream(1, &[3]),
    );
    let mut g = testkit::rng(71);
    let mut dq = Vec::new();
    // A continuous path, as a scan is: the controller's IK stays on one arm branch.
    let q0 = [0.3, 0.2, -0.1, 0.5, 0.6, 0.1];
    for k in 0..3000 {
        let w = testkit::random_joints(&robot, &mut g, 0.2);
        let q: [f64; 6] = std::array::from_fn(|i| q0[i] + 0.05 * (w[i] * 1.3).sin());
        let a = d.actual(&robot, &robot.fk(&q), k);
        // The nominal model maps the actual pose back to the noisy joints exactly.
        let qa = robot.ik_nearest(&a, &q).unwrap();
        dq.extend(qa.iter().zip(&q).map(|(x, y)| x - y));
    }
    let sigma = (dq.iter().map(|x| x * x).sum::<f64>() / dq.len() as f64).sqrt();
    assert!((sigma / s - 1.0).abs() < 0.03, "sigma {sigma} vs {s}");
}

#[test]
fn kinematic_error_is_systematic() {
    let robot = irb120();
    let err = RobotError {
        link_error: 0.1e-3,
        joint_offset_error: 0.01f64.to_radians(),
        ..Default::default()
    };
    let mut d = Disturbance::new(&robot, err, Vibration::default(), rng::stream(1, &[4]));
    let q = [0.3, 0.2, -0.1, 0.5, 0.6, 0.1];
    let nominal = robot.fk(&q);
    let (a1, a2) = (d.actual(&robot, &nominal, 0), d.actual(&robot, &nominal, 1));
    let off = (a1.translation.vector - nominal.translation.vector).norm();
    assert!(off > 1e-5 && off < 2e-3, "offset {off}");
    assert!(
        (a1.translation.vector - a2.translation.vector).norm() < 1e-15,
        "the same command lands at the same place"
    );
    // Another trial's robot is another draw.
    let mut d2 = Disturbance::new(&robot, err, Vibration::default(), rng::stream(1, &[5]));
    assert!(
        (d2.actual(&robot, &nominal, 0).translation.vector - a1.translation.vector).norm() > 1e-7
    );
}

#[test]
fn vibration_rms_and_band_match_parameters() {
    let robot = irb120();
    let vib = Vibration {
        amplitude_rms: 0.02e-3,
        band_low_hz: 5.0,
        band_high_hz: 20.0,
        profile_rate_hz: 500.0,
    };
    let mut rms = 0.0;
    let trials = 200;
    for t in 0..trials {
        let d = Disturbance::new(&robot, RobotError::default(), vib, rng::stream(7, &[t]));
        let v: Vec<f64> = (0..2000)
            .flat_map(|k| d.vibration_at(k).iter().copied().collect::<Vec<_>>())
            .collect();
        rms += v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64;
        // Band-limited: between samples 1/500 s apart, a 20 Hz signal moves at most 2 pi 20 / 500 of
        // its peak (about 0.25 of it).
        let x: Vec<f64> = (0..2000).map(|k| d.vibration_at(k).x).collect();
        let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let step = x
            .windows(2)
            .map(|w| (w[1] - w[0]).abs())
            .fold(0.0, f64::max);
        assert!(step <= 0.26 * peak * 2.0, "steps {step} vs peak {peak}");
    }
    let rms = (rms / trials as f64).sqrt();
    assert!((rms / 0.02e-3 - 1.0).abs() < 0.05, "rms {rms}");
}

#[test]
fn every_simulation_path_feels_the_robot_error() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/");
    for (file, method) in [
        ("chen2018-disk.toml", "disk"),
        ("chen2018-disk-raycast.toml", "disk"),
        ("chen2018-ball.toml", "ball"),
        ("xu2021-edge.toml", "edge"),
    ] {
        let text = std::fs::read_to_string(format!("{dir}{file}")).unwrap();
        let ideal = ScenarioFile::parse(&text, file)
            .unwrap()
            .scenario
            .build(file)
            .unwrap();
        let shaken = ScenarioFile::parse(&format!("{text}\n[vibration]\namplitude_mm = 0.05\nband_low_hz = 5.0\nband_high_hz = 20.0\nprofile_rate_hz = 170.0\n"), file)
            .unwrap()
            .scenario
            .build(file)
            .unwrap();
        let (a, b) = (
            run_trial(&ideal, method.parse().unwrap(), 1, 0),
            run_trial(&shaken, method.parse().unwrap(), 1, 0),
        );
        let (ea, eb) = (a.result.unwrap().error(), b.result.unwrap().error());
        assert!(ea != eb, "{file}: vibration changed nothing");
    }
}

#[test]
fn radius_tolerance_biases_the_disk_method_in_proportion() {
    let text = base().replace("sigma_mm = 0.1", "sigma_mm = 0.0");
    let mean_err = |tol: f64| {
        let t = text.replace(
            "rpy_deg = [0.0, 0.0, 0.0]",
            &format!("rpy_deg = [0.0, 0.0, 0.0]\nradius_tolerance_mm = {tol}"),
        );
        let setup = ScenarioFile::parse(&t, "r.toml")
            .unwrap()
            .scenario
            .build("r")
            .unwrap();
        (0..30)
            .map(|k| {
                run_trial(&setup, "disk".parse().unwrap(), 5, k)
                    .result
                    .unwrap()
                    .error()
                    .translation_error_mm
            })
            .sum::<f64>()
            / 30.0
    };
    let (e0, e1, e2) = (mean_err(0.0), mean_err(0.02), mean_err(0.2));
    assert!(e0 < 1e-9, "no tolerance: exact ({e0})");
    assert!(e1 > 1e-4, "a 0.02 mm radius tolerance shows ({e1})");
    assert!(
        (e2 / e1 - 10.0).abs() < 1.5,
        "ten times the tolerance, about ten times the error ({e1} -> {e2})"
    );
    // A negative tolerance is refused with the key named.
    let bad = text.replace(
        "rpy_deg = [0.0, 0.0, 0.0]",
        "rpy_deg = [0.0, 0.0, 0.0]\nradius_tolerance_mm = -1.0",
    );
    let e = ScenarioFile::parse(&bad, "bad.toml")
        .unwrap_err()
        .to_string();
    assert!(e.contains("specimen.radius_tolerance_mm"), "{e}");
}

/// The accuracy a simulated rig states for the verdict (`RobotError::point_sd`) against the
/// spread of the flange's position over many drawn robots: close for link-length errors, an
/// upper bound (within 2.5 times) for joint-zero errors, whose lever it takes as half the reach.
#[test]
fn the_stated_robot_accuracy_matches_the_drawn_robots() {
    let robot = irb120();
    let q = [0.3, 0.2, -0.1, 0.5, 0.6, 0.1];
    let nominal = robot.fk(&q);
    let spread = |err: RobotError| {
        let n = 400;
        let mut sum = 0.0;
        for k in 0..n {
            let mut d = Disturbance::new(&robot, err, Vibration::default(), rng::stream(9, &[k]));
            let off = d.actual(&robot, &nominal, 0).translation.vector - nominal.translation.vector;
            sum += off.norm_squared() / 3.0;
        }
        (sum / n as f64).sqrt()
    };
    let links = RobotError {
        link_error: 0.1e-3,
        ..Default::default()
    };
    let (stated, drawn) = (links.point_sd(&robot), spread(links));
    assert!((stated / drawn - 1.0).abs() < 0.15, "{stated} vs {drawn}");
    let zeros = RobotError {
        joint_offset_error: 0.01f64.to_radians(),
        ..Default::default()
    };
    let (stated, drawn) = (zeros.point_sd(&robot), spread(zeros));
    assert!(
        stated >= drawn && stated < 3.0 * drawn,
        "{stated} vs {drawn}"
    );
    assert_eq!(RobotError::default().point_sd(&robot), 0.0);
    // A simulated rig states the arm's one draw as its accuracy and what each pose draws
    // alone (repeatability, encoder noise) as its repeatability; together the same whole.
    let own = RobotError {
        repeatability: 0.03e-3,
        joint_noise: 0.002f64.to_radians(),
        ..Default::default()
    };
    assert_eq!(own.common_sd(&robot), 0.0);
    assert!(own.own_sd(&robot) > 0.03e-3 / (3.0 * 3f64.sqrt()));
    assert_eq!(links.own_sd(&robot), 0.0);
    let both = RobotError {
        link_error: 0.1e-3,
        joint_offset_error: 0.01f64.to_radians(),
        ..own
    };
    let whole = both.common_sd(&robot).hypot(both.own_sd(&robot));
    assert!((both.point_sd(&robot) / whole - 1.0).abs() < 1e-12);
    assert_eq!(
        both.common_sd(&robot),
        links.common_sd(&robot).hypot(zeros.common_sd(&robot))
    );
}

#[test]
fn a_placement_jitter_slides_each_trial_and_keeps_the_result_exact() {
    use lasercal::calib::PoseError;
    use lasercal::method::{Kind, estimate};
    use lasercal::trial::trial_captures;
    // Noise-free analytic chords: the disk slid within +-1 mm per trial must leave the closed
    // form exact (it estimates where the disk stands) while the chords move.
    let exact = base().replace("sigma_mm = 0.1", "sigma_mm = 0.0");
    let build = |text: &str| {
        ScenarioFile::parse(text, "p.toml")
            .unwrap()
            .scenario
            .build("p")
            .unwrap()
    };
    let fixed = build(&exact);
    let slid = build(&format!("{exact}\n[placement]\njitter_mm = 1.0\n"));
    let mut chords = Vec::new();
    for t in 0..3 {
        let a = trial_captures(&fixed, Kind::Disk, 3, t).0.unwrap();
        let b = trial_captures(&slid, Kind::Disk, 3, t).0.unwrap();
        // The file records the same commanded poses; the specimen stands elsewhere.
        for (pa, pb) in a.profiles.iter().zip(&b.profiles) {
            assert_eq!(pa.base_to_flange, pb.base_to_flange);
        }
        assert_ne!(a.profiles[0].data, b.profiles[0].data, "trial {t}");
        let (cal, _) = estimate("disk".parse().unwrap(), &b, &slid.rig.sensor).unwrap();
        let e = PoseError::between(&cal.flange_to_sensor, &slid.rig.flange_to_sensor);
        assert!(
            e.rotation_error_deg < 1e-9 && e.translation_error_mm < 1e-9,
            "trial {t}: {e:?}"
        );
        // The same trial slides alike every time.
        let again = trial_captures(&slid, Kind::Disk, 3, t).0.unwrap();
        assert_eq!(b.profiles[0].data, again.profiles[0].data);
        chords.push(b.profiles[0].data.clone());
    }
    assert!(chords[0] != chords[1] && chords[1] != chords[2]);
    // Out of range: a clear error naming the key.
    for bad in ["-1.0", "50.0"] {
        let err = ScenarioFile::parse(
            &format!("{exact}\n[placement]\njitter_mm = {bad}\n"),
            "bad.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("placement.jitter_mm"), "{err}");
    }
}
