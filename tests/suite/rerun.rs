//! Issue 6: Rerun recordings, checked with Rerun's own tools (`rerun rrd verify` and `rerun rrd
//! print` from the PyPI package `rerun-sdk` 0.36.3, which .ci/run installs). Without the `rerun`
//! command the test says so and passes, except under CI, where it is required.
#![cfg(feature = "rerun")]

use crate::common;

use std::collections::BTreeMap;
use std::process::Command;

fn rerun_cli() -> Option<String> {
    let ok = Command::new("rerun")
        .arg("--version")
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    if ok {
        return Some("rerun".into());
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "the `rerun` command is required under CI: pip install rerun-sdk==0.36.3"
    );
    eprintln!("SKIPPED: no `rerun` command (pip install rerun-sdk==0.36.3)");
    None
}

/// Rows per entity path from `rerun rrd print`.
fn rows(rrd: &std::path::Path, cli: &str) -> BTreeMap<String, usize> {
    let out = Command::new(cli)
        .args(["rrd", "print"])
        .arg(rrd)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let mut m = BTreeMap::new();
    for line in text.lines().filter(|l| l.starts_with("Chunk(")) {
        let n: usize = line
            .split(" with ")
            .nth(1)
            .and_then(|s| s.split(' ').next())
            .and_then(|s| s.parse().ok())
            .unwrap();
        let path = line.split(" - ").nth(1).unwrap().trim().to_string();
        *m.entry(path).or_insert(0) += n;
    }
    m
}

#[test]
fn run_records_a_verifiable_rrd_with_every_entity() {
    let Some(cli) = rerun_cli() else { return };
    let dir = tempfile::tempdir().unwrap();
    let rrd = dir.path().join("run.rrd");
    let scen = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/chen2018-disk-raycast.toml"
    );
    let out = Command::new(env!("CARGO_BIN_EXE_lasercal"))
        .args(["run", scen, "--rerun", rrd.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v = Command::new(&cli)
        .args(["rrd", "verify"])
        .arg(&rrd)
        .output()
        .unwrap();
    assert!(
        v.status.success(),
        "rrd verify: {}",
        String::from_utf8_lossy(&v.stderr)
    );
    let m = rows(&rrd, &cli);
    // 4 scans x 100 profiles: one row per capture for the moving entities, the profile and its
    // feature in the sensor frame and in the laser plane's 2D view, the error and residual.
    expect_rows(
        &m,
        &[
            "/world/sensor",
            "/world/flange",
            "/world/truth/sensor",
            "/world/truth/sensor/error_arrow",
            "/world/sensor/profile",
            "/world/sensor/features",
            "/laser_plane/profile",
            "/laser_plane/features",
            "/error/rotation_deg",
            "/error/sensor_origin_mm",
            "/residual/rms_mm",
            "/world/arm/link_3",
            "/world/arm/tool0",
        ],
        400,
    );
    // Static geometry and the mapped profiles once.
    expect_rows(
        &m,
        &[
            "/world",
            "/summary",
            "/world/table",
            "/world/specimen/0/part_0",
            "/world/sensor/fan",
            "/world/sensor/body",
            "/world/arm/link_2/visual_0",
            "/world/truth/sensor/axes",
            "/world/mapped/profiles",
            "/world/mapped/features",
            "/world/mapped/fitted_specimen",
        ],
        1,
    );
    // The layout: views (blueprint entities) come with the recording.
    assert!(
        m.keys().any(|k| k.starts_with("/view/")),
        "no blueprint: {m:?}"
    );
    // That each capture's feature is found, on every source: tests/suite/view.rs.
}

#[test]
fn calibrate_records_a_capture_file_mapped_with_the_recovered_transform() {
    let Some(cli) = rerun_cli() else { return };
    let dir = tempfile::tempdir().unwrap();
    let caps = dir.path().join("ball.json");
    let rrd = dir.path().join("cal.rrd");
    let (code, _, err) = common::lasercal(&[
        "simulate",
        &common::scen("ball-free.toml"),
        "--out",
        caps.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let (code, _, err) = common::lasercal(&[
        "calibrate",
        caps.to_str().unwrap(),
        "--rerun",
        rrd.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let m = rows(&rrd, &cli);
    // 15 free poses; no arm or scene (a capture file has neither); the file's truth shows the error.
    expect_rows(
        &m,
        &[
            "/world/sensor",
            "/world/sensor/profile",
            "/laser_plane/features",
            "/residual/rms_mm",
            "/error/rotation_deg",
        ],
        15,
    );
    expect_rows(
        &m,
        &[
            "/world/mapped/profiles",
            "/world/mapped/fitted_specimen",
            "/summary",
        ],
        1,
    );
    assert!(!m.keys().any(|k| k.starts_with("/world/arm")), "{m:?}");
}

#[test]
fn sweep_records_its_curves() {
    let Some(cli) = rerun_cli() else { return };
    let dir = tempfile::tempdir().unwrap();
    let rrd = dir.path().join("sweep.rrd");
    let scen = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/chen2018-fig15.toml");
    let sweep = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_lasercal"))
            .arg("sweep")
            .args(args)
            .env("CI", "1")
            .output()
            .unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let (code, err) = sweep(&[
        scen,
        "--trials",
        "5",
        "--out",
        dir.path().join("o").to_str().unwrap(),
        "--rerun",
        rrd.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{err}");
    let m = rows(&rrd, &cli);
    // One view: every series under the plotted column, one per sigma, a row per chord count
    // (and the static row naming it).
    let series: Vec<_> = m
        .keys()
        .filter(|k| k.starts_with("/sweep/centre_error_mm_std/"))
        .collect();
    assert_eq!(series.len(), 9, "one series per sigma: {m:?}");
    assert!(
        series.iter().all(|k| m[*k] >= 20),
        "20 chord counts each: {m:?}"
    );
    assert!(
        m.keys()
            .filter(|k| k.starts_with("/sweep"))
            .all(|k| !k.contains("__")),
        "clean entity paths: {m:?}"
    );
    // The same curves from the finished folder, without a trial run and without touching it.
    let folder = dir.path().join("o");
    let before: Vec<Vec<u8>> = ["trials.csv", "summary.csv", "plot.svg", "sweep.json"]
        .iter()
        .map(|f| std::fs::read(folder.join(f)).unwrap())
        .collect();
    let again = dir.path().join("again.rrd");
    let from = |scenario: &str| {
        sweep(&[
            scenario,
            "--from",
            folder.to_str().unwrap(),
            "--rerun",
            again.to_str().unwrap(),
        ])
    };
    let (code, err) = from(scen);
    assert_eq!(code, Some(0), "{err}");
    let curves = |m: &BTreeMap<String, usize>| -> BTreeMap<String, usize> {
        m.iter()
            .filter(|(k, _)| k.starts_with("/sweep"))
            .map(|(k, v)| (k.clone(), *v))
            .collect()
    };
    assert_eq!(
        curves(&rows(&again, &cli)),
        curves(&m),
        "the same curves as the run's own recording"
    );
    let after: Vec<Vec<u8>> = ["trials.csv", "summary.csv", "plot.svg", "sweep.json"]
        .iter()
        .map(|f| std::fs::read(folder.join(f)).unwrap())
        .collect();
    assert_eq!(before, after);
    // Another scenario's folder is refused.
    let (code, err) = from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/chen2018-fig17.toml"
    ));
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("another version"), "{err}");
}

#[test]
fn mesh_visuals_that_cannot_be_shown_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let root = env!("CARGO_MANIFEST_DIR");
    let urdf = std::fs::read_to_string(format!("{root}/robots/irb120_3_58.urdf"))
        .unwrap()
        .replacen(
            "<geometry><box size=\"0.24 0.18 0.02\"/></geometry>",
            "<geometry><mesh filename=\"package://abb/meshes/base.stl\"/></geometry>",
            1,
        );
    assert!(urdf.contains("base.stl"));
    std::fs::write(dir.path().join("arm.urdf"), urdf).unwrap();
    let scen = std::fs::read_to_string(format!("{root}/scenarios/chen2018-disk-raycast.toml"))
        .unwrap()
        .replacen("name = \"irb120\"", "name = \"arm.urdf\"", 1);
    assert!(scen.contains("arm.urdf"));
    let p = dir.path().join("s.toml");
    std::fs::write(&p, scen).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_lasercal"))
        .args([
            "run",
            p.to_str().unwrap(),
            "--rerun",
            dir.path().join("r.rrd").to_str().unwrap(),
        ])
        .env("CI", "1")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("mesh visual") && err.contains("base.stl"),
        "{err}"
    );
}

#[test]
fn a_recording_that_cannot_be_written_fails_before_the_work() {
    // The .rrd is opened first: a bad path is named at once, not after the calibration ran.
    let dir = tempfile::tempdir().unwrap();
    let caps = ball_capture(dir.path());
    let bad = dir.path().join("no/such/dir/x.rrd");
    let (code, out, err) = common::lasercal(&[
        "calibrate",
        caps.to_str().unwrap(),
        "--rerun",
        bad.to_str().unwrap(),
    ]);
    assert_eq!(code, 2, "{out}{err}");
    assert!(err.contains("no/such/dir/x.rrd"), "{err}");
    assert!(!out.contains("verdict"), "the calibration ran first: {out}");
    let (code, out, err) = common::lasercal(&[
        "run",
        &common::scen("chen2018-disk.toml"),
        "--rerun-method",
        "ball",
        "--rerun",
        dir.path().join("r.rrd").to_str().unwrap(),
    ]);
    assert_eq!(code, 2, "{out}{err}");
    assert!(
        err.contains("--rerun-method ball") && err.contains("disk"),
        "{err}"
    );
    assert!(!out.contains("recovered"), "the run went first: {out}");
}

/// The ball-free scenario's captures written to `dir`/ball.json (15 free poses, the truth in it).
fn ball_capture(dir: &std::path::Path) -> std::path::PathBuf {
    let caps = dir.join("ball.json");
    let (code, _, err) = common::lasercal(&[
        "simulate",
        &common::scen("ball-free.toml"),
        "--out",
        caps.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    caps
}

/// Each of `entities` has `n` rows in the recording.
fn expect_rows(m: &BTreeMap<String, usize>, entities: &[&str], n: usize) {
    for e in entities {
        assert_eq!(m.get(*e).copied(), Some(n), "{e}: {m:?}");
    }
}

/// A capture file whose profiles were placed by their time stamps on a pose log (a simulated
/// moving scan) shows them on their own clock too, the timeline `profile_time`; a file of stated
/// poses has no such timeline.
#[test]
fn profiles_placed_by_time_get_their_own_timeline() {
    let Some(cli) = rerun_cli() else { return };
    let dir = tempfile::tempdir().unwrap();
    let timelines = |scenario: &str| {
        let caps = dir.path().join(format!("{scenario}.json"));
        let rrd = dir.path().join(format!("{scenario}.rrd"));
        let (code, _, err) = common::lasercal(&[
            "simulate",
            &common::scen(&format!("{scenario}.toml")),
            "--out",
            caps.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{err}");
        let (code, _, err) = common::lasercal(&[
            "calibrate",
            caps.to_str().unwrap(),
            "--method",
            "disk",
            "--rerun",
            rrd.to_str().unwrap(),
        ]);
        assert!(code == 0 || code == 3 || code == 4, "{err}");
        let out = Command::new(&cli)
            .args(["rrd", "print", "-vv"])
            .arg(&rrd)
            .output()
            .unwrap();
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let moving = timelines("disk-on-the-move");
    assert!(
        moving.contains("index_name: profile_time"),
        "no profile_time timeline"
    );
    assert!(moving.contains("index_name: capture"));
    assert!(!timelines("chen2018-disk").contains("index_name: profile_time"));
}
