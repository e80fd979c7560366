//! Helpers shared by the end-to-end tests.
#![allow(dead_code)]

/// Run the `lasercal` binary (with CI set, so no progress bar): exit code, stdout, stderr.
pub fn lasercal(args: &[&str]) -> (i32, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lasercal"))
        .args(args)
        .env("CI", "1")
        .output()
        .expect("run lasercal");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Path of a file in scenarios/.
pub fn scen(name: &str) -> String {
    format!("{}/scenarios/{name}", env!("CARGO_MANIFEST_DIR"))
}
