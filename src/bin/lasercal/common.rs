//! Helpers shared by the subcommands.

use anyhow::Result;
use lasercal::scenario::ScenarioFile;
use std::path::Path;

/// Load a scenario file with a clear error.
pub fn load_scenario(path: &Path) -> Result<ScenarioFile> {
    Ok(ScenarioFile::load(path)?)
}

/// A progress bar on stderr when it is a terminal and not under CI; hidden otherwise.
pub fn progress(total: u64, what: &str) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    let quiet = std::env::var_os("CI").is_some() || !std::io::stderr().is_terminal();
    if quiet {
        return indicatif::ProgressBar::hidden();
    }
    let pb = indicatif::ProgressBar::new(total);
    pb.set_style(
        indicatif::ProgressStyle::with_template(
            "{msg} [{bar:40}] {pos}/{len} trials, {per_sec}, ETA {eta}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    pb.set_message(what.to_string());
    pb
}

/// A 4x4 pose (mm) printed as rows.
pub fn matrix_text(rows: &[[f64; 4]; 4]) -> String {
    rows.iter()
        .map(|r| {
            format!(
                "  [{:>11.6} {:>11.6} {:>11.6} {:>12.5}]",
                r[0], r[1], r[2], r[3]
            )
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Print a refinement's predicted uncertainty and observability; the same as JSON.
pub fn refinement(
    method: lasercal::method::MethodId,
    r: &lasercal::calib::refine::Refined,
) -> serde_json::Value {
    let o = &r.observability;
    let (sr, st) = (r.sd_rotation_deg, r.sd_translation_mm);
    println!(
        "{method}: predicted sd: rotation about sensor x/y/z {:.4} / {:.4} / {:.4} deg, \
         translation along flange x/y/z {:.4} / {:.4} / {:.4} mm; cost {:.3e} -> {:.3e}, \
         residual RMS {:.4} mm",
        sr.x,
        sr.y,
        sr.z,
        st.x,
        st.y,
        st.z,
        r.initial_cost,
        r.cost,
        r.residual_rms * 1e3
    );
    println!(
        "{method}: observability: singular values {:.3?} (condition {:.1}); weakest: {}",
        o.singular_values, o.condition, o.weakest
    );
    serde_json::json!({
        "sd_rotation_deg": [sr.x, sr.y, sr.z],
        "sd_translation_mm": [st.x, st.y, st.z],
        "initial_cost": r.initial_cost,
        "cost": r.cost,
        "residual_rms_mm": r.residual_rms * 1e3,
        "singular_values": o.singular_values,
        "condition": o.condition,
        "weakest": o.weakest,
    })
}
