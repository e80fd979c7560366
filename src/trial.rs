//! One trial: simulate the captures of a scenario, calibrate with a method, score against the
//! truth. Its numbers depend only on (scenario, seed, trial index).

use crate::calib::{PoseError, Status};
use crate::rng::{self, tag};
use crate::scenario::Setup;
use nalgebra::{Isometry3, Vector3};

/// What a successful calibration gave.
#[derive(Debug, Clone, PartialEq)]
pub struct Score {
    pub estimate: Isometry3<f64>,
    pub error: PoseError,
    /// Distance of the reconstructed specimen centre from the true one (disk, ball), mm.
    pub centre_error_mm: f64,
    /// The method's own accuracy figure (disk paper Sec. III-D), mm.
    pub accuracy_mm: f64,
    pub status: Status,
    pub centre_in_base: Vector3<f64>,
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
        error: PoseError::between(&sol.flange_to_sensor, &setup.rig.flange_to_sensor),
        centre_error_mm: (sol.centre_in_base - d.target.centre.coords).norm() * 1e3,
        accuracy_mm: sol.accuracy * 1e3,
        status: sol.status,
        centre_in_base: sol.centre_in_base,
        estimate: sol.flange_to_sensor,
    });
    (result.map_err(|e| e.to_string()), missed)
}
