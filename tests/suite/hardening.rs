//! Bad environments and bad inputs (issue 15, item 4): a clean error naming what failed, never a
//! panic, a hang or a huge allocation. Each case failed (exit 101, abort or hang) before its fix.

use crate::common;

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

/// Shards 1..3 of xu2021-rotations (6 trials) in `dir`/s1..s3.
fn shards(dir: &std::path::Path) -> Vec<String> {
    (1..=3)
        .map(|k| {
            let d = dir.join(format!("s{k}")).to_str().unwrap().to_string();
            let (code, _, err) = common::lasercal(&[
                "sweep",
                &common::scen("xu2021-rotations.toml"),
                "--trials",
                "6",
                "--shard",
                &format!("{k}/3"),
                "--out",
                &d,
            ]);
            assert_eq!(code, 0, "{err}");
            d
        })
        .collect()
}

#[test]
fn merge_checks_every_row_against_its_shard() {
    let dir = tempfile::tempdir().unwrap();
    let s = shards(dir.path());
    let out = dir.path().join("m").to_str().unwrap().to_string();
    let trials = |k: usize| std::path::Path::new(&s[k]).join("trials.csv");
    let original: Vec<String> = (0..3)
        .map(|k| std::fs::read_to_string(trials(k)).unwrap())
        .collect();
    let merge = |expect: &str| {
        let (code, _, err) = common::lasercal(&["merge", &s[0], &s[1], &s[2], "--out", &out]);
        assert_eq!(code, 2, "{expect}: {err}");
        assert!(
            err.contains(expect) && !err.contains("panicked"),
            "{expect}: {err}"
        );
        assert!(
            std::path::Path::new(&out).join("INCOMPLETE").exists()
                || !std::path::Path::new(&out).join("summary.csv").exists(),
            "{expect}: a refused merge must not look complete"
        );
    };
    let restore = || {
        for k in 0..3 {
            std::fs::write(trials(k), &original[k]).unwrap();
        }
    };
    // Shard 2's trials.csv copied over shard 1's.
    std::fs::write(trials(0), &original[1]).unwrap();
    merge("belongs to shard 2/3");
    restore();
    // A duplicated row.
    let mut lines: Vec<&str> = original[0].lines().collect();
    lines.insert(2, lines[1]);
    std::fs::write(trials(0), lines.join("\n") + "\n").unwrap();
    merge("repeats or is out of order");
    restore();
    // A NaN, an unknown method, a point outside the grid.
    let first_row = original[0].lines().nth(1).unwrap().to_string();
    let header = original[0].lines().next().unwrap();
    let col = |name: &str| header.split(',').position(|h| h == name).unwrap();
    let edit = |c: usize, v: &str| {
        let mut f: Vec<String> = first_row.split(',').map(String::from).collect();
        f[c] = v.into();
        original[0].replacen(&first_row, &f.join(","), 1)
    };
    std::fs::write(trials(0), edit(col("rotation_error_deg"), "NaN")).unwrap();
    merge("not a finite number");
    std::fs::write(trials(0), edit(col("method"), "disk")).unwrap();
    merge("not in the scenario's methods");
    std::fs::write(trials(0), edit(col("point"), "999")).unwrap();
    merge("outside the sweep");
    restore();
    // The output is one of the inputs.
    let (code, _, err) = common::lasercal(&["merge", &s[0], &s[1], &s[2], "--out", &s[1]]);
    assert_eq!(code, 2);
    assert!(err.contains("that is shard folder"), "{err}");
    // Restored, it merges, and the folder is complete.
    let (code, _, err) = common::lasercal(&["merge", &s[0], &s[1], &s[2], "--out", &out]);
    assert_eq!(code, 0, "{err}");
    let m = std::path::Path::new(&out);
    assert!(m.join("summary.csv").exists() && !m.join("INCOMPLETE").exists());
}

#[test]
fn a_sweep_marks_its_folder_until_done_and_replaces_an_old_run() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    let o = out.to_str().unwrap();
    // An old run's outputs, one of which this run would not rewrite were it not cleared.
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("summary.csv"), "stale\n").unwrap();
    std::fs::write(out.join("plot.png"), "stale").unwrap();
    let (code, _, err) = common::lasercal(&[
        "sweep",
        &common::scen("xu2021-rotations.toml"),
        "--trials",
        "2",
        "--out",
        o,
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("replacing the previous run's"), "{err}");
    assert_ne!(
        std::fs::read_to_string(out.join("summary.csv")).unwrap(),
        "stale\n"
    );
    assert!(!out.join("INCOMPLETE").exists());
    assert!(!out.join(".trials.csv.partial").exists());
    // Interrupted: the marker stays and no trials.csv appears under its real name.
    let out2 = dir.path().join("killed");
    let mut child = Command::new(env!("CARGO_BIN_EXE_lasercal"))
        .args([
            "sweep",
            &common::scen("chen2018-fig15.toml"),
            "--out",
            out2.to_str().unwrap(),
        ])
        .env("CI", "1")
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let marker = out2.join("INCOMPLETE");
    for _ in 0..200 {
        if marker.exists() {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(25));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(marker.exists(), "the marker is written first");
    assert!(!out2.join("trials.csv").exists() && !out2.join("summary.csv").exists());
}

#[test]
fn a_grid_beyond_a_million_points_is_refused_before_it_is_built() {
    let hundred: Vec<toml::Value> = (0..100)
        .map(|i| toml::Value::Float(0.01 * i as f64))
        .collect();
    let e = scenario_error(&|t| {
        let grid = t["sweep"]["grid"].as_table_mut().unwrap();
        grid.clear();
        for k in [
            "sensor.noise.z_sigma_far_mm",
            "sensor.noise.z_sigma_near_mm",
            "sensor.noise.x_sigma_mm",
            "sensor.noise.dropout",
        ] {
            grid.insert(k.into(), toml::Value::Array(hundred.clone()));
        }
    });
    assert!(
        e.contains("sweep.grid") && e.contains("more than 1000000 grid points"),
        "{e}"
    );
}

#[test]
fn an_analytic_disk_out_of_the_sensors_view_is_refused() {
    // The sensor mounted 3 m out: the analytic source gave chords anyway and a confident answer.
    let text = std::fs::read_to_string(common::scen("chen2018-disk.toml")).unwrap();
    let far: String = text
        .lines()
        .map(|l| {
            if l.starts_with("mount_position_mm") {
                "mount_position_mm = [6.0, 54.0, 3000.0]".to_string()
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("far.toml");
    std::fs::write(&p, far).unwrap();
    let (code, _, err) = common::lasercal(&["run", p.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("out of range") && err.contains("mount_position_mm"),
        "{err}"
    );
}
