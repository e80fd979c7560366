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
        vec!["ik", "irb120", "374", "0", "630", "0.7071068", "0", "0.7071068", "0"],
        vec!["run", &disk],
        vec!["calibrate", caps.to_str().unwrap()],
        vec!["check", &disk, "--trials", "2", "--max-rotation-deg", "1", "--max-translation-mm", "1"],
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
