//! Issue 14, item 2: `disk-full` refines over the disk's face points (up to 512 per profile, their
//! distance from the plane) and the cylinder's wall points (their distance from the wall) besides
//! the chord ends where no wall shows; `edge-full` over the bar's face points besides the edge
//! points.

use crate::common;

use lasercal::calib::PoseError;
use lasercal::calib::refine::Options;
use lasercal::method::{Estimator, Kind, MethodId, calibrate, estimate};
use lasercal::scenario::{ScenarioFile, Setup};
use nalgebra::{DVector, Isometry3, UnitQuaternion, Vector3};

fn comparison() -> Setup {
    let text = std::fs::read_to_string(common::scen("comparison.toml")).unwrap();
    let sf = ScenarioFile::parse(&text, "comparison.toml").unwrap();
    sf.scenario.build(&sf.file).unwrap()
}

#[test]
fn the_full_profile_jacobian_matches_finite_differences() {
    // disk-full (chord ends, walls and face points; 11 parameters) and edge-full (the bar's face,
    // both edges or their walls; 12) on the comparison rig's ray-cast captures, away from the
    // optimum.
    let s = comparison();
    for (kind, min_rows_per_profile, params, step) in [
        (Kind::Disk, 4, 11, &[1e-3, 2e-3, -1e-3, 0.02, -0.01][..]),
        (
            Kind::Edge,
            2,
            12,
            &[0.01, -0.02, 0.015, 1e-3, -2e-3, 1.5e-3][..],
        ),
    ] {
        let caps = lasercal::trial::trial_captures(&s, kind, 1, 0).0.unwrap();
        let cal = calibrate(&caps, &s.rig.sensor).unwrap();
        let p = cal
            .full_profile
            .clone()
            .expect("ray-cast captures have face points");
        assert!(
            p.n_params() == params,
            "{kind}: {} parameters",
            p.n_params()
        );
        let p = p.with_specimen_step(step);
        let x = cal.flange_to_sensor
            * Isometry3::from_parts(
                Vector3::new(1e-3, -2e-3, 1.5e-3).into(),
                UnitQuaternion::from_scaled_axis(Vector3::new(0.01, -0.02, 0.015)),
            );
        let (r0, j) = p.residuals_and_jacobian(&x);
        // Features (chord ends: two residuals each; edges: one per edge, or a wall's points) and face
        // points (one each).
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

/// Median rotation (deg) and translation (mm) errors of the feature refinement and the
/// full-profile refinement of `kind` over `trials` captures, each made by `make` from lasercal's
/// own capture of that trial.
fn medians(
    s: &Setup,
    kind: Kind,
    trials: u64,
    sensor: &lasercal::sensor::SensorModel,
    make: &dyn Fn(lasercal::captures::Captures, u64) -> lasercal::captures::Captures,
) -> [(f64, f64); 2] {
    let refined = MethodId::new(kind, Estimator::Refined);
    let full = MethodId::new(kind, Estimator::FullProfile);
    let mut errors = [Vec::new(), Vec::new()];
    for trial in 0..trials {
        let caps = lasercal::trial::trial_captures(s, kind, 1, trial)
            .0
            .unwrap();
        let caps = make(caps, trial);
        for (id, out) in [(refined, 0), (full, 1)] {
            let (cal, _) = estimate(id, &caps, sensor).unwrap();
            errors[out].push(PoseError::between(
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
    errors.map(|e| {
        (
            median(&e, |e| e.rotation_error_deg),
            median(&e, |e| e.translation_error_mm),
        )
    })
}

#[test]
fn full_profile_beats_the_chord_ends_on_the_comparison_rig() {
    // Issue 14 asked for 2x better than the feature refinement, and it was (2.1-6x). Since the
    // chord ends stopped taking wall points for the face (twentieth session) the chord ends are
    // better too: on the comparison rig (Gocator 2340, quantised) at far z noise 0.12 mm, 30
    // trials, 1.5x in rotation and 3.4x in translation; since a wall point within the noise is
    // told from the face by the balanced threshold (twenty-first session) the chord ends'
    // translation is better still: 1.7x and 2.4x (0.0027 / 0.0030 against 0.0046 / 0.0070);
    // 200 trials per noise give 1.7-4.3x and 2.2-3.3x (docs/guide/methods.md). 60 trials since
    // the forty-third session: at 30 the translation's median stood 2.04x with the clip at 6
    // and 1.999x at 20 (one trial's place in the order), at 60 2.08x (rotation 2.62x).
    let text = std::fs::read_to_string(common::scen("comparison.toml"))
        .unwrap()
        .replace("z_sigma_far_mm = 0.06", "z_sigma_far_mm = 0.12");
    let sf = ScenarioFile::parse(&text, "comparison.toml").unwrap();
    let s = sf.scenario.build(&sf.file).unwrap();
    let [(ra, ta), (rb, tb)] = medians(&s, Kind::Disk, 60, &s.rig.sensor, &|c, _| c);
    eprintln!(
        "disk-refined {ra:.4} deg / {ta:.4} mm, disk-full {rb:.4} deg / {tb:.4} mm (medians)"
    );
    assert!(
        1.3 * rb <= ra && 2.0 * tb <= ta,
        "disk-full is not 1.3x / 2.0x better: {rb} / {tb} against {ra} / {ta}"
    );
}

/// `medians` on the comparison rig's poses with every profile from the independent generator
/// (`common::fan_295`, its own ray caster and camera occlusion) seeing `solids`, z noise 0.1 mm,
/// declared as such; trial `t`'s profiles are drawn with seed `seed + t`.
fn independent_medians(
    s: &Setup,
    kind: Kind,
    trials: u64,
    solids: &[lasercal::testkit::fan::Solid],
    seed: u64,
) -> [(f64, f64); 2] {
    let fan = common::fan_295();
    let mut sensor = common::declared(&fan, "fan-295");
    sensor.noise.z_sigma_near = 0.1e-3;
    sensor.noise.z_sigma_far = 0.1e-3;
    let noise = lasercal::testkit::fan::Noise {
        sigma_z: 0.1e-3,
        dropout: 0.0,
        sigma_z_far: 0.0,
    };
    medians(s, kind, trials, &sensor, &|c, trial| {
        common::regenerate(&c, s, &fan, solids, noise, seed + trial)
    })
}

#[test]
fn full_profile_beats_chord_ends_on_profiles_lasercal_did_not_make() {
    // The comparison rig's poses, every profile from the independent generator (its own ray
    // caster, cylinder wall and camera occlusion), z noise 0.1 mm; 20 trials. Its camera sees
    // the wall beyond fewer ends, and the chord ends of its unquantised equal-angle rays are
    // good to start with: measured 3.0x in rotation and 1.7x in translation while the chord ends
    // took wall points for the face; since they do not, 1.75x in rotation (0.0044 against 0.0077
    // deg), while in translation the chord ends were the better (0.0035 against 0.0041 mm).
    // With the balanced threshold at the wall's first point (twenty-first session) the chord
    // ends are better in rotation (0.0047 deg) and worse in translation (0.0057 mm), and
    // disk-full better in both: 1.15x and 1.43x (0.0041 deg / 0.0040 mm). Per end, against the
    // exact chords of these profiles (10 trials, 1,000 ends per scan and side, standard error
    // 0.0011 mm), the threshold cut the outward biases on the wall's sides from 0.0029 / 0.0051
    // / 0.0028 mm to 0.0009 / 0.0024 / -0.0004: this one rig's result moved with the biases it
    // keeps (0.0065 mm on a side the wall does not decide, -0.0027 on another).
    use lasercal::testkit::fan::Solid;
    let s = comparison();
    let solids = [
        Solid::DiskOnCylinder {
            frame: s.base_to_specimen,
            radius: 0.050,
            height: 0.020,
        },
        Solid::Table { height: -0.00852 },
    ];
    let [(ra, ta), (rb, tb)] = independent_medians(&s, Kind::Disk, 20, &solids, 100);
    eprintln!(
        "independent profiles: disk-refined {ra:.4} deg / {ta:.4} mm, disk-full {rb:.4} deg / \
         {tb:.4} mm (medians)"
    );
    assert!(
        1.1 * rb <= ra && 1.2 * tb <= ta,
        "disk-full is not 1.1x better in rotation and 1.2x in translation: {rb} / {tb} against \
         {ra} / {ta}"
    );
}

#[test]
fn edge_full_beats_edge_points_on_profiles_lasercal_did_not_make() {
    // The comparison rig's bar poses, every profile from the independent generator (its own ray
    // caster, box and camera occlusion), z noise 0.1 mm; 20 trials: measured 2.7x in rotation and
    // in translation.
    use lasercal::testkit::fan::Solid;
    let s = comparison();
    let (bar, pose) = s
        .plan(Kind::Edge)
        .unwrap()
        .scene()
        .specimens
        .iter()
        .find(|(b, _)| matches!(b.kind, lasercal::scene::SpecimenKind::ParallelBar { .. }))
        .expect("the comparison rig has a parallel bar");
    let solids = [
        common::bar_solid(bar, *pose),
        Solid::Table { height: -0.00852 },
    ];
    let [(ra, ta), (rb, tb)] = independent_medians(&s, Kind::Edge, 20, &solids, 300);
    eprintln!(
        "independent profiles: edge-refined {ra:.4} deg / {ta:.4} mm, edge-full {rb:.4} deg / \
         {tb:.4} mm (medians)"
    );
    assert!(
        2.0 * rb <= ra && 2.0 * tb <= ta,
        "edge-full is not 2x better: {rb} / {tb} against edge-refined's {ra} / {ta}"
    );
}

#[test]
fn edge_full_on_the_comparison_rig() {
    // The comparison rig's bar (25 x 10 grouped poses on its riser), uniform z noise 0.1 mm, 100
    // trials (4.2x / 2.3x here). Measured over 200: rotation 4.0x better than edge-refined,
    // translation 2.3x (the face fixes the rotation; across the edges, the side walls' points
    // where they show, weighted as their residuals say, else the edges as censored intervals).
    // Translation had been 3.0x: since the censored edges' own threshold (twenty-fifth session)
    // edge-refined is better there (0.0111 -> 0.0106 mm on the 30 trials this test took), and they
    // read 1.94x.
    let text = std::fs::read_to_string(common::scen("comparison.toml"))
        .unwrap()
        .replace("z_sigma_near_mm = 0.02", "z_sigma_near_mm = 0.1")
        .replace("z_sigma_far_mm = 0.06", "z_sigma_far_mm = 0.1");
    let sf = ScenarioFile::parse(&text, "comparison.toml").unwrap();
    let s = sf.scenario.build(&sf.file).unwrap();
    let [(ra, ta), (rb, tb)] = medians(&s, Kind::Edge, 100, &s.rig.sensor, &|c, _| c);
    eprintln!(
        "edge-refined {ra:.4} deg / {ta:.4} mm, edge-full {rb:.4} deg / {tb:.4} mm (medians)"
    );
    assert!(
        2.0 * rb <= ra && 2.0 * tb <= ta,
        "edge-full is not 2x better: {rb} / {tb} against edge-refined's {ra} / {ta}"
    );
}

/// Issue 14: `disk-full` and `edge-full` converge in at least 99.5 % of 1,000 trials per sigma up
/// to 0.3 mm (uniform z noise, the comparison rig's ray-cast captures). About 10 min on 2 cores:
/// `cargo test --release --test suite full_profile::full_profile_converges -- --ignored --nocapture`.
#[test]
#[ignore]
fn full_profile_converges_over_a_thousand_trials() {
    use rayon::prelude::*;
    let base = std::fs::read_to_string(common::scen("comparison.toml")).unwrap();
    for kind in [Kind::Disk, Kind::Edge] {
        for sigma in [0.05, 0.1, 0.2, 0.3] {
            let text = base
                .replace(
                    "z_sigma_near_mm = 0.02",
                    &format!("z_sigma_near_mm = {sigma}"),
                )
                .replace(
                    "z_sigma_far_mm = 0.06",
                    &format!("z_sigma_far_mm = {sigma}"),
                );
            let sf = ScenarioFile::parse(&text, "comparison.toml").unwrap();
            let s = sf.scenario.build(&sf.file).unwrap();
            let id = MethodId::new(kind, Estimator::FullProfile);
            let converged = (0..1000u64)
                .into_par_iter()
                .filter(|&trial| {
                    let Ok(caps) = lasercal::trial::trial_captures(&s, kind, 1, trial).0 else {
                        return false;
                    };
                    estimate(id, &caps, &s.rig.sensor).is_ok_and(|(cal, r)| {
                        matches!(
                            r.map_or(cal.status, |r| r.status),
                            lasercal::calib::Status::Converged { .. }
                        )
                    })
                })
                .count();
            println!("| comparison | {sigma} | {id} | {converged} / 1000 |");
            assert!(converged >= 995, "{id} at {sigma} mm: {converged} of 1000");
        }
    }
}

/// Issue 14: the predicted standard deviations within 20 % of Monte Carlo, per axis. The specimen
/// is placed anew in each trial (within 2 mm in base x and y): on one fixed placement the rim and
/// the edges fall at the same place between two columns in every trial, a bias of that
/// placement which the covariance counts as noise (it predicted `disk-full`'s rotation sd 35-60 %
/// high over trials that differ by the sensor noise only). 100 trials per specimen, the
/// comparison rig at far z noise 0.25 mm (disk) and uniform 0.2 mm (bar).
#[test]
fn full_profile_predicted_sd_matches_monte_carlo_over_placements() {
    use rayon::prelude::*;
    let base = std::fs::read_to_string(common::scen("comparison.toml")).unwrap();
    for (kind, noise, place) in [
        (
            Kind::Disk,
            ("z_sigma_far_mm = 0.06", "z_sigma_far_mm = 0.25"),
            (
                [-319.622, -304.086, 11.48],
                "position_mm = [-319.622, -304.086, 11.48]",
            ),
        ),
        (
            Kind::Edge,
            ("z_sigma_near_mm = 0.02", "z_sigma_near_mm = 0.2"),
            ([300.0, -100.0, 40.0], "position_mm = [300.0, -100.0, 40.0]"),
        ),
    ] {
        let text = base.replace(noise.0, noise.1);
        let text = if kind == Kind::Edge {
            text.replace("z_sigma_far_mm = 0.06", "z_sigma_far_mm = 0.2")
        } else {
            text
        };
        let id = MethodId::new(kind, Estimator::FullProfile);
        let runs: Vec<(nalgebra::Vector6<f64>, nalgebra::Vector6<f64>)> = (0..100u64)
            .into_par_iter()
            .map(|t| {
                let u = |k: u64| {
                    (lasercal::rng::derive(14, &[t, k]) >> 11) as f64 / (1u64 << 53) as f64
                };
                let (dx, dy) = (4.0 * u(0) - 2.0, 4.0 * u(1) - 2.0);
                let moved = format!(
                    "position_mm = [{}, {}, {}]",
                    place.0[0] + dx,
                    place.0[1] + dy,
                    place.0[2]
                );
                let text = text.replace(place.1, &moved);
                let sf = ScenarioFile::parse(&text, "comparison.toml").unwrap();
                let s = sf.scenario.build(&sf.file).unwrap();
                let caps = lasercal::trial::trial_captures(&s, kind, 1, t).0.unwrap();
                let (cal, r) = estimate(id, &caps, &s.rig.sensor).unwrap();
                let r = r.unwrap();
                let truth = s.rig.flange_to_sensor;
                let w = (truth.rotation.inverse() * cal.flange_to_sensor.rotation).scaled_axis();
                let dt = cal.flange_to_sensor.translation.vector - truth.translation.vector;
                let e = nalgebra::Vector6::new(w.x, w.y, w.z, dt.x, dt.y, dt.z);
                (e, r.covariance.diagonal())
            })
            .collect();
        let n = runs.len() as f64;
        let mean = runs.iter().map(|r| r.0).sum::<nalgebra::Vector6<f64>>() / n;
        let sd = runs
            .iter()
            .map(|r| (r.0 - mean).component_mul(&(r.0 - mean)))
            .sum::<nalgebra::Vector6<f64>>()
            .map(|v| (v / (n - 1.0)).sqrt());
        let predicted =
            (runs.iter().map(|r| r.1).sum::<nalgebra::Vector6<f64>>() / n).map(f64::sqrt);
        let ratio = sd.component_div(&predicted);
        eprintln!("{kind}-full: Monte Carlo sd / predicted per axis {ratio:.3?}");
        for r in ratio.iter() {
            assert!((0.8..=1.2).contains(r), "{kind}-full: ratios {ratio:.3?}");
        }
    }
}

/// `edge-full` reads how far to trust its wall points from its own residuals
/// (`calib::refine::slant`): noise along z alone leaves the walls' points nearly exact across the
/// wall (kappa at its lower end), x jitter of sigma_x adds kappa = sigma_x / sigma_z.
#[test]
fn edge_full_reads_the_walls_noise_from_its_residuals() {
    for (x_sigma_mm, low, high) in [(0.0, 0.0, 0.04), (0.01, 0.17, 0.23)] {
        let text = std::fs::read_to_string(common::scen("comparison.toml"))
            .unwrap()
            .replace("z_sigma_near_mm = 0.02", "z_sigma_near_mm = 0.05")
            .replace(
                "z_sigma_far_mm = 0.06",
                &format!("z_sigma_far_mm = 0.05\nx_sigma_mm = {x_sigma_mm}"),
            );
        let sf = ScenarioFile::parse(&text, "comparison.toml").unwrap();
        let s = sf.scenario.build(&sf.file).unwrap();
        let full = MethodId::new(Kind::Edge, Estimator::FullProfile);
        for trial in 0..3 {
            let caps = lasercal::trial::trial_captures(&s, Kind::Edge, 1, trial)
                .0
                .unwrap();
            let (_, r) = estimate(full, &caps, &s.rig.sensor).unwrap();
            let noise = r.unwrap().slant.expect("the walls' noise was read");
            assert!(
                (low..=high).contains(&noise.kappa),
                "x sigma {x_sigma_mm} mm, trial {trial}: kappa {} not in [{low}, {high}]",
                noise.kappa
            );
            assert!(
                (noise.sigma / 0.05e-3 - 1.0).abs() < 0.05,
                "sigma {}",
                noise.sigma
            );
        }
    }
}

#[test]
fn an_edge_corner_keeps_the_face_points_out_of_its_wall() {
    // Where a well-sampled wall meets the face the edge is their lines' corner. The wall's
    // 4-RMS walk took the face's last points near the corner (they lie near both lines), which
    // tilted the wall's line and carried the corner outward as the noise grew: on the comparison
    // rig at far z noise 0.25 mm, in the 3rd orientation group (a corner view), 20 trials: the
    // corner lay a column past the edge's in 40 of 200 profiles (2 % at 0.02 mm); with each
    // line fitted to the points on its side of the corner, 16 (8 %). edge-refined's bound held
    // 2 % of 100 trials there before, 98 % after (docs/verdict.md).
    use lasercal::captures::ProfileData;
    use lasercal::features;
    let text = std::fs::read_to_string(common::scen("comparison.toml"))
        .unwrap()
        .replace("z_sigma_far_mm = 0.06", "z_sigma_far_mm = 0.25");
    let sf = ScenarioFile::parse(&text, "p.toml").unwrap();
    let s = sf.scenario.build(&sf.file).unwrap();
    let sensor = &s.rig.sensor;
    let plan = s
        .plan(Kind::Edge)
        .unwrap()
        .as_any()
        .downcast_ref::<lasercal::method::edge::EdgePlan>()
        .unwrap();
    let sense = lasercal::sim::edge::sense(&s.rig, &plan.target);
    let cfg = features::SplitMerge::for_sensor(sensor);
    let (mut out, mut n) = (0, 0);
    for trial in 0..20 {
        let caps = lasercal::trial::trial_captures(&s, Kind::Edge, 7, trial)
            .0
            .unwrap();
        for p in caps.profiles.iter().filter(|p| p.group == 2) {
            let ProfileData::Raw(prof) = &p.data else {
                continue;
            };
            let b2s = p.base_to_flange * s.rig.flange_to_sensor;
            let want = lasercal::sim::edge::exact_point(&b2s, &plan.target).unwrap();
            let got = features::edge_point_and_face(prof, sensor, sense, &cfg).unwrap();
            let u_want = sensor.column_of(want.x, want.y).unwrap();
            let u_got = sensor.column_of(got.end.from.x, got.end.from.y).unwrap();
            out += usize::from(u_got - u_want.floor() >= 1.0);
            n += 1;
        }
    }
    eprintln!("{out} of {n} edge ends a column or more past the edge's column");
    assert_eq!(n, 200);
    assert!(out <= 26, "{out} of {n} ends a column or more out");
}
