//! Issue 5: the straight-edge method (Xu et al.).

use lasercal::calib::edge::{self, EdgeProblem};
use lasercal::calib::{CalibError, PoseError};
use lasercal::scenario::ScenarioFile;
use lasercal::sim::edge::analytic_problem;
use lasercal::testkit;

#[test]
fn edge_exact_data_recovers_truth() {
    let mut g = testkit::rng(60);
    let mut worst = (0.0f64, 0.0f64);
    for setup in 0..100 {
        let rotations = [4, 8, 25][setup % 3];
        let translations = [5, 6, 10][setup % 3];
        let (rig, target, plans) = testkit::random_edge_setup(&mut g, rotations, translations);
        let p = analytic_problem(&rig, &target, &plans, 0.0, &mut g).unwrap();
        let sol = edge::solve(&p).unwrap_or_else(|e| panic!("setup {setup}: {e}"));
        let err = PoseError::between(&sol.flange_to_sensor, &rig.flange_to_sensor);
        worst = (
            worst.0.max(err.rotation_error_deg),
            worst.1.max(err.translation_error_mm),
        );
        assert!(
            err.rotation_error_deg <= 1e-9 && err.translation_error_mm <= 1e-9,
            "setup {setup} ({rotations} x {translations}): {err:?}"
        );
        assert!(sol.point_distances.iter().all(|d| *d < 1e-9));
    }
    eprintln!(
        "worst exact-data error: {:.2e} deg, {:.2e} mm",
        worst.0, worst.1
    );
}

#[test]
fn edge_degenerate_inputs_are_typed_errors() {
    let mut g = testkit::rng(61);
    let (rig, target, plans) = testkit::random_edge_setup(&mut g, 5, 6);
    let p = analytic_problem(&rig, &target, &plans, 0.0, &mut g).unwrap();
    // A single group.
    let e = edge::solve(&EdgeProblem {
        orientation_tolerance_deg: lasercal::calib::ORIENTATION_TOLERANCE_DEG,
        groups: p.groups[..1].to_vec(),
    })
    .unwrap_err();
    assert!(
        matches!(
            e,
            CalibError::TooFewData {
                what: "rotation groups",
                ..
            }
        ),
        "{e}"
    );
    // Collinear translations (a straight line instead of an arc).
    let mut line = p.clone();
    let g0 = &mut line.groups[0];
    let (t0, t1) = (g0[0].t_tcp, g0[1].t_tcp);
    for (k, c) in g0.iter_mut().enumerate() {
        c.t_tcp = t0 + (t1 - t0) * k as f64;
    }
    let e = edge::solve(&line).unwrap_err();
    assert!(e.to_string().contains("collinear"), "{e}");
    // Motion along the edge: the profile point never moves.
    let mut along = p.clone();
    let base = along.groups[1][0].t_tcp;
    for (k, c) in along.groups[1].iter_mut().enumerate() {
        c.t_tcp = base
            + target.dir.into_inner() * (0.01 * k as f64)
            + target.up.into_inner() * (0.001 * (k * k) as f64);
        c.p_in_sensor = p.groups[1][0].p_in_sensor;
    }
    let e = edge::solve(&along).unwrap_err();
    assert!(
        e.to_string().contains("parallel to the edge") || e.to_string().contains("one line"),
        "{e}"
    );
}

#[test]
fn edge_raycast_recovers_truth_for_each_specimen() {
    // Noise-free ray-cast profiles. A bar or scale edge is found at the corner with a visible side
    // wall or halfway between two columns: at most half an x sample (0.03 mm at 75-105 mm depth)
    // off, which the linear method turns into about 0.02 deg and 0.02 mm; bound: 0.1 deg, 0.1 mm.
    // A knife blade's 1 mm bevel turns away from the laser under the larger tilts, so in some
    // profiles the edge is found at the bevel's start, about 1 mm short: the calibration is then
    // clearly worse (measured 2.3 deg, 1.0 mm), which the bench is there to show.
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/xu2021-edge.toml");
    let mut bar_err = 0.0;
    for kind in ["parallel-bar", "scale", "knife-blade"] {
        let text = std::fs::read_to_string(path)
            .unwrap()
            .replace("source = \"analytic\"", "source = \"raycast\"")
            .replace("kind = \"parallel-bar\"", &format!("kind = \"{kind}\""))
            .replace(
                "preset = \"vlm350\"",
                "preset = \"vlm350\"\nquantise = false",
            );
        let sf = ScenarioFile::parse(&text, "edge-raycast.toml").unwrap();
        let setup = sf.scenario.build(&sf.file).unwrap();
        let out = lasercal::trial::run_trial(&setup, "edge".parse().unwrap(), 1, 0);
        let s = out.result.unwrap_or_else(|e| panic!("{kind}: {e}"));
        eprintln!(
            "ray-cast {kind}: {:?}, missed {}",
            s.error(),
            out.missed_profiles
        );
        assert_eq!(out.missed_profiles, 0, "{kind}");
        match kind {
            "knife-blade" => {
                assert!(
                    s.error().rotation_error_deg > 10.0 * bar_err,
                    "the blade's hidden bevel should show"
                );
                assert!(
                    s.error().rotation_error_deg < 5.0 && s.error().translation_error_mm < 2.0,
                    "{kind}: {:?}",
                    s.error()
                );
            }
            _ => {
                assert!(
                    s.error().rotation_error_deg < 0.1 && s.error().translation_error_mm < 0.1,
                    "{kind}: {:?}",
                    s.error()
                );
                bar_err = f64::max(bar_err, s.error().rotation_error_deg);
            }
        }
    }
}

#[test]
fn xu2021_table3_ball_radius_close_to_20mm() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/xu2021-edge.toml");
    let sf = ScenarioFile::load(std::path::Path::new(path)).unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    for t in 0..5 {
        let s = lasercal::trial::run_trial(&setup, "edge".parse().unwrap(), sf.scenario.seed, t)
            .result
            .unwrap();
        let r = s
            .metrics
            .get(lasercal::metrics::Metric::SphereRadius)
            .unwrap();
        // The paper's Table 3: 19.92 to 20.06 mm.
        assert!((r - 20.0).abs() < 0.08, "trial {t}: radius {r}");
    }
}
