//! One trial: simulate the captures of a scenario, calibrate with a method, score against the
//! truth. Its numbers depend only on (scenario, seed, trial index).

use crate::calib::{PoseError, Status};
use crate::rng::{self, tag};
use crate::scenario::Setup;
use nalgebra::Isometry3;

/// What a successful calibration gave.
#[derive(Debug, Clone, PartialEq)]
pub struct Score {
    pub estimate: Isometry3<f64>,
    pub error: PoseError,
    /// Distance of the reconstructed specimen centre from the true one (disk, ball), mm.
    pub centre_error_mm: Option<f64>,
    /// The method's own accuracy figure: the spread of the specimen centres (disk paper Sec.
    /// III-D, Eq. 56), mm.
    pub accuracy_mm: Option<f64>,
    /// Edge method: mean angle of the group edge directions from the global one (Table 1), deg.
    pub edge_angle_dev_deg: Option<f64>,
    /// Edge method: mean distance of the points from the fitted edge (Table 2), mm.
    pub edge_distance_mm: Option<f64>,
    /// Edge method: radius of the precision ball reconstructed with the estimate (Table 3), mm.
    pub sphere_radius_mm: Option<f64>,
    pub status: Status,
}

impl Score {
    fn new(estimate: Isometry3<f64>, truth: &Isometry3<f64>, status: Status) -> Score {
        Score {
            error: PoseError::between(&estimate, truth),
            estimate,
            centre_error_mm: None,
            accuracy_mm: None,
            edge_angle_dev_deg: None,
            edge_distance_mm: None,
            sphere_radius_mm: None,
            status,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct TrialOutcome {
    pub trial: u64,
    pub method: String,
    /// The score, or why the method failed on this trial's data.
    pub result: Result<Score, String>,
    /// Profiles in which the feature could not be found.
    pub missed_profiles: usize,
}

/// Run trial `trial` of `method` on a built scenario.
pub fn run_trial(setup: &Setup, method: &str, seed: u64, trial: u64) -> TrialOutcome {
    let mut r = rng::stream(seed, &[tag::TRIAL, trial]);
    let (result, missed) = match method {
        "disk" => disk_trial(setup, &mut r),
        "ball" => ball_trial(setup, &mut r),
        "edge" => edge_trial(setup, &mut r),
        other => (
            Err(format!(
                "method '{other}' is not available for this scenario"
            )),
            0,
        ),
    };
    TrialOutcome {
        trial,
        method: method.to_string(),
        result,
        missed_profiles: missed,
    }
}

fn disk_trial(setup: &Setup, r: &mut rng::Rng) -> (Result<Score, String>, usize) {
    let Some(d) = &setup.disk else {
        return (Err("the scenario has no disk plan".into()), 0);
    };
    let Some((scans, missed)) = crate::scenario::disk_scans(setup, r) else {
        return (Err("the scenario has no disk plan".into()), 0);
    };
    let mut problem = crate::calib::disk::DiskProblem::new(d.target.radius, scans);
    problem.min_scan_angle = (d.min_angle * 0.5).min(1f64.to_radians());
    let result = crate::calib::disk::solve(&problem).map(|sol| Score {
        centre_error_mm: Some((sol.centre_in_base - d.target.centre.coords).norm() * 1e3),
        accuracy_mm: Some(sol.accuracy * 1e3),
        ..Score::new(
            sol.flange_to_sensor,
            &setup.rig.flange_to_sensor,
            sol.status,
        )
    });
    (result.map_err(|e| e.to_string()), missed)
}

fn ball_trial(setup: &Setup, r: &mut rng::Rng) -> (Result<Score, String>, usize) {
    let Some(b) = &setup.ball else {
        return (Err("the scenario has no ball plan".into()), 0);
    };
    let problem = if b.raycast {
        let noisy = !setup.rig.sensor.noise.is_off();
        crate::sim::ball::raycast_problem(
            &setup.rig,
            &b.scene,
            &b.target,
            &b.plan,
            noisy.then_some(r),
        )
    } else {
        crate::sim::ball::analytic_problem(&setup.rig, &b.target, &b.plan, b.x_step, b.sigma, r)
    };
    let result = problem
        .and_then(|p| crate::calib::ball::solve(&p).map_err(|e| e.to_string()))
        .map(|sol| Score {
            centre_error_mm: Some((sol.centre_in_base - b.target.centre.coords).norm() * 1e3),
            accuracy_mm: Some(sol.spread * 1e3),
            ..Score::new(
                sol.flange_to_sensor,
                &setup.rig.flange_to_sensor,
                sol.status,
            )
        });
    (result, 0)
}

fn edge_trial(setup: &Setup, r: &mut rng::Rng) -> (Result<Score, String>, usize) {
    let Some(e) = &setup.edge else {
        return (Err("the scenario has no edge plan".into()), 0);
    };
    // The Table 3 scan draws from its own stream, so it never shifts the calibration's draws.
    let validation_seed: u64 = rand::RngExt::random(r);
    let (problem, missed) = if e.raycast {
        let noisy = !setup.rig.sensor.noise.is_off();
        let (p, m) = crate::sim::edge::raycast_problem(
            &setup.rig,
            &e.scene,
            &e.target,
            &e.plans,
            noisy.then_some(&mut *r),
        );
        (Ok(p), m)
    } else {
        (
            crate::sim::edge::analytic_problem(&setup.rig, &e.target, &e.plans, e.sigma, r),
            0,
        )
    };
    let result = problem
        .and_then(|p| crate::calib::edge::solve(&p).map_err(|er| er.to_string()))
        .map(|sol| {
            let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
            let radius = e
                .validation
                .as_ref()
                .and_then(|(ball, groups, translations, sigma)| {
                    let mut vr = rng::stream(validation_seed, &[rng::tag::SPECIMEN]);
                    crate::sim::edge::ball_radius_check(
                        &setup.rig,
                        &sol.flange_to_sensor,
                        ball,
                        *groups,
                        *translations,
                        *sigma,
                        0.1e-3,
                        &mut vr,
                    )
                });
            Score {
                edge_angle_dev_deg: Some(mean(&sol.group_angle_dev).to_degrees()),
                edge_distance_mm: Some(mean(&sol.point_distances) * 1e3),
                sphere_radius_mm: radius.map(|x| x * 1e3),
                ..Score::new(
                    sol.flange_to_sensor,
                    &setup.rig.flange_to_sensor,
                    sol.status,
                )
            }
        });
    (result, missed)
}
