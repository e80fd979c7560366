//! Bad environments and bad inputs (issue 15, item 4): a clean error naming what failed, never a
//! panic, a hang or a huge allocation. Each case failed (exit 101, abort or hang) before its fix.

mod common;

use std::process::{Command, Stdio};

/// Run lasercal with standard output on a full disk (/dev/full).
fn to_full_disk(args: &[&str]) -> (i32, String) {
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .expect("/dev/full (Linux)");
    let out = Command::new(env!("CARGO_BIN_EXE_lasercal"))
        .args(args)
        .env("CI", "1")
        .stdout(Stdio::from(full))
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn a_full_disk_on_standard_output_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let caps = dir.path().join("c.json");
    let (code, _, err) = common::lasercal(&[
        "simulate",
        &common::scen("chen2018-disk.toml"),
        "--out",
        caps.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let disk = common::scen("chen2018-disk.toml");
    let cases: Vec<Vec<&str>> = vec![
        vec!["fk", "irb120", "0", "0", "0", "0", "0", "0"],
        vec![
            "ik",
            "irb120",
            "374",
            "0",
            "630",
            "0.7071068",
            "0",
            "0.7071068",
            "0",
        ],
        vec!["run", &disk],
        vec!["calibrate", caps.to_str().unwrap()],
        vec![
            "check",
            &disk,
            "--trials",
            "2",
            "--max-rotation-deg",
            "1",
            "--max-translation-mm",
            "1",
        ],
        vec!["scan", &disk],
    ];
    for args in cases {
        let (code, err) = to_full_disk(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(
            err.contains("standard output") && !err.contains("panicked"),
            "{args:?}: {err}"
        );
    }
}

fn irb120() -> String {
    std::fs::read_to_string(format!(
        "{}/robots/irb120_3_58.urdf",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap()
}

fn urdf_error(text: &str) -> String {
    lasercal::robot::Robot::from_urdf_str(text, "arm.urdf")
        .err()
        .expect("refused")
        .to_string()
}

#[test]
fn broken_urdfs_are_refused_without_hanging_or_overflowing() {
    let good = irb120();
    assert!(lasercal::robot::Robot::from_urdf_str(&good, "arm.urdf").is_ok());
    // A chain that loops back: joint_3's child is link_1 again (it hung and grew to 3.9 GB).
    let looped = good.replacen(
        "<parent link=\"link_2\"/>\n    <child link=\"link_3\"/>",
        "<parent link=\"link_2\"/>\n    <child link=\"link_1\"/>",
        1,
    );
    assert_ne!(looped, good);
    let e = urdf_error(&looped);
    assert!(
        e.contains("arm.urdf") && e.contains("loops back to link 'link_1'"),
        "{e}"
    );
    // 100,000 nested elements (overflowed the parser's stack).
    let deep = format!(
        "<robot name=\"r\">{}{}</robot>",
        "<link name=\"a\">".repeat(100_000),
        "</link>".repeat(100_000)
    );
    let e = urdf_error(&deep);
    assert!(e.contains("nested more than 64 deep"), "{e}");
    // A NaN joint origin (printed nulls with exit 0).
    let nan = good.replacen("<origin xyz=\"0 0 0.29\"", "<origin xyz=\"0 nan 0.29\"", 1);
    assert_ne!(nan, good);
    let e = urdf_error(&nan);
    assert!(
        e.contains("joint_2") && e.contains("not a finite number"),
        "{e}"
    );
    // Limits of +-1e6 rad (IK listed every turn and aborted).
    let huge = good.replacen(
        "lower=\"-2.8797932657906435\" upper=\"2.8797932657906435\"",
        "lower=\"-1e6\" upper=\"1e6\"",
        1,
    );
    assert_ne!(huge, good);
    let e = urdf_error(&huge);
    assert!(e.contains("joint_1") && e.contains("1080 deg"), "{e}");
}

fn scenario_error(edit: &dyn Fn(&mut toml::Table)) -> String {
    let path = format!("{}/scenarios/comparison.toml", env!("CARGO_MANIFEST_DIR"));
    let mut t: toml::Table = std::fs::read_to_string(&path).unwrap().parse().unwrap();
    edit(&mut t);
    lasercal::scenario::ScenarioFile::parse(&t.to_string(), "s.toml")
        .err()
        .expect("refused")
        .to_string()
}

fn set(t: &mut toml::Table, path: &[&str], v: toml::Value) {
    let mut cur = t;
    for k in &path[..path.len() - 1] {
        cur = cur
            .entry(k.to_string())
            .or_insert_with(|| toml::Value::Table(Default::default()))
            .as_table_mut()
            .unwrap();
    }
    cur.insert(path[path.len() - 1].to_string(), v);
}

#[test]
fn nan_and_inf_are_refused_by_key() {
    // Each of these passed validation, or panicked, or was blamed on another key.
    for (path, v) in [
        (&["vibration", "band_high_hz"][..], f64::INFINITY),
        (&["vibration", "profile_rate_hz"][..], f64::NAN),
        (&["table", "height_mm"][..], f64::NAN),
        (&["edge", "validation", "sigma_mm"][..], f64::NAN),
        (&["edge", "arc_radius_mm"][..], f64::NAN),
        (&["specimen", "radius_mm"][..], f64::NEG_INFINITY),
    ] {
        let e = scenario_error(&|t| set(t, path, toml::Value::Float(v)));
        let key = path.join(".");
        assert!(
            e.contains(&format!("{key} = ")) && e.contains("not a finite number"),
            "{key}: {e}"
        );
    }
}

#[test]
fn sizes_are_bounded_before_anything_is_allocated() {
    // A ball of 1e9 mm (288 GB of arc points) and a 5e-324 mm sample step.
    let e = scenario_error(&|t| {
        set(
            t,
            &["ball", "specimen", "radius_mm"],
            toml::Value::Float(1e9),
        )
    });
    assert!(
        e.contains("ball.specimen.radius_mm") && e.contains("100000"),
        "{e}"
    );
    let e = scenario_error(&|t| {
        set(
            t,
            &["ball", "source"],
            toml::Value::String("analytic".into()),
        );
        set(t, &["ball", "x_step_mm"], toml::Value::Float(5e-324));
    });
    assert!(e.contains("ball.x_step_mm"), "{e}");
    // Trials beyond any machine (aborted allocating).
    let (code, _, err) = common::lasercal(&[
        "check",
        &common::scen("chen2018-disk.toml"),
        "--trials",
        "100000000000",
        "--max-rotation-deg",
        "1",
        "--max-translation-mm",
        "1",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--trials"), "{err}");
}
