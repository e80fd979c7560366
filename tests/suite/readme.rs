//! Every command the README and the guide (docs/guide/) show works as written: each `sh` block's
//! lines run with bash in a scratch folder holding the repository's scenarios and robots, `lasercal` on the
//! PATH, `LASERCAL_MAX_TRIALS=2` so sweeps take seconds, and the files a block names but does not
//! make (a rig's pose list and profiles) prepared from a simulation. `cargo run --release --` is
//! the binary; `cargo test` is this test's own run and is skipped.

use crate::common;

use std::path::Path;
use std::process::Command;

/// A document's `sh` blocks, each as logical lines (continuations joined, comments dropped; a
/// `for ... done` loop kept whole), with the line number each starts on.
fn blocks(text: &str) -> Vec<Vec<(usize, String)>> {
    let mut out = Vec::new();
    // Outside a block: None; inside: Some(the sh block's lines) or Some(None) for another kind.
    let mut cur: Option<Option<Vec<(usize, String)>>> = None;
    let mut pending: Option<(usize, String)> = None;
    for (i, raw) in text.lines().enumerate() {
        if let Some(lang) = raw.strip_prefix("```") {
            cur = match cur.take() {
                Some(Some(b)) => {
                    out.push(b);
                    None
                }
                Some(None) => None,
                None => Some((lang.trim() == "sh").then(Vec::new)),
            };
            continue;
        }
        let Some(Some(b)) = cur.as_mut() else {
            continue;
        };
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        // A trailing comment ("   # what it does").
        let code = match line.find("  #") {
            Some(k) => line[..k].trim_end(),
            None => line,
        };
        let (start, mut acc) = pending.take().unwrap_or((i + 1, String::new()));
        if let Some(head) = code.strip_suffix('\\') {
            acc += head;
            acc.push(' ');
            pending = Some((start, acc));
            continue;
        }
        acc += code;
        if let Some((_, last)) = b
            .last_mut()
            .filter(|(_, l)| l.starts_with("for ") && !l.ends_with("done"))
        {
            *last += "\n";
            *last += &acc;
        } else {
            b.push((start, acc));
        }
    }
    out
}

/// The rig recording the import examples name: the ball-free scenario's captures written out as
/// a pose list (CSV, and in the controllers' own formats) and one profile CSV per pose.
fn rig_recording(dir: &Path) {
    let (_, doc) = common::simulated_capture(dir, "ball-free.toml", ".sim-rig.json");
    common::rig_recording(&doc, dir);
    common::pose_files(&doc, dir);
}

/// The README and the guide's pages: (name, text).
fn documents(root: &str) -> Vec<(String, String)> {
    let mut docs = vec![("README.md".to_string(), format!("{root}/README.md"))];
    let mut guide: Vec<_> = std::fs::read_dir(format!("{root}/docs/guide"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    guide.sort();
    docs.extend(guide.into_iter().map(|p| {
        (
            format!("docs/guide/{}", p.file_name().unwrap().to_string_lossy()),
            p.display().to_string(),
        )
    }));
    docs.into_iter()
        .map(|(name, path)| (name, std::fs::read_to_string(path).unwrap()))
        .collect()
}

#[test]
fn every_readme_and_guide_command_works_as_written() {
    let root = env!("CARGO_MANIFEST_DIR");
    let dir = tempfile::tempdir().unwrap();
    for d in ["scenarios", "robots"] {
        std::os::unix::fs::symlink(format!("{root}/{d}"), dir.path().join(d)).unwrap();
    }
    rig_recording(dir.path());
    let bin = Path::new(env!("CARGO_BIN_EXE_lasercal")).parent().unwrap();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut ran = 0;
    let docs = documents(root);
    let all = docs
        .iter()
        .flat_map(|(name, text)| blocks(text).into_iter().map(move |b| (name, b)));
    for (doc, block) in all {
        for (line_no, cmd) in block {
            if cmd == "cargo test" {
                continue;
            }
            let cmd = cmd.replace("cargo run --release -- ", "lasercal ");
            assert!(
                cmd.starts_with("lasercal ") || cmd.starts_with("for "),
                "{doc} line {line_no}: not a lasercal command: {cmd}"
            );
            let out = Command::new("bash")
                .args(["-c", &cmd])
                .current_dir(dir.path())
                .env("PATH", &path)
                .env("CI", "1")
                .env("LASERCAL_MAX_TRIALS", "2")
                .env("SLURM_ARRAY_TASK_ID", "1")
                .output()
                .unwrap();
            let code = out.status.code().unwrap_or(-1);
            let err = String::from_utf8_lossy(&out.stderr);
            // A calibration judged suspect (3) or imprecise (4) still worked; a viewer needs a
            // display.
            let fine = code == 0
                || ((code == 3 || code == 4) && cmd.contains("calibrate"))
                || (code == 2 && cmd.contains("--spawn") && err.contains("needs a display"));
            assert!(fine, "{doc} line {line_no}: `{cmd}` exited {code}:\n{err}");
            ran += 1;
        }
    }
    assert!(
        ran >= 40,
        "only {ran} commands found in the README and the guide"
    );
}
