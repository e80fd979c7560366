//! The guide's Slurm job array (docs/guide/sweeps.md), run on a real cluster: one node on this machine
//! (`.ci/slurm-up` installs Slurm from the distribution's packages and starts munge, slurmctld and
//! slurmd; `.ci/run` calls it). The array's shards are merged with the guide's command and must be
//! byte for byte the unsharded sweep. Under CI a Slurm that is not up fails the test with the
//! reason; elsewhere the test says it was skipped.

use crate::common;

use std::path::Path;
use std::process::Command;

/// Whether a Slurm node is up and idle; under CI, a panic saying why not.
fn slurm_up() -> bool {
    let out = Command::new("sinfo").args(["-h", "-o", "%T"]).output();
    let why = match &out {
        Err(e) => format!("`sinfo` cannot run ({e}): Slurm is not installed"),
        Ok(o) if !o.status.success() => format!(
            "`sinfo` failed: {}",
            String::from_utf8_lossy(&o.stderr).trim()
        ),
        Ok(o)
            if !String::from_utf8_lossy(&o.stdout)
                .lines()
                .any(|l| l == "idle") =>
        {
            format!(
                "no idle node: {}",
                String::from_utf8_lossy(&o.stdout).trim()
            )
        }
        Ok(_) => return true,
    };
    assert!(
        std::env::var_os("CI").is_none(),
        "Slurm is required under CI and is not up: {why}; `.ci/slurm-up` starts it (see its output)"
    );
    eprintln!("SKIPPED: {why} (run .ci/slurm-up as root to start a one-node cluster)");
    false
}

/// The guide's `sh` block holding the job array, as written.
fn readme_job_script() -> String {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/guide/sweeps.md"))
            .unwrap();
    text.split("```sh\n")
        .skip(1)
        .map(|b| b.split("```").next().unwrap())
        .find(|b| b.contains("#SBATCH --array"))
        .expect("docs/guide/sweeps.md shows a Slurm job array")
        .to_string()
}

fn run(dir: &Path, path: &str, cmd: &str) {
    let out = Command::new("bash")
        .args(["-c", cmd])
        .current_dir(dir)
        .env("PATH", path)
        .env("LASERCAL_MAX_TRIALS", "40")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "`{cmd}` failed:\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn the_readme_job_array_runs_on_slurm_and_merges_to_the_unsharded_bytes() {
    if !slurm_up() {
        return;
    }
    let root = env!("CARGO_MANIFEST_DIR");
    let dir = tempfile::tempdir().unwrap();
    for d in ["scenarios", "robots"] {
        std::os::unix::fs::symlink(format!("{root}/{d}"), dir.path().join(d)).unwrap();
    }
    let script = readme_job_script();
    std::fs::write(dir.path().join("job.sh"), &script).unwrap();
    let bin = Path::new(env!("CARGO_BIN_EXE_lasercal")).parent().unwrap();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    // The array as written, but one CPU a task (the machine has two) and 40 trials in all (two a
    // task): `--wait` returns when every task has ended, with the worst task's exit status.
    run(
        dir.path(),
        &path,
        "timeout 900 sbatch --wait --quiet --cpus-per-task=1 --time=10 job.sh",
    );
    let tasks = std::fs::read_dir(dir.path().join("shards"))
        .unwrap()
        .count();
    assert_eq!(tasks, 20, "one shard folder per array task");
    // The guide's merge command (a comment in the script), then the unsharded sweep.
    let merge = script
        .lines()
        .find_map(|l| {
            l.trim_start_matches(['#', ' '])
                .strip_prefix("lasercal merge")
        })
        .expect("the script names its merge command");
    run(dir.path(), &path, &format!("lasercal merge{merge}"));
    let sweep = script
        .lines()
        .find(|l| l.starts_with("lasercal sweep"))
        .unwrap();
    let trials = sweep
        .split("--trials ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .unwrap();
    let scenario = sweep.split(' ').nth(2).unwrap();
    run(
        dir.path(),
        &path,
        &format!("lasercal sweep {scenario} --trials {trials} --out unsharded"),
    );
    let merged = merge.split("--out ").nth(1).unwrap().trim();
    common::assert_same_sweep_outputs(
        &dir.path().join("unsharded"),
        &dir.path().join(merged),
        "the guide's job array, merged",
    );
    let rows = std::fs::read_to_string(dir.path().join("unsharded/trials.csv")).unwrap();
    assert!(rows.lines().count() > 40, "{rows}");
}
