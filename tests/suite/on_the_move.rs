//! Scanning on the move with the profiler's clock off the controller's (`[disk]
//! scan_speed_mm_s`, `clock_offset_ms`): every profile's recorded pose leads the one it was
//! taken at by speed x offset along its scan, a bias no amount of data averages away.

use lasercal::method::{Kind, MethodId};
use lasercal::scenario::ScenarioFile;
use lasercal::trial::trial_captures;
use nalgebra::Vector3;

/// The scenario `name` (in scenarios/) with `edit` applied to its text, built.
fn scenario_with(name: &str, edit: impl Fn(String) -> String) -> lasercal::scenario::Setup {
    let path = format!("{}/scenarios/{name}.toml", env!("CARGO_MANIFEST_DIR"));
    let text = edit(std::fs::read_to_string(path).unwrap());
    ScenarioFile::parse(&text, "moving.toml")
        .unwrap()
        .scenario
        .build("moving.toml")
        .unwrap()
}

/// chen2018-disk without noise, its scans moving at `speed` mm/s with the clock `offset` ms late.
fn moving(speed: f64, offset: f64) -> lasercal::scenario::Setup {
    scenario_with("chen2018-disk", |text| {
        let text = text.replace("sigma_mm = 0.1", "sigma_mm = 0.0").replace(
            "[disk]\n",
            &format!("[disk]\nscan_speed_mm_s = {speed}\nclock_offset_ms = {offset}\n"),
        );
        assert!(
            text.contains("clock_offset_ms"),
            "the scenario's [disk] moved"
        );
        text
    })
}

/// The closed form's translation error (flange frame, m) from the scenario's first trial.
fn translation_error(setup: &lasercal::scenario::Setup) -> Vector3<f64> {
    let caps = trial_captures(setup, Kind::Disk, 1, 0).0.unwrap();
    let id: MethodId = "disk".parse().unwrap();
    let (cal, _) = lasercal::method::estimate(id, &caps, &setup.rig.sensor).unwrap();
    cal.flange_to_sensor.translation.vector - setup.rig.flange_to_sensor.translation.vector
}

/// The closed form's error (rotation deg, translation error vector in m) on the scenario's first
/// trial.
fn errors(setup: &lasercal::scenario::Setup) -> (f64, Vector3<f64>) {
    let caps = trial_captures(setup, Kind::Disk, 1, 0).0.unwrap();
    let id: MethodId = "disk".parse().unwrap();
    let (cal, _) = lasercal::method::estimate(id, &caps, &setup.rig.sensor).unwrap();
    let e = lasercal::calib::PoseError::between(&cal.flange_to_sensor, &setup.rig.flange_to_sensor);
    (e.rotation_error_deg, translation_error(setup))
}

/// The bias is the lead's alone (speed x offset, whatever the split), linear in it and in the
/// translation only: each scan is shifted along itself, which moves the disk's centre as seen
/// from it but not the chords' directions. On the paper's protocol the closed form's translation
/// moves 0.415 mm per mm of lead (measured here; docs/guide/causes.md).
#[test]
fn a_clock_offset_while_scanning_biases_the_translation_by_speed_times_offset() {
    let (rot, still) = errors(&moving(0.0, 10.0));
    assert!(
        still.norm() < 1e-12 && rot < 1e-9,
        "stop and go: no bias ({still:?})"
    );
    // One millimetre of lead.
    let (rot, per_mm) = errors(&moving(100.0, 10.0));
    assert!(rot < 1e-9, "the rotation is untouched: {rot} deg");
    assert!(
        per_mm.norm() > 0.3e-3 && per_mm.norm() < 1e-3,
        "a bias of the lead's order: {per_mm:?}"
    );
    for (speed, offset) in [
        (50.0, 20.0),
        (200.0, 5.0),
        (100.0, -8.0),
        (150.0, 2.0),
        (400.0, 12.5),
    ] {
        let lead_mm = speed * offset * 1e-3;
        let (rot, got) = errors(&moving(speed, offset));
        let want = per_mm * lead_mm;
        eprintln!(
            "{speed} mm/s, {offset} ms: lead {lead_mm:.3} mm, bias {:.4} mm",
            got.norm() * 1e3
        );
        assert!(rot < 1e-9, "{speed} mm/s, {offset} ms: rotation {rot} deg");
        assert!(
            (got - want).norm() <= 1e-6 * want.norm() + 1e-12,
            "{speed} mm/s, {offset} ms: {got:?}, want {want:?}"
        );
    }
}

#[test]
fn bad_motion_keys_are_refused() {
    let path = format!(
        "{}/scenarios/chen2018-disk.toml",
        env!("CARGO_MANIFEST_DIR")
    );
    let base = std::fs::read_to_string(path).unwrap();
    for (keys, want) in [
        ("scan_speed_mm_s = -5.0", "disk.scan_speed_mm_s"),
        ("clock_offset_ms = 5000.0", "disk.clock_offset_ms"),
        ("clock_drift_ppm = 20000.0", "disk.clock_drift_ppm"),
        ("clock_jitter_ms = -1.0", "disk.clock_jitter_ms"),
        ("exposure_ms = -2.0", "disk.exposure_ms"),
        ("estimate_clock_drift = true", "disk.estimate_clock_drift"),
    ] {
        let text = base.replace("[disk]\n", &format!("[disk]\n{keys}\n"));
        let e = ScenarioFile::parse(&text, "bad.toml")
            .and_then(|f| f.scenario.build("bad.toml").map(|_| ()))
            .err()
            .expect("refused")
            .to_string();
        assert!(e.contains(want) && e.contains("bad.toml"), "{e}");
    }
}

/// A simulated moving scan's capture file carries the controller's pose log and each profile's
/// stamp, as a real cell's would: read back, the poses are the simulation's own; stating the
/// clock's offset in the file (`profile_clock_offset_s`) removes the bias.
#[test]
fn the_simulated_file_logs_poses_and_stamps_and_the_stated_offset_removes_the_bias() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = dir.path().join("moving.toml");
    let path = format!(
        "{}/scenarios/disk-on-the-move.toml",
        env!("CARGO_MANIFEST_DIR")
    );
    let text = std::fs::read_to_string(path)
        .unwrap()
        .replace("sigma_mm = 0.05", "sigma_mm = 0.0")
        .replace("clock_offset_ms = 0.0", "clock_offset_ms = 10.0");
    std::fs::write(&scenario, text).unwrap();
    let file = dir.path().join("moving.json");
    let (code, _, err) = crate::common::lasercal(&[
        "simulate",
        scenario.to_str().unwrap(),
        "--out",
        file.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let stream = doc["pose_stream"].as_array().expect("a pose log").len();
    assert!(stream > 400, "{stream} logged poses");
    assert!(doc["profiles"][0]["t_s"].is_number());
    assert!(doc["profiles"][0].get("tcp_position_mm").is_none());
    let error_mm = |f: &std::path::Path| {
        let (code, out, err) =
            crate::common::lasercal(&["calibrate", f.to_str().unwrap(), "--method", "disk"]);
        assert!(code == 0 || code == 3 || code == 4, "{out}{err}");
        let line = out
            .lines()
            .find(|l| l.contains("against the file's truth"))
            .unwrap_or_else(|| panic!("{out}"));
        line.rsplit("translation error ")
            .next()
            .unwrap()
            .trim_end_matches(" mm")
            .parse::<f64>()
            .unwrap()
    };
    // 100 mm/s and 10 ms: 1 mm of lead, 0.415 mm of bias.
    let biased = error_mm(&file);
    assert!((biased - 0.415).abs() < 0.01, "{biased} mm");
    // The profiler's stamps are 10 ms late: 10 ms taken off each puts it on the log's clock.
    doc["profile_clock_offset_s"] = serde_json::json!(-0.010);
    let fixed = dir.path().join("fixed.json");
    std::fs::write(&fixed, serde_json::to_string(&doc).unwrap()).unwrap();
    let unbiased = error_mm(&fixed);
    assert!(unbiased < 1e-5, "{unbiased} mm");
}

/// The offset estimated with the transform (`calib::refine::timed`): on the paper's four scans
/// without noise, `disk-refined` recovers the stamps' lateness and the transform exactly, for
/// every speed and offset; with the offset held (`estimate_clock_offset = false`) the bias
/// stands.
#[test]
fn disk_refined_estimates_the_offset_exactly_without_noise() {
    let id: MethodId = "disk-refined".parse().unwrap();
    for (speed, offset) in [(100.0, 10.0), (50.0, 20.0), (200.0, -5.0), (150.0, 0.0)] {
        let setup = moving(speed, offset);
        let mut caps = trial_captures(&setup, Kind::Disk, 1, 0).0.unwrap();
        let (cal, r) = lasercal::method::estimate(id, &caps, &setup.rig.sensor).unwrap();
        let clock = r.unwrap().clock.expect("a clock figure");
        let e =
            lasercal::calib::PoseError::between(&cal.flange_to_sensor, &setup.rig.flange_to_sensor);
        // The stamps are `offset` late: the estimate takes it off.
        let off = (clock.shift_s + offset * 1e-3).abs();
        assert!(
            off < 1e-6 && e.rotation_error_deg < 1e-9 && e.translation_error_mm < 1e-9,
            "{speed} mm/s, {offset} ms: offset off by {off} s, {e:?}"
        );
        caps.timing.as_mut().unwrap().estimate_offset = false;
        let (held, r) = lasercal::method::estimate(id, &caps, &setup.rig.sensor).unwrap();
        let bias = lasercal::calib::PoseError::between(
            &held.flange_to_sensor,
            &setup.rig.flange_to_sensor,
        );
        let lead_mm = (speed * offset * 1e-3).abs();
        assert!(
            lead_mm == 0.0 || bias.translation_error_mm > 0.2 * lead_mm,
            "{speed} mm/s, {offset} ms held: {bias:?}"
        );
        // Held, the clock figure predicts the bias from the data (per second of offset error):
        // within 10 % of the one the held fit shows.
        let c = r.unwrap().clock.expect("a held clock figure");
        assert!(c.sd_s.is_infinite());
        let b = c.bias_per_s.expect("a predicted bias");
        let predicted_mm = Vector3::new(b[3], b[4], b[5]).norm() * offset.abs();
        assert!(
            (predicted_mm - bias.translation_error_mm).abs()
                <= 0.1 * bias.translation_error_mm + 1e-9,
            "{speed} mm/s, {offset} ms: predicted {predicted_mm} mm, held fit {bias:?}"
        );
    }
}

/// The paper's four scans at z noise 0.05 mm, moving at `speed` mm/s with the stamps `offset` ms
/// late.
fn noisy_moving(speed: f64, offset: f64) -> lasercal::scenario::Setup {
    scenario_with("disk-on-the-move", |text| {
        text.replace(
            "scan_speed_mm_s = 100.0",
            &format!("scan_speed_mm_s = {speed}"),
        )
        .replace(
            "clock_offset_ms = 0.0",
            &format!("clock_offset_ms = {offset}"),
        )
    })
}

/// Monte Carlo of the estimated offset (issue 30's acceptance): at 50-200 mm/s with the stamps
/// 0-20 ms late and z noise 0.05 mm, `disk-refined` estimating the offset against the same trials
/// with no offset at all, and the offset's predicted sd against its scatter over the trials.
/// `cargo test --release --test suite on_the_move::offset_monte_carlo -- --ignored --nocapture`
#[test]
#[ignore]
fn offset_monte_carlo() {
    let id: MethodId = "disk-refined".parse().unwrap();
    let trials = 300;
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
    eprintln!(
        "speed mm/s | offset ms | rms error mm: none, estimated, held | offset sd ms: predicted, MC"
    );
    for speed in [50.0, 100.0, 200.0] {
        let still = noisy_moving(speed, 0.0);
        let reference: Vec<f64> = (0..trials)
            .map(|t| {
                let mut caps = trial_captures(&still, Kind::Disk, 2030, t).0.unwrap();
                caps.timing.as_mut().unwrap().estimate_offset = false;
                let (cal, _) = lasercal::method::estimate(id, &caps, &still.rig.sensor).unwrap();
                (cal.flange_to_sensor.translation.vector
                    - still.rig.flange_to_sensor.translation.vector)
                    .norm()
                    * 1e3
            })
            .collect();
        for offset in [0.0, 10.0, 20.0] {
            let setup = noisy_moving(speed, offset);
            let (mut estimated, mut held, mut shifts, mut sds) = (vec![], vec![], vec![], vec![]);
            for t in 0..trials {
                let mut caps = trial_captures(&setup, Kind::Disk, 2030, t).0.unwrap();
                let (cal, r) = lasercal::method::estimate(id, &caps, &setup.rig.sensor).unwrap();
                let c = r.unwrap().clock.unwrap();
                let err = |c: &lasercal::method::Calibration| {
                    (c.flange_to_sensor.translation.vector
                        - setup.rig.flange_to_sensor.translation.vector)
                        .norm()
                        * 1e3
                };
                estimated.push(err(&cal));
                shifts.push(c.shift_s * 1e3 + offset);
                sds.push(c.sd_s * 1e3);
                caps.timing.as_mut().unwrap().estimate_offset = false;
                let (h, _) = lasercal::method::estimate(id, &caps, &setup.rig.sensor).unwrap();
                held.push(err(&h));
            }
            let mean = shifts.iter().sum::<f64>() / trials as f64;
            let mc = (shifts.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / (trials - 1) as f64)
                .sqrt();
            sds.sort_by(f64::total_cmp);
            let predicted = sds[sds.len() / 2];
            eprintln!(
                "{speed:>5} | {offset:>4} | {:.4} {:.4} {:.4} | {predicted:.4} {mc:.4} (bias {mean:+.4})",
                rms(&reference),
                rms(&estimated),
                rms(&held)
            );
            assert!(
                rms(&estimated) <= 1.2 * rms(&reference),
                "{speed} mm/s {offset} ms"
            );
            assert!(
                (predicted / mc - 1.0).abs() <= 0.2,
                "{speed} mm/s {offset} ms: sd {predicted} vs {mc}"
            );
        }
    }
}

/// Moves from rest to rest (`scan_accel_mm_s2`) and controllers that log only waypoints
/// (`pose_log_hz = 0`), noise-free, the stamps 10 ms late: a 250 Hz log of an accelerating move
/// leaves micrometres (its chords cut the curve of position against time) and the offset comes
/// back; a waypoints-only log is exact at a steady speed and, on moves that speed up and brake,
/// misplaces the profiles by millimetres, which the verdict does not pass.
#[test]
fn accelerating_moves_and_waypoint_logs() {
    let id: MethodId = "disk-refined".parse().unwrap();
    let run = |keys: &str| {
        let setup = scenario_with("disk-on-the-move", |text| {
            text.replace("sigma_mm = 0.05", "sigma_mm = 0.0").replace(
                "clock_offset_ms = 0.0",
                &format!("clock_offset_ms = 10.0\n{keys}"),
            )
        });
        let caps = trial_captures(&setup, Kind::Disk, 1, 0).0.unwrap();
        let (cal, r) = lasercal::method::estimate(id, &caps, &setup.rig.sensor).unwrap();
        let e =
            lasercal::calib::PoseError::between(&cal.flange_to_sensor, &setup.rig.flange_to_sensor);
        let d = lasercal::method::verdict::decide(&caps, &setup.rig.sensor, Some(id)).unwrap();
        (e, r.unwrap().clock.unwrap(), d.judged.verdict)
    };
    let (e, c, _) = run("pose_log_hz = 0.0");
    assert!(
        e.translation_error_mm < 1e-9 && (c.shift_s + 0.010).abs() < 1e-9,
        "{e:?} {c:?}"
    );
    let (e, c, v) = run("scan_accel_mm_s2 = 500.0");
    assert!(
        e.translation_error_mm < 0.005 && (c.shift_s + 0.010).abs() < 5e-5,
        "{e:?} {c:?}"
    );
    assert_eq!(v, lasercal::method::verdict::Verdict::Ok);
    let (e, _, v) = run("scan_accel_mm_s2 = 500.0\npose_log_hz = 0.0");
    assert!(e.translation_error_mm > 1.0, "{e:?}");
    // Noise-free, the bound alone says it (imprecise); with noise the residuals do (suspect).
    assert_ne!(v, lasercal::method::verdict::Verdict::Ok);
}

/// Free pose sets passed on the move (`[X.poses] scan_speed_mm_s`, `clock_offset_ms`): the arm
/// passes each pose toward the next without stopping (the plane's 48 poses on a circle, the
/// ball's, the bar's and the disk's generated sets), the stamps 10 ms late. Each any-pose
/// estimator finds the offset within its stated uncertainty and ends nearer the truth than with
/// the stamps taken as they are.
#[test]
fn free_poses_passed_on_the_move() {
    for (name, section, id) in [
        ("plane-48-circle", "[plane.poses]", "plane-any-pose"),
        ("ball-free", "[ball.poses]", "ball-any-pose"),
        ("edge-8-poses", "[edge.poses]", "edge-any-pose"),
        ("disk-free", "[disk.poses]", "disk-any-pose"),
    ] {
        let setup = scenario_with(name, |text| {
            let text = text.replace(
                &format!("{section}\n"),
                &format!("{section}\nscan_speed_mm_s = 100.0\nclock_offset_ms = 10.0\n"),
            );
            assert!(text.contains("clock_offset_ms = 10.0"), "{name}");
            text
        });
        let id: MethodId = id.parse().unwrap();
        let mut caps = trial_captures(&setup, id.kind, 1, 0).0.unwrap();
        assert!(caps.timing.is_some(), "{name}: placed by time");
        let truth = setup.rig.flange_to_sensor;
        let (cal, r) = lasercal::method::estimate(id, &caps, &setup.rig.sensor).unwrap();
        let c = r.unwrap().clock.unwrap();
        let estimated = lasercal::calib::PoseError::between(&cal.flange_to_sensor, &truth);
        caps.timing.as_mut().unwrap().estimate_offset = false;
        let (held, _) = lasercal::method::estimate(id, &caps, &setup.rig.sensor).unwrap();
        let held = lasercal::calib::PoseError::between(&held.flange_to_sensor, &truth);
        eprintln!(
            "{name}: offset {:.3} ms sd {:.3}; error {:.4} mm estimated, {:.4} mm held",
            c.shift_s * 1e3,
            c.sd_s * 1e3,
            estimated.translation_error_mm,
            held.translation_error_mm
        );
        assert!((c.shift_s + 0.010).abs() < 4.0 * c.sd_s, "{name}: {c:?}");
        assert!(
            estimated.translation_error_mm < held.translation_error_mm
                && estimated.rotation_error_deg < held.rotation_error_deg,
            "{name}: {estimated:?} against {held:?}"
        );
    }
}

/// A held offset the data contradict is named as the likely cause: with the stamps 10 ms late and
/// the offset taken as stated, `disk-refined` is suspect (its scans disagree), and estimating the
/// offset finds it and passes.
#[test]
fn a_held_wrong_offset_is_named_as_the_likely_cause() {
    let setup = noisy_moving(100.0, 10.0);
    let id: MethodId = "disk-refined".parse().unwrap();
    let mut caps = trial_captures(&setup, Kind::Disk, 2030, 0).0.unwrap();
    caps.timing.as_mut().unwrap().estimate_offset = false;
    let d = lasercal::method::verdict::decide(&caps, &setup.rig.sensor, Some(id)).unwrap();
    assert_eq!(
        d.judged.verdict,
        lasercal::method::verdict::Verdict::Suspect
    );
    let first = &d.judged.reasons[0];
    assert!(
        first.contains("likely cause: the profiles' clock offset") && first.contains("-9.9"),
        "{first}"
    );
    caps.timing.as_mut().unwrap().estimate_offset = true;
    let d = lasercal::method::verdict::decide(&caps, &setup.rig.sensor, Some(id)).unwrap();
    assert_eq!(
        d.judged.verdict,
        lasercal::method::verdict::Verdict::Ok,
        "{:?}",
        d.judged.reasons
    );
}

/// Every variant judged together (`calibrate` without `--method`): the closed form takes the
/// stamps as stated and is off by the offset's bias, which is no disagreement with the variants
/// that estimated the offset. The ray-cast disk rig at 100 mm/s with the stamps 10 ms late: the
/// closed form, 0.7 mm off with a bound of 0.1 mm, is not suspect by its own figures, and the
/// chosen variant passes.
#[test]
fn the_closed_forms_offset_bias_is_no_disagreement() {
    let setup = scenario_with("chen2018-disk-raycast", |text| {
        text.replace(
            "[disk]\n",
            "[disk]\nscan_speed_mm_s = 100.0\nclock_offset_ms = 10.0\n",
        )
    });
    let caps = trial_captures(&setup, Kind::Disk, 1, 0).0.unwrap();
    let d = lasercal::method::verdict::decide(&caps, &setup.rig.sensor, None).unwrap();
    assert_ne!(d.method().to_string(), "disk");
    assert_eq!(
        d.judged.verdict,
        lasercal::method::verdict::Verdict::Ok,
        "{}: {:?}",
        d.method(),
        d.judged.reasons
    );
}

/// chen2018-disk without noise at `speed` mm/s, with the `[disk]` clock keys `keys` added.
fn moving_with(speed: f64, keys: &str) -> lasercal::scenario::Setup {
    scenario_with("chen2018-disk", |text| {
        text.replace("sigma_mm = 0.1", "sigma_mm = 0.0").replace(
            "[disk]\n",
            &format!("[disk]\nscan_speed_mm_s = {speed}\n{keys}\n"),
        )
    })
}

/// The profiler's clock in simulation beyond a constant offset (`[disk] clock_drift_ppm`,
/// `exposure_ms`), without noise: a drift estimated with the offset (`estimate_clock_drift`)
/// comes back exactly, with the transform; an exposure's profile is the image at its middle, so
/// the stamps (at its start) are half of it early.
#[test]
fn a_drifting_clock_and_an_exposure_in_simulation_are_recovered_exactly() {
    let id: MethodId = "disk-refined".parse().unwrap();
    let setup = moving_with(
        120.0,
        "clock_offset_ms = 8.0\nclock_drift_ppm = 800.0\nestimate_clock_drift = true",
    );
    let caps = trial_captures(&setup, Kind::Disk, 1, 0).0.unwrap();
    assert!(caps.timing.as_ref().unwrap().estimate_drift);
    let (cal, r) = lasercal::method::estimate(id, &caps, &setup.rig.sensor).unwrap();
    let clock = r.unwrap().clock.expect("a clock figure");
    let e = lasercal::calib::PoseError::between(&cal.flange_to_sensor, &setup.rig.flange_to_sensor);
    let (drift, _) = clock.drift.expect("the drift estimated");
    // The profiles were taken 800 ppm of their stamp earlier still: the estimate's drift is
    // its negative (the shift is the offset at the profiles' mean time).
    assert!(
        (drift + 800e-6).abs() < 1e-9
            && e.rotation_error_deg < 1e-9
            && e.translation_error_mm < 1e-9,
        "drift {drift}, {e:?}"
    );
    // Held without the drift, the same capture's offset alone leaves a bias.
    let mut no_drift = caps.clone();
    no_drift.timing.as_mut().unwrap().estimate_drift = false;
    let (cal, _) = lasercal::method::estimate(id, &no_drift, &setup.rig.sensor).unwrap();
    let e = lasercal::calib::PoseError::between(&cal.flange_to_sensor, &setup.rig.flange_to_sensor);
    assert!(
        e.translation_error_mm > 1e-4,
        "an unmodelled drift shows: {e:?}"
    );

    let setup = moving_with(100.0, "clock_offset_ms = 5.0\nexposure_ms = 4.0");
    let caps = trial_captures(&setup, Kind::Disk, 1, 0).0.unwrap();
    let (cal, r) = lasercal::method::estimate(id, &caps, &setup.rig.sensor).unwrap();
    let clock = r.unwrap().clock.expect("a clock figure");
    let e = lasercal::calib::PoseError::between(&cal.flange_to_sensor, &setup.rig.flange_to_sensor);
    let off = (clock.shift_s + (5.0 - 2.0) * 1e-3).abs();
    assert!(
        off < 1e-6 && e.rotation_error_deg < 1e-9 && e.translation_error_mm < 1e-9,
        "exposure: offset off by {off} s, {e:?}"
    );
}

/// Each stamp's own error (`clock_jitter_ms`) scatters the profiles along their moves: on the
/// noise-free paper protocol at 100 mm/s, 1 ms of jitter (0.1 mm) leaves the offset's estimate
/// within its 95 % bound and the transform within its honest bound, and the draws are the
/// trial's own (the same seed, the same capture).
#[test]
fn jittered_stamps_are_covered_by_the_bounds() {
    let id: MethodId = "disk-refined".parse().unwrap();
    let setup = moving_with(100.0, "clock_offset_ms = 10.0\nclock_jitter_ms = 1.0");
    let mut covered = 0;
    for trial in 0..20 {
        let caps = trial_captures(&setup, Kind::Disk, 1, trial).0.unwrap();
        let again = trial_captures(&setup, Kind::Disk, 1, trial).0.unwrap();
        assert_eq!(caps.profiles, again.profiles, "trial {trial}: drawn alike");
        let (cal, r) = lasercal::method::estimate(id, &caps, &setup.rig.sensor).unwrap();
        let clock = r.unwrap().clock.expect("a clock figure");
        let off = (clock.shift_s + 0.01).abs();
        assert!(
            off < 4.0 * clock.sd_s && off < 1e-3,
            "trial {trial}: {clock:?}"
        );
        let d = lasercal::method::verdict::decide(&caps, &setup.rig.sensor, Some(id)).unwrap();
        let e =
            lasercal::calib::PoseError::between(&cal.flange_to_sensor, &setup.rig.flange_to_sensor);
        let (br, bt) = d.judged.quality.error_bound();
        covered += (e.rotation_error_deg <= br && e.translation_error_mm <= bt) as usize;
        assert!(
            d.judged.verdict == lasercal::method::verdict::Verdict::Ok,
            "trial {trial}: {:?}",
            d.judged.lines().collect::<Vec<_>>()
        );
    }
    eprintln!("covered {covered} of 20");
    assert!(covered >= 17, "the bound covered {covered} of 20");
}

/// 2 ms of jitter at 100 mm/s scatters the profiles 0.2 mm along their moves, four times the
/// stated noise: the features are found again at the estimated offset's poses
/// (`ClockFit::replaced_at`), and each leave-one-out run still drops its group's poses (it
/// dropped none, and moved nothing, when it looked for the file's poses), at a stated offset too.
#[test]
fn leave_one_out_drops_its_group_where_the_features_were_found_again() {
    let id: MethodId = "disk-refined".parse().unwrap();
    let setup = scenario_with("disk-clock-jitter", |t| {
        t.replace("clock_jitter_ms = 0.0", "clock_jitter_ms = 2.0")
    });
    let mut caps = trial_captures(&setup, Kind::Disk, 1, 0).0.unwrap();
    for stated in [0.0, -0.004] {
        caps.timing.as_mut().unwrap().offset_s = stated;
        let d = lasercal::method::verdict::decide(&caps, &setup.rig.sensor, Some(id)).unwrap();
        let clock = d.assessed().refined.as_ref().unwrap().clock.unwrap();
        assert!(clock.replaced_at.is_some(), "found again: {clock:?}");
        let l = d.leave_one_out.as_ref().expect("leave-one-out runs");
        assert!(
            l.runs == 4 && l.failed == 0 && l.translation_mm > 1e-3,
            "stated {stated} s: {l:?}"
        );
    }
}
