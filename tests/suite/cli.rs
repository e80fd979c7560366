//! End-to-end tests of the `lasercal` binary.

use crate::common;
use common::lasercal;

#[test]
fn cli_fk_zero_pose_irb120() {
    let (code, out, err) = lasercal(&["fk", "irb120", "0", "0", "0", "0", "0", "0"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    let p: Vec<f64> = serde_json::from_value(v["position_mm"].clone()).unwrap();
    let q: Vec<f64> = serde_json::from_value(v["quaternion_wxyz"].clone()).unwrap();
    assert_eq!(p, vec![374.0, 0.0, 630.0]);
    assert!(
        (q[0] - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-6
            && q[1] == 0.0
            && (q[2] - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-6
            && q[3] == 0.0
    );
}

#[test]
fn cli_fk_negative_angles_and_irb2600() {
    let (code, out, err) = lasercal(&["fk", "irb2600", "-30", "10", "-20", "45", "-60", "90"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("position_mm"));
}

#[test]
fn cli_ik_roundtrip() {
    let (_, out, _) = lasercal(&["fk", "irb120", "10", "20", "-30", "40", "50", "60"]);
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    let mut args = vec!["ik".to_string(), "irb120".to_string()];
    for k in ["position_mm", "quaternion_wxyz"] {
        for x in v[k].as_array().unwrap() {
            args.push(x.to_string());
        }
    }
    let argv: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
    let (code, out, err) = lasercal(&argv);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    let sols: Vec<Vec<f64>> = serde_json::from_value(v["solutions_deg"].clone()).unwrap();
    assert!(
        sols.iter().any(|s| s
            .iter()
            .zip([10.0, 20.0, -30.0, 40.0, 50.0, 60.0])
            .all(|(a, b)| (a - b).abs() < 1e-4)),
        "{sols:?}"
    );
}

#[test]
fn cli_bad_arguments_fail_cleanly() {
    for args in [
        vec!["fk", "irb120", "0", "0", "0"],
        vec!["fk", "irb999", "0", "0", "0", "0", "0", "0"],
        vec!["fk", "irb120", "0", "x", "0", "0", "0", "0"],
        vec!["fk", "irb120", "0", "0", "0", "0", "0", "900"],
        vec!["ik", "irb120", "2000", "0", "0", "1", "0", "0", "0"],
        vec!["ik", "irb120", "300", "0", "400", "2", "0", "0", "0"],
        vec!["bogus"],
    ] {
        let (code, out, err) = lasercal(&args);
        assert_ne!(code, 0, "{args:?} should fail");
        assert!(out.is_empty(), "{args:?} printed {out}");
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
        assert!(!err.trim().is_empty());
    }
    let (_, _, err) = lasercal(&["ik", "irb120", "2000", "0", "0", "1", "0", "0", "0"]);
    assert!(err.contains("out of reach"), "{err}");
}

#[test]
fn cli_errors_name_the_missing_argument_and_bad_plot_keys() {
    let (code, _, err) = common::lasercal(&["simulate", &common::scen("comparison.toml")]);
    assert_eq!(code, 2);
    assert!(err.contains("--out"), "{err}");
    let (code, _, err) = common::lasercal(&["run"]);
    assert_eq!(code, 2);
    assert!(err.contains("<SCENARIO>"), "{err}");
    // A typo in [sweep.plot] y: refused before any trial runs (it gave an empty plot, exit 0).
    let text = std::fs::read_to_string(common::scen("comparison.toml")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("typo.toml");
    std::fs::write(
        &p,
        text.replace(
            "y = \"translation_error_mm_p95\"",
            "y = \"translation_eror_mm_p95\"",
        ),
    )
    .unwrap();
    let (code, _, err) = common::lasercal(&[
        "sweep",
        p.to_str().unwrap(),
        "--out",
        dir.path().join("o").to_str().unwrap(),
    ]);
    assert_eq!(code, 2);
    assert!(
        err.contains("sweep.plot.y") && err.contains("translation_error_mm_p95"),
        "{err}"
    );
}

#[test]
fn a_long_run_off_a_terminal_prints_progress_lines() {
    let dir = tempfile::tempdir().unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lasercal"))
        .args([
            "sweep",
            &common::scen("xu2021-rotations.toml"),
            "--trials",
            "12",
            "--out",
            dir.path().join("o").to_str().unwrap(),
        ])
        .env("CI", "1")
        .env("LASERCAL_PROGRESS_EVERY_S", "0")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("trials (") && err.contains("to go"), "{err}");
}

/// Output that meets closed pipes (`lasercal run ... 2>&1 | head -1`) ends the command with an
/// error, not a panic (exit 101).
#[test]
fn closed_pipes_end_a_run_without_a_panic() {
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_lasercal"))
        .args(["run", &common::scen("ridge-16-poses.toml")])
        .env("CI", "1")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run lasercal");
    drop(child.stdout.take());
    drop(child.stderr.take());
    let code = child.wait().unwrap().code();
    assert!(matches!(code, Some(0 | 2)), "exit {code:?}");
}

#[test]
fn a_failed_variant_is_named_once() {
    let dir = tempfile::tempdir().unwrap();
    let (caps, _) = common::simulated_capture(dir.path(), "ridge-16-poses.toml", "ridge.json");
    // Free poses: the closed form has no rotation groups and says so, naming its variant once.
    let (code, _, err) = lasercal(&["calibrate", caps.to_str().unwrap(), "--method", "edge"]);
    assert_ne!(code, 0);
    assert!(
        err.contains("edge: ") && !err.contains("edge: edge:") && err.contains("edge-any-pose"),
        "{err}"
    );
    let (code, _, err) = lasercal(&["run", &common::scen("ridge-16-poses.toml")]);
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("edge-any-pose: edge:"), "{err}");
}

#[test]
fn new_writes_a_starter_scenario_that_runs_as_written() {
    let dir = tempfile::tempdir().unwrap();
    let kinds = [
        "ball",
        "disk-cylinder",
        "parallel-bar",
        "scale",
        "knife-blade",
        "ridge",
        "v-groove",
        "fillet",
        "step",
        "plane",
    ];
    for (i, kind) in kinds.iter().enumerate() {
        let robot = ["irb120", "irb2600"][i % 2];
        let sweep = ["noise", "poses", "none"][i % 3];
        let out = dir.path().join(format!("{kind}.toml"));
        let (code, said, err) = lasercal(&[
            "new",
            "--robot",
            robot,
            "--specimen",
            kind,
            "--sweep",
            sweep,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{kind}: {err}");
        assert!(said.contains("trial 0 calibrates"), "{said}");
        let sf = lasercal::scenario::ScenarioFile::load(&out).unwrap();
        assert_eq!(sf.scenario.sweep.is_some(), sweep != "none", "{kind}");
        let setup = sf.scenario.build(&sf.file).unwrap();
        let id = sf.scenario.methods[0];
        assert_eq!(id.estimator, lasercal::method::Estimator::AnyPose);
        let e = lasercal::trial::run_trial(&setup, id, sf.scenario.seed, 1)
            .result
            .unwrap_or_else(|e| panic!("{kind}: {e}"))
            .error();
        assert!(
            e.rotation_error_deg < 0.5 && e.translation_error_mm < 2.0,
            "{kind}: {e:?}"
        );
    }
    let out = dir.path().join("ball.toml");
    for (args, want) in [
        (vec!["--specimen", "ball"], "exists"),
        (vec!["--specimen", "cube", "--force"], "--specimen cube"),
        (vec!["--specimen", "disk-paper", "--force"], "disk-cylinder"),
        (vec!["--sweep", "speed", "--force"], "--sweep speed"),
        (vec!["--sensor", "gocator-9999", "--force"], "gocator-9999"),
    ] {
        let mut a = vec!["new", "--out", out.to_str().unwrap()];
        a.extend(args);
        let (code, _, err) = lasercal(&a);
        assert_eq!(code, 2, "{a:?}: {err}");
        assert!(err.contains(want), "{a:?}: {err}");
    }
}

#[test]
fn outputs_carry_no_float_noise_and_errors_name_the_key_to_edit() {
    // A quantised z of -5.174 mm is written as such, and no value carries more digits than a
    // picometre needs.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("scan.csv");
    let (code, _, err) = lasercal(&[
        "scan",
        &common::scen("chen2018-disk-raycast.toml"),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let text = std::fs::read_to_string(&out).unwrap();
    for cell in text.lines().skip(1).flat_map(|l| l.split(',')) {
        let decimals = cell.split('.').nth(1).map_or(0, str::len);
        assert!(decimals <= 9, "float noise: {cell}");
    }
    // A specimen out of the arm's reach: the error names the key that places it.
    let path = common::scen("chen2018-disk.toml");
    let moved = std::fs::read_to_string(&path).unwrap().replace(
        "position_mm = [-319.622, -304.086, 11.48]",
        "position_mm = [-1319.622, -304.086, 11.48]",
    );
    let file = dir.path().join("far.toml");
    std::fs::write(&file, moved).unwrap();
    let (code, _, err) = lasercal(&["run", file.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("not reachable") && err.contains("position_mm"),
        "{err}"
    );
}
