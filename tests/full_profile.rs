//! Issue 14, item 2: `disk-full` refines over the disk's face points (up to 64 per profile, their
//! distance from the plane) besides the chord ends; `edge-full` over the bar's face points besides
//! the edge points.

mod common;

use lasercal::calib::PoseError;
use lasercal::calib::refine::Options;
use lasercal::method::{Estimator, Kind, MethodId, calibrate, estimate};
use lasercal::scenario::{ScenarioFile, Setup};
use nalgebra::{DVector, Isometry3, UnitQuaternion, Vector3};

const FULL: MethodId = MethodId::new(Kind::Disk, Estimator::FullProfile);

fn comparison() -> Setup {
    let text = std::fs::read_to_string(common::scen("comparison.toml")).unwrap();
    let sf = ScenarioFile::parse(&text, "comparison.toml").unwrap();
    sf.scenario.build(&sf.file).unwrap()
}

#[test]
fn the_full_profile_jacobian_matches_finite_differences() {
    // disk-full (chord ends and face points) and edge-full (edge points and the bar's face) on
    // the comparison rig's ray-cast captures, away from the optimum.
    let s = comparison();
    for (kind, min_rows_per_profile, step) in [
        (Kind::Disk, 4, [1e-3, 2e-3, -1e-3, 0.02, -0.01]),
        (Kind::Edge, 1, [0.01, -0.02, 0.015, 1e-3, -2e-3]),
    ] {
        let caps = lasercal::trial::trial_captures(&s, kind, 1, 0).0.unwrap();
        let cal = calibrate(&caps, &s.rig.sensor).unwrap();
        let p = cal
            .full_profile
            .clone()
            .expect("ray-cast captures have face points");
        assert!(p.n_params() == 11, "{kind}");
        let p = p.with_specimen_step(&step);
        let x = cal.flange_to_sensor
            * Isometry3::from_parts(
                Vector3::new(1e-3, -2e-3, 1.5e-3).into(),
                UnitQuaternion::from_scaled_axis(Vector3::new(0.01, -0.02, 0.015)),
            );
        let (r0, j) = p.residuals_and_jacobian(&x);
        // Features (chord ends: two residuals each; edge points: one) and face points (one each).
        let feature_rows = min_rows_per_profile * caps.profiles.len();
        assert!(
            r0.len() > feature_rows + 1000,
            "{kind}: {} residuals",
            r0.len()
        );
        let h = 1e-6;
        let mut worst: f64 = 0.0;
        for c in 0..j.ncols() {
            let mut dx = DVector::zeros(j.ncols());
            dx[c] = h;
            let rp = p.residuals_after_step(&x, &dx);
            dx[c] = -h;
            let rm = p.residuals_after_step(&x, &dx);
            let fd = (rp - rm) / (2.0 * h);
            let scale = j.column(c).amax().max(1e-3);
            worst = worst.max((fd - j.column(c)).amax() / scale);
        }
        assert!(
            worst < 1e-6,
            "{kind}: Jacobian off by {worst:.2e} (relative)"
        );
    }
}

#[test]
fn the_full_profile_refinement_reaches_one_minimum() {
    // From the closed form and from the truth: the same transform (to a thousandth of its sd).
    let s = comparison();
    for trial in 0..3 {
        let caps = lasercal::trial::trial_captures(&s, Kind::Disk, 1, trial)
            .0
            .unwrap();
        let cal = calibrate(&caps, &s.rig.sensor).unwrap();
        let p = cal.full_profile.clone().unwrap();
        let a = p
            .refine(&cal.flange_to_sensor, &Options::default())
            .unwrap();
        let b = p
            .refine(&s.rig.flange_to_sensor, &Options::default())
            .unwrap();
        let d = PoseError::between(&a.flange_to_sensor, &b.flange_to_sensor);
        assert!(
            d.rotation_error_deg < 1e-3 * a.sd_rotation_deg.max()
                && d.translation_error_mm < 1e-3 * a.sd_translation_mm.max(),
            "trial {trial}: {d:?}"
        );
        assert!(matches!(
            a.status,
            lasercal::calib::Status::Converged { .. }
        ));
    }
}

#[test]
fn full_profile_against_chord_ends_on_the_comparison_rig() {
    // Median over 30 trials (the comparison rig: Gocator 2340, z noise 0.02-0.06 mm, quantised).
    let s = comparison();
    let refined = MethodId::new(Kind::Disk, Estimator::Refined);
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for trial in 0..30 {
        let caps = lasercal::trial::trial_captures(&s, Kind::Disk, 1, trial)
            .0
            .unwrap();
        for (id, out) in [(refined, &mut a), (FULL, &mut b)] {
            let (cal, _) = estimate(id, &caps, &s.rig.sensor).unwrap();
            out.push(PoseError::between(
                &cal.flange_to_sensor,
                &s.rig.flange_to_sensor,
            ));
        }
    }
    let median = |v: &[PoseError], f: fn(&PoseError) -> f64| {
        let mut x: Vec<f64> = v.iter().map(f).collect();
        x.sort_by(f64::total_cmp);
        x[x.len() / 2]
    };
    let (ra, ta) = (
        median(&a, |e| e.rotation_error_deg),
        median(&a, |e| e.translation_error_mm),
    );
    let (rb, tb) = (
        median(&b, |e| e.rotation_error_deg),
        median(&b, |e| e.translation_error_mm),
    );
    eprintln!(
        "disk-refined {ra:.4} deg / {ta:.4} mm, disk-full {rb:.4} deg / {tb:.4} mm (medians)"
    );
    assert!(
        tb < ta && rb < ra,
        "disk-full is no better: {rb} / {tb} against {ra} / {ta}"
    );
}
