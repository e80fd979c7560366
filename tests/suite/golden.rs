//! Every scenario in scenarios/ gives the same trials.csv and summary.csv as recorded in
//! tests/golden/ (two trials per grid point; scenarios without a sweep get a one-point grid).
//! A deliberate change of numbers re-records them with `LASERCAL_BLESS=1 cargo test --test suite golden::`
//! and names the reason in the commit.

use crate::common;
use common::lasercal;
use std::path::{Path, PathBuf};

const TRIALS: &str = "8";

fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

/// The scenario to sweep: the file itself, or (without a [sweep]) a copy with a one-point grid
/// over its own seed, written next to the output.
fn sweepable(path: &Path, tmp: &Path) -> PathBuf {
    let text = std::fs::read_to_string(path).unwrap();
    if text.lines().any(|l| l.trim() == "[sweep]") {
        return path.to_path_buf();
    }
    let seed = text
        .lines()
        .find_map(|l| {
            l.trim()
                .strip_prefix("seed = ")
                .map(|s| s.trim().to_string())
        })
        .unwrap_or_else(|| "1".into());
    let copy = tmp.join(path.file_name().unwrap());
    std::fs::write(
        &copy,
        format!(
            "{text}\n[sweep]\ntrials = 2\ndraws = \"common\"\n[sweep.grid]\n\"seed\" = [{seed}]\n"
        ),
    )
    .unwrap();
    copy
}

#[test]
fn every_scenario_reproduces_its_recorded_outputs() {
    let bless = std::env::var_os("LASERCAL_BLESS").is_some();
    let tmp = tempfile::tempdir().unwrap();
    let mut scenarios: Vec<PathBuf> =
        std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .collect();
    scenarios.sort();
    assert!(scenarios.len() >= 13, "{scenarios:?}");
    let mut differ = Vec::new();
    for path in &scenarios {
        let stem = path.file_stem().unwrap().to_string_lossy().into_owned();
        let out = tmp.path().join(&stem);
        let file = sweepable(path, tmp.path());
        let (code, _, err) = lasercal(&[
            "sweep",
            file.to_str().unwrap(),
            "--trials",
            TRIALS,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{stem}: {err}");
        for f in ["trials.csv", "summary.csv"] {
            let got = std::fs::read_to_string(out.join(f)).unwrap();
            let want_path = golden_dir().join(&stem).join(f);
            if bless {
                std::fs::create_dir_all(want_path.parent().unwrap()).unwrap();
                std::fs::write(&want_path, &got).unwrap();
                continue;
            }
            let want = std::fs::read_to_string(&want_path)
                .unwrap_or_else(|e| panic!("{}: {e}", want_path.display()));
            if got != want {
                let line = got
                    .lines()
                    .zip(want.lines())
                    .position(|(a, b)| a != b)
                    .map(|i| i + 1)
                    .unwrap_or(got.lines().count().min(want.lines().count()) + 1);
                differ.push(format!("{stem}/{f}: first difference at line {line}"));
            }
        }
    }
    assert!(differ.is_empty(), "outputs changed:\n{}", differ.join("\n"));
}
