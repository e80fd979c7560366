//! Issue 6 (part) and issue 3's scan command: end to end through the binary in temporary folders.

use crate::common;
use common::lasercal;
use common::scen;

use std::path::Path;

#[test]
fn scan_prints_a_profile_for_each_specimen() {
    for (file, method, min_valid) in [
        ("chen2018-disk-raycast.toml", "disk", 1000),
        ("chen2018-ball.toml", "ball", 300),
        ("xu2021-edge.toml", "edge", 100),
    ] {
        let (code, out, err) = lasercal(&["scan", &scen(file), "--method", method]);
        assert_eq!(code, 0, "{file}: {err}");
        let lines: Vec<&str> = out.lines().collect();
        assert_eq!(lines[0], "column,x_mm,z_mm,intensity");
        let valid = lines[1..].iter().filter(|l| !l.ends_with(",,,")).count();
        assert!(valid >= min_valid, "{file}: {valid} valid points");
    }
    // Every specimen kind at the scenario's specimen position: each shows a different profile.
    let mut seen = std::collections::HashSet::new();
    for kind in [
        "disk-cylinder",
        "disk-paper",
        "ball",
        "parallel-bar",
        "scale",
        "knife-blade",
    ] {
        let (code, out, err) = lasercal(&[
            "scan",
            &scen("chen2018-disk-raycast.toml"),
            "--specimen",
            kind,
        ]);
        assert_eq!(code, 0, "{kind}: {err}");
        assert!(
            seen.insert(out),
            "{kind}: the same profile as another specimen"
        );
    }
    let (code, _, err) = lasercal(&["scan", &scen("chen2018-disk.toml"), "--specimen", "donut"]);
    assert_eq!(code, 2);
    assert!(err.contains("donut"), "{err}");
    // An explicit joint pose, written to a file.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.csv");
    let (code, _, err) = lasercal(&[
        "scan",
        &scen("chen2018-disk.toml"),
        "--joints-deg",
        "-126,30,10,0,50,0",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(
        std::fs::read_to_string(&out)
            .unwrap()
            .starts_with("column,x_mm")
    );
    // Bad input: a clear error, exit 2.
    let (code, _, err) = lasercal(&["scan", &scen("chen2018-disk.toml"), "--joints-deg", "1,2,3"]);
    assert_eq!(code, 2);
    assert!(err.contains("--joints-deg"), "{err}");
}

#[test]
fn check_gates_on_the_error_percentile() {
    let s = scen("chen2018-disk.toml");
    let (code, out, _) = lasercal(&[
        "check",
        &s,
        "--max-rotation-deg",
        "1",
        "--max-translation-mm",
        "1",
        "--trials",
        "40",
    ]);
    assert_eq!(code, 0, "{out}");
    assert!(out.starts_with("ok disk"), "{out}");
    let (code, out, _) = lasercal(&[
        "check",
        &s,
        "--max-rotation-deg",
        "0.001",
        "--max-translation-mm",
        "1",
        "--trials",
        "40",
    ]);
    assert_eq!(code, 1);
    assert!(
        out.contains("FAIL disk") && out.contains("rotation error") && out.contains("exceeds"),
        "{out}"
    );
    let (code, _, err) = lasercal(&[
        "check",
        &s,
        "--max-rotation-deg",
        "-1",
        "--max-translation-mm",
        "1",
    ]);
    assert_eq!(code, 2, "{err}");
    let (code, _, err) = lasercal(&[
        "check",
        "/nonexistent.toml",
        "--max-rotation-deg",
        "1",
        "--max-translation-mm",
        "1",
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("/nonexistent.toml"), "{err}");
}

#[test]
fn check_takes_bounds_per_method_and_reports_for_ci() {
    let dir = tempfile::tempdir().unwrap();
    let (json, junit) = (dir.path().join("check.json"), dir.path().join("check.xml"));
    let s = scen("shootout.toml");
    let args = |extra: &[&str]| {
        let mut v = vec![
            "check",
            s.as_str(),
            "--trials",
            "8",
            "--json",
            json.to_str().unwrap(),
            "--junit",
            junit.to_str().unwrap(),
        ];
        v.extend(extra);
        v.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let run = |extra: &[&str]| {
        let a = args(extra);
        lasercal(&a.iter().map(String::as_str).collect::<Vec<_>>())
    };
    // One method held tight, the rest loose: only it fails, and every line gives both figures.
    let (code, out, err) = run(&[
        "--max-rotation-deg",
        "5",
        "--max-translation-mm",
        "5",
        "--bound",
        "disk=0.0001,5",
    ]);
    assert_eq!(code, 1, "{out}{err}");
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 7, "{out}");
    for l in &lines {
        assert!(
            l.contains("rotation error") && l.contains("translation error"),
            "{l}"
        );
        assert_eq!(l.starts_with("FAIL disk:"), !l.starts_with("ok "), "{l}");
    }
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let methods = doc["methods"].as_array().unwrap();
    assert_eq!(methods.len(), 7);
    assert_eq!(doc["passed"], false);
    assert_eq!(methods[0]["method"], "disk");
    assert_eq!(methods[0]["passed"], false);
    assert_eq!(methods[0]["max_rotation_deg"], 0.0001);
    assert!(methods[1..].iter().all(|m| m["passed"] == true));
    let xml = std::fs::read_to_string(&junit).unwrap();
    assert!(
        xml.contains("tests=\"7\" failures=\"1\"")
            && xml.matches("<testcase").count() == 7
            && xml.matches("<failure").count() == 1,
        "{xml}"
    );
    // A method without bounds, a negative bound, a method the scenario does not run: refused.
    for (extra, want) in [
        (vec!["--bound", "disk=1,1"], "disk-refined has no bounds"),
        (
            vec!["--max-rotation-deg", "-0.1", "--max-translation-mm", "1"],
            "positive",
        ),
        (
            vec!["--bound", "plane-any-pose=1,1"],
            "does not run plane-any-pose",
        ),
    ] {
        let (code, _, err) = run(&extra);
        assert_eq!(code, 2, "{extra:?}: {err}");
        assert!(err.contains(want), "{extra:?}: {err}");
    }
}

fn read(p: &Path) -> Vec<u8> {
    std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn sharded_sweep_merges_to_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let d = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    for s in ["chen2018-fig15.toml", "xu2021-rotations.toml"] {
        let (code, _, err) = lasercal(&["sweep", &scen(s), "--trials", "6", "--out", &d("full")]);
        assert_eq!(code, 0, "{err}");
        for k in 1..=3 {
            let (code, _, err) = lasercal(&[
                "sweep",
                &scen(s),
                "--trials",
                "6",
                "--shard",
                &format!("{k}/3"),
                "--out",
                &d(&format!("s{k}")),
            ]);
            assert_eq!(code, 0, "{err}");
        }
        // An incomplete set is refused.
        let (code, _, err) = lasercal(&["merge", &d("s1"), &d("s3"), "--out", &d("bad")]);
        assert_ne!(code, 0);
        assert!(err.contains("exactly once"), "{err}");
        let (code, _, err) =
            lasercal(&["merge", &d("s1"), &d("s2"), &d("s3"), "--out", &d("merged")]);
        assert_eq!(code, 0, "{err}");
        common::assert_same_sweep_outputs(&dir.path().join("full"), &dir.path().join("merged"), s);
        let report = String::from_utf8(read(&dir.path().join("full/report.md"))).unwrap();
        assert!(
            report.contains("seed:")
                && report.contains("lasercal 0.")
                && report.contains("plot.svg"),
            "{report}"
        );
    }
    let (code, _, err) = lasercal(&["sweep", &scen("chen2018-fig15.toml"), "--shard", "4/3"]);
    assert_eq!(code, 2);
    assert!(err.contains("1 <= K <= N"), "{err}");
}

#[test]
fn simulate_then_calibrate_equals_run() {
    let dir = tempfile::tempdir().unwrap();
    // The scenario's method (calibrate alone would pick the best of every variant).
    for (s, method) in [
        ("chen2018-disk.toml", "disk"),
        ("chen2018-disk-raycast.toml", "disk"),
        ("chen2018-ball.toml", "ball"),
        ("xu2021-edge.toml", "edge"),
    ] {
        let caps = dir.path().join("c.json");
        let (r_json, c_json) = (dir.path().join("r.json"), dir.path().join("k.json"));
        let (code, _, err) = lasercal(&[
            "simulate",
            &scen(s),
            "--out",
            caps.to_str().unwrap(),
            "--trial",
            "2",
            "--seed",
            "9",
        ]);
        assert_eq!(code, 0, "{s}: {err}");
        let (code, _, err) = lasercal(&[
            "calibrate",
            caps.to_str().unwrap(),
            "--method",
            method,
            "--json",
            c_json.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{s}: {err}");
        let (code, _, err) = lasercal(&[
            "run",
            &scen(s),
            "--trial",
            "2",
            "--seed",
            "9",
            "--json",
            r_json.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{s}: {err}");
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&r_json).unwrap()).unwrap();
        let c: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&c_json).unwrap()).unwrap();
        let m = |v: &serde_json::Value| -> Vec<Vec<f64>> {
            serde_json::from_value(v["flange_to_sensor"].clone()).unwrap()
        };
        let (mr, mc) = (m(&r), m(&c));
        for i in 0..4 {
            for j in 0..4 {
                // The file is in mm: a round trip through it may move the last bits.
                assert!(
                    (mr[i][j] - mc[i][j]).abs() < 1e-9,
                    "{s}: [{i}][{j}] {} vs {}",
                    mr[i][j],
                    mc[i][j]
                );
            }
        }
        assert!(
            (r["rotation_error_deg"].as_f64().unwrap() - c["rotation_error_deg"].as_f64().unwrap())
                .abs()
                < 1e-9
        );
    }
}

#[test]
fn malformed_capture_files_name_record_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("g.json");
    let (code, _, err) = lasercal(&[
        "simulate",
        &scen("chen2018-disk.toml"),
        "--out",
        good.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let text = std::fs::read_to_string(&good).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let cases: Vec<(Box<dyn Fn(&mut serde_json::Value)>, &str)> = vec![
        (
            Box::new(|v| {
                v["profiles"][12]["tcp_quaternion_wxyz"] = serde_json::json!([2.0, 0.0, 0.0, 0.0])
            }),
            "profiles[12].tcp_quaternion_wxyz",
        ),
        (
            Box::new(|v| v["profiles"][3]["group"] = serde_json::json!(99)),
            "profiles[3].group",
        ),
        (
            Box::new(|v| v["groups"][1]["sign"] = serde_json::json!(2)),
            "groups[1].sign",
        ),
        (Box::new(|v| v["version"] = serde_json::json!(7)), "version"),
        (
            Box::new(|v| v["sensor"] = serde_json::json!("kinect")),
            "sensor",
        ),
        (
            Box::new(|v| v["profiles"][0]["edge_point_mm"] = serde_json::json!([1.0, 2.0])),
            "profiles[0]",
        ),
        (
            Box::new(|v| v["profiles"][0]["colour"] = serde_json::json!("red")),
            "colour",
        ),
        (
            Box::new(|v| v["specimen"]["radius_mm"] = serde_json::json!(-50.0)),
            "specimen.radius_mm",
        ),
    ];
    for (edit, want) in cases {
        let mut w = v.clone();
        edit(&mut w);
        let p = dir.path().join("bad.json");
        std::fs::write(&p, serde_json::to_string(&w).unwrap()).unwrap();
        let (code, out, err) = lasercal(&["calibrate", p.to_str().unwrap()]);
        assert_eq!(code, 2, "{want}: {out}");
        assert!(
            err.contains("bad.json") && err.contains(want),
            "{want}: {err}"
        );
    }
    // A sign not recorded (0): the closed form says so and names the estimator that needs none.
    let mut w = v.clone();
    w["groups"][1]["sign"] = serde_json::json!(0);
    let p = dir.path().join("unsigned.json");
    std::fs::write(&p, serde_json::to_string(&w).unwrap()).unwrap();
    let (code, _, err) = lasercal(&["calibrate", p.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(
        err.contains("group 1") && err.contains("sign") && err.contains("disk-any-pose"),
        "{err}"
    );
    // A method mismatch is refused.
    let (code, _, err) = lasercal(&["calibrate", good.to_str().unwrap(), "--method", "edge"]);
    assert_eq!(code, 2);
    assert!(err.contains("disk"), "{err}");
    v["method"] = serde_json::json!("disk");
}
