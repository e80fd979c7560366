//! Issue 16, item 1: what a recording shows of a calibration (`method::view`), on every source:
//! each profile's feature is found (ray-cast and analytic alike), the specimen is fitted to the
//! profiles mapped with the recovered transform, and a wrong transform shows as residuals far
//! above the noise.

use lasercal::math::rot_zyx;
use lasercal::method::{Kind, view::view};
use lasercal::scenario::ScenarioFile;
use nalgebra::{Isometry3, Translation3};

fn scen(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenarios")
        .join(name)
}

/// A typical profile's residual RMS (m) in a view.
fn rms(v: &lasercal::method::view::View) -> f64 {
    v.median_profile_rms().expect("residuals")
}

#[test]
fn every_capture_of_every_source_shows_its_feature_and_a_wrong_transform_shows() {
    // The counts: disk 400/400 and edge 250/250 ray-cast profiles, 8/8 ball arcs, and the
    // analytic sources, whose features were logged with empty profiles.
    let cases = [
        ("chen2018-disk-raycast.toml", Kind::Disk, 400),
        ("comparison.toml", Kind::Ball, 0),
        ("comparison.toml", Kind::Edge, 0),
        ("chen2018-ball.toml", Kind::Ball, 0),
        ("xu2021-edge.toml", Kind::Edge, 0),
        ("chen2018-disk.toml", Kind::Disk, 0),
        ("plane.toml", Kind::Plane, 0),
    ];
    for (file, kind, expect) in cases {
        let sf = ScenarioFile::load(&scen(file)).unwrap();
        let setup = sf.scenario.build(&sf.file).unwrap();
        let (caps, _) = lasercal::trial::trial_captures(&setup, kind, sf.scenario.seed, 0);
        let caps = caps.unwrap();
        let truth = setup.rig.flange_to_sensor;
        let v = view(&caps, &setup.rig.sensor, &truth);
        let n = caps.profiles.len();
        if expect > 0 {
            assert_eq!(n, expect, "{file} {kind}");
        }
        let with = v.profiles.iter().filter(|p| p.feature.is_some()).count();
        assert_eq!(with, n, "{file} {kind}: features in {with} of {n} profiles");
        assert!(
            v.profiles.iter().all(|p| !p.points.is_empty()),
            "{file} {kind}: a profile without points"
        );
        assert!(v.fitted.is_some(), "{file} {kind}: no specimen fitted");
        let good = rms(&v);
        // A degree and a millimetre off: the profiles no longer land on one specimen.
        let wrong = truth
            * Isometry3::from_parts(
                Translation3::new(1e-3, 0.0, 0.0),
                rot_zyx(0.8f64.to_radians(), 0.6f64.to_radians(), 0.0).into(),
            );
        let bad = rms(&view(&caps, &setup.rig.sensor, &wrong));
        eprintln!(
            "{file} {kind}: residual RMS {:.4} mm with the truth, {:.4} mm off",
            good * 1e3,
            bad * 1e3
        );
        assert!(bad > 3.0 * good, "{file} {kind}: {good} vs {bad}");
    }
}
