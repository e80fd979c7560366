//! Issue 6 (part) and issue 3's scan command: end to end through the binary in temporary folders.

use std::path::Path;
use std::process::Command;

fn lasercal(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_lasercal"))
        .args(args)
        .env("CI", "1")
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

fn scen(name: &str) -> String {
    format!("{}/scenarios/{name}", env!("CARGO_MANIFEST_DIR"))
}

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
        for f in [
            "trials.csv",
            "summary.csv",
            "plot.svg",
            "plot.png",
            "report.md",
        ] {
            assert_eq!(
                read(&dir.path().join("full").join(f)),
                read(&dir.path().join("merged").join(f)),
                "{s}: {f} differs"
            );
        }
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
