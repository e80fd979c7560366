//! Issue 4: the disk method (Chen et al. 2018).

use lasercal::calib::CalibError;
use lasercal::calib::PoseError;
use lasercal::calib::disk::{self, DiskChord, DiskProblem, DiskScan, SensingDatum};
use lasercal::math::rot_zyx;
use lasercal::papers::chen2018 as paper;
use lasercal::sim::disk::{analytic_scan, exact_chord};
use lasercal::testkit;
use nalgebra::{Matrix3, Vector3};

fn v(a: [f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}

fn table1() -> Vec<SensingDatum> {
    (0..4)
        .map(|i| SensingDatum {
            r_tcp: rot_zyx(
                paper::TABLE1_R_TCP[i][0],
                paper::TABLE1_R_TCP[i][1],
                paper::TABLE1_R_TCP[i][2],
            ),
            t_tcp: v(paper::TABLE1_T_TCP[i]) * 1e-3,
            q_in_sensor: v(paper::TABLE1_Q[i]) * 1e-3,
            d_in_sensor: v(paper::TABLE1_D_SENSOR[i]),
            d_in_base: v(paper::TABLE1_D_BASE[i]),
            alpha: f64::NAN,
            ellipse_rms: 0.0,
        })
        .collect()
}

#[test]
fn chen2018_table1_reproduces_eq49() {
    let data = table1();
    let (est, _) = disk::transformation_solution(&data).unwrap();
    // Compare with the published matrix as printed (not orthonormalised).
    let r_est = est.rotation.to_rotation_matrix().into_inner();
    let r_pub = Matrix3::from_fn(|i, j| paper::EQ49[i][j]);
    let frob = (r_est - r_pub).norm();
    let t_pub = Vector3::new(paper::EQ49[0][3], paper::EQ49[1][3], paper::EQ49[2][3]);
    let dt = (est.translation.vector * 1e3 - t_pub).norm();
    let (_, centre, acc) = disk::centres(&data, &est);
    let dc = (centre * 1e3 - v(paper::EQ50_DISK_CENTRE)).norm();
    eprintln!(
        "Table I -> Frobenius {frob:.5}, translation {dt:.3} mm, centre off {dc:.3} mm, accuracy {:.3} mm",
        acc * 1e3
    );
    assert!(frob < 0.005, "rotation Frobenius {frob}");
    assert!(dt < 0.5, "translation off by {dt} mm");
    assert!(
        (acc * 1e3 - paper::EQ51_ACCURACY_MM).abs() < 0.1,
        "accuracy {} mm vs 0.212",
        acc * 1e3
    );
    assert!(dc < 1.0, "disk centre off by {dc} mm");
}

#[test]
fn disk_exact_data_recovers_truth() {
    let mut g = testkit::rng(40);
    let mut worst = (0.0f64, 0.0f64);
    for setup in 0..200 {
        let n = 4 + setup % 3;
        let m = [3, 10, 100][setup % 3];
        let (rig, target, plans) = testkit::random_disk_setup(&mut g, n, m);
        let scans: Vec<DiskScan> = plans
            .iter()
            .map(|p| analytic_scan(&rig, &target, p, 0.0, &mut g))
            .collect();
        let sol = disk::solve(&DiskProblem::new(target.radius, scans))
            .unwrap_or_else(|e| panic!("setup {setup}: {e}"));
        let err = PoseError::between(&sol.flange_to_sensor, &rig.flange_to_sensor);
        worst = (
            worst.0.max(err.rotation_error_deg),
            worst.1.max(err.translation_error_mm),
        );
        assert!(
            err.rotation_error_deg <= 1e-9 && err.translation_error_mm <= 1e-9,
            "setup {setup} (n {n}, m {m}): {err:?}"
        );
        assert!(
            (sol.centre_in_base - target.centre.coords).norm() < 1e-11,
            "setup {setup}: centre"
        );
    }
    eprintln!(
        "worst exact-data error: {:.2e} deg, {:.2e} mm",
        worst.0, worst.1
    );
}

fn scan_with(chords: Vec<DiskChord>) -> DiskScan {
    DiskScan {
        r_tcp: nalgebra::Rotation3::identity(),
        t_start: Vector3::zeros(),
        t_end: Vector3::new(0.0, 0.01, 0.0),
        s: 1.0,
        chords,
    }
}

#[test]
fn disk_too_few_sensing_data() {
    let mut g = testkit::rng(41);
    let (rig, target, plans) = testkit::random_disk_setup(&mut g, 3, 20);
    let scans: Vec<DiskScan> = plans
        .iter()
        .map(|p| analytic_scan(&rig, &target, p, 0.0, &mut g))
        .collect();
    match disk::solve(&DiskProblem::new(target.radius, scans)) {
        Err(CalibError::TooFewData {
            got: 3, need: 4, ..
        }) => {}
        other => panic!("expected TooFewData, got {other:?}"),
    }
    assert!(matches!(
        disk::transformation_solution(&table1()[..3]),
        Err(CalibError::TooFewData { .. })
    ));
}

#[test]
fn disk_conic_not_an_ellipse() {
    // Chord ends on a straight line (a scan parallel to the disk plane projects it to a segment).
    let chords = (0..10)
        .map(|j| DiskChord {
            u: j as f64 / 9.0,
            a: nalgebra::Vector2::new(-0.02, 0.001 * j as f64),
            b: nalgebra::Vector2::new(0.02, 0.001 * j as f64),
        })
        .collect();
    let e = disk::sensing_datum(2, &scan_with(chords), 0.05, 0.01).unwrap_err();
    assert!(matches!(e, CalibError::NotAnEllipse { scan: 2, .. }), "{e}");
}

#[test]
fn disk_parallel_offsets_are_degenerate() {
    let mut data = table1();
    for d in &mut data {
        d.d_in_sensor = v(paper::TABLE1_D_SENSOR[0]);
        d.d_in_base = d.r_tcp * (rot_zyx(0.0, 0.0, 0.0) * v(paper::TABLE1_D_SENSOR[0]));
    }
    match disk::transformation_solution(&data) {
        Err(CalibError::Degenerate {
            part: "rotation", ..
        }) => {}
        other => panic!("expected a degenerate rotation, got {other:?}"),
    }
}

#[test]
fn disk_same_orientation_is_degenerate_for_translation() {
    let mut data = table1();
    for d in &mut data {
        d.r_tcp = data_first_rotation();
    }
    match disk::transformation_solution(&data) {
        Err(CalibError::Degenerate {
            part: "translation",
            ..
        }) => {}
        other => panic!("expected a degenerate translation, got {other:?}"),
    }
}

fn data_first_rotation() -> nalgebra::Rotation3<f64> {
    rot_zyx(
        paper::TABLE1_R_TCP[0][0],
        paper::TABLE1_R_TCP[0][1],
        paper::TABLE1_R_TCP[0][2],
    )
}

#[test]
fn disk_scan_parallel_or_perpendicular_to_disk_is_rejected() {
    use lasercal::sim::disk::{Coverage, Direction, DiskPlanSpec, ScanRequest, plan_unchecked};
    let mut g = testkit::rng(42);
    let (rig, target, _) = testkit::random_disk_setup(&mut g, 4, 20);
    // A move along the disk normal, then one in the disk plane.
    let r_tcp = testkit::random_rotation(&mut g).to_rotation_matrix();
    let n = target.normal.into_inner();
    let in_plane = n.cross(&Vector3::new(0.3, 0.5, 0.8)).normalize();
    for (dir, want_perp) in [(n, true), (in_plane, false)] {
        let spec = DiskPlanSpec {
            scans: vec![ScanRequest {
                r_tcp,
                centre_tcp: None,
                direction: Direction::InBase(dir),
            }],
            coverage: Coverage::Whole,
            span_fraction: 0.9,
            m: 20,
            min_angle: 1f64.to_radians(),
        };
        let e = plan_unchecked(&rig, &target, &spec)
            .unwrap_err()
            .to_string();
        assert!(e.contains("Eq. 2") || e.contains("does not sweep"), "{e}");
        let _ = want_perp;
    }
    // The solver catches a near-parallel move in data too: chords from a scan whose move is 0.5 deg
    // off the disk plane.
    let (rig, target, plans) = testkit::random_disk_setup(&mut g, 4, 30);
    let mut p = plans[0].clone();
    let n = target.normal.into_inner();
    let y_b = p.r_tcp * (rig.flange_to_sensor.rotation * Vector3::y());
    let along = (y_b - n * y_b.dot(&n)).normalize();
    let dir = (along * 0.5f64.to_radians().cos() + n * 0.5f64.to_radians().sin()).normalize();
    let mid = (p.t_start + p.t_end) / 2.0;
    let half = 0.9 * target.radius / y_b.dot(&dir).abs();
    p.t_start = mid - dir * half;
    p.t_end = mid + dir * half;
    let scan = analytic_scan(&rig, &target, &p, 0.0, &mut g);
    if scan.chords.len() >= 3 {
        let e = disk::sensing_datum(0, &scan, target.radius, 1f64.to_radians()).unwrap_err();
        assert!(
            matches!(
                e,
                CalibError::ScanParallelToDisk { .. } | CalibError::NotAnEllipse { .. }
            ),
            "{e}"
        );
    }
}

#[test]
fn exact_chord_lies_on_disk_and_laser_plane() {
    let mut g = testkit::rng(43);
    let (rig, target, plans) = testkit::random_disk_setup(&mut g, 4, 10);
    for p in &plans {
        for j in 0..p.m {
            let pose = rig.base_to_sensor(&lasercal::sim::flange_pose(&p.r_tcp, &p.tcp(j)));
            let (a, b) = exact_chord(&pose, &target).expect("plane cuts the disk");
            for e in [a, b] {
                let pb = pose * nalgebra::Point3::new(e.x, 0.0, e.y);
                assert!(((pb - target.centre).norm() - target.radius).abs() < 1e-12);
                assert!((pb - target.centre).dot(&target.normal).abs() < 1e-12);
            }
        }
    }
}
