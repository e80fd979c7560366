//! A verdict with every calibration: truth-free quality figures of the variant that produced the
//! transform (its residuals at that transform, the predicted uncertainty, the conditioning, the
//! profiles it could not use), and `ok` or `suspect` with the reasons.
//!
//! The residual test is chi-square-type: with residuals r_i of stated standard deviation sigma,
//! sum (r_i / sigma)^2 over the degrees of freedom has mean 1 and standard deviation
//! sqrt(2 / dof). The stated noise of a real sensor is a data-sheet figure, not a measured one, so
//! the test allows the noise to be `NOISE_FACTOR` times the statement before it calls the
//! residuals inconsistent.

use super::Calibration;
use crate::calib::Status;
use crate::calib::refine::Refined;
use crate::captures::{Captures, ProfileData};
use crate::sensor::SensorModel;
use nalgebra::Matrix6;

/// How many times the stated noise the residuals may show before the data are called
/// inconsistent with the noise model.
pub const NOISE_FACTOR: f64 = 2.0;
/// The chi-square test's one-sided 99.9 % normal quantile.
const Z_999: f64 = 3.09;
/// A predicted standard deviation beyond a third of these is suspect: the result could be this
/// far off (deg, mm).
pub const MAX_ERROR_DEG: f64 = 1.0;
pub const MAX_ERROR_MM: f64 = 1.0;
/// The share of profiles whose feature may be rejected before the rest are not trusted.
pub const MAX_REJECTED_SHARE: f64 = 0.5;
/// The observability's condition (largest over smallest singular value, rotations scaled to
/// displacements 0.1 m away) beyond which a pose set is near-degenerate.
pub const MAX_CONDITION: f64 = 1e4;

/// Truth-free figures of one calibration result.
#[derive(Debug, Clone, PartialEq)]
pub struct Quality {
    /// Residual RMS at the result (mm) under the variant's own residual model; None when the
    /// captures hold only reduced features (circles) that no residual model takes.
    pub residual_rms_mm: Option<f64>,
    /// The noise the data state (mm, one standard deviation per residual): the features' stated
    /// noise, or for raw profiles the sensor's z noise with its column spacing and quantum.
    pub stated_noise_mm: Option<f64>,
    /// Residual RMS over the stated noise, and the largest the test allows.
    pub noise_ratio: Option<f64>,
    pub noise_ratio_bound: Option<f64>,
    pub n_residuals: usize,
    /// Predicted standard deviations: rotation about the sensor's x/y/z (deg), translation along
    /// the flange's x/y/z (mm), from the 6x6 covariance (rotation rad, translation m).
    pub sd_rotation_deg: [f64; 3],
    pub sd_translation_mm: [f64; 3],
    pub covariance: Option<Matrix6<f64>>,
    /// Observability: condition and the least determined direction in words.
    pub condition: Option<f64>,
    pub weakest: Option<String>,
    /// How far the result is from the least-squares fit of its own features (one Gauss-Newton
    /// step; deg, mm): a closed form's inefficiency or a wrong label shows here. None for a
    /// refined result (it is that fit).
    pub from_fit_deg: Option<f64>,
    pub from_fit_mm: Option<f64>,
    pub status: Status,
    /// Profiles in the captures and those whose feature was rejected.
    pub profiles: usize,
    pub rejected: usize,
}

impl Quality {
    /// The correlations of the covariance (unit diagonal).
    pub fn correlations(&self) -> Option<Matrix6<f64>> {
        let c = self.covariance?;
        let d: Vec<f64> = (0..6).map(|i| c[(i, i)].max(0.0).sqrt()).collect();
        Some(Matrix6::from_fn(|r, k| {
            if d[r] > 0.0 && d[k] > 0.0 && d[r].is_finite() && d[k].is_finite() {
                c[(r, k)] / (d[r] * d[k])
            } else {
                f64::NAN
            }
        }))
    }

    /// The largest predicted standard deviation of the rotation (deg) and translation (mm).
    pub fn worst_sd(&self) -> (f64, f64) {
        let m = |v: &[f64; 3]| v.iter().fold(0.0f64, |a, &b| a.max(b));
        (m(&self.sd_rotation_deg), m(&self.sd_translation_mm))
    }

    /// How far off the result could be (deg, mm): its distance from the fit of its own data plus
    /// three predicted standard deviations of that fit.
    pub fn error_bound(&self) -> (f64, f64) {
        let (sr, st) = self.worst_sd();
        (
            self.from_fit_deg.unwrap_or(0.0) + 3.0 * sr,
            self.from_fit_mm.unwrap_or(0.0) + 3.0 * st,
        )
    }
}

/// `ok` or `suspect`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    Ok,
    Suspect,
}

impl std::fmt::Display for Verdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Verdict::Ok => "ok",
            Verdict::Suspect => "suspect",
        })
    }
}

/// The verdict and why.
#[derive(Debug, Clone, PartialEq)]
pub struct Judged {
    pub quality: Quality,
    pub verdict: Verdict,
    /// One sentence per reason, each saying what to check or collect; empty when `ok`.
    pub reasons: Vec<String>,
}

/// The noise a residual of these captures has, as the data state it (metres).
pub fn stated_noise(caps: &Captures, sensor: &SensorModel) -> Option<f64> {
    let raw = caps
        .profiles
        .iter()
        .all(|p| matches!(p.data, ProfileData::Raw(_)));
    if !raw {
        return caps.feature_sigma;
    }
    // A point's depth noise, its lateral jitter, and for a feature placed at a profile's end
    // (chord end, edge point) the column spacing: the end lies anywhere within one step, uniform,
    // an RMS of step / sqrt(3) from the last column.
    let n = &sensor.noise;
    let z = n.z_sigma_near.max(n.z_sigma_far) * n.dark_noise_factor.max(1.0);
    let step = sensor.x_step_at_depth(sensor.depth_far);
    let q = sensor.z_quantum.unwrap_or(0.0);
    Some((z * z + n.x_sigma * n.x_sigma + step * step / 3.0 + q * q / 12.0).sqrt())
}

/// The quality figures of a result: `refined` when the variant refined (its own figures), else
/// the closed form judged under the feature model at its transform.
pub fn quality(
    cal: &Calibration,
    refined: Option<&Refined>,
    caps: &Captures,
    sensor: &SensorModel,
) -> Quality {
    let assessed;
    let mut step = None;
    let figures = match refined {
        Some(r) => Some(r),
        None => match &cal.refinable {
            Some(p) => {
                let (f, s) = crate::calib::refine::assess(&**p, &cal.flange_to_sensor, cal.status);
                assessed = f;
                step = Some(s);
                Some(&assessed)
            }
            None => None,
        },
    };
    let noise = stated_noise(caps, sensor).filter(|s| *s > 0.0);
    let rms = figures.map(|f| f.residual_rms);
    let dof = figures.map(|f| f.n_residuals.saturating_sub(f.n_params).max(1));
    let bound = dof.map(|d| NOISE_FACTOR * (1.0 + Z_999 * (2.0 / d as f64).sqrt()).sqrt());
    Quality {
        residual_rms_mm: rms.map(|r| r * 1e3),
        stated_noise_mm: noise.map(|s| s * 1e3),
        noise_ratio: rms.zip(noise).map(|(r, s)| r / s),
        noise_ratio_bound: bound.filter(|_| noise.is_some()),
        n_residuals: figures.map_or(0, |f| f.n_residuals),
        sd_rotation_deg: figures.map_or([f64::NAN; 3], |f| f.sd_rotation_deg.into()),
        sd_translation_mm: figures.map_or([f64::NAN; 3], |f| f.sd_translation_mm.into()),
        covariance: figures.map(|f| f.covariance),
        condition: figures.map(|f| f.observability.condition),
        weakest: figures.map(|f| f.observability.weakest.clone()),
        from_fit_deg: step.map(|s| s.fixed_rows::<3>(0).norm().to_degrees()),
        from_fit_mm: step.map(|s| s.fixed_rows::<3>(3).norm() * 1e3),
        status: cal.status,
        profiles: caps.profiles.len(),
        rejected: cal.missed,
    }
}

/// Judge a result from its quality figures.
pub fn judge(q: Quality) -> Judged {
    let mut reasons = Vec::new();
    if let (Some(ratio), Some(bound), Some(rms), Some(noise)) = (
        q.noise_ratio,
        q.noise_ratio_bound,
        q.residual_rms_mm,
        q.stated_noise_mm,
    ) && !(ratio <= bound)
    {
        reasons.push(format!(
            "the residuals do not fit the noise model: RMS {rms:.4} mm is {ratio:.1} times the \
             stated noise {noise:.4} mm (at most {bound:.2} passes); check the specimen's size, \
             the group signs or edge sense, the sensor's noise figures and the robot's accuracy"
        ));
    }
    if let Some(c) = q.condition
        && !(c <= MAX_CONDITION)
    {
        reasons.push(format!(
            "the pose set is near-degenerate (condition {c:.3e}, above {MAX_CONDITION:.0e}): the \
             {} is barely determined; add poses that move it",
            q.weakest.as_deref().unwrap_or("weakest direction")
        ));
    }
    let (br, bt) = q.error_bound();
    if q.covariance.is_some() && (!(br <= MAX_ERROR_DEG) || !(bt <= MAX_ERROR_MM)) {
        let (sr, st) = q.worst_sd();
        let mut why = format!(
            "the result could be off by {br:.3} deg / {bt:.3} mm (more than {MAX_ERROR_DEG} deg \
             or {MAX_ERROR_MM} mm): predicted sd up to {sr:.3} deg and {st:.3} mm"
        );
        match (q.from_fit_deg, q.from_fit_mm) {
            (Some(d), Some(m)) if d > 3.0 * sr || m > 3.0 * st => {
                why += &format!(
                    ", and {d:.3} deg / {m:.3} mm from the least-squares fit of its own features \
                     (use the refined or any-pose variant, or check the labels)"
                );
            }
            _ => why += "; collect more or more varied poses",
        }
        reasons.push(why);
    }
    if q.profiles > 0 && q.rejected as f64 > MAX_REJECTED_SHARE * q.profiles as f64 {
        reasons.push(format!(
            "{} of {} profiles were rejected (more than {:.0} %): the rest may not be \
             representative; check the sensor's exposure and the specimen's placement",
            q.rejected,
            q.profiles,
            MAX_REJECTED_SHARE * 100.0
        ));
    }
    if let Status::NotConverged { iterations } = q.status {
        reasons.push(format!(
            "the refinement did not converge in {iterations} iterations"
        ));
    }
    Judged {
        verdict: if reasons.is_empty() {
            Verdict::Ok
        } else {
            Verdict::Suspect
        },
        reasons,
        quality: q,
    }
}

/// One variant's result on a capture set, judged.
#[derive(Debug, Clone)]
pub struct Assessed {
    pub method: super::MethodId,
    pub calibration: Calibration,
    pub refined: Option<Refined>,
    pub judged: Judged,
}

impl Assessed {
    /// The error bound in units of the suspect limits (below 1: within them).
    fn score(&self) -> f64 {
        let (r, t) = self.judged.quality.error_bound();
        let s = (r / MAX_ERROR_DEG).max(t / MAX_ERROR_MM);
        if s.is_nan() { f64::INFINITY } else { s }
    }
}

/// Calibrate with one variant and judge the result.
pub fn assess(
    method: super::MethodId,
    caps: &Captures,
    sensor: &SensorModel,
) -> Result<Assessed, crate::error::Error> {
    let (calibration, refined) = super::estimate(method, caps, sensor)?;
    let judged = judge(quality(&calibration, refined.as_ref(), caps, sensor));
    Ok(Assessed {
        method,
        calibration,
        refined,
        judged,
    })
}

/// Every variant of the captures' specimen method, each judged or with why it could not run.
pub fn assess_every(
    caps: &Captures,
    sensor: &SensorModel,
) -> Vec<(super::MethodId, Result<Assessed, crate::error::Error>)> {
    caps.method
        .estimators()
        .iter()
        .map(|&e| {
            let id = super::MethodId::new(caps.method, e);
            (id, assess(id, caps, sensor))
        })
        .collect()
}

/// The best result: the smallest error bound among those judged ok, else among all (first in
/// the estimators' order on a tie). None when no variant ran.
pub fn best(results: &[(super::MethodId, Result<Assessed, crate::error::Error>)]) -> Option<usize> {
    let ran = || {
        results
            .iter()
            .enumerate()
            .filter_map(|(i, (_, r))| r.as_ref().ok().map(|a| (i, a)))
    };
    let pick = |ok_only: bool| {
        ran()
            .filter(|(_, a)| !ok_only || a.judged.verdict == Verdict::Ok)
            .min_by(|x, y| x.1.score().total_cmp(&y.1.score()))
            .map(|(i, _)| i)
    };
    pick(true).or_else(|| pick(false))
}

/// Variants judged ok that disagree beyond both of their error bounds: one of their model
/// assumptions (a label, the radius) is wrong. A reason per disagreeing variant.
pub fn disagreements(
    results: &[(super::MethodId, Result<Assessed, crate::error::Error>)],
    chosen: usize,
) -> Vec<String> {
    let Some(Ok(c)) = results.get(chosen).map(|r| &r.1) else {
        return Vec::new();
    };
    let (cr, ct) = c.judged.quality.error_bound();
    results
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != chosen)
        .filter_map(|(_, (_, r))| r.as_ref().ok())
        .filter(|o| o.judged.verdict == Verdict::Ok)
        .filter_map(|o| {
            let e = crate::calib::PoseError::between(
                &c.calibration.flange_to_sensor,
                &o.calibration.flange_to_sensor,
            );
            let (or, ot) = o.judged.quality.error_bound();
            (e.rotation_error_deg > cr + or || e.translation_error_mm > ct + ot).then(|| {
                format!(
                    "{} and {} disagree by {:.3} deg / {:.3} mm, more than their error bounds \
                     allow: a label (sign, edge sense) or the specimen's size fits one model \
                     and not the other",
                    c.method, o.method, e.rotation_error_deg, e.translation_error_mm
                )
            })
        })
        .collect()
}

/// How much one group moves the result: the variant re-run without each group in turn.
#[derive(Debug, Clone, PartialEq)]
pub struct LeaveOneOut {
    /// Groups left out in turn, and the runs that could not calibrate without them.
    pub runs: usize,
    pub failed: usize,
    /// The largest change of the result (deg, mm) and the group that made it.
    pub rotation_deg: f64,
    pub translation_mm: f64,
    pub group: usize,
}

/// Groups of more than this many are not left out one by one (the figure would cost as many
/// calibrations).
pub const MAX_LEAVE_ONE_OUT: usize = 64;

/// Leave each group out in turn and re-run `a`'s variant. None when there are fewer than two
/// groups or more than `MAX_LEAVE_ONE_OUT`.
pub fn leave_one_out(a: &Assessed, caps: &Captures, sensor: &SensorModel) -> Option<LeaveOneOut> {
    let n = caps.groups.len();
    if !(2..=MAX_LEAVE_ONE_OUT).contains(&n) {
        return None;
    }
    let mut out = LeaveOneOut {
        runs: n,
        failed: 0,
        rotation_deg: 0.0,
        translation_mm: 0.0,
        group: caps.groups[0].id,
    };
    let mut worst = -1.0;
    for g in &caps.groups {
        let mut c = caps.clone();
        c.groups.retain(|h| h.id != g.id);
        c.profiles.retain(|p| p.group != g.id);
        match super::estimate(a.method, &c, sensor) {
            Err(_) => out.failed += 1,
            Ok((cal, _)) => {
                let e = crate::calib::PoseError::between(
                    &cal.flange_to_sensor,
                    &a.calibration.flange_to_sensor,
                );
                let s = (e.rotation_error_deg / MAX_ERROR_DEG)
                    .max(e.translation_error_mm / MAX_ERROR_MM);
                if s > worst {
                    worst = s;
                    out.rotation_deg = e.rotation_error_deg;
                    out.translation_mm = e.translation_error_mm;
                    out.group = g.id;
                }
            }
        }
    }
    Some(out)
}

/// The leave-one-out figure's reason, when one group moves the result beyond the limits.
pub fn leave_one_out_reason(l: &LeaveOneOut) -> Option<String> {
    (l.rotation_deg > MAX_ERROR_DEG || l.translation_mm > MAX_ERROR_MM).then(|| {
        format!(
            "leaving out group {} moves the result by {:.3} deg / {:.3} mm: the result hangs on \
             one group; check that group's captures",
            l.group, l.rotation_deg, l.translation_mm
        )
    })
}

impl Judged {
    /// Add reasons found beyond the result's own figures (other variants, leave-one-out).
    pub fn add_reasons(&mut self, more: impl IntoIterator<Item = String>) {
        self.reasons.extend(more);
        if !self.reasons.is_empty() {
            self.verdict = Verdict::Suspect;
        }
    }
}

/// The hand-given group signs the data contradict: when the closed form (the one variant that
/// uses them) is judged suspect or disagrees with `chosen`, each group's sign is flipped in turn;
/// a flip that makes the closed form ok and agree with `chosen` names a wrong sign. A reason
/// naming them, or None.
pub fn contradicted_signs(
    caps: &Captures,
    sensor: &SensorModel,
    chosen: &Assessed,
    closed_form: Option<&Assessed>,
) -> Option<String> {
    let m = super::method(caps.method);
    if !m.uses_group_signs() || chosen.judged.verdict != Verdict::Ok {
        return None;
    }
    let id = super::MethodId::new(caps.method, super::Estimator::ClosedForm);
    let agrees = |a: &Assessed| {
        let e = crate::calib::PoseError::between(
            &a.calibration.flange_to_sensor,
            &chosen.calibration.flange_to_sensor,
        );
        let (ar, at) = a.judged.quality.error_bound();
        let (cr, ct) = chosen.judged.quality.error_bound();
        a.judged.verdict == Verdict::Ok
            && e.rotation_error_deg <= ar + cr
            && e.translation_error_mm <= at + ct
    };
    let own;
    let closed_form = match closed_form {
        Some(a) => a,
        None => match assess(id, caps, sensor) {
            Ok(a) => {
                own = a;
                &own
            }
            // Without the closed form nothing tests the signs.
            Err(_) => return None,
        },
    };
    if agrees(closed_form) {
        return None;
    }
    let flipped: Vec<usize> = caps
        .groups
        .iter()
        .enumerate()
        .filter(|(_, g)| g.sign != 0.0)
        .filter(|&(i, _)| {
            let mut c = caps.clone();
            c.groups[i].sign = -c.groups[i].sign;
            assess(id, &c, sensor).is_ok_and(|a| agrees(&a))
        })
        .map(|(_, g)| g.id)
        .collect();
    let named = if flipped.is_empty() {
        "no single flip makes it agree".to_string()
    } else {
        format!(
            "with the sign of group {} flipped it agrees",
            flipped
                .iter()
                .map(|g| g.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )
    };
    Some(format!(
        "the file's group signs (s_i) contradict the data: the closed form, which uses them, \
         does not agree with {} ({named}); correct the signs or leave them out",
        chosen.method
    ))
}
