//! One seeded kit shared by every test and benchmark: reference robots, pose generators and
//! perturbations. Deterministic for a given seed.

pub mod fan;

use crate::rng::{self, Rng};
use crate::robot::{Joints, Robot};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rand::RngExt;

/// The IRB 120 of the disk paper.
pub fn irb120() -> Robot {
    Robot::resolve("irb120").expect("built-in irb120 loads")
}

/// The IRB 2600 of the edge paper.
pub fn irb2600() -> Robot {
    Robot::resolve("irb2600").expect("built-in irb2600 loads")
}

/// A generator for test `seed`.
pub fn rng(seed: u64) -> Rng {
    rng::stream(seed, &[0x7e57])
}

/// Uniform joint values within limits, `margin` radians away from each limit.
pub fn random_joints(robot: &Robot, r: &mut Rng, margin: f64) -> Joints {
    std::array::from_fn(|i| {
        let j = &robot.joints[i];
        r.random_range(j.lower_rad + margin..j.upper_rad - margin)
    })
}

/// A uniformly distributed rotation.
pub fn random_rotation(r: &mut Rng) -> UnitQuaternion<f64> {
    // Shoemake's method.
    let (u1, u2, u3): (f64, f64, f64) = (r.random(), r.random(), r.random());
    let tau = std::f64::consts::TAU;
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
        b * (tau * u3).cos(),
        a * (tau * u2).sin(),
        a * (tau * u2).cos(),
        b * (tau * u3).sin(),
    ))
}

/// A random unit vector.
pub fn random_unit(r: &mut Rng) -> Vector3<f64> {
    random_rotation(r) * Vector3::z()
}

/// A random pose: uniform rotation, translation uniform in a cube of half-width `half_m`.
pub fn random_pose(r: &mut Rng, half_m: f64) -> Isometry3<f64> {
    let t = Vector3::new(
        r.random_range(-half_m..half_m),
        r.random_range(-half_m..half_m),
        r.random_range(-half_m..half_m),
    );
    Isometry3::from_parts(Translation3::from(t), random_rotation(r))
}

/// Perturb a pose by a random rotation of up to `angle_rad` and a shift of up to `shift_m`.
pub fn perturb(r: &mut Rng, pose: &Isometry3<f64>, angle_rad: f64, shift_m: f64) -> Isometry3<f64> {
    let axis = nalgebra::Unit::new_normalize(random_unit(r));
    let rot = UnitQuaternion::from_axis_angle(&axis, r.random_range(-angle_rad..=angle_rad));
    let shift = random_unit(r) * r.random_range(0.0..=shift_m);
    Isometry3::from_parts(
        Translation3::from(pose.translation.vector + shift),
        rot * pose.rotation,
    )
}

use crate::sensor::SensorModel;
use crate::sim::Rig;
use crate::sim::disk::{Coverage, Direction, DiskPlanSpec, DiskScanPlan, DiskTarget, ScanRequest};

/// A random disk experiment for a free-flying sensor: random true mounting, random disk pose,
/// `n` random orientations that look at the disk from 20-60 deg off its normal, and a move that
/// sweeps the whole disk. Deterministic for a given generator state.
pub fn random_disk_setup(r: &mut Rng, n: usize, m: usize) -> (Rig, DiskTarget, Vec<DiskScanPlan>) {
    let flange_to_sensor = random_pose(r, 0.2);
    let rig = Rig {
        robot: irb120(),
        sensor: SensorModel::gocator_2340(),
        flange_to_sensor,
    };
    let disk_pose = random_pose(r, 0.5);
    let disk = DiskTarget::from_pose(&disk_pose, r.random_range(0.02..0.08));
    loop {
        let mut scans = Vec::new();
        for _ in 0..n {
            // Sensor z (pointing back at the sensor) within 20-60 deg of the disk normal.
            let tilt = r.random_range(20f64..60.0).to_radians();
            let spin = r.random_range(0.0..std::f64::consts::TAU);
            let roll = r.random_range(0.0..std::f64::consts::TAU);
            let n_axis = disk.normal;
            let perp = nalgebra::Unit::new_normalize(n_axis.cross(&random_unit(r)));
            let tilt_q = UnitQuaternion::from_axis_angle(&perp, tilt);
            let base_rot = UnitQuaternion::rotation_between(&Vector3::z(), &n_axis)
                .unwrap_or_else(UnitQuaternion::identity);
            let r_bs = UnitQuaternion::from_axis_angle(&n_axis, spin)
                * tilt_q
                * base_rot
                * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), roll);
            let r_tcp = (r_bs * flange_to_sensor.rotation.inverse()).to_rotation_matrix();
            let dir = Vector3::new(r.random_range(-0.3..0.3), 1.0, r.random_range(-0.6..0.6));
            scans.push(ScanRequest {
                r_tcp,
                centre_tcp: None,
                direction: Direction::InSensor(dir),
            });
        }
        let spec = DiskPlanSpec {
            scans,
            coverage: Coverage::Whole,
            span_fraction: 0.9,
            m,
            min_angle: 10f64.to_radians(),
        };
        if let Ok(plans) = crate::sim::disk::plan_unchecked(&rig, &disk, &spec) {
            return (rig, disk, plans);
        }
    }
}

use crate::sim::ball::{BallPlan, BallTarget, Pose};

/// A random ball experiment for a free-flying sensor: random true mounting and ball; a rotation set
/// of `n_rot` captures sharing one random orientation (the laser plane within 0.6 r of the centre)
/// and a translation set of `n_trans` random orientations.
pub fn random_ball_setup(r: &mut Rng, n_rot: usize, n_trans: usize) -> (Rig, BallTarget) {
    let _ = (n_rot, n_trans);
    let flange_to_sensor = random_pose(r, 0.2);
    let rig = Rig {
        robot: irb120(),
        sensor: SensorModel::gocator_2340(),
        flange_to_sensor,
    };
    let ball = BallTarget {
        centre: nalgebra::Point3::from(random_pose(r, 0.5).translation.vector),
        radius: r.random_range(0.01..0.08),
    };
    (rig, ball)
}

/// A flange pose that puts the ball centre at `c_in_sensor` with the sensor rotated `r_bs`.
pub fn pose_seeing(
    rig: &Rig,
    ball: &BallTarget,
    r_bs: &UnitQuaternion<f64>,
    c_in_sensor: Vector3<f64>,
) -> Pose {
    let base_to_sensor = Isometry3::from_parts(
        Translation3::from(ball.centre.coords - r_bs * c_in_sensor),
        *r_bs,
    );
    let base_to_flange = base_to_sensor * rig.flange_to_sensor.inverse();
    Pose {
        r_tcp: base_to_flange.rotation.to_rotation_matrix(),
        t_tcp: base_to_flange.translation.vector,
    }
}

/// A random ball plan for `random_ball_setup`.
pub fn random_ball_plan(
    r: &mut Rng,
    rig: &Rig,
    ball: &BallTarget,
    n_rot: usize,
    n_trans: usize,
    arcs: usize,
) -> BallPlan {
    let offset = |r: &mut Rng| {
        Vector3::new(
            r.random_range(-0.3..0.3) * ball.radius,
            r.random_range(-0.6..0.6) * ball.radius,
            r.random_range(-0.05..0.05),
        )
    };
    let r0 = random_rotation(r);
    let rotation_set = (0..n_rot)
        .map(|_| pose_seeing(rig, ball, &r0, offset(r)))
        .collect();
    let translation_set = (0..n_trans)
        .map(|_| pose_seeing(rig, ball, &random_rotation(r), offset(r)))
        .collect();
    BallPlan {
        rotation_set,
        translation_set,
        arcs,
    }
}

use crate::sim::edge::{EdgeGroupPlan, EdgePlanSpec, EdgeTarget};

/// A random edge experiment for a free-flying sensor: random mounting and edge, the paper's grid.
pub fn random_edge_setup(
    r: &mut Rng,
    rotations: usize,
    translations: usize,
) -> (Rig, EdgeTarget, Vec<EdgeGroupPlan>) {
    let flange_to_sensor = random_pose(r, 0.2);
    let rig = Rig {
        robot: irb2600(),
        sensor: SensorModel::vlm350(),
        flange_to_sensor,
    };
    let edge = EdgeTarget::from_pose(&random_pose(r, 0.5), f64::INFINITY);
    let spec = EdgePlanSpec {
        rotations,
        translations,
        tilt: r.random_range(10f64..30.0).to_radians(),
        arc_radius: r.random_range(0.02..0.06),
        arc_span: r.random_range(40f64..120.0).to_radians(),
        arc_heading: r.random_range(15f64..60.0).to_radians(),
        edge_z: 0.08,
    };
    let plans = crate::sim::edge::plan_unchecked(&rig, &edge, &spec).expect("valid spec");
    (rig, edge, plans)
}

/// Scanning on the move, for tests: a controller's pose log through `passes` (pose, body twist:
/// angular rad/s, linear m/s), pass i at time `i spacing_s`, the flange moving through each at
/// its steady twist for `half_s` either side (F(t) = pose exp((t - t_i) twist)) and straight from
/// the end of one pass to the start of the next, logged at `rate_hz`. A profile's true pose is
/// the log's pose at its time (`math::pose_at`): what a capture file's reader interpolates, so
/// noise-free data fit exactly. Written apart from the simulator's moving scans.
pub fn pose_log(
    passes: &[(Isometry3<f64>, Vector3<f64>, Vector3<f64>)],
    spacing_s: f64,
    half_s: f64,
    rate_hz: f64,
) -> Vec<(f64, Isometry3<f64>)> {
    let step = 1.0 / rate_hz;
    let along = |(pose, w, v): &(Isometry3<f64>, Vector3<f64>, Vector3<f64>), u: f64| {
        // The steady twist's exact motion: rotation exp(u w); the position's integral of the
        // turning linear velocity, summed finely (the log need only be some smooth motion).
        let n = ((u.abs() / 1e-4).ceil() as usize).max(1);
        let h = u / n as f64;
        let mut p = Vector3::zeros();
        for k in 0..n {
            let mid = UnitQuaternion::from_scaled_axis(w * (h * (k as f64 + 0.5)));
            p += mid * v * h;
        }
        Isometry3::from_parts(
            Translation3::from(pose.translation.vector + pose.rotation * p),
            pose.rotation * UnitQuaternion::from_scaled_axis(w * u),
        )
    };
    let mut log = Vec::new();
    for (i, pass) in passes.iter().enumerate() {
        let t0 = i as f64 * spacing_s;
        let samples = (2.0 * half_s / step).round() as usize;
        for k in 0..=samples {
            let u = -half_s + k as f64 * step;
            log.push((t0 + u, along(pass, u)));
        }
    }
    log
}
