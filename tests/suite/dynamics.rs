//! Issue 7 (part): the rapier arm.

use lasercal::scenario::ScenarioFile;
use lasercal::sim::dynamics::{ArmDynamics, ServoGains};
use lasercal::testkit;
use lasercal::trial::run_trial;

#[test]
fn the_arm_settles_to_the_commanded_pose_within_servo_tolerance() {
    for robot in [testkit::irb120(), testkit::irb2600()] {
        let mut arm = ArmDynamics::new(&robot, ServoGains::default(), 1e-3).unwrap();
        let q = [0.5, 0.3, -0.2, 0.4, 0.8, 0.2];
        let r = arm.move_to(&q, 0.5, 1.5, 100.0);
        let nominal = robot.fk(&q);
        let last = r.samples.last().unwrap();
        let dev = (last.translation.vector - nominal.translation.vector).norm();
        eprintln!(
            "{}: {:.4} mm off the commanded pose after 1.5 s, peak {:.3} mm",
            robot.name,
            dev * 1e3,
            r.peak_deviation * 1e3
        );
        // Servo tolerance: the gravity sag the finite stiffness allows, a few hundredths of a mm.
        assert!(
            dev < 0.05e-3,
            "{}: {:.4} mm off after settling",
            robot.name,
            dev * 1e3
        );
        assert!(last.rotation.angle_to(&nominal.rotation) < 1e-4);
        // The stop leaves a transient that decays.
        assert!(
            r.peak_deviation > 10.0 * dev,
            "{}: no transient ({} vs {})",
            robot.name,
            r.peak_deviation,
            dev
        );
        let n = r.samples.len();
        let early = (r.samples[1].translation.vector - nominal.translation.vector).norm();
        let late = (r.samples[n - 1].translation.vector - nominal.translation.vector).norm();
        assert!(late < early, "{}: the transient grows", robot.name);
    }
}

#[test]
fn the_dynamic_arm_is_deterministic() {
    let robot = testkit::irb120();
    let run = || {
        let mut arm = ArmDynamics::new(&robot, ServoGains::default(), 1e-3).unwrap();
        arm.move_to(&[0.2, 0.1, 0.1, 0.0, 0.5, 0.0], 0.5, 0.2, 200.0)
    };
    assert_eq!(run(), run());
}

#[test]
fn settle_time_controls_the_transient_error() {
    let base = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/chen2018-disk.toml"
    ))
    .unwrap()
    .replace("sigma_mm = 0.1", "sigma_mm = 0.0");
    let err = |settle: f64| {
        let sf = ScenarioFile::parse(
            &format!("{base}\n[dynamics]\nsettle_ms = {settle}\n"),
            "d.toml",
        )
        .unwrap();
        let setup = sf.scenario.build("d").unwrap();
        run_trial(&setup, "disk".parse().unwrap(), 1, 0)
            .result
            .unwrap()
            .error()
            .translation_error_mm
    };
    let (no_wait, waited) = (err(0.0), err(20.0));
    assert!(
        no_wait > 0.5,
        "without settling the transient should dominate ({no_wait} mm)"
    );
    assert!(
        waited < 0.1 * no_wait,
        "20 ms of settling should cut it ({no_wait} -> {waited} mm)"
    );
    let bad = ScenarioFile::parse(
        &format!("{base}\n[dynamics]\nsettle_ms = -1.0\n"),
        "bad.toml",
    )
    .unwrap_err()
    .to_string();
    assert!(bad.contains("dynamics.settle_ms"), "{bad}");
}
