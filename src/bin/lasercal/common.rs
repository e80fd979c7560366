//! Helpers shared by the subcommands.

use anyhow::Result;
use lasercal::scenario::ScenarioFile;
use std::path::Path;

/// Load a scenario file with a clear error.
pub fn load_scenario(path: &Path) -> Result<ScenarioFile> {
    Ok(ScenarioFile::load(path)?)
}

/// Progress of a long run on stderr: a bar on a terminal; off a terminal (a batch job, CI, a
/// pipe) a line every 10 s, so a long run is never silent.
pub struct Progress {
    bar: Option<indicatif::ProgressBar>,
    what: String,
    total: u64,
    done: std::sync::atomic::AtomicU64,
    started: std::time::Instant,
    last_line: std::sync::Mutex<std::time::Instant>,
    every_s: f64,
}

/// Seconds between progress lines off a terminal (`LASERCAL_PROGRESS_EVERY_S` overrides it).
fn line_every_s() -> f64 {
    std::env::var("LASERCAL_PROGRESS_EVERY_S")
        .ok()
        .and_then(|v| v.parse().ok())
        .filter(|v: &f64| *v >= 0.0)
        .unwrap_or(10.0)
}

impl Progress {
    pub fn inc(&self, n: u64) {
        let done = self.done.fetch_add(n, std::sync::atomic::Ordering::Relaxed) + n;
        self.show(done);
    }

    pub fn set_position(&self, done: u64) {
        self.done.store(done, std::sync::atomic::Ordering::Relaxed);
        self.show(done);
    }

    fn show(&self, done: u64) {
        if let Some(b) = &self.bar {
            b.set_position(done);
            return;
        }
        let Ok(mut last) = self.last_line.lock() else {
            return;
        };
        if last.elapsed().as_secs_f64() < self.every_s {
            return;
        }
        *last = std::time::Instant::now();
        let t = self.started.elapsed().as_secs_f64();
        let eta = if done > 0 {
            t * (self.total.saturating_sub(done)) as f64 / done as f64
        } else {
            f64::NAN
        };
        note!(
            "{}: {done} of {} trials ({:.0} %), {t:.0} s, about {eta:.0} s to go",
            self.what,
            self.total,
            100.0 * done as f64 / self.total.max(1) as f64
        );
    }

    pub fn finish_and_clear(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

/// Progress on stderr: a bar on a terminal (not under CI), lines every 10 s otherwise.
pub fn progress(total: u64, what: &str) -> Progress {
    use std::io::IsTerminal;
    let terminal = std::env::var_os("CI").is_none() && std::io::stderr().is_terminal();
    let bar = terminal.then(|| {
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
    });
    Progress {
        bar,
        what: what.to_string(),
        total,
        done: std::sync::atomic::AtomicU64::new(0),
        started: std::time::Instant::now(),
        last_line: std::sync::Mutex::new(std::time::Instant::now()),
        every_s: line_every_s(),
    }
}

/// A spinner naming the stage of a one-off run (`calibrate` of a continuous scan's thousands of
/// profiles takes seconds), on a terminal only and only once the run has taken a second: a
/// quick run prints nothing extra, and off a terminal the output stays clean.
pub struct Stage(Option<indicatif::ProgressBar>);

impl Stage {
    pub fn start(what: &str) -> Stage {
        use std::io::IsTerminal;
        let terminal = std::env::var_os("CI").is_none() && std::io::stderr().is_terminal();
        Stage(terminal.then(|| {
            let pb = indicatif::ProgressBar::hidden();
            pb.set_style(
                indicatif::ProgressStyle::with_template("{spinner} {msg} ({elapsed})")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
            );
            pb.set_message(what.to_string());
            let shown = pb.clone();
            // Drawn from the second second on, ticking a few times a second.
            std::thread::spawn(move || {
                std::thread::sleep(std::time::Duration::from_secs(1));
                if !shown.is_finished() {
                    shown.set_draw_target(indicatif::ProgressDrawTarget::stderr());
                    shown.enable_steady_tick(std::time::Duration::from_millis(200));
                }
            });
            pb
        }))
    }

    pub fn next(&self, what: &str) {
        if let Some(pb) = &self.0 {
            pb.set_message(what.to_string());
        }
    }

    pub fn done(&self) {
        if let Some(pb) = &self.0 {
            pb.finish_and_clear();
        }
    }
}

impl Drop for Stage {
    /// Cleared on every way out, an error's included, so no spinner line is left behind.
    fn drop(&mut self) {
        self.done();
    }
}

/// `LASERCAL_MAX_TRIALS`, when set: the most trials a sweep point or `check` runs (the README
/// command test runs every documented command in seconds with it). Said on stderr when it cuts.
pub fn trials_cap(trials: usize) -> usize {
    let cap = std::env::var("LASERCAL_MAX_TRIALS")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
        .filter(|c| *c >= 1);
    match cap {
        Some(c) if c < trials => {
            note!("LASERCAL_MAX_TRIALS={c}: {trials} trials cut to {c}");
            c
        }
        _ => trials,
    }
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

/// A refinement's figures as JSON (printed by `verdict_text`).
pub fn refinement(r: &lasercal::calib::refine::Refined) -> serde_json::Value {
    let o = &r.observability;
    let (sr, st) = (r.sd_rotation_deg, r.sd_translation_mm);
    serde_json::json!({
        "sd_rotation_deg": [sr.x, sr.y, sr.z],
        "sd_translation_mm": [st.x, st.y, st.z],
        "initial_cost": r.initial_cost,
        "cost": r.cost,
        "residual_rms_mm": r.residual_rms * 1e3,
        "singular_values": o.singular_values,
        "condition": o.condition,
        "weakest": o.weakest,
        "status": r.status,
    })
}

/// Print a result's quality figures and verdict (one block) and return them as JSON.
pub fn verdict_text(
    method: lasercal::method::MethodId,
    j: &lasercal::method::verdict::Judged,
    loo: Option<&lasercal::method::verdict::LeaveOneOut>,
) -> Result<serde_json::Value> {
    print_figures(method, j, loo)?;
    print_verdict(method, j)?;
    Ok(verdict_json(j, loo))
}

/// The truth-free figures' lines: residuals, predicted sd, observability, correlations, the
/// distance from the fit, leave-one-out and rejected profiles.
fn print_figures(
    method: lasercal::method::MethodId,
    j: &lasercal::method::verdict::Judged,
    loo: Option<&lasercal::method::verdict::LeaveOneOut>,
) -> Result<()> {
    let q = &j.quality;
    let f3 = |v: &[f64; 3], d: usize| {
        v.iter()
            .map(|x| format!("{x:.d$}"))
            .collect::<Vec<_>>()
            .join(" / ")
    };
    match (q.residual_rms_mm, q.stated_noise_mm, q.noise_ratio_bound) {
        (Some(rms), Some(noise), Some(bound)) => say!(
            "{method}: residual RMS {rms:.4} mm over {} residuals = {:.2} x the stated noise \
             {noise:.4} mm (passes up to {bound:.2})",
            q.n_residuals,
            rms / noise
        ),
        (Some(rms), _, _) => say!(
            "{method}: residual RMS {rms:.4} mm over {} residuals (no noise stated: give the \
             sensor's noise or feature_sigma_mm to test it)",
            q.n_residuals
        ),
        _ => say!("{method}: no residuals (the captures hold fitted features only)"),
    }
    if q.covariance.is_some() {
        say!(
            "{method}: predicted sd from the sensor's noise alone: rotation about sensor x/y/z {} \
             deg, translation along flange x/y/z {} mm",
            f3(&q.sd_rotation_deg, 4),
            f3(&q.sd_translation_mm, 4)
        );
    }
    if let (Some(c), Some(w)) = (q.condition, &q.weakest) {
        say!("{method}: observability condition {c:.1}; weakest: {w}");
    }
    let names = ["rx", "ry", "rz", "tx", "ty", "tz"];
    let mut strong = Vec::new();
    if let Some(cor) = q.correlations() {
        for r in 0..6 {
            for c in r + 1..6 {
                if cor[(r, c)].abs() > 0.9 {
                    strong.push(format!("{}-{} {:+.2}", names[r], names[c], cor[(r, c)]));
                }
            }
        }
    }
    if !strong.is_empty() {
        say!("{method}: correlations above 0.9: {}", strong.join(", "));
    }
    if let (Some(d), Some(m)) = (q.from_fit_deg, q.from_fit_mm) {
        say!("{method}: {d:.4} deg / {m:.4} mm from the least-squares fit of its own features");
    }
    if let Some(l) = loo.filter(|l| l.failed == l.runs) {
        say!(
            "{method}: leave one group out: no run could calibrate without any one of the {} \
             groups (the protocol needs them all)",
            l.runs
        );
    } else if let Some(l) = loo {
        say!(
            "{method}: leave one group out ({} runs{}): the result moves up to {:.4} deg / {:.4} \
             mm (group {})",
            l.runs,
            if l.failed > 0 {
                format!(", {} could not calibrate", l.failed)
            } else {
                String::new()
            },
            l.rotation_deg,
            l.translation_mm,
            l.group
        );
    }
    if q.rejected > 0 {
        say!(
            "{method}: {} of {} profiles rejected",
            q.rejected,
            q.profiles
        );
    }
    Ok(())
}

/// The bound's line, the verdict and its reasons.
fn print_verdict(
    method: lasercal::method::MethodId,
    j: &lasercal::method::verdict::Judged,
) -> Result<()> {
    let q = &j.quality;
    let (br, bt) = q.error_bound();
    if let Some(b) = &q.bounds {
        let f = |v: &[f64; 3]| v.map(|x| format!("{x:.4}")).join("/");
        say!(
            "{method}: 95 % error bound {br:.4} deg / {bt:.4} mm (per axis: rotation about the \
             sensor's x/y/z {} deg, translation along the flange's x/y/z {} mm; {} poses{}{})",
            f(&b.rotation_deg),
            f(&b.translation_mm),
            q.poses,
            match q.orientation_groups {
                0 => String::new(),
                g => format!(" in {g} orientations"),
            },
            // Printed from 1.05 (a factor that rounds to 1.0 widened nothing a user sees).
            q.inflation
                .filter(|f| *f >= 1.05)
                .map_or(String::new(), |f| format!(
                    ", widened {f:.1} times by the scatter between poses{}",
                    q.group_widening
                        .filter(|w| *w > 1.0)
                        .map_or(String::new(), |w| format!(
                            " ({w:.2} of it shared by poses of one orientation)"
                        ))
                ))
        );
    }
    say!(
        "{method}: verdict {} (tolerance {} deg / {} mm)",
        j.verdict,
        q.judging.tolerance_deg,
        q.judging.tolerance_mm
    );
    for r in j.lines() {
        say!("  - {r}");
    }
    Ok(())
}

/// A result's quality figures and verdict as JSON (`quality` in `calibrate --json`).
fn verdict_json(
    j: &lasercal::method::verdict::Judged,
    loo: Option<&lasercal::method::verdict::LeaveOneOut>,
) -> serde_json::Value {
    let q = &j.quality;
    let (br, bt) = q.error_bound();
    let between = q.between_variants.as_ref().map(|v| {
        serde_json::json!({
            "method": v.method,
            "rotation_deg": v.rotation_deg,
            "translation_mm": v.translation_mm,
        })
    });
    let mut doc = serde_json::json!({
        "verdict": j.verdict,
        "reasons": j.reasons,
        "precision": j.precision,
        "notes": j.notes,
        "tolerance_deg": q.judging.tolerance_deg,
        "tolerance_mm": q.judging.tolerance_mm,
        "robot_accuracy_mm": q.judging.robot_accuracy * 1e3,
        "bound_rotation_deg": q.bounds.map(|b| b.rotation_deg),
        "bound_translation_mm": q.bounds.map(|b| b.translation_mm),
        "poses": q.poses,
        "inflation": q.inflation,
        "residual_rms_mm": q.residual_rms_mm,
        "stated_noise_mm": q.stated_noise_mm,
        "noise_ratio": q.noise_ratio,
        "noise_ratio_bound": q.noise_ratio_bound,
        "n_residuals": q.n_residuals,
        "sd_rotation_deg": q.sd_rotation_deg,
        "sd_translation_mm": q.sd_translation_mm,
        "covariance_rad_m": q.covariance.map(|c| (0..6).map(|r| (0..6).map(|k| c[(r, k)]).collect::<Vec<_>>()).collect::<Vec<_>>()),
        "correlations": q.correlations().map(|c| (0..6).map(|r| (0..6).map(|k| c[(r, k)]).collect::<Vec<_>>()).collect::<Vec<_>>()),
        "condition": q.condition,
        "weakest": q.weakest,
        "from_fit_deg": q.from_fit_deg,
        "from_fit_mm": q.from_fit_mm,
        "error_bound_deg": br,
        "error_bound_mm": bt,
        "profiles": q.profiles,
        "rejected_profiles": q.rejected,
        // Scanning on the move: the clock offset estimated (null sd: the motion cannot tell it).
        "clock_offset": q.clock.map(|(c, stated, held)| serde_json::json!({
            "held": held,
            "bias_per_ms_deg_mm": c.bias_per_s.map(|b| [
                (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt().to_degrees() * 1e-3,
                (b[3] * b[3] + b[4] * b[4] + b[5] * b[5]).sqrt(),
            ]),
            "stated_ms": stated * 1e3,
            "estimated_ms": c.sd_s.is_finite().then_some((stated + c.shift_s) * 1e3),
            "sd_ms": c.sd_s.is_finite().then_some(c.sd_s * 1e3),
            "separation": c.separation,
            "drift_ppm": c.drift.map(|(d, _)| d * 1e6),
            "drift_sd_ppm": c.drift.map(|(_, sd)| sd * 1e6),
            // Held because the estimate would put profiles beyond the pose log.
            "off_log_estimate_ms": c.off_log.map(|s| (stated + s) * 1e3),
        })),
        "leave_one_out": loo.map(|l| serde_json::json!({
            "runs": l.runs, "failed": l.failed, "rotation_deg": l.rotation_deg,
            "translation_mm": l.translation_mm, "group": l.group,
            "carriers": l.carriers.iter().map(|(g, w)| serde_json::json!({"group": g, "direction": w})).collect::<Vec<_>>(),
            "outlier": l.outlier.map(|(g, b)| serde_json::json!({"group": g, "beyond_bounds": b})),
            "moves": group_moves(l),
        })),
    });
    // Where another variant's result widened the bound (`verdict::decide`).
    doc["between_variants"] = serde_json::json!(between);
    doc["orientation_groups"] = serde_json::json!(q.orientation_groups);
    // The bounds' own covariance (the sensor's noise and what it leaves out) and its degrees of
    // freedom (the bounds' Student's t).
    doc["bound_covariance_rad_m"] = serde_json::json!(q.bound_covariance.map(|(c, _)| {
        (0..6)
            .map(|r| (0..6).map(|k| c[(r, k)]).collect::<Vec<_>>())
            .collect::<Vec<_>>()
    }));
    doc["bound_dof"] = serde_json::json!(q.bound_covariance.map(|(_, d)| d));
    doc["group_widening"] = serde_json::json!(q.group_widening);
    doc["kinematic"] = serde_json::json!(q.kinematic.as_ref().map(|k| serde_json::json!({
        "robot": k.robot, "link_error_mm": k.link_error_mm,
        "joint_offset_error_deg": k.joint_offset_error_deg, "sd_deg": k.sd_deg, "sd_mm": k.sd_mm,
        // Not stated: an uncalibrated arm's of the stated accuracy (a few scans).
        "assumed": k.assumed,
        // Where assumed: the share of its variance in the joint origins the poses' steps show.
        "link_share_read": k.link_share_read.map(|r| r.0),
        "link_share_read_sd": k.link_share_read.map(|r| r.1),
        // The largest over the arm's other configurations where the joints were not given.
        "other_configurations_sd_deg": k.other_configurations.map(|o| o.0),
        "other_configurations_sd_mm": k.other_configurations.map(|o| o.1),
    })));
    doc["robot_repeatability_mm"] = serde_json::json!(q.judging.robot_repeatability * 1e3);
    doc["radius_tolerance_mm"] = serde_json::json!(q.judging.radius_tolerance * 1e3);
    doc["radius_shift_deg_per_mm"] = serde_json::json!(q.radius_shift.map(|s| s.0));
    doc["radius_shift_mm_per_mm"] = serde_json::json!(q.radius_shift.map(|s| s.1));
    doc["straightness_mm"] = serde_json::json!(q.judging.straightness * 1e3);
    doc["bow_shift_deg_per_mm"] = serde_json::json!(q.bow_shift.map(|s| s.0));
    doc["bow_shift_mm_per_mm"] = serde_json::json!(q.bow_shift.map(|s| s.1));
    doc
}

/// The recordings asked for, opened before any work so that a bad path or a missing viewer
/// fails at once: an .rrd file, a spawned viewer, or both (none when neither is asked for).
#[cfg(feature = "rerun")]
pub type Recorders = Vec<lasercal::io::rerun::Recorder>;
#[cfg(not(feature = "rerun"))]
pub type Recorders = Vec<()>;

#[cfg(not(feature = "rerun"))]
pub fn open_recorders(rerun: Option<&Path>, spawn: bool) -> Result<Recorders> {
    if rerun.is_some() || spawn {
        anyhow::bail!(
            "this lasercal was built without the `rerun` feature: rebuild with default features for --rerun/--spawn"
        );
    }
    Ok(Vec::new())
}

#[cfg(feature = "rerun")]
pub fn open_recorders(
    rerun: Option<&Path>,
    spawn: bool,
) -> Result<Vec<lasercal::io::rerun::Recorder>> {
    use lasercal::io::rerun::Recorder;
    let mut recorders = Vec::new();
    if let Some(p) = rerun {
        recorders.push(Recorder::save(p)?);
    }
    if spawn {
        // Without a display the viewer cannot start and the recording waits for it to connect:
        // fail at once with what to do instead.
        let display = ["DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET"]
            .iter()
            .any(|v| std::env::var_os(v).is_some_and(|x| !x.is_empty()));
        if cfg!(target_os = "linux") && !display {
            anyhow::bail!(
                "--spawn needs a display (DISPLAY and WAYLAND_DISPLAY are not set): record with \
                 --rerun run.rrd and open it with `rerun run.rrd` where there is one"
            );
        }
        recorders.push(Recorder::spawn()?);
    }
    Ok(recorders)
}

/// After recording: name the URDF mesh visuals the recording could not show.
#[cfg(feature = "rerun")]
pub fn warn_skipped_meshes(recorders: &[lasercal::io::rerun::Recorder]) {
    if let Some(r) = recorders.first() {
        let meshes = r.skipped_meshes();
        if !meshes.is_empty() {
            note!(
                "warning: the robot's {} mesh visual(s) are not shown ({}); boxes, cylinders and \
                 spheres are",
                meshes.len(),
                meshes.join(", ")
            );
        }
    }
}

/// The text a recording's summary view shows: what was calibrated, the verdict and its
/// reasons, the error bound, the result line and the recovered matrix.
pub fn summary_text(
    header: &str,
    method: lasercal::method::MethodId,
    j: &lasercal::method::verdict::Judged,
    line: &str,
    flange_to_sensor: &nalgebra::Isometry3<f64>,
) -> String {
    let (br, bt) = j.quality.error_bound();
    let mut s = format!("{header}\n\n{method}: verdict {}\n", j.verdict);
    for r in j.lines() {
        s += &format!("  - {r}\n");
    }
    s += &format!("95 % error bound {br:.4} deg / {bt:.4} mm");
    if let Some(n) = j.quality.noise_ratio {
        s += &format!(", residual {n:.2} x the stated noise");
    }
    format!(
        "{s}\n\n{line}\n\nrecovered flange_to_sensor (mm):\n{}",
        matrix_text(&lasercal::math::pose_to_rows_mm(flange_to_sensor))
    )
}

/// "variant: why it failed", without the specimen's name twice ("ball: ball: ...") where the
/// error names it too.
pub fn failure(id: lasercal::method::MethodId, e: &dyn std::fmt::Display) -> String {
    format!("{id}: {}", without_kind(id, e))
}

/// An error's text without the specimen's name it starts with, for a line that names the
/// variant already.
pub fn without_kind(id: lasercal::method::MethodId, e: &dyn std::fmt::Display) -> String {
    let text = e.to_string();
    let kind = format!("{}: ", id.kind);
    text.strip_prefix(&kind)
        .map_or(text.clone(), str::to_string)
}

/// `verdict::decide`, or an error that lists why every variant failed.
pub fn decide(
    name: &str,
    caps: &lasercal::captures::Captures,
    sensor: &lasercal::sensor::SensorModel,
    method: Option<lasercal::method::MethodId>,
) -> anyhow::Result<lasercal::method::verdict::Decision> {
    lasercal::method::verdict::decide(caps, sensor, method).map_err(|failed| {
        let why: Vec<String> = failed.iter().map(|(id, e)| failure(*id, e)).collect();
        anyhow::anyhow!(
            "{name}: no variant could calibrate:\n  {}",
            why.join("\n  ")
        )
    })
}

/// Each leave-one-group-out run's move from the full result, per axis (deg about the sensor's
/// axes, mm along the flange's).
fn group_moves(l: &lasercal::method::verdict::LeaveOneOut) -> Vec<serde_json::Value> {
    l.moves
        .iter()
        .map(|(g, m)| {
            serde_json::json!({
                "group": g,
                "rotation_deg": [m[0].to_degrees(), m[1].to_degrees(), m[2].to_degrees()],
                "translation_mm": [m[3] * 1e3, m[4] * 1e3, m[5] * 1e3],
            })
        })
        .collect()
}
