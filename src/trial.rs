//! One trial: simulate the captures of a scenario, calibrate with a method, score against the
//! truth. Its numbers depend only on (scenario, seed, trial index).

use crate::calib::refine::Refined;
use crate::calib::{PoseError, Status};
use crate::captures::Captures;
use crate::error::Error;
use crate::method::Calibration;
use crate::method::{Kind, MethodId, Sim};
use crate::metrics::{Metric, Metrics};
use crate::rng::{self, tag};
use crate::scenario::Setup;
use crate::sim::disturb::Disturbance;
use nalgebra::Isometry3;

/// What a successful calibration gave.
#[derive(Debug, Clone, PartialEq)]
pub struct Score {
    pub estimate: Isometry3<f64>,
    /// Every figure the method reports (errors against the truth and its own figures).
    pub metrics: Metrics,
    pub status: Status,
    /// Refined methods: the refinement (uncertainty, observability, costs).
    pub refined: Option<Refined>,
    /// The truth-free verdict on the result (its figures are in `metrics` too).
    pub judged: crate::method::verdict::Judged,
}

impl Score {
    /// The errors of the estimate against the truth.
    pub fn error(&self) -> PoseError {
        let g = |m| self.metrics.get(m).unwrap_or(f64::NAN);
        PoseError {
            rotation_error_deg: g(Metric::RotationError),
            translation_error_mm: g(Metric::TranslationError),
            frobenius_rotation: g(Metric::FrobeniusRotation),
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct TrialOutcome {
    pub trial: u64,
    pub method: MethodId,
    /// The score, or why the method failed on this trial's data.
    pub result: Result<Score, Error>,
    /// Profiles in which the feature could not be found.
    pub missed_profiles: usize,
}

/// Run trial `trial` of `method` on a built scenario: simulate the captures, calibrate them with
/// the estimator (the code a capture file from a real rig goes through), score.
pub fn run_trial(setup: &Setup, method: MethodId, seed: u64, trial: u64) -> TrialOutcome {
    let (caps, validation_seed) = trial_captures(setup, method.kind, seed, trial);
    let estimate = caps.and_then(|caps| {
        crate::method::estimate(method, &caps, &setup.rig.sensor).map(|(c, r)| (c, r, caps))
    });
    let (result, missed) = match estimate {
        Err(e) => (Err(e), 0),
        Ok((cal, refined, caps)) => {
            let judged = crate::method::verdict::judge(crate::method::verdict::quality(
                &cal,
                refined.as_ref(),
                method.estimator,
                &caps,
                &setup.rig.sensor,
            ));
            let slid = placement(setup.placement_jitter, seed, trial);
            let mut s = score(setup, method.kind, &cal, validation_seed, slid, judged);
            s.refined = refined;
            (Ok(s), cal.missed)
        }
    };
    TrialOutcome {
        trial,
        method,
        result,
        missed_profiles: missed,
    }
}

/// The captures of trial `trial` of a specimen method (exactly those `run_trial` calibrates) and
/// the seed of its truth checks (the edge paper's Table 3 scan).
pub fn trial_captures(
    setup: &Setup,
    kind: Kind,
    seed: u64,
    trial: u64,
) -> (Result<Captures, Error>, u64) {
    let mut r = rng::stream(seed, &[tag::TRIAL, trial]);
    // The Table 3 scan of the edge method draws from its own stream.
    let validation_seed: u64 = rand::RngExt::random(&mut r);
    (simulate(setup, kind, seed, trial, &mut r), validation_seed)
}

/// Trial `trial`'s slide of every pose (the specimen's placement, `[placement]`): uniform within
/// +-`jitter` (m) along base x and y, from its own stream (none without jitter).
fn placement(jitter: f64, seed: u64, trial: u64) -> nalgebra::Vector3<f64> {
    if !(jitter > 0.0) {
        return nalgebra::Vector3::zeros();
    }
    let mut r = rng::stream(seed, &[tag::PLACEMENT, trial]);
    let mut axis = || rand::RngExt::random_range(&mut r, -jitter..=jitter);
    nalgebra::Vector3::new(axis(), axis(), 0.0)
}

fn simulate(
    setup: &Setup,
    kind: Kind,
    seed: u64,
    trial: u64,
    r: &mut rng::Rng,
) -> Result<Captures, Error> {
    // Robot error and vibration draw from their own stream: switched off, nothing changes.
    let mut disturbance = Disturbance::new(
        &setup.rig.robot,
        setup.robot_error,
        setup.vibration,
        rng::stream(seed, &[tag::ROBOT_ERROR, trial]),
    )
    .with_placement(placement(setup.placement_jitter, seed, trial));
    if let Some(d) = &setup.dynamics {
        let gains = crate::sim::dynamics::ServoGains {
            stiffness: d.stiffness,
            damping: d.damping,
        };
        let arm = crate::sim::dynamics::ArmDynamics::new(&setup.rig.robot, gains, d.dt_ms * 1e-3)?;
        disturbance.dynamic = Some(crate::sim::disturb::Dynamic {
            arm,
            settle_s: d.settle_ms * 1e-3,
            speed_fraction: d.speed_fraction,
        });
    }
    // The specimen's imperfection likewise: the true radius is nominal + z * tolerance (z
    // standard normal), then the form error; the captures carry the nominal radius.
    let mut specimen_rng = rng::stream(seed, &[tag::SPECIMEN, trial]);
    let radius_z = rng::gauss(&mut specimen_rng);
    let plan = setup.plan(kind)?;
    let mut caps = plan.simulate(
        &setup.rig,
        &mut Sim {
            rng: r,
            mover: crate::method::Mover::new(&mut disturbance),
            specimen_rng: &mut specimen_rng,
            radius_z,
        },
    )?;
    // The rig states its robot's accuracy and repeatability as a real cell would (0 without
    // robot error): the error its arm's one draw makes as the accuracy, what each pose draws
    // alone as the repeatability. Vibration stays with the accuracy: sampled at the profile
    // rate, neighbouring profiles share it.
    let (robot, vibration) = (
        setup.robot_error.common_sd(&setup.rig.robot),
        if setup.vibration.is_off() {
            0.0
        } else {
            setup.vibration.amplitude_rms
        },
    );
    caps.judging.robot_accuracy = robot.hypot(vibration);
    caps.judging.robot_repeatability = setup.robot_error.own_sd(&setup.rig.robot);
    // And its arm's kinematic error, which the bound carries through each pose's configuration
    // (not where the arm is the dynamic model's, which moves the nominal arm).
    let err = &setup.robot_error;
    if (err.link_error > 0.0 || err.joint_offset_error > 0.0) && setup.dynamics.is_none() {
        caps.kinematic = crate::captures::Kinematic::new(
            setup.rig.robot.source.clone(),
            std::sync::Arc::new(setup.rig.robot.clone()),
            err.link_error,
            err.joint_offset_error,
            caps.profiles.iter().map(|p| (&p.base_to_flange, None)),
        )
        .ok();
    }
    // The rig's mounting as designed: what a drawing of a real cell states.
    caps.judging.nominal = Some(setup.rig.flange_to_sensor);
    Ok(caps)
}

/// The verdict's figures as metrics (trials.csv's columns).
fn with_verdict(m: Metrics, j: &crate::method::verdict::Judged) -> Metrics {
    use crate::method::verdict::Verdict;
    let (sr, st) = j.quality.worst_sd();
    let (br, bt) = j.quality.error_bound();
    let finite = |v: f64| v.is_finite().then_some(v);
    let ok = |e: Metric| m.get(e).filter(|_| j.verdict == Verdict::Ok);
    let covered = match (
        m.get(Metric::RotationError),
        m.get(Metric::TranslationError),
    ) {
        (Some(r), Some(t)) => Some(f64::from(r <= br && t <= bt)),
        _ => None,
    };
    m.with(Metric::NoiseRatio, j.quality.noise_ratio.and_then(finite))
        .with(Metric::PredictedSdRotation, finite(sr))
        .with(Metric::PredictedSdTranslation, finite(st))
        .with(
            Metric::Suspect,
            Some(f64::from(j.verdict == Verdict::Suspect)),
        )
        .with(Metric::BoundRotation, finite(br))
        .with(Metric::BoundTranslation, finite(bt))
        .with(
            Metric::Imprecise,
            Some(f64::from(j.verdict == Verdict::Imprecise)),
        )
        .with(Metric::Covered, covered)
        .with(Metric::RotationErrorOk, ok(Metric::RotationError))
        .with(Metric::TranslationErrorOk, ok(Metric::TranslationError))
}

/// Score a calibration of a specimen method against the scenario's truth. `placement`: the
/// trial's slide of every pose (`placement`), which the captures' poses do not show: through
/// them the specimen sits that much the other way.
pub fn score(
    setup: &Setup,
    kind: Kind,
    cal: &Calibration,
    validation_seed: u64,
    placement: nalgebra::Vector3<f64>,
    judged: crate::method::verdict::Judged,
) -> Score {
    let e = PoseError::between(&cal.flange_to_sensor, &setup.rig.flange_to_sensor);
    let plan = setup.plan(kind).ok();
    let mut metrics = cal.figures;
    metrics.set(Metric::RotationError, Some(e.rotation_error_deg));
    metrics.set(Metric::TranslationError, Some(e.translation_error_mm));
    metrics.set(Metric::FrobeniusRotation, Some(e.frobenius_rotation));
    metrics.set(
        Metric::CentreError,
        cal.centre_in_base
            .zip(plan.and_then(|p| p.true_centre()))
            .map(|(c, t)| (c - (t.coords - placement)).norm() * 1e3),
    );
    if let Some(p) = plan {
        for (m, v) in p
            .truth_checks(&setup.rig, &cal.flange_to_sensor, validation_seed)
            .present()
        {
            metrics.set(m, Some(v));
        }
    }
    Score {
        estimate: cal.flange_to_sensor,
        status: cal.status,
        refined: None,
        metrics: with_verdict(metrics, &judged),
        judged,
    }
}
