//! Issue 14, item 1 for the ball: `ball-any-pose` calibrates from any poses that see the ball, with
//! no groups, no hand-given side of the laser plane and no start. Tested on profiles from the
//! independent generator (`testkit::fan`) for random declared sensors, random mountings and random
//! pose sets.

use crate::common;

use lasercal::calib::PoseError;
use lasercal::captures::{CaptureProfile, Captures, Group, ProfileData, Role};
use lasercal::method::{Estimator, Kind, MethodId};
use lasercal::rng::{Rng, gauss};
use lasercal::scene::SpecimenType;
use lasercal::sensor::SensorModel;
use lasercal::testkit::fan::{Fan, Noise, Solid, profile};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use rand::RngExt;

const ANY: MethodId = MethodId::new(Kind::Ball, Estimator::AnyPose);
const RADIUS: f64 = 0.0254; // a 2-inch sphere, as in public data sets

fn uniform(rng: &mut Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

/// A random fan (z toward the sensor, Gocator-like frame: range centred on z = 0).
fn random_fan(rng: &mut Rng) -> Fan {
    let apex = uniform(rng, 0.15, 0.45);
    let half_range = uniform(rng, 0.04, 0.1);
    Fan {
        apex_z: apex,
        dir_z: -1.0,
        half_angle: uniform(rng, 8.0, 20.0).to_radians(),
        columns: [640, 1000, 1280, 2048][rng.random_range(0..4)],
        equal_angle: rng.random::<bool>(),
        reversed: rng.random::<bool>(),
        z_range: (-half_range, half_range),
        camera: Point3::new(0.0, uniform(rng, 0.05, 0.15), apex),
    }
}

fn random_rotation(rng: &mut Rng, scale: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_scaled_axis(Vector3::new(gauss(rng), gauss(rng), gauss(rng)) * scale)
}

/// A sensor pose that sees the ball: the fan axis tilted up to 50 deg from straight down, the
/// ball's centre within the range and the middle half of the fan, the laser plane up to 0.7 R from
/// the centre; `orientation`: reuse this rotation (for pure translations).
fn sensor_pose(
    rng: &mut Rng,
    fan: &Fan,
    centre: &Point3<f64>,
    orientation: Option<UnitQuaternion<f64>>,
) -> Isometry3<f64> {
    let rot = orientation.unwrap_or_else(|| {
        // Sensor z (toward the sensor) points up, tilted; a random turn about it.
        let tilt = uniform(rng, 0.0, 50f64.to_radians());
        let azimuth = uniform(rng, 0.0, std::f64::consts::TAU);
        let up = Vector3::new(
            tilt.sin() * azimuth.cos(),
            tilt.sin() * azimuth.sin(),
            tilt.cos(),
        );
        let turn = uniform(rng, 0.0, std::f64::consts::TAU);
        UnitQuaternion::rotation_between(&Vector3::z(), &up).unwrap()
            * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), turn)
    });
    // The ball centre in the sensor frame: z within the range (less the radius), x within the
    // fan's middle, y within 0.7 R of the plane.
    let z = uniform(rng, fan.z_range.0 + RADIUS, fan.z_range.1 - RADIUS);
    let half_width = (fan.apex_z - z) * fan.half_angle.tan();
    let s = Vector3::new(
        uniform(rng, -0.4, 0.4) * half_width,
        uniform(rng, -0.7, 0.7) * RADIUS,
        z,
    );
    // centre = pose * s  =>  translation = centre - rot * s.
    Isometry3::from_parts(Translation3::from(centre.coords - rot * s), rot)
}

pub(crate) struct Setup {
    pub(crate) caps: Captures,
    pub(crate) sensor: SensorModel,
    pub(crate) truth: Isometry3<f64>,
    /// The plane's or bar's frame (top face z = 0).
    face: Isometry3<f64>,
    /// What made the profiles: the fan and the solids it saw.
    pub(crate) fan: Fan,
    pub(crate) solids: Vec<Solid>,
}

/// A random rig and `n` poses (`translations` of them pure translations of the first), one group
/// each, no signs recorded.
pub(crate) fn random_setup(seed: u64, n: usize, translations: usize, sigma: f64) -> Setup {
    let mut rng = lasercal::testkit::rng(seed);
    let fan = random_fan(&mut rng);
    let sensor = common::declared(&fan, "random fan");
    let truth = Isometry3::from_parts(
        Translation3::new(
            uniform(&mut rng, -0.1, 0.1),
            uniform(&mut rng, -0.1, 0.1),
            uniform(&mut rng, 0.05, 0.4),
        ),
        random_rotation(&mut rng, 2.0),
    );
    let centre = Point3::new(
        uniform(&mut rng, 0.3, 0.8),
        uniform(&mut rng, -0.4, 0.4),
        uniform(&mut rng, 0.0, 0.3),
    );
    let solids = [Solid::Sphere {
        centre,
        radius: RADIUS,
    }];
    let mut groups = Vec::new();
    let mut profiles = Vec::new();
    let mut first = None;
    for i in 0..n {
        let orientation = (i > 0 && i <= translations).then(|| first.unwrap());
        let base_to_sensor = sensor_pose(&mut rng, &fan, &centre, orientation);
        first.get_or_insert(base_to_sensor.rotation);
        let base_to_flange = base_to_sensor * truth.inverse();
        let noise = Noise {
            sigma_z: sigma,
            dropout: 0.0,
            sigma_z_far: 0.0,
        };
        let pts = profile(&fan, &solids, &base_to_sensor, noise, &mut rng);
        groups.push(Group {
            id: i,
            role: Role::Translation,
            sign: 0.0,
        });
        profiles.push(CaptureProfile {
            group: i,
            base_to_flange,
            data: common::raw(pts),
        });
    }
    Setup {
        caps: Captures {
            timing: None,
            kinematic: None,
            feature_sigma: None,
            // A simulated rig without robot error states so.
            judging: lasercal::captures::Judging {
                robot_accuracy: 0.0,
                ..Default::default()
            },
            orientation_tolerance_deg: lasercal::calib::ORIENTATION_TOLERANCE_DEG,
            method: Kind::Ball,
            sensor: sensor.name.clone(),
            specimen_kind: SpecimenType::Ball,
            specimen_radius: Some(RADIUS),
            edge_sense: None,
            truth: Some(truth),
            groups,
            profiles,
        },
        sensor,
        truth,
        face: Isometry3::identity(),
        fan,
        solids: solids.to_vec(),
    }
}

#[test]
fn exact_on_a_hundred_random_rigs_and_pose_sets() {
    // 100 setups: random sensor, mounting, ball position and 6-50 poses (a few of them pure
    // translations, as in public data sets); no signs, no start. Noise-free: the truth to 1e-9.
    let mut worst = (0.0f64, 0.0f64);
    for seed in 0..100u64 {
        let n = 6 + (seed as usize * 7) % 45;
        let s = random_setup(1000 + seed, n, (seed % 4) as usize, 0.0);
        let (cal, r) = lasercal::method::estimate(ANY, &s.caps, &s.sensor)
            .unwrap_or_else(|e| panic!("setup {seed} ({n} poses): {e}"));
        let r = r.unwrap();
        assert!(
            matches!(r.status, lasercal::calib::Status::Converged { .. }),
            "setup {seed}: {:?}",
            r.status
        );
        let e = PoseError::between(&cal.flange_to_sensor, &s.truth);
        worst.0 = worst.0.max(e.rotation_error_deg);
        worst.1 = worst.1.max(e.translation_error_mm);
        assert!(
            e.rotation_error_deg < 1e-9 && e.translation_error_mm < 1e-9,
            "setup {seed} ({n} poses): {e:?}"
        );
        assert_eq!(cal.missed, 0, "setup {seed}");
    }
    eprintln!("worst of 100: {:.1e} deg, {:.1e} mm", worst.0, worst.1);
}

#[test]
fn pure_translations_are_refused_with_the_missing_motion() {
    // Every pose at one orientation: the translation cannot be told from the ball's position.
    let s = random_setup(7, 12, 11, 0.0);
    let e = lasercal::method::estimate(ANY, &s.caps, &s.sensor)
        .err()
        .expect("refused")
        .to_string();
    assert!(
        e.contains("cannot determine") && e.contains("translation") && e.contains("orientations"),
        "{e}"
    );
}

#[test]
fn noisy_free_poses_against_the_truth() {
    // sigma 0.1 mm, 15 free poses (3 translations): median over 20 rigs, and every run converged.
    let (rot, tr) = noisy_errors(ANY, "15 free poses", |seed| {
        random_setup(5000 + seed, 15, 3, 0.1e-3)
    });
    assert!(rot[10] < 0.1 && tr[10] < 0.2, "{rot:?} {tr:?}");
}

/// Rotation and translation errors (sorted) of `id` over 20 random setups at z noise 0.1 mm (the
/// sensor told so), every refinement converged; prints median and worst.
fn noisy_errors(id: MethodId, what: &str, setup: impl Fn(u64) -> Setup) -> (Vec<f64>, Vec<f64>) {
    let (mut rot, mut tr) = (Vec::new(), Vec::new());
    for seed in 0..20u64 {
        let s = setup(seed);
        let mut sensor = s.sensor.clone();
        sensor.noise.z_sigma_near = 0.1e-3;
        sensor.noise.z_sigma_far = 0.1e-3;
        let (cal, r) = lasercal::method::estimate(id, &s.caps, &sensor).unwrap();
        assert!(matches!(
            r.unwrap().status,
            lasercal::calib::Status::Converged { .. }
        ));
        let e = PoseError::between(&cal.flange_to_sensor, &s.truth);
        rot.push(e.rotation_error_deg);
        tr.push(e.translation_error_mm);
    }
    rot.sort_by(f64::total_cmp);
    tr.sort_by(f64::total_cmp);
    eprintln!(
        "{id}, sigma 0.1 mm, {what}: median {:.4} deg / {:.4} mm, worst {:.4} / {:.4}",
        rot[10], tr[10], rot[19], tr[19]
    );
    (rot, tr)
}

#[test]
fn the_papers_protocol_captures_calibrate_too() {
    // The disk paper's ball protocol (ray-cast, z noise 0.02-0.06 mm): any-pose ignores the
    // groups and signs and lands where the refined two-step method does (one minimum).
    let text = std::fs::read_to_string(common::scen("comparison.toml")).unwrap();
    let sf = lasercal::scenario::ScenarioFile::parse(&text, "comparison.toml").unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    for trial in 0..3 {
        let caps = lasercal::trial::trial_captures(&setup, Kind::Ball, 1, trial)
            .0
            .unwrap();
        let refined = MethodId::new(Kind::Ball, Estimator::Refined);
        let (a, _) = lasercal::method::estimate(ANY, &caps, &setup.rig.sensor).unwrap();
        let (b, _) = lasercal::method::estimate(refined, &caps, &setup.rig.sensor).unwrap();
        let ea = PoseError::between(&a.flange_to_sensor, &setup.rig.flange_to_sensor);
        let eb = PoseError::between(&b.flange_to_sensor, &setup.rig.flange_to_sensor);
        eprintln!("trial {trial}: any-pose {ea:?}, refined {eb:?}");
        let d = PoseError::between(&a.flange_to_sensor, &b.flange_to_sensor);
        assert!(
            d.rotation_error_deg < 1e-6 && d.translation_error_mm < 1e-6,
            "trial {trial}: any-pose and refined differ by {d:?}"
        );
    }
}

#[test]
fn calibrate_a_capture_file_without_signs() {
    // `lasercal calibrate --method ball-any-pose` on a file whose groups carry no sign; the closed
    // form on the same file says what it misses and names the fix.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("ball.json");
    let (code, _, err) = common::lasercal(&[
        "simulate",
        &common::scen("comparison.toml"),
        "--method",
        "ball",
        "--out",
        file.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    for g in doc["groups"].as_array_mut().unwrap() {
        g.as_object_mut().unwrap().remove("sign");
    }
    std::fs::write(&file, doc.to_string()).unwrap();
    let json = dir.path().join("out.json");
    let (code, out, err) = common::lasercal(&[
        "calibrate",
        file.to_str().unwrap(),
        "--method",
        "ball-any-pose",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("ball-any-pose"), "{out}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert!(v["rotation_error_deg"].as_f64().unwrap() < 0.05, "{v}");
    assert!(v["translation_error_mm"].as_f64().unwrap() < 0.1, "{v}");
    // The paper's closed form needs the signs and says what runs without them; calibrate alone
    // runs every variant and keeps the one that can.
    let (code, _, err) =
        common::lasercal(&["calibrate", file.to_str().unwrap(), "--method", "ball"]);
    assert_eq!(code, 2);
    assert!(
        err.contains("sign") && err.contains("ball-any-pose"),
        "{err}"
    );
    let (code, out, err) = common::lasercal(&["calibrate", file.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("chosen: ball-any-pose") && out.contains("ball            cannot run"),
        "{out}"
    );
}

/// A random plane, rig and `n` free poses looking at it (tilt 5-40 deg from its normal, the line's
/// middle at a random depth in the range); `same_orientation`: every pose at the first's.
pub(crate) fn random_plane_setup(seed: u64, n: usize, same_orientation: bool, sigma: f64) -> Setup {
    random_face_setup(seed, n, same_orientation, sigma, Target::Plane)
}

/// A bar lying on a plane, its long edges along its frame's x, 10-60 mm wide: `n` free poses
/// looking at its top face as `random_plane_setup` does, the laser crossing the edges at 30 deg or
/// more, the line's middle on the face or up to 10 mm beside it.
pub(crate) fn random_bar_setup(seed: u64, n: usize, sigma: f64) -> Setup {
    let mut rng = lasercal::testkit::rng(seed ^ 0xba5);
    let width = uniform(&mut rng, 0.01, 0.06);
    let height = uniform(&mut rng, 0.005, 0.03);
    random_face_setup(seed, n, false, sigma, Target::Bar { width, height })
}

/// A disk on a cylinder (its radius 10-20 % of the fan's width at its near end, 5-30 mm high) on a
/// plane: `n` free poses looking at its face as `random_plane_setup` does, the line's middle
/// within 0.6 R of the centre.
fn random_disk_setup(seed: u64, n: usize, sigma: f64) -> Setup {
    let fan = random_fan(&mut lasercal::testkit::rng(seed));
    let near_width = 2.0 * (fan.apex_z - fan.z_range.1) * fan.half_angle.tan();
    let mut rng = lasercal::testkit::rng(seed ^ 0xd15c);
    let radius = uniform(&mut rng, 0.1, 0.2) * near_width;
    let height = uniform(&mut rng, 0.005, 0.03);
    random_face_setup(seed, n, false, sigma, Target::Disk { radius, height })
}

/// A ridge (or, `groove`, a V groove) whose faces slope 15-50 deg: `n` free poses looking at its
/// line as `random_bar_setup` does at a bar's edge, the laser crossing it in one sense.
fn random_wedge_setup(seed: u64, n: usize, sigma: f64, groove: bool) -> Setup {
    let mut rng = lasercal::testkit::rng(seed ^ 0x7ed9e);
    let slope = uniform(&mut rng, 15f64.to_radians(), 50f64.to_radians());
    random_face_setup(seed, n, false, sigma, Target::Wedge { slope, groove })
}

/// What the poses look at: a plane, or a bar or a disk lying on it (its top face), or a ridge or
/// groove.
#[derive(Clone, Copy, PartialEq)]
enum Target {
    Plane,
    Bar { width: f64, height: f64 },
    Disk { radius: f64, height: f64 },
    Wedge { slope: f64, groove: bool },
}

fn random_face_setup(
    seed: u64,
    n: usize,
    same_orientation: bool,
    sigma: f64,
    target: Target,
) -> Setup {
    let bar = match target {
        Target::Bar { width, height } => Some((width, height)),
        _ => None,
    };
    let mut rng = lasercal::testkit::rng(seed);
    let fan = random_fan(&mut rng);
    let sensor = common::declared(&fan, "random fan");
    // The flange behind the sensor (beyond its apex, away from the plane), as on a robot: an arm
    // does not reach through the plane, which is what tells the sensor's side (calib::plane).
    let rot = random_rotation(&mut rng, 2.0);
    let flange_in_sensor = Vector3::new(
        uniform(&mut rng, -0.1, 0.1),
        uniform(&mut rng, -0.1, 0.1),
        fan.apex_z + uniform(&mut rng, 0.05, 0.3),
    );
    let truth = Isometry3::from_parts(Translation3::from(-(rot * flange_in_sensor)), rot);
    let normal =
        (Vector3::z() + Vector3::new(gauss(&mut rng), gauss(&mut rng), 0.0) * 0.3).normalize();
    let point = Point3::new(
        uniform(&mut rng, 0.3, 0.8),
        uniform(&mut rng, -0.4, 0.4),
        0.0,
    );
    let face_frame = Isometry3::from_parts(
        Translation3::from(point.coords),
        UnitQuaternion::rotation_between(&Vector3::z(), &normal).unwrap(),
    );
    let solids = match target {
        Target::Plane => vec![Solid::Plane { point, normal }],
        Target::Disk { radius, height } => vec![
            Solid::DiskOnCylinder {
                frame: face_frame,
                radius,
                height,
            },
            Solid::Plane {
                point: point - normal * height,
                normal,
            },
        ],
        Target::Bar { width, height } => vec![
            Solid::Bar {
                frame: face_frame,
                lx: 0.4,
                ly: width,
                lz: height,
            },
            Solid::Plane {
                point: point - normal * height,
                normal,
            },
        ],
        Target::Wedge { slope, groove } => vec![Solid::Wedge {
            frame: face_frame,
            slope,
            groove,
        }],
    };
    let (mut groups, mut profiles) = (Vec::new(), Vec::new());
    let mut first: Option<UnitQuaternion<f64>> = None;
    for i in 0..n {
        let rot = match (same_orientation, first) {
            (true, Some(r)) => r,
            _ => {
                let tilt = uniform(&mut rng, 5f64.to_radians(), 40f64.to_radians());
                let az = uniform(&mut rng, 0.0, std::f64::consts::TAU);
                let axis = UnitQuaternion::rotation_between(&Vector3::z(), &normal).unwrap();
                // The sensor's z (toward the sensor) tilted from the plane's normal.
                let up =
                    axis * Vector3::new(tilt.sin() * az.cos(), tilt.sin() * az.sin(), tilt.cos());
                let tilted = UnitQuaternion::rotation_between(&Vector3::z(), &up).unwrap();
                let turned =
                    |turn: f64| tilted * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), turn);
                let mut rot = turned(uniform(&mut rng, 0.0, std::f64::consts::TAU));
                // A bar's edges (its x) must cross the laser plane at 30 deg or more.
                while bar.is_some()
                    && (rot * Vector3::y()).dot(&(face_frame * Vector3::x())).abs() < 0.5
                {
                    rot = turned(uniform(&mut rng, 0.0, std::f64::consts::TAU));
                }
                // A ridge's line likewise, crossed from its -y face to its +y face.
                let wedge = matches!(target, Target::Wedge { .. });
                while wedge
                    && ((rot * Vector3::y()).dot(&(face_frame * Vector3::x())).abs() < 0.5
                        || (rot * Vector3::x()).dot(&(face_frame * Vector3::y())) <= 0.0)
                {
                    rot = turned(uniform(&mut rng, 0.0, std::f64::consts::TAU));
                }
                rot
            }
        };
        first.get_or_insert(rot);
        // The line's middle on the plane at a random depth of the range.
        let z = uniform(&mut rng, 0.8 * fan.z_range.0, 0.8 * fan.z_range.1);
        let aim = match target {
            Target::Plane => {
                point
                    + nalgebra::Vector3::new(
                        uniform(&mut rng, -0.05, 0.05),
                        uniform(&mut rng, -0.05, 0.05),
                        0.0,
                    )
            }
            Target::Disk { radius, .. } => {
                let (r, a) = (
                    0.6 * radius * uniform(&mut rng, 0.0, 1.0).sqrt(),
                    uniform(&mut rng, 0.0, std::f64::consts::TAU),
                );
                face_frame * Point3::new(r * a.cos(), r * a.sin(), 0.0)
            }
            Target::Bar { width, .. } => {
                face_frame
                    * Point3::new(
                        uniform(&mut rng, -0.1, 0.1),
                        uniform(&mut rng, -width - 0.01, 0.01),
                        0.0,
                    )
            }
            Target::Wedge { .. } => {
                face_frame
                    * Point3::new(
                        uniform(&mut rng, -0.1, 0.1),
                        uniform(&mut rng, -0.005, 0.005),
                        0.0,
                    )
            }
        };
        let aim = aim - normal * normal.dot(&(aim - point));
        let base_to_sensor = Isometry3::from_parts(
            Translation3::from(aim.coords - rot * Vector3::new(0.0, 0.0, z)),
            rot,
        );
        let noise = Noise {
            sigma_z: sigma,
            dropout: 0.0,
            sigma_z_far: 0.0,
        };
        let pts = profile(&fan, &solids, &base_to_sensor, noise, &mut rng);
        groups.push(Group {
            id: i,
            role: Role::Pose,
            sign: 0.0,
        });
        profiles.push(CaptureProfile {
            group: i,
            base_to_flange: base_to_sensor * truth.inverse(),
            data: common::raw(pts),
        });
    }
    Setup {
        caps: Captures {
            timing: None,
            kinematic: None,
            feature_sigma: None,
            // A simulated rig without robot error states so.
            judging: lasercal::captures::Judging {
                robot_accuracy: 0.0,
                ..Default::default()
            },
            orientation_tolerance_deg: lasercal::calib::ORIENTATION_TOLERANCE_DEG,
            method: match target {
                Target::Plane => Kind::Plane,
                Target::Bar { .. } | Target::Wedge { .. } => Kind::Edge,
                Target::Disk { .. } => Kind::Disk,
            },
            sensor: sensor.name.clone(),
            specimen_kind: match target {
                Target::Plane => SpecimenType::Plane,
                Target::Bar { .. } => SpecimenType::ParallelBar,
                Target::Disk { .. } => SpecimenType::DiskCylinder,
                Target::Wedge { groove: false, .. } => SpecimenType::Ridge,
                Target::Wedge { groove: true, .. } => SpecimenType::VGroove,
            },
            specimen_radius: match target {
                Target::Disk { radius, .. } => Some(radius),
                _ => None,
            },
            edge_sense: None,
            truth: Some(truth),
            groups,
            profiles,
        },
        sensor,
        truth,
        face: face_frame,
        fan,
        solids,
    }
}

/// `id` on one noise-free setup's captures: converged, and exact to 1e-9 against `truth`
/// (`what` names it in a failure). Returns the error.
fn exact_one(
    id: MethodId,
    caps: &Captures,
    sensor: &SensorModel,
    truth: &Isometry3<f64>,
    what: &str,
) -> PoseError {
    let (cal, r) =
        lasercal::method::estimate(id, caps, sensor).unwrap_or_else(|e| panic!("{what}: {e}"));
    assert!(
        matches!(r.unwrap().status, lasercal::calib::Status::Converged { .. }),
        "{what}"
    );
    let e = PoseError::between(&cal.flange_to_sensor, truth);
    assert!(
        e.rotation_error_deg < 1e-9 && e.translation_error_mm < 1e-9,
        "{what}: {e:?}"
    );
    e
}

const PLANE: MethodId = MethodId::new(Kind::Plane, Estimator::AnyPose);
/// `id` on 100 noise-free setups of 7-50 poses (`setup(seed, n)`): every one converged and exact
/// to 1e-9; prints the worst.
fn exact_on_a_hundred(id: MethodId, what: &str, setup: impl Fn(u64, usize) -> Setup) {
    let mut worst = (0.0f64, 0.0f64);
    for seed in 0..100u64 {
        let n = 7 + (seed as usize * 7) % 44;
        let s = setup(seed, n);
        let e = exact_one(
            id,
            &s.caps,
            &s.sensor,
            &s.truth,
            &format!("setup {seed} ({n} poses)"),
        );
        worst.0 = worst.0.max(e.rotation_error_deg);
        worst.1 = worst.1.max(e.translation_error_mm);
    }
    eprintln!(
        "{what}, worst of 100: {:.1e} deg, {:.1e} mm",
        worst.0, worst.1
    );
}

const EDGE: MethodId = MethodId::new(Kind::Edge, Estimator::AnyPose);

#[test]
fn edge_exact_on_a_hundred_random_bars_rigs_and_pose_sets() {
    exact_on_a_hundred(EDGE, "edge", |seed, n| {
        random_bar_setup(8000 + seed, n, 0.0)
    });
}

const DISK: MethodId = MethodId::new(Kind::Disk, Estimator::AnyPose);

/// A ridge's or groove's two faces from 12-50 free poses (some profiles see one face only):
/// `edge-any-pose` on 100 noise-free random rigs each, exact to 1e-9.
#[test]
fn ridge_and_groove_exact_on_a_hundred_random_rigs_and_pose_sets() {
    for (what, groove, base) in [("ridge", false, 14_000), ("v-groove", true, 15_000)] {
        let mut worst = (0.0f64, 0.0f64);
        for seed in 0..100u64 {
            let n = 12 + (seed as usize * 7) % 39;
            let s = random_wedge_setup(base + seed, n, 0.0, groove);
            let e = exact_one(
                EDGE,
                &s.caps,
                &s.sensor,
                &s.truth,
                &format!("{what} {seed} ({n} poses)"),
            );
            worst = (
                worst.0.max(e.rotation_error_deg),
                worst.1.max(e.translation_error_mm),
            );
        }
        eprintln!(
            "{what}, worst of 100: {:.1e} deg, {:.1e} mm",
            worst.0, worst.1
        );
    }
}

/// A step edge (the kit's bar on its plane: a top face, a riser, a lower face) and a fillet joint
/// (a groove whose faces meet at 90 deg) named as such in the captures: `edge-any-pose` exact to
/// 1e-9 on 30 noise-free random rigs each.
#[test]
fn step_and_fillet_exact_on_random_rigs() {
    for seed in 0..30u64 {
        let n = 12 + (seed as usize * 7) % 39;
        let mut step = random_bar_setup(19_000 + seed, n, 0.0);
        step.caps.specimen_kind = SpecimenType::Step;
        let slope = std::f64::consts::FRAC_PI_4;
        let mut fillet = random_face_setup(
            19_100 + seed,
            n,
            false,
            0.0,
            Target::Wedge {
                slope,
                groove: true,
            },
        );
        fillet.caps.specimen_kind = SpecimenType::Fillet;
        for (what, s) in [("step", &step), ("fillet", &fillet)] {
            exact_one(
                EDGE,
                &s.caps,
                &s.sensor,
                &s.truth,
                &format!("{what} {seed} ({n} poses)"),
            );
        }
    }
}

#[test]
fn ridge_and_groove_with_noise() {
    for groove in [false, true] {
        let (rot, tr) = noisy_errors(EDGE, "16 free poses", |seed| {
            random_wedge_setup(16_000 + seed, 16, 0.1e-3, groove)
        });
        assert!(rot[10] < 0.05 && tr[10] < 0.1, "{rot:?} {tr:?}");
    }
}

#[test]
fn disk_exact_on_a_hundred_random_disks_rigs_and_pose_sets() {
    exact_on_a_hundred(DISK, "disk", |seed, n| {
        random_disk_setup(10_000 + seed, n, 0.0)
    });
}

#[test]
fn disk_with_noise() {
    let (rot, tr) = noisy_errors(DISK, "16 free poses", |seed| {
        random_disk_setup(11_000 + seed, 16, 0.1e-3)
    });
    assert!(rot[10] < 0.05 && tr[10] < 0.1, "{rot:?} {tr:?}");
}

#[test]
fn edge_with_noise() {
    let (rot, tr) = noisy_errors(EDGE, "16 free poses", |seed| {
        random_bar_setup(9000 + seed, 16, 0.1e-3)
    });
    assert!(rot[10] < 0.05 && tr[10] < 0.1, "{rot:?} {tr:?}");
}

#[test]
fn plane_exact_on_a_hundred_random_rigs_and_pose_sets() {
    // 7-50 poses (from 6, two random setups of two had a second exact solution: the plane needs 7).
    exact_on_a_hundred(PLANE, "plane", |seed, n| {
        random_plane_setup(2000 + seed, n, false, 0.0)
    });
}

/// A continuous scan's many profiles: past `calib::POINT_BUDGET` points every profile is thinned
/// and the plane's starts are screened on a subset of the views; both must leave noise-free
/// data exact. (The time this saves is measured in docs/performance.md, not here.)
#[test]
fn thinned_many_profiles_stay_exact() {
    for (id, what, s) in [
        (PLANE, "plane", random_plane_setup(2400, 1500, false, 0.0)),
        (DISK, "disk", random_disk_setup(2401, 1500, 0.0)),
    ] {
        let raw: usize = s
            .caps
            .profiles
            .iter()
            .map(|p| match &p.data {
                ProfileData::Raw(r) => r.points.iter().flatten().count(),
                _ => 0,
            })
            .sum();
        assert!(
            raw > lasercal::calib::POINT_BUDGET,
            "{what}: {raw} points do not reach the budget: the test would not thin"
        );
        exact_one(
            id,
            &s.caps,
            &s.sensor,
            &s.truth,
            &format!("{what}, 1500 poses"),
        );
    }
}

#[test]
fn points_per_profile_thins_only_past_the_budget() {
    use lasercal::calib::{POINT_BUDGET, points_per_profile, stride_for};
    assert_eq!(points_per_profile(POINT_BUDGET, 400, 512), 512);
    assert_eq!(
        points_per_profile(POINT_BUDGET + 1, 1000, 512),
        POINT_BUDGET / 1000
    );
    // Never fewer than a line needs, never more than asked.
    assert_eq!(points_per_profile(10 * POINT_BUDGET, 1_000_000, 512), 16);
    assert_eq!(points_per_profile(10 * POINT_BUDGET, 1_000_000, 8), 8);
    assert_eq!(stride_for(417, 16), 27);
    assert_eq!(417usize.div_ceil(stride_for(417, 16)), 16);
    assert_eq!(stride_for(10, usize::MAX), 1);
}

#[test]
fn plane_from_one_orientation_is_refused_with_what_adds_the_missing_direction() {
    let s = random_plane_setup(3, 12, true, 0.0);
    let e = lasercal::method::estimate(PLANE, &s.caps, &s.sensor)
        .err()
        .expect("refused")
        .to_string();
    assert!(
        e.contains("cannot determine") && e.contains("tilt the sensor") && e.contains("second"),
        "{e}"
    );
}

#[test]
fn plane_with_noise() {
    let (rot, tr) = noisy_errors(PLANE, "24 free poses", |seed| {
        random_plane_setup(6000 + seed, 24, false, 0.1e-3)
    });
    assert!(rot[19] < 0.2 && tr[19] < 0.3, "{rot:?} {tr:?}");
}

#[test]
fn protocols_accept_a_controllers_orientation_jitter() {
    // Public data sets' "pure translations" report W, P, R that jitter by 0.003-0.055 deg. The
    // ball's rotation set with such jitter calibrates (within 0.1 deg); beyond the tolerance the
    // error gives the measured angle and the tolerance. (Here the recorded orientations are
    // jittered and the arcs are not: the calibration error is that reporting error.)
    let text = std::fs::read_to_string(common::scen("chen2018-ball.toml")).unwrap();
    let sf = lasercal::scenario::ScenarioFile::parse(&text, "ball.toml").unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    let caps = lasercal::trial::trial_captures(&setup, Kind::Ball, 1, 0)
        .0
        .unwrap();
    let jitter = |caps: &Captures, deg: f64| {
        let mut c = caps.clone();
        let rot_group = c
            .groups
            .iter()
            .find(|g| g.role == Role::Rotation)
            .unwrap()
            .id;
        let mut k = 0.0;
        for p in c.profiles.iter_mut().filter(|p| p.group == rot_group) {
            k += 1.0;
            let turn = UnitQuaternion::from_scaled_axis(
                Vector3::new(1.0, -0.5, 0.3).normalize() * (deg * k / 4.0).to_radians(),
            );
            p.base_to_flange.rotation = p.base_to_flange.rotation * turn;
        }
        c
    };
    let closed = MethodId::new(Kind::Ball, Estimator::ClosedForm);
    let (cal, _) = lasercal::method::estimate(closed, &jitter(&caps, 0.05), &setup.rig.sensor)
        .expect("0.05 deg of jitter is a controller's");
    let e = PoseError::between(&cal.flange_to_sensor, &setup.rig.flange_to_sensor);
    eprintln!("rotation set jittered by up to 0.05 deg: {e:?}");
    assert!(
        e.rotation_error_deg < 0.1 && e.translation_error_mm < 0.5,
        "{e:?}"
    );
    let err = lasercal::method::estimate(closed, &jitter(&caps, 0.5), &setup.rig.sensor)
        .err()
        .expect("0.5 deg is not one orientation")
        .to_string();
    assert!(
        err.contains("deg from the set's mean orientation")
            && err.contains("tolerance 0.1")
            && err.contains("--orientation-tolerance-deg"),
        "{err}"
    );
    // The user's tolerance: 0.5 deg of jitter passes at 1 deg, in the captures and from a file
    // through `calibrate --orientation-tolerance-deg` (which refuses what is no tolerance).
    let mut wide = jitter(&caps, 0.5);
    wide.orientation_tolerance_deg = 1.0;
    lasercal::method::estimate(closed, &wide, &setup.rig.sensor).expect("within 1 deg");
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("jitter.json");
    std::fs::write(
        &file,
        lasercal::io::captures::to_json(&jitter(&caps, 0.5), &setup.rig.sensor),
    )
    .unwrap();
    let f = file.to_str().unwrap();
    let (code, _, err) = common::lasercal(&["calibrate", f, "--method", "ball"]);
    assert_ne!(code, 0, "{err}");
    let (code, out, err) = common::lasercal(&[
        "calibrate",
        f,
        "--method",
        "ball",
        "--orientation-tolerance-deg",
        "1",
    ]);
    // It runs; the recorded orientations (0.5 deg off, the arcs not) do not fit the arcs, and
    // the verdict says so (exit 3).
    assert_eq!(code, 3, "{out} {err}");
    assert!(
        out.contains("ball: recovered") && out.contains("ball: verdict suspect"),
        "{out}"
    );
    for bad in ["0", "NaN", "10"] {
        let (code, _, err) =
            common::lasercal(&["calibrate", f, "--orientation-tolerance-deg", bad]);
        assert_eq!(code, 2, "{bad}: {err}");
        assert!(
            err.contains("--orientation-tolerance-deg") && err.contains("jitter.json"),
            "{bad}: {err}"
        );
    }
}

fn plane_setup(text: &str) -> Result<lasercal::scenario::Setup, String> {
    let sf =
        lasercal::scenario::ScenarioFile::parse(text, "plane.toml").map_err(|e| e.to_string())?;
    sf.scenario.build(&sf.file).map_err(|e| e.to_string())
}

#[test]
fn pose_sets_listed_as_flange_poses_or_joints_give_the_generated_results() {
    // The generated pose set of scenarios/plane.toml, written back as a list of flange poses (as a
    // quaternion, FANUC's W, P, R, KUKA's A, B, C and UR's rotation vector) and as joint angles:
    // the same captures and the same calibration.
    // Without the sweep (its grid sets the count).
    let full = std::fs::read_to_string(common::scen("plane.toml")).unwrap();
    let text = full[..full.find("[sweep]").unwrap()].to_string();
    let generated = plane_setup(&text).unwrap();
    let plan = generated.plan(Kind::Plane).unwrap();
    let poses = plan
        .as_any()
        .downcast_ref::<lasercal::method::plane::PlanePlan>()
        .unwrap()
        .poses
        .clone();
    let tcp: Vec<String> = poses
        .iter()
        .map(|f| {
            let (t, q) = (f.translation.vector * 1e3, f.rotation);
            format!(
                "[{}, {}, {}, {}, {}, {}, {}]",
                t.x, t.y, t.z, q.w, q.i, q.j, q.k
            )
        })
        .collect();
    let joints: Vec<String> = poses
        .iter()
        .map(|f| {
            let q = generated.rig.robot.ik(f, None).unwrap()[0];
            format!("{:?}", q.map(f64::to_degrees))
        })
        .collect();
    // The controllers' conventions, from the rotation matrix: R = Rz(c) Ry(b) Rx(a) gives
    // b = -asin(R20), a = atan2(R21, R22), c = atan2(R10, R00).
    let euler = |kuka: bool| -> Vec<String> {
        poses
            .iter()
            .map(|f| {
                let (t, m) = (
                    f.translation.vector * 1e3,
                    f.rotation.to_rotation_matrix().into_inner(),
                );
                let b = (-m[(2, 0)]).asin().to_degrees();
                let a = m[(2, 1)].atan2(m[(2, 2)]).to_degrees();
                let c = m[(1, 0)].atan2(m[(0, 0)]).to_degrees();
                let (r1, r3) = if kuka { (c, a) } else { (a, c) };
                format!("[{}, {}, {}, {r1}, {b}, {r3}]", t.x, t.y, t.z)
            })
            .collect()
    };
    let (wpr, abc) = (euler(false), euler(true));
    let rotvec: Vec<String> = poses
        .iter()
        .map(|f| {
            let (t, v) = (f.translation.vector * 1e3, f.rotation.scaled_axis());
            format!("[{}, {}, {}, {}, {}, {}]", t.x, t.y, t.z, v.x, v.y, v.z)
        })
        .collect();
    let as_list = |key: &str, items: &[String]| {
        text.replace("count = 24", &format!("{key} = [{}]", items.join(", ")))
    };
    let cal = |s: &lasercal::scenario::Setup| {
        let caps = lasercal::trial::trial_captures(s, Kind::Plane, 1, 0)
            .0
            .unwrap();
        lasercal::method::estimate(PLANE, &caps, &s.rig.sensor)
            .unwrap()
            .0
            .flange_to_sensor
    };
    let reference = cal(&generated);
    for (key, items) in [
        ("tcp_mm_wxyz", &tcp),
        ("joints_deg", &joints),
        ("tcp_mm_wpr_deg", &wpr),
        ("tcp_mm_abc_deg", &abc),
        ("tcp_mm_rotvec_rad", &rotvec),
    ] {
        let s = plane_setup(&as_list(key, items)).unwrap_or_else(|e| panic!("{key}: {e}"));
        let d = PoseError::between(&cal(&s), &reference);
        assert!(
            d.rotation_error_deg < 1e-6 && d.translation_error_mm < 1e-6,
            "{key}: {d:?}"
        );
    }
    // The same lists from CSV files beside the scenario (the header names the convention).
    let dir = tempfile::tempdir().unwrap();
    let strip = |v: &String| v.trim_matches(|c| c == '[' || c == ']').to_string();
    for (header, items) in [
        ("x_mm,y_mm,z_mm,qw,qx,qy,qz", &tcp),
        ("X_mm, Y_mm, Z_mm, W_deg, P_deg, R_deg", &wpr),
        ("j1_deg,j2_deg,j3_deg,j4_deg,j5_deg,j6_deg", &joints),
    ] {
        let rows: Vec<String> = items.iter().map(strip).collect();
        std::fs::write(
            dir.path().join("poses.csv"),
            format!("{header}\n{}\n", rows.join("\n")),
        )
        .unwrap();
        let path = dir.path().join("plane.toml");
        std::fs::write(&path, text.replace("count = 24", "csv = \"poses.csv\"")).unwrap();
        let sf = lasercal::scenario::ScenarioFile::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let s = sf.scenario.build(&sf.file).unwrap();
        let d = PoseError::between(&cal(&s), &reference);
        assert!(
            d.rotation_error_deg < 1e-6 && d.translation_error_mm < 1e-6,
            "{header}: {d:?}"
        );
    }
    // A bad header or value names the file, line and column.
    for (content, want) in [
        ("x,y,z\n1,2,3\n", "header"),
        (
            "x_mm,y_mm,z_mm,qw,qx,qy,qz\n1,2,3,1,0,0,nan\n",
            "line 2, qz",
        ),
        ("x_mm,y_mm,z_mm,qw,qx,qy,qz\n1,2,3,1,0,0\n", "line 2"),
    ] {
        std::fs::write(dir.path().join("poses.csv"), content).unwrap();
        let e = lasercal::scenario::ScenarioFile::load(&dir.path().join("plane.toml"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("plane.poses.csv") && e.contains("poses.csv") && e.contains(want),
            "{e}"
        );
    }
    // Two ways at once, a bad quaternion, the two-step method on free poses: errors that say so.
    let both = text.replace(
        "count = 24",
        "count = 24\njoints_deg = [[0, 0, 0, 0, 0, 0]]",
    );
    let e = plane_setup(&both).unwrap_err();
    assert!(
        e.contains("plane.poses") && e.contains("exactly one of"),
        "{e}"
    );
    let bad_q = as_list("tcp_mm_wxyz", &tcp).replacen(&tcp[3], "[400, 0, 300, 2, 0, 0, 0]", 1);
    let e = plane_setup(&bad_q).unwrap_err();
    assert!(
        e.contains("plane.poses.tcp_mm_wxyz[3]") && e.contains("unit quaternion"),
        "{e}"
    );
    let ball = std::fs::read_to_string(common::scen("ball-free.toml"))
        .unwrap()
        .replace(
            "methods = [\"ball-any-pose\"]",
            "methods = [\"ball\", \"ball-any-pose\"]",
        );
    let sf = lasercal::scenario::ScenarioFile::parse(&ball, "ball-free.toml");
    let e = sf.map(|_| ()).unwrap_err().to_string();
    assert!(
        e.contains("methods") && e.contains("use ball-any-pose"),
        "{e}"
    );
}

/// Monte Carlo against the predicted standard deviations: the spread of `trials` estimates per
/// axis (rotation about the sensor's axes, translation along the flange's) over the mean
/// predicted sd.
fn sd_ratio(scenario: &str, kind: Kind, trials: u64) -> ([f64; 3], [f64; 3]) {
    let full = std::fs::read_to_string(common::scen(scenario)).unwrap();
    let text = full[..full.find("[sweep]").unwrap_or(full.len())].to_string();
    let sf = lasercal::scenario::ScenarioFile::parse(&text, scenario).unwrap();
    let s = sf.scenario.build(&sf.file).unwrap();
    let id = MethodId::new(kind, Estimator::AnyPose);
    let truth = s.rig.flange_to_sensor;
    let (mut errs, mut pred) = (Vec::new(), nalgebra::Vector6::<f64>::zeros());
    for t in 0..trials {
        let caps = lasercal::trial::trial_captures(&s, kind, 1, t).0.unwrap();
        let (cal, r) = lasercal::method::estimate(id, &caps, &s.rig.sensor).unwrap();
        let r = r.unwrap();
        let w = (truth.rotation.inverse() * cal.flange_to_sensor.rotation).scaled_axis();
        let dt = cal.flange_to_sensor.translation.vector - truth.translation.vector;
        errs.push(nalgebra::Vector6::new(
            w.x.to_degrees(),
            w.y.to_degrees(),
            w.z.to_degrees(),
            dt.x * 1e3,
            dt.y * 1e3,
            dt.z * 1e3,
        ));
        pred += nalgebra::Vector6::new(
            r.sd_rotation_deg.x,
            r.sd_rotation_deg.y,
            r.sd_rotation_deg.z,
            r.sd_translation_mm.x,
            r.sd_translation_mm.y,
            r.sd_translation_mm.z,
        ) / trials as f64;
    }
    let n = errs.len() as f64;
    let mean = errs.iter().sum::<nalgebra::Vector6<f64>>() / n;
    let sd = errs
        .iter()
        .map(|e| (e - mean).component_mul(&(e - mean)))
        .sum::<nalgebra::Vector6<f64>>()
        .map(|v| (v / (n - 1.0)).sqrt());
    let ratio = sd.component_div(&pred);
    eprintln!("{scenario}: Monte Carlo sd {sd:.5?}, predicted {pred:.5?}, ratio {ratio:.3?}");
    (
        [ratio[0], ratio[1], ratio[2]],
        [ratio[3], ratio[4], ratio[5]],
    )
}

#[test]
fn predicted_standard_deviations_match_monte_carlo() {
    // Issue 14: within 20 % of Monte Carlo (200 trials: the Monte Carlo sd itself is known to
    // about 5 %).
    for (scenario, kind) in [
        ("plane.toml", Kind::Plane),
        ("ball-free.toml", Kind::Ball),
        ("edge-8-poses.toml", Kind::Edge),
    ] {
        let (rot, tr) = sd_ratio(scenario, kind, 200);
        for r in rot.iter().chain(&tr) {
            assert!((0.8..=1.2).contains(r), "{scenario}: ratios {rot:?} {tr:?}");
        }
    }
}

/// Issue 14: on a plate's edges seen from 8 poses each at its own orientation
/// (scenarios/edge-8-poses.toml), median errors at most half the public peer's at z noise 0.05 /
/// 0.1 / 0.2 mm (its 0.016 / 0.032 / 0.064 deg and 0.17 / 0.35 / 0.70 mm), over 100 trials each.
#[test]
fn edge_from_eight_free_poses_halves_the_peers_errors() {
    let full = std::fs::read_to_string(common::scen("edge-8-poses.toml")).unwrap();
    let id = MethodId::new(Kind::Edge, Estimator::AnyPose);
    for (scale, peer_deg, peer_mm) in [(0.5, 0.016, 0.17), (1.0, 0.032, 0.35), (2.0, 0.064, 0.70)] {
        let text = full[..full.find("[sweep]").unwrap()]
            .replace("scale = 1.0", &format!("scale = {scale}"));
        let sf = lasercal::scenario::ScenarioFile::parse(&text, "edge-8-poses.toml").unwrap();
        let s = sf.scenario.build(&sf.file).unwrap();
        let (mut rot, mut tr, mut its) = (Vec::new(), Vec::new(), 0);
        for t in 0..100 {
            let caps = lasercal::trial::trial_captures(&s, Kind::Edge, 1, t)
                .0
                .unwrap();
            let (cal, r) = lasercal::method::estimate(id, &caps, &s.rig.sensor).unwrap();
            let status = r.unwrap().status;
            assert!(
                matches!(status, lasercal::calib::Status::Converged { .. }),
                "trial {t}: {status:?}"
            );
            if let lasercal::calib::Status::Converged { iterations } = status {
                its = its.max(iterations);
            }
            let e = PoseError::between(&cal.flange_to_sensor, &s.rig.flange_to_sensor);
            rot.push(e.rotation_error_deg);
            tr.push(e.translation_error_mm);
        }
        rot.sort_by(f64::total_cmp);
        tr.sort_by(f64::total_cmp);
        let (r, t) = ((rot[49] + rot[50]) / 2.0, (tr[49] + tr[50]) / 2.0);
        eprintln!(
            "edge-8-poses, z noise {:.2} mm: median {r:.4} deg / {t:.4} mm ({its} iterations at most)",
            0.1 * scale
        );
        assert!(
            r <= peer_deg / 2.0 && t <= peer_mm / 2.0,
            "scale {scale}: {r} deg, {t} mm"
        );
    }
}

/// Issue 14: `ball-refined` (and `ball-any-pose`) converge in at least 99.5 % of 1,000 trials per
/// sigma up to 0.3 mm (the disk paper's ball protocol, analytic arcs). Prints the counts:
/// `cargo test --release --test suite any_pose::ball_convergence -- --ignored --nocapture`.
#[test]
#[ignore]
fn ball_convergence_over_a_thousand_trials() {
    let text = std::fs::read_to_string(common::scen("chen2018-ball.toml")).unwrap();
    for sigma in [0.05, 0.1, 0.2, 0.3] {
        let t = text.replace("sigma_mm = 0.1", &format!("sigma_mm = {sigma}"));
        let sf = lasercal::scenario::ScenarioFile::parse(&t, "ball.toml").unwrap();
        let s = sf.scenario.build(&sf.file).unwrap();
        for est in [Estimator::Refined, Estimator::AnyPose] {
            let id = MethodId::new(Kind::Ball, est);
            let converged = (0..1000u64)
                .filter(|&trial| {
                    let caps = lasercal::trial::trial_captures(&s, Kind::Ball, 1, trial)
                        .0
                        .unwrap();
                    lasercal::method::estimate(id, &caps, &s.rig.sensor).is_ok_and(|(_, r)| {
                        matches!(
                            r.map(|r| r.status),
                            Some(lasercal::calib::Status::Converged { .. })
                        )
                    })
                })
                .count();
            println!("| {sigma} | {id} | {converged} / 1000 |");
            assert!(converged >= 995, "{id} at {sigma} mm: {converged} of 1000");
        }
    }
}

/// Issue 14: every refined variant converges in at least 99.5 % of 1,000 trials per sigma up to
/// 0.3 mm: the papers' protocols (analytic chords and edge points, noise along them) for the
/// refined closed forms, and the free-pose scenarios (ray-cast, z noise) for the any-pose
/// estimators. Prints the counts:
/// `cargo test --release --test suite any_pose::every_refined_variant_converges -- --ignored --nocapture`.
#[test]
#[ignore]
fn every_refined_variant_converges_over_a_thousand_trials() {
    let cases: [(&str, Kind, &[Estimator], fn(&str, f64) -> String); 5] = [
        (
            "chen2018-disk.toml",
            Kind::Disk,
            &[Estimator::Refined],
            |t, s| t.replacen("sigma_mm = 0.1", &format!("sigma_mm = {s}"), 1),
        ),
        (
            "xu2021-edge.toml",
            Kind::Edge,
            &[Estimator::Refined],
            |t, s| t.replacen("sigma_mm = 0.05", &format!("sigma_mm = {s}"), 1),
        ),
        (
            "disk-free.toml",
            Kind::Disk,
            &[Estimator::AnyPose],
            |t, s| {
                t.replace("z_sigma_near_mm = 0.02", &format!("z_sigma_near_mm = {s}"))
                    .replace("z_sigma_far_mm = 0.06", &format!("z_sigma_far_mm = {s}"))
                    .replace("quantise = true", "quantise = false")
            },
        ),
        ("plane.toml", Kind::Plane, &[Estimator::AnyPose], |t, s| {
            t.replace("z_sigma_near_mm = 0.02", &format!("z_sigma_near_mm = {s}"))
                .replace("z_sigma_far_mm = 0.06", &format!("z_sigma_far_mm = {s}"))
                .replace("quantise = true", "quantise = false")
        }),
        (
            "edge-8-poses.toml",
            Kind::Edge,
            &[Estimator::AnyPose],
            |t, s| t.replace("scale = 1.0", &format!("scale = {}", s / 0.1)),
        ),
    ];
    for (scenario, kind, estimators, with_sigma) in cases {
        let full = std::fs::read_to_string(common::scen(scenario)).unwrap();
        let text = full[..full.find("[sweep]").unwrap_or(full.len())].to_string();
        for sigma in [0.05, 0.1, 0.2, 0.3] {
            let t = with_sigma(&text, sigma);
            let sf = lasercal::scenario::ScenarioFile::parse(&t, scenario).unwrap();
            let s = sf.scenario.build(&sf.file).unwrap();
            for &est in estimators {
                let id = MethodId::new(kind, est);
                let converged = (0..1000u64)
                    .filter(|&trial| {
                        let Ok(caps) = lasercal::trial::trial_captures(&s, kind, 1, trial).0 else {
                            return false;
                        };
                        lasercal::method::estimate(id, &caps, &s.rig.sensor).is_ok_and(
                            |(cal, r)| {
                                matches!(
                                    r.map_or(cal.status, |r| r.status),
                                    lasercal::calib::Status::Converged { .. }
                                )
                            },
                        )
                    })
                    .count();
                println!("| {scenario} | {sigma} | {id} | {converged} / 1000 |");
                assert!(converged >= 995, "{id} at {sigma} mm: {converged} of 1000");
            }
        }
    }
}

#[test]
fn a_file_of_free_poses_calibrates_with_the_any_pose_estimator_by_default() {
    let dir = tempfile::tempdir().unwrap();
    for (scenario, method) in [
        ("edge-8-poses.toml", "edge-any-pose"),
        ("disk-free.toml", "disk-any-pose"),
    ] {
        let file = dir.path().join("caps.json");
        let (code, _, err) = common::lasercal(&[
            "simulate",
            &common::scen(scenario),
            "--out",
            file.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{err}");
        let (code, out, err) = common::lasercal(&["calibrate", file.to_str().unwrap()]);
        assert_eq!(code, 0, "{scenario}: {out} {err}");
        assert!(
            out.contains(&format!("chosen: {method}"))
                && out.contains(&format!("{method}: recovered")),
            "{scenario}: {out} {err}"
        );
    }
}

#[test]
fn free_poses_take_only_the_any_pose_estimator_on_raycast_profiles() {
    for (scenario, kind) in [("edge-8-poses.toml", "edge"), ("disk-free.toml", "disk")] {
        let text = std::fs::read_to_string(common::scen(scenario)).unwrap();
        let both = text.replace(
            &format!("methods = [\"{kind}-any-pose\"]"),
            &format!("methods = [\"{kind}\", \"{kind}-any-pose\"]"),
        );
        let e = lasercal::scenario::ScenarioFile::parse(&both, scenario)
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("methods") && e.contains(&format!("use {kind}-any-pose")),
            "{e}"
        );
        let analytic = text.replace("source = \"raycast\"", "source = \"analytic\"");
        let e = lasercal::scenario::ScenarioFile::parse(&analytic, scenario)
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&format!("{kind}.source")) && e.contains("raycast"),
            "{e}"
        );
    }
}

/// The independent generator's random rigs of `the_verdict_holds_*`: each specimen's any-pose
/// estimator and its rig for a seed (16 free poses, z noise `sigma`), seeds from `base` on
/// (each specimen 100 further).
fn random_rigs(base: u64, sigma: f64) -> Vec<(MethodId, &'static str, Box<dyn Fn(u64) -> Setup>)> {
    let any = |k: Kind| MethodId::new(k, Estimator::AnyPose);
    vec![
        (
            any(Kind::Ball),
            "ball",
            Box::new(move |seed| random_setup(base + seed, 16, 3, sigma)),
        ),
        (
            any(Kind::Plane),
            "plane",
            Box::new(move |seed| random_plane_setup(base + 100 + seed, 16, false, sigma)),
        ),
        (
            any(Kind::Edge),
            "bar",
            Box::new(move |seed| random_bar_setup(base + 200 + seed, 16, sigma)),
        ),
        (
            any(Kind::Disk),
            "disk",
            Box::new(move |seed| random_disk_setup(base + 300 + seed, 16, sigma)),
        ),
        (
            any(Kind::Edge),
            "ridge",
            Box::new(move |seed| random_wedge_setup(base + 400 + seed, 16, sigma, false)),
        ),
        (
            any(Kind::Edge),
            "v-groove",
            Box::new(move |seed| random_wedge_setup(base + 500 + seed, 16, sigma, true)),
        ),
    ]
}

/// A rig's result from estimator `id`, judged as the verdict judges one result
/// (`verdict::judge(verdict::quality(..))`), the sensor told its noise `sigma`, with its error
/// against the rig's truth; None: the estimator refused the captures.
fn judged_on_rig(
    id: MethodId,
    s: &Setup,
    sigma: f64,
) -> Option<(lasercal::method::verdict::Judged, PoseError)> {
    use lasercal::method::verdict::{judge, quality};
    let mut sensor = s.sensor.clone();
    sensor.noise.z_sigma_near = sigma;
    sensor.noise.z_sigma_far = sigma;
    let (cal, r) = lasercal::method::estimate(id, &s.caps, &sensor).ok()?;
    let j = judge(quality(&cal, r.as_ref(), id.estimator, &s.caps, &sensor));
    Some((j, PoseError::between(&cal.flange_to_sensor, &s.truth)))
}

#[test]
fn the_verdict_holds_on_profiles_lasercal_did_not_make() {
    // The independent generator's rigs (random fans, mountings, specimens, 16 free poses, z noise
    // 0.1 mm, the sensor told so): correct captures are judged ok; a ball 5 % smaller than the
    // file says is judged suspect whenever the answer is off by more than 1 deg or 1 mm.
    use lasercal::method::verdict::Verdict;
    let sigma = 0.1e-3;
    let any = |k: Kind| MethodId::new(k, Estimator::AnyPose);
    let cases = random_rigs(7000, sigma);
    // LASERCAL_VERDICT_SEEDS rigs per estimator (default 10) for a larger measurement.
    let seeds: u64 = std::env::var("LASERCAL_VERDICT_SEEDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10);
    let (mut passed, mut flagged, mut covered) = (0, Vec::new(), 0);
    let (mut off, mut refused) = (0u64, 0u64);
    let mut per = std::collections::BTreeMap::new();
    for (id, what, setup) in cases {
        for seed in 0..seeds {
            let Some((j, e)) = judged_on_rig(id, &setup(seed), sigma) else {
                refused += 1;
                continue;
            };
            // A wrong answer (beyond 1 deg or 1 mm) must not pass as ok.
            if !(e.rotation_error_deg < 1.0 && e.translation_error_mm < 1.0) {
                off += 1;
                eprintln!("  wrong, judged {}: {id} ({what}) {seed}: {e:?}", j.verdict);
                assert_ne!(
                    j.verdict,
                    Verdict::Ok,
                    "{id} ({what}) {seed}: {e:?} judged ok"
                );
                continue;
            }
            let (br, bt) = j.quality.error_bound();
            if e.rotation_error_deg <= br && e.translation_error_mm <= bt {
                covered += 1;
                *per.entry(format!("{id} ({what})")).or_insert(0) += 1;
            }
            match j.verdict {
                Verdict::Ok => passed += 1,
                Verdict::Suspect | Verdict::Imprecise => flagged.push(format!(
                    "{id} ({what}) {seed}: {} {:?} {:?}",
                    j.verdict, j.reasons, j.precision
                )),
            }
        }
    }
    for f in &flagged {
        eprintln!("  flagged: {f}");
    }
    // The honest 95 % bound on profiles lasercal did not make: 40 results are too few to show
    // 95 %, but far fewer than 85 % would say the bound is not honest there.
    let n = 6 * seeds - off - refused;
    assert!(
        off + refused <= seeds / 10,
        "{off} wrong answers, {refused} refused"
    );
    eprintln!(
        "honest bound on independent rigs: {covered} of {n} right answers' errors within it \
         ({off} wrong answers, none judged ok; {refused} refused); covered per estimator \
         (of {seeds}): {per:?}"
    );
    assert!(
        covered as f64 >= 0.85 * n as f64,
        "{covered} of {n} errors within their 95 % bounds"
    );
    assert!(
        flagged.len() as u64 <= 1 + seeds / 25,
        "correct results judged suspect or imprecise: {flagged:#?}"
    );
    let mut wrong = 0;
    for seed in 0..10u64 {
        let mut s = random_setup(7000 + seed, 16, 3, sigma);
        s.caps.specimen_radius = s.caps.specimen_radius.map(|r| r * 1.05);
        let Some((j, e)) = judged_on_rig(any(Kind::Ball), &s, sigma) else {
            continue;
        };
        if e.rotation_error_deg > 1.0 || e.translation_error_mm > 1.0 {
            wrong += 1;
            assert_eq!(j.verdict, Verdict::Suspect, "seed {seed}: {e:?} judged ok");
        }
        // The residuals say so even when the answer stays within 1 deg and 1 mm.
        assert!(
            j.quality.noise_ratio.unwrap() > 1.5,
            "seed {seed}: {:?}",
            j.quality
        );
    }
    eprintln!(
        "verdict on independent rigs: {passed} of {n} correct ok; {wrong} of 10 wrong-radius answers off"
    );
}

/// The same rigs with robot pose error: each profile cast from its pose moved by up to 0.3 mm
/// (a random direction) and turned by up to 0.017 deg (a random axis), the file recording the
/// commanded pose and stating a repeatability of 0.1 mm (the shift's sd per axis; the turn, 0.1
/// mm at most at the specimen, is the scatter's to show), no accuracy common to the poses. No
/// wrong answer (beyond 1 deg or 1 mm) may be ok and no more than 1 in 25 right ones suspect;
/// the 95 % bound's coverage is printed per estimator (covered, right answers, rotation
/// covered, translation covered; `LASERCAL_VERDICT_SEEDS` rigs each, default 10;
/// docs/verdict.md has a release run of 1,000; one specimen: `LASERCAL_VERDICT_CASE`).
#[test]
fn the_verdict_holds_on_random_rigs_with_robot_pose_error() {
    use lasercal::method::verdict::Verdict;
    let sigma = 0.1e-3;
    let (shift, turn) = (0.3e-3, 0.3e-3);
    let cases = random_rigs(8000, sigma);
    // One specimen alone: `LASERCAL_VERDICT_CASE=plane` (ball, bar, disk, ridge, v-groove).
    let only = std::env::var("LASERCAL_VERDICT_CASE").ok();
    let seeds: u64 = std::env::var("LASERCAL_VERDICT_SEEDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10);
    let (mut right, mut suspect, mut imprecise, mut off, mut refused) = (0u64, 0, 0, 0, 0);
    let mut covered = std::collections::BTreeMap::new();
    let mut over_all = std::collections::BTreeMap::new();
    let mut missed = Vec::new();
    for (id, what, setup) in cases {
        if only.as_deref().is_some_and(|c| c != what) {
            continue;
        }
        for seed in 0..seeds {
            let mut s = setup(seed);
            let mut g = lasercal::testkit::rng(9000 + seed);
            for p in &mut s.caps.profiles {
                p.base_to_flange =
                    lasercal::testkit::perturb(&mut g, &p.base_to_flange, turn, shift);
            }
            s.caps.judging.robot_repeatability = shift / 3.0;
            let Some((j, e)) = judged_on_rig(id, &s, sigma) else {
                refused += 1;
                continue;
            };
            let (br, bt) = j.quality.error_bound();
            let within = e.rotation_error_deg <= br && e.translation_error_mm <= bt;
            // Coverage over every answer, the wrong ones too (over the right ones alone it
            // leaves out the largest errors).
            let all = over_all
                .entry(format!("{id} ({what})"))
                .or_insert((0u64, 0u64));
            all.0 += within as u64;
            all.1 += 1;
            if !(e.rotation_error_deg < 1.0 && e.translation_error_mm < 1.0) {
                off += 1;
                if j.verdict == Verdict::Ok {
                    missed.push(format!(
                        "{id} ({what}) {seed}: {:.3} deg / {:.3} mm off judged ok, bounds {:?}",
                        e.rotation_error_deg,
                        e.translation_error_mm,
                        j.quality.error_bound()
                    ));
                }
                continue;
            }
            right += 1;
            match j.verdict {
                Verdict::Suspect => {
                    suspect += 1;
                    eprintln!("  suspect: {id} ({what}) {seed}: {:?}", j.reasons);
                }
                Verdict::Imprecise => imprecise += 1,
                Verdict::Ok => {}
            }
            let c = covered
                .entry(format!("{id} ({what})"))
                .or_insert((0u64, 0u64, 0u64, 0u64));
            c.0 += within as u64;
            c.1 += 1;
            c.2 += (e.rotation_error_deg <= br) as u64;
            c.3 += (e.translation_error_mm <= bt) as u64;
        }
    }
    let held: u64 = covered.values().map(|c| c.0).sum();
    eprintln!(
        "random rigs with robot pose error: {right} right ({suspect} suspect, {imprecise} \
         imprecise), {off} wrong ({} judged ok), {refused} refused; covered {held} of {right}; \
         per estimator (covered, right, rotation covered, translation covered): {covered:?}; \
         over every answer (covered, answers): {over_all:?}",
        missed.len()
    );
    assert!(missed.is_empty(), "wrong answers judged ok: {missed:#?}");
    assert!(
        suspect <= 1 + right / 25,
        "{suspect} of {right} right answers suspect"
    );
    assert!(
        off + refused <= seeds,
        "{off} wrong answers, {refused} refused"
    );
    assert!(
        held as f64 >= 0.85 * right as f64,
        "{held} of {right} errors within their 95 % bounds"
    );
}

#[test]
fn the_view_fits_the_specimen_on_profiles_lasercal_did_not_make() {
    // The recordings' truth-free picture (`method::view`) on the independent generator's rigs:
    // with the right transform a typical profile lands on the fitted specimen within the noise (and
    // the ball's fitted radius is the true one); with a transform a degree off it does not.
    use lasercal::method::view::{Fitted, view};
    let sigma = 0.1e-3;
    let cases: [(Kind, &dyn Fn(u64) -> Setup); 4] = [
        (Kind::Ball, &|seed| random_setup(7400 + seed, 16, 3, sigma)),
        (Kind::Plane, &|seed| {
            random_plane_setup(7500 + seed, 16, false, sigma)
        }),
        (Kind::Edge, &|seed| random_bar_setup(7600 + seed, 16, sigma)),
        (Kind::Disk, &|seed| {
            random_disk_setup(7700 + seed, 16, sigma)
        }),
    ];
    let rms = |v: &lasercal::method::view::View| v.median_profile_rms().unwrap();
    for (kind, setup) in cases {
        for seed in 0..5u64 {
            let s = setup(seed);
            let v = view(&s.caps, &s.sensor, &s.truth);
            let with = v.profiles.iter().filter(|p| p.feature.is_some()).count();
            assert!(
                with * 10 >= 9 * v.profiles.len(),
                "{kind} {seed}: {with} features"
            );
            let good = rms(&v);
            assert!(good < 4.0 * sigma, "{kind} {seed}: residual RMS {good}");
            // The fitted shape is the true one: the ball's radius, the plane's or bar face's normal.
            let up = s.face * Vector3::z();
            let off_deg = |n: &Vector3<f64>| n.dot(&up).abs().min(1.0).acos().to_degrees();
            match &v.fitted {
                Some(Fitted::Sphere { radius, .. }) => {
                    assert!((radius - RADIUS).abs() < 0.1e-3, "{seed}: radius {radius}")
                }
                Some(Fitted::Plane { normal, .. }) => {
                    assert!(
                        off_deg(normal) < 0.1,
                        "{seed}: plane {} deg off",
                        off_deg(normal)
                    )
                }
                Some(Fitted::Edge {
                    face: Some((_, n)), ..
                }) => {
                    assert!(off_deg(n) < 0.1, "{seed}: face {} deg off", off_deg(n))
                }
                _ => {}
            }
            assert!(v.fitted.is_some(), "{kind} {seed}: nothing fitted");
            let wrong = s.truth
                * Isometry3::from_parts(
                    Translation3::new(0.0, 1e-3, 0.0),
                    UnitQuaternion::from_euler_angles(0.0, 1f64.to_radians(), 0.0),
                );
            let bad = rms(&view(&s.caps, &s.sensor, &wrong));
            eprintln!(
                "view {kind} {seed}: typical profile RMS {:.4} mm, {:.4} mm off",
                good * 1e3,
                bad * 1e3
            );
            assert!(bad > 2.0 * good, "{kind} {seed}: {good} vs {bad}");
        }
    }
}

#[test]
fn noise_the_sensor_does_not_declare_is_read_from_the_profiles() {
    // A profiler declared exact (a real one's noise is rarely known) giving z noise 0.1 mm: the
    // extraction reads the noise from the profiles (`method::extraction_sensor`). Before, on these
    // random bars edge-any-pose went wrong by 1-68 deg in 41 of 60 rigs; the verdict, which tests
    // residuals against the declared noise, still says the noise was understated.
    let sigma = 0.1e-3;
    let cases: [(Kind, &dyn Fn(u64) -> Setup); 4] = [
        (Kind::Edge, &|seed| random_bar_setup(7600 + seed, 16, sigma)),
        (Kind::Ball, &|seed| random_setup(7800 + seed, 16, 3, sigma)),
        (Kind::Plane, &|seed| {
            random_plane_setup(7900 + seed, 16, false, sigma)
        }),
        (Kind::Disk, &|seed| {
            random_disk_setup(8000 + seed, 16, sigma)
        }),
    ];
    for (kind, setup) in cases {
        let mut worst = (0.0f64, 0.0f64);
        for seed in 0..30u64 {
            let s = setup(seed);
            assert!(s.sensor.noise.is_off());
            let id = MethodId::new(kind, Estimator::AnyPose);
            let (cal, _) = lasercal::method::estimate(id, &s.caps, &s.sensor)
                .unwrap_or_else(|e| panic!("{kind} {seed}: {e}"));
            let e = PoseError::between(&cal.flange_to_sensor, &s.truth);
            worst = (
                worst.0.max(e.rotation_error_deg),
                worst.1.max(e.translation_error_mm),
            );
        }
        eprintln!(
            "{kind}-any-pose, noise undeclared, 30 rigs: worst {:.3} deg / {:.3} mm",
            worst.0, worst.1
        );
        assert!(worst.0 < 0.5 && worst.1 < 1.0, "{kind}: {worst:?}");
    }
}

/// `pattern = "circle"` turns generated pose i by i / count of a full turn about the normal: the
/// lasers' directions, projected on the table, step evenly round it; a pattern on a listed set
/// is refused naming the key.
#[test]
fn circle_patterns_step_evenly_round_the_normal() {
    let full = std::fs::read_to_string(common::scen("plane-48-circle.toml")).unwrap();
    let s = plane_setup(&full).unwrap();
    let plan = s.plan(Kind::Plane).unwrap();
    let poses = &plan
        .as_any()
        .downcast_ref::<lasercal::method::plane::PlanePlan>()
        .unwrap()
        .poses;
    assert_eq!(poses.len(), 48);
    // The laser's direction in the base frame (the sensor's z; the table's normal is base z).
    let azimuth = |f: &nalgebra::Isometry3<f64>| {
        let z = (f * s.rig.flange_to_sensor).rotation * nalgebra::Vector3::z();
        z.y.atan2(z.x)
    };
    let step = std::f64::consts::TAU / 48.0;
    for (i, w) in poses.windows(2).enumerate() {
        let d = (azimuth(&w[1]) - azimuth(&w[0])).rem_euclid(std::f64::consts::TAU);
        assert!(
            (d - step).abs() < 1e-9,
            "pose {i} to {}: {} deg",
            i + 1,
            d.to_degrees()
        );
    }
    let pose = "[-300.0, -250.0, 650.0, 0.0, 0.7071068, 0.7071068, 0.0]";
    let listed = full.replace(
        "count = 48",
        &format!("tcp_mm_wxyz = [{}]", vec![pose; 7].join(", ")),
    );
    let err = plane_setup(&listed).unwrap_err();
    assert!(err.contains("plane.poses.pattern"), "{err}");
}

/// A setup's captures as a capture file that names no sensor (`sensor` as given: None drops the
/// field), read back: the sensor lasercal builds from the points alone.
fn points_only_file(
    s: &Setup,
    sensor: Option<serde_json::Value>,
) -> Result<(Captures, SensorModel), String> {
    let text = lasercal::io::captures::to_json(&s.caps, &s.sensor);
    let mut doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let o = doc.as_object_mut().unwrap();
    o.remove("sensor_noise");
    match sensor {
        Some(v) => o.insert("sensor".into(), v),
        None => o.remove("sensor"),
    };
    lasercal::io::captures::from_json(&doc.to_string(), "points.json").map_err(|e| e.to_string())
}

#[test]
fn a_sensor_known_only_by_its_points_calibrates_the_independent_kits_rigs() {
    // The kit's fans are Gocator-like: z toward the sensor. The ball's arcs show it; a disk's or a
    // bar's profiles need it stated; a plane needs nothing.
    let toward = Some(serde_json::json!({ "points_only": { "z_axis": "toward" } }));
    let cases: [(
        Kind,
        Option<serde_json::Value>,
        &dyn Fn(u64, usize) -> Setup,
    ); 4] = [
        (Kind::Ball, None, &|seed, n| {
            random_setup(12_000 + seed, n, 3, 0.0)
        }),
        (Kind::Plane, None, &|seed, n| {
            random_plane_setup(12_100 + seed, n, false, 0.0)
        }),
        (Kind::Disk, toward.clone(), &|seed, n| {
            random_disk_setup(12_200 + seed, n, 0.0)
        }),
        (Kind::Edge, toward.clone(), &|seed, n| {
            random_bar_setup(12_300 + seed, n, 0.0)
        }),
    ];
    for (kind, sensor, setup) in cases {
        let mut worst = (0.0f64, 0.0f64);
        for seed in 0..20u64 {
            // From 10 poses: 8 free plane poses can have a second exact solution, whatever the
            // sensor (`plane_exact_on_a_hundred_random_rigs_and_pose_sets`).
            let n = 10 + (seed as usize * 5) % 30;
            let s = setup(seed, n);
            let (caps, sensor) = points_only_file(&s, sensor.clone()).unwrap();
            assert!(
                sensor.points_only && sensor.dir_z == -1.0,
                "{kind} {seed}: {}",
                sensor.name
            );
            if kind == Kind::Ball {
                assert!(
                    sensor.name.contains("read from the ball's arcs"),
                    "{}",
                    sensor.name
                );
            }
            let id = MethodId::new(kind, Estimator::AnyPose);
            let e = exact_one(
                id,
                &caps,
                &sensor,
                &s.truth,
                &format!("{kind} {seed} ({n} poses)"),
            );
            worst = (
                worst.0.max(e.rotation_error_deg),
                worst.1.max(e.translation_error_mm),
            );
        }
        eprintln!(
            "{kind}-any-pose, points only, 20 rigs: worst {:.1e} deg / {:.1e} mm",
            worst.0, worst.1
        );
    }
}

#[test]
fn a_points_only_disk_without_its_z_axis_is_refused_naming_the_key() {
    let s = random_disk_setup(12_200, 12, 0.0);
    let e = points_only_file(&s, None).err().expect("refused");
    assert!(
        e.contains("points.json")
            && e.contains("sensor.points_only.z_axis")
            && e.contains("toward"),
        "{e}"
    );
}

#[test]
fn noisy_profiles_of_a_sensor_known_only_by_its_points_state_their_own_noise() {
    // z noise 0.1 mm: the points-only sensor's noise is measured from the profiles, and the
    // verdict's residual test compares with it (a right answer is not suspect).
    let s = random_setup(12_400, 16, 3, 0.1e-3);
    let (caps, sensor) = points_only_file(&s, None).unwrap();
    let sigma = sensor.noise.z_sigma_far;
    assert!((sigma / 0.1e-3 - 1.0).abs() < 0.2, "measured {sigma}");
    let (cal, r) = lasercal::method::estimate(ANY, &caps, &sensor).unwrap();
    let judged = lasercal::method::verdict::judge(lasercal::method::verdict::quality(
        &cal,
        r.as_ref(),
        ANY.estimator,
        &caps,
        &sensor,
    ));
    assert_ne!(
        judged.verdict,
        lasercal::method::verdict::Verdict::Suspect,
        "{judged:?}"
    );
    let e = PoseError::between(&cal.flange_to_sensor, &s.truth);
    assert!(
        e.rotation_error_deg < 0.2 && e.translation_error_mm < 0.3,
        "{e:?}"
    );
}

#[test]
fn points_only_profiles_at_noise_lose_little_to_a_declared_fan() {
    // z noise 0.1 mm, 16 free poses, 30 rigs per target: the median error from points alone
    // against the same profiles read through the fan they came from.
    let toward = Some(serde_json::json!({ "points_only": { "z_axis": "toward" } }));
    let cases: [(Kind, &dyn Fn(u64) -> Setup); 4] = [
        (Kind::Ball, &|seed| {
            random_setup(13_000 + seed, 16, 3, 0.1e-3)
        }),
        (Kind::Plane, &|seed| {
            random_plane_setup(13_100 + seed, 16, false, 0.1e-3)
        }),
        (Kind::Disk, &|seed| {
            random_disk_setup(13_200 + seed, 16, 0.1e-3)
        }),
        (Kind::Edge, &|seed| {
            random_bar_setup(13_300 + seed, 16, 0.1e-3)
        }),
    ];
    for (kind, setup) in cases {
        let id = MethodId::new(kind, Estimator::AnyPose);
        let (mut declared, mut points, mut wrong) = (Vec::new(), Vec::new(), 0);
        for seed in 0..30u64 {
            let s = setup(seed);
            let err = |caps: &Captures, sensor: &SensorModel| {
                lasercal::method::estimate(id, caps, sensor).map_or(f64::INFINITY, |(c, _)| {
                    let e = PoseError::between(&c.flange_to_sensor, &s.truth);
                    e.rotation_error_deg.max(e.translation_error_mm)
                })
            };
            let mut sensor = s.sensor.clone();
            sensor.noise.z_sigma_near = 0.1e-3;
            sensor.noise.z_sigma_far = 0.1e-3;
            declared.push(err(&s.caps, &sensor));
            let (caps, sensor) = points_only_file(
                &s,
                (kind != Kind::Ball && kind != Kind::Plane).then(|| toward.clone().unwrap()),
            )
            .unwrap();
            points.push(err(&caps, &sensor));
            // A feature misread without rays may spoil a result: the verdict must say so.
            if let Ok((c, r)) = lasercal::method::estimate(id, &caps, &sensor) {
                let e = PoseError::between(&c.flange_to_sensor, &s.truth);
                let j = lasercal::method::verdict::judge(lasercal::method::verdict::quality(
                    &c,
                    r.as_ref(),
                    id.estimator,
                    &caps,
                    &sensor,
                ));
                if e.rotation_error_deg > 0.5 || e.translation_error_mm > 0.5 {
                    wrong += 1;
                    assert_eq!(
                        j.verdict,
                        lasercal::method::verdict::Verdict::Suspect,
                        "{kind} {seed}: {e:?}"
                    );
                }
            }
        }
        declared.sort_by(f64::total_cmp);
        points.sort_by(f64::total_cmp);
        eprintln!(
            "{kind}-any-pose at 0.1 mm, max(deg, mm) median / 90th percentile / worst: declared \
             fan {:.4} / {:.4} / {:.4}, points only {:.4} / {:.4} / {:.4} ({wrong} over 0.5, \
             judged suspect)",
            declared[15], declared[27], declared[29], points[15], points[27], points[29]
        );
        assert!(
            points[15] <= 1.5 * declared[15] + 0.005,
            "{kind}: {points:?} vs {declared:?}"
        );
        assert!(wrong <= 1, "{kind}: {points:?}");
    }
}

/// Leave-one-pose-out prediction (`Refinable::predict`) on the independent kit's rigs: at the true
/// transform every pose's points are predicted exactly from the others without noise; a transform
/// 0.5 deg off predicts them worse; at z noise 0.1 mm the truth predicts better than a transform
/// 0.5 deg / 0.5 mm off in every rig.
#[test]
fn each_pose_is_predicted_from_the_others_best_by_the_true_transform() {
    let off = |x: &Isometry3<f64>, deg: f64, mm: f64| {
        x * Isometry3::from_parts(
            Translation3::new(mm * 1e-3, 0.0, 0.0),
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), deg.to_radians()),
        )
    };
    let cases: [(Kind, &dyn Fn(u64, f64) -> Setup); 4] = [
        (Kind::Ball, &|seed, s| random_setup(17_000 + seed, 12, 3, s)),
        (Kind::Plane, &|seed, s| {
            random_plane_setup(17_100 + seed, 12, false, s)
        }),
        (Kind::Disk, &|seed, s| {
            random_disk_setup(17_200 + seed, 12, s)
        }),
        (Kind::Edge, &|seed, s| {
            random_wedge_setup(17_300 + seed, 14, s, false)
        }),
    ];
    for (kind, setup) in cases {
        let id = MethodId::new(kind, Estimator::AnyPose);
        for seed in 0..5u64 {
            let s = setup(seed, 0.0);
            let (cal, _) = lasercal::method::estimate(id, &s.caps, &s.sensor).unwrap();
            let p = cal.problem(id.estimator).unwrap();
            let exact = p.predict(&s.truth).expect("a prediction");
            assert!(
                exact.rms < 1e-9 && exact.poses >= 10,
                "{kind} {seed}: {exact:?}"
            );
            let wrong = p.predict(&off(&s.truth, 0.5, 0.0)).unwrap();
            assert!(wrong.rms > 1e-5, "{kind} {seed}: {wrong:?}");
            let mut sensor = s.sensor.clone();
            sensor.noise.z_sigma_near = 0.1e-3;
            sensor.noise.z_sigma_far = 0.1e-3;
            let n = setup(seed, 0.1e-3);
            let (cal, _) = lasercal::method::estimate(id, &n.caps, &sensor).unwrap();
            let p = cal.problem(id.estimator).unwrap();
            let (truth, wrong) = (
                p.predict(&n.truth).unwrap(),
                p.predict(&off(&n.truth, 0.5, 0.5)).unwrap(),
            );
            assert!(
                truth.rms < wrong.rms && truth.rms > 0.05e-3 && truth.rms < 0.2e-3,
                "{kind} {seed}: truth {truth:?}, off {wrong:?}"
            );
        }
    }
}

/// A scenario's text with the sensor made exact (no noise, z not quantised).
fn exact_scenario(name: &str) -> lasercal::scenario::Setup {
    exact_scenario_with(name, |t| t)
}

/// `exact_scenario` with the text edited by `edit` first.
fn exact_scenario_with(name: &str, edit: impl Fn(String) -> String) -> lasercal::scenario::Setup {
    let text = edit(std::fs::read_to_string(common::scen(name)).unwrap());
    let text: String = text
        .lines()
        .map(|l| {
            // The noise off, and the cause study's scale on it (`[causes]`) at 0.
            if l.starts_with("z_sigma_near_mm")
                || l.starts_with("z_sigma_far_mm")
                || l.starts_with("scale =")
            {
                format!("{} = 0.0\n", l.split('=').next().unwrap().trim())
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    let sf = lasercal::scenario::ScenarioFile::parse(&text, name).unwrap();
    sf.scenario.build(&sf.file).unwrap()
}

/// The simulator's ridge, V groove, fillet joint and step (ray-cast profiles of
/// `scene::SpecimenKind::{Ridge, VGroove, Fillet, Step}`, 16 generated poses): with the sensor exact, edge-any-pose recovers the truth to
/// 1e-9; trials are deterministic; a capture file round-trips; the two-face model's Jacobian
/// matches finite differences away from the optimum.
#[test]
fn the_simulators_line_targets_calibrate_exactly() {
    use lasercal::trial::{run_trial, trial_captures};
    for name in [
        "ridge-16-poses.toml",
        "v-groove-16-poses.toml",
        "fillet-16-poses.toml",
        "step-16-poses.toml",
    ] {
        let s = exact_scenario(name);
        for trial in 0..3 {
            let out = run_trial(&s, EDGE, 1, trial);
            let e = out.result.as_ref().unwrap().error();
            assert!(
                e.frobenius_rotation < 1e-9 && e.translation_error_mm < 1e-6,
                "{name} {trial}: {e:?}"
            );
            assert_eq!(
                out,
                run_trial(&s, EDGE, 1, trial),
                "{name}: not deterministic"
            );
        }
        let caps = trial_captures(&s, Kind::Edge, 1, 0).0.unwrap();
        let json = lasercal::io::captures::to_json(&caps, &s.rig.sensor);
        let (back, sensor) = lasercal::io::captures::from_json(&json, "c.json").unwrap();
        let (a, _) = lasercal::method::estimate(EDGE, &caps, &s.rig.sensor).unwrap();
        let (b, _) = lasercal::method::estimate(EDGE, &back, &sensor).unwrap();
        let e = PoseError::between(&a.flange_to_sensor, &b.flange_to_sensor);
        assert!(
            e.rotation_error_deg < 1e-6 && e.translation_error_mm < 1e-6,
            "{name}: {e:?}"
        );
        // The Jacobian, away from the optimum.
        let p = a.problem(Estimator::AnyPose).unwrap();
        let p = p.with_specimen_step(&[1e-3, -2e-3, 1e-3, 2e-3, 1e-3, -1e-3]);
        let x = a.flange_to_sensor
            * Isometry3::from_parts(
                Vector3::new(1e-3, -2e-3, 1.5e-3).into(),
                UnitQuaternion::from_scaled_axis(Vector3::new(0.01, -0.02, 0.015)),
            );
        let (r0, worst) = common::jacobian_error(p.as_ref(), &x);
        assert!(
            r0 > 1e-5 && worst < 1e-6,
            "{name}: Jacobian off by {worst:.2e}"
        );
    }
}

/// The edge paper's protocol on the two-face targets (`scenarios/line-targets.toml`, ray-cast,
/// the sensor exact): the closed form on each profile's corner, its refinement and the
/// full-profile refinement of both faces recover the truth to 1e-9; on the bar and the step, whose
/// face ends lie between columns, every estimator runs and the full-profile one is within
/// 0.01 deg / 0.01 mm.
#[test]
fn every_line_target_runs_the_papers_protocol() {
    use lasercal::trial::run_trial;
    for kind in ["ridge", "v-groove", "fillet", "parallel-bar", "step"] {
        let s = exact_scenario_with("line-targets.toml", |t| {
            t.replace("kind = \"ridge\"", &format!("kind = \"{kind}\""))
        });
        let two_faces = matches!(kind, "ridge" | "v-groove" | "fillet");
        for e in [
            Estimator::ClosedForm,
            Estimator::Refined,
            Estimator::FullProfile,
            Estimator::AnyPose,
        ] {
            let id = MethodId::new(Kind::Edge, e);
            let out = run_trial(&s, id, 1, 0);
            let err = out
                .result
                .as_ref()
                .unwrap_or_else(|x| panic!("{kind} {id}: {x}"))
                .error();
            if two_faces {
                assert!(
                    err.frobenius_rotation < 1e-9 && err.translation_error_mm < 1e-6,
                    "{kind} {id}: {err:?}"
                );
            } else if e == Estimator::FullProfile {
                assert!(
                    err.rotation_error_deg < 0.01 && err.translation_error_mm < 0.01,
                    "{kind} {id}: {err:?}"
                );
            }
        }
    }
}

/// Free ball poses with no labels (as an import gives them) that hold the two-step protocol (four
/// or more pure translations at one orientation, the rest at their own): the closed form and its
/// refinement run on labels inferred from the data (the rotation set by orientation, each
/// profile's side of the laser plane from ball-any-pose's centre), exact without noise on the
/// independent kit's random rigs; fewer than four at one orientation, the closed form says what
/// it misses.
#[test]
fn the_ball_closed_form_runs_on_labels_the_data_determine() {
    for seed in 0..20u64 {
        let s = random_setup(18_000 + seed, 14, 5, 0.0);
        assert!(s.caps.groups.iter().all(|g| g.sign == 0.0));
        for e in [Estimator::ClosedForm, Estimator::Refined] {
            let id = MethodId::new(Kind::Ball, e);
            let (cal, _) = lasercal::method::estimate(id, &s.caps, &s.sensor)
                .unwrap_or_else(|err| panic!("{id} {seed}: {err}"));
            let err = PoseError::between(&cal.flange_to_sensor, &s.truth);
            assert!(
                err.rotation_error_deg < 1e-9 && err.translation_error_mm < 1e-9,
                "{id} {seed}: {err:?}"
            );
        }
    }
    let s = random_setup(18_100, 14, 2, 0.0);
    let e = lasercal::method::estimate(
        MethodId::new(Kind::Ball, Estimator::ClosedForm),
        &s.caps,
        &s.sensor,
    )
    .err()
    .expect("refused")
    .to_string();
    assert!(e.contains("sign") && e.contains("ball-any-pose"), "{e}");
}

/// The disk paper's four ray-cast scans written as an import writes them (one group per pose, no
/// roles, no signs): the closed form finds the scans (runs of one orientation) and their signs
/// (the move against the sensor's y, read with disk-any-pose's rotation) and gives the result
/// the labelled file gives.
#[test]
fn the_disk_closed_form_finds_its_scans_and_signs() {
    let sf = lasercal::scenario::ScenarioFile::load(std::path::Path::new(&common::scen(
        "chen2018-disk-raycast.toml",
    )))
    .unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    let caps = lasercal::trial::trial_captures(&setup, Kind::Disk, 1, 0)
        .0
        .unwrap();
    assert!(caps.groups.iter().all(|g| g.sign.abs() == 1.0));
    let bare = one_group_per_pose(&caps);
    let id = MethodId::new(Kind::Disk, Estimator::ClosedForm);
    let (a, _) = lasercal::method::estimate(id, &caps, &setup.rig.sensor).unwrap();
    let (b, _) = lasercal::method::estimate(id, &bare, &setup.rig.sensor).unwrap();
    let e = PoseError::between(&a.flange_to_sensor, &b.flange_to_sensor);
    assert!(
        e.rotation_error_deg < 1e-9 && e.translation_error_mm < 1e-9,
        "{e:?}"
    );
}

/// The edge paper's protocol written as an import writes it (one group per pose, no roles): the
/// closed form and its refinements find the rotation groups (the profiles at one flange
/// orientation) and give the result the labelled file gives; with only one orientation of three
/// or more profiles, the closed form says what it needs and names the any-pose estimator.
#[test]
fn the_edge_closed_form_finds_its_rotation_groups() {
    let sf = lasercal::scenario::ScenarioFile::load(std::path::Path::new(&common::scen(
        "xu2021-edge.toml",
    )))
    .unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    let caps = lasercal::trial::trial_captures(&setup, Kind::Edge, 1, 0)
        .0
        .unwrap();
    assert!(caps.groups.len() >= 2);
    for e in [Estimator::ClosedForm, Estimator::Refined] {
        let id = MethodId::new(Kind::Edge, e);
        let (a, _) = lasercal::method::estimate(id, &caps, &setup.rig.sensor).unwrap();
        let (b, _) =
            lasercal::method::estimate(id, &one_group_per_pose(&caps), &setup.rig.sensor).unwrap();
        let err = PoseError::between(&a.flange_to_sensor, &b.flange_to_sensor);
        assert!(
            err.rotation_error_deg < 1e-12 && err.translation_error_mm < 1e-12,
            "{id}: {err:?}"
        );
    }
    // Only the first group's orientation has three profiles or more.
    let mut one = caps.clone();
    let first = one.groups[0].id;
    let mut seen = std::collections::HashSet::new();
    one.profiles
        .retain(|p| p.group == first || seen.insert(p.group));
    let e = lasercal::method::estimate(
        MethodId::new(Kind::Edge, Estimator::ClosedForm),
        &one_group_per_pose(&one),
        &setup.rig.sensor,
    )
    .err()
    .expect("refused")
    .to_string();
    assert!(e.contains("1 groups") && e.contains("edge-any-pose"), "{e}");
}

/// Captures as an import writes them: one `pose` group per profile, no roles, no signs.
fn one_group_per_pose(caps: &Captures) -> Captures {
    let mut bare = caps.clone();
    for (i, p) in bare.profiles.iter_mut().enumerate() {
        p.group = i;
    }
    bare.groups = (0..bare.profiles.len())
        .map(|id| Group {
            id,
            role: lasercal::captures::Role::Pose,
            sign: 0.0,
        })
        .collect();
    bare
}

/// The disk paper's four scans on the comparison rig, the Gocator's 1,280 columns declared, exact
/// data, the disk slid anew each trial (`disk-placements` without noise).
const FOUR_SCANS_EXACT: &str = r#"
name = "four-scans-exact"
seed = 17
methods = ["disk-any-pose"]
[robot]
name = "irb120"
[sensor]
mount_rotation = [[0.99996, -0.00547, -0.00716], [-0.00544, -0.99998, 0.00288], [-0.00718, -0.00284, -0.99997]]
mount_position_mm = [6.0252, 54.18211, 364.25534]
[sensor.geometry]
name = "g1280"
columns = 1280
spacing = "equal-tan"
z_axis = "toward"
x_range_mm = [[105.0, 96.0], [-105.0, 194.0]]
range_z_mm = [-105.0, 105.0]
camera_mm = [0.0, 120.0, 310.7]
[sensor.noise]
z_sigma_near_mm = 0.0
z_sigma_far_mm = 0.0
[specimen]
kind = "disk-cylinder"
radius_mm = 50.0
height_mm = 20.0
position_mm = [-319.622, -304.086, 11.48]
[table]
height_mm = -8.52
[placement]
jitter_mm = 1.0
[disk]
chords = 100
source = "raycast"
span_fraction = 0.8
orientations_rpy_rad = [[3.057, -0.103, -2.008], [3.115, -0.2, -2.269], [-2.981, 0.256, -2.491], [3.092, 0.208, 3.11]]
centre_tcp_mm = [[-222.966, -295.994, 360.786], [-232.113, -298.165, 344.196], [-374.932, -347.138, 338.836], [-377.572, -373.611, 352.241]]
directions_in_sensor = [[0.1, 1.0, -0.5], [-0.2, 1.0, -0.4], [0.2, 1.0, -0.6], [-0.1, 1.0, -0.45]]
"#;

#[test]
fn the_four_scan_disk_finds_its_plane_where_the_best_eight_normals_miss_it() {
    // The disk paper's four scans on the comparison rig (the Gocator's 1,280 columns declared,
    // exact data), placement 183 of seed 17: the truth's plane ranked past the eighth normal
    // screened, and `disk-any-pose` ended 80 deg / 171 mm off (1 of 200 placements; 1 of 4 at
    // 12,800 columns). Screening more normals while the best fits the profiles worse than their
    // own lines finds it; the rest is the censored rims' feasible set (under 1e-5 mm over 200).
    let sf =
        lasercal::scenario::ScenarioFile::parse(FOUR_SCANS_EXACT, "four-scans-exact.toml").unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    let caps = lasercal::trial::trial_captures(&setup, Kind::Disk, 17, 183)
        .0
        .unwrap();
    let (cal, _) = lasercal::method::estimate(DISK, &caps, &setup.rig.sensor).unwrap();
    let e = PoseError::between(&cal.flange_to_sensor, &setup.rig.flange_to_sensor);
    assert!(
        e.rotation_error_deg < 1e-5 && e.translation_error_mm < 1e-4,
        "{e:?}"
    );
}

#[test]
fn the_centre_error_counts_the_placement() {
    // The placement slides every pose, which the captures do not show: the centre the estimator
    // finds through them is the true one slid back (it was scored against the unslid centre and
    // read 0.5-1.4 mm off on exact data).
    let sf =
        lasercal::scenario::ScenarioFile::parse(FOUR_SCANS_EXACT, "four-scans-exact.toml").unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    for trial in 0..3 {
        let o = lasercal::trial::run_trial(&setup, DISK, 17, trial);
        let s = o.result.unwrap();
        let e = s
            .metrics
            .get(lasercal::metrics::Metric::CentreError)
            .unwrap();
        assert!(e < 1e-3, "trial {trial}: centre error {e} mm");
    }
}
