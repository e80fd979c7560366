//! Issue 2: URDF loading, forward and inverse kinematics, typed errors.

use lasercal::math::quat_wxyz;
use lasercal::robot::{Robot, RobotError};
use lasercal::testkit::{self, irb120, irb2600};
use nalgebra::{Isometry3, Translation3, UnitQuaternion};

fn assert_zero_pose(robot: &Robot, want_mm: [f64; 3]) {
    let t = robot.fk(&[0.0; 6]);
    let p = t.translation.vector * 1000.0;
    for k in 0..3 {
        assert!(
            (p[k] - want_mm[k]).abs() < 1e-9,
            "{}: {p:?} vs {want_mm:?}",
            robot.name
        );
    }
    let q = quat_wxyz(&t.rotation);
    let h = std::f64::consts::FRAC_1_SQRT_2;
    for (a, b) in q.iter().zip([h, 0.0, h, 0.0]) {
        assert!((a - b).abs() < 1e-12, "{}: quaternion {q:?}", robot.name);
    }
}

#[test]
fn zero_pose_irb120() {
    assert_zero_pose(&irb120(), [374.0, 0.0, 630.0]);
}

#[test]
fn zero_pose_irb2600() {
    assert_zero_pose(&irb2600(), [1030.0, 0.0, 1260.0]);
}

#[test]
fn urdfs_carry_the_reference_limits() {
    let r = irb2600();
    let deg = |v: f64| v.to_degrees();
    // ABB's ranges, not the widely copied wrong ones.
    assert!((deg(r.joints[1].lower_rad) + 95.0).abs() < 1e-9);
    assert!((deg(r.joints[1].upper_rad) - 155.0).abs() < 1e-9);
    assert!((deg(r.joints[2].lower_rad) + 180.0).abs() < 1e-9);
    assert!((deg(r.joints[2].upper_rad) - 75.0).abs() < 1e-9);
    assert!((deg(r.joints[5].max_speed_rad_s) - 500.0).abs() < 1e-9);
    let s = irb120();
    assert!((deg(s.joints[2].lower_rad) + 110.0).abs() < 1e-9);
    assert!((deg(s.joints[2].upper_rad) - 70.0).abs() < 1e-9);
    assert!((deg(s.joints[5].upper_rad) - 400.0).abs() < 1e-9);
    // The IRB 120's CAD inertials are loaded.
    let l2 = s.links.iter().find(|l| l.name == "link_2").unwrap();
    assert!((l2.inertial.as_ref().unwrap().mass_kg - 3.909).abs() < 1e-12);
    // OPW parameters derived from the URDF match the published ones.
    let o = s.opw;
    assert!((o.a1 - 0.0).abs() < 1e-12 && (o.d - 0.070).abs() < 1e-12);
    assert!((o.c1 - 0.290).abs() < 1e-12 && (o.c2 - 0.270).abs() < 1e-12);
    assert!((o.c3 - 0.302).abs() < 1e-12 && (o.c4 - 0.072).abs() < 1e-12);
    let o = r.opw;
    assert!((o.a1 - 0.150).abs() < 1e-12 && (o.d - 0.115).abs() < 1e-12);
    assert!((o.c1 - 0.445).abs() < 1e-12 && (o.c2 - 0.700).abs() < 1e-12);
    assert!((o.c3 - 0.795).abs() < 1e-12 && (o.c4 - 0.085).abs() < 1e-12);
}

#[test]
fn fk_to_links_is_consistent_with_tool0() {
    let r = irb120();
    let mut g = testkit::rng(11);
    let q = testkit::random_joints(&r, &mut g, 0.1);
    let tool0 = r.fk_link(&q, "tool0").unwrap();
    assert!((tool0.to_homogeneous() - r.fk(&q).to_homogeneous()).norm() < 1e-12);
    let flange = r.fk_link(&q, "flange").unwrap();
    assert!((flange.translation.vector - tool0.translation.vector).norm() < 1e-12);
    // tool0's z axis is the flange's x axis.
    let z_tool = tool0.rotation * nalgebra::Vector3::z();
    let x_flange = flange.rotation * nalgebra::Vector3::x();
    assert!((z_tool - x_flange).norm() < 1e-12);
    assert_eq!(r.link_poses(&q).len(), r.links.len());
    assert!(matches!(
        r.fk_link(&q, "nope"),
        Err(RobotError::UnknownLink { .. })
    ));
}

fn roundtrip(robot: &Robot, seed: u64, n: usize) {
    let mut g = testkit::rng(seed);
    let mut worst = (0.0f64, 0.0f64);
    for i in 0..n {
        let q = testkit::random_joints(robot, &mut g, 1e-3);
        let target = robot.fk(&q);
        let sols = robot
            .ik(&target, None)
            .unwrap_or_else(|e| panic!("{} config {i} {q:?}: {e}", robot.name));
        let mut seed_found = false;
        for s in &sols {
            assert!(
                robot.within_limits(s, 1e-12),
                "{} solution out of limits: {s:?}",
                robot.name
            );
            let t = robot.fk(s);
            let dp = (t.translation.vector - target.translation.vector).norm();
            let dr = t.rotation.angle_to(&target.rotation);
            worst = (worst.0.max(dp), worst.1.max(dr));
            assert!(
                dp < 1e-9 && dr < 1e-9,
                "{} config {i}: solution {s:?} misses by {dp} m, {dr} rad",
                robot.name
            );
            if s.iter().zip(&q).all(|(a, b)| (a - b).abs() < 1e-7) {
                seed_found = true;
            }
        }
        assert!(
            seed_found,
            "{} config {i}: {q:?} not among {} solutions {sols:?}",
            robot.name,
            sols.len()
        );
        let nearest = robot.ik_nearest(&target, &q).unwrap();
        assert!(nearest.iter().zip(&q).all(|(a, b)| (a - b).abs() < 1e-7));
    }
    eprintln!(
        "{}: worst IK->FK error {:.2e} m, {:.2e} rad",
        robot.name, worst.0, worst.1
    );
}

#[test]
fn ik_fk_roundtrip_irb120() {
    roundtrip(&irb120(), 1, 2000);
}

#[test]
fn ik_fk_roundtrip_irb2600() {
    roundtrip(&irb2600(), 2, 2000);
}

#[test]
fn ik_returns_up_to_eight_branches_and_extra_turns() {
    let r = irb2600();
    // A comfortable pose in front of the robot: all 8 branches exist geometrically; joints 4 and 6
    // (range +-400 deg) add extra turns.
    let q = [0.3, 0.2, -0.3, 0.4, 0.6, 0.5];
    let sols = r.ik(&r.fk(&q), None).unwrap();
    assert!(sols.len() > 8, "{} solutions", sols.len());
}

#[test]
fn unreachable_pose_is_a_typed_error() {
    let r = irb120();
    let far = Isometry3::from_parts(Translation3::new(2.0, 0.0, 0.5), UnitQuaternion::identity());
    match r.ik(&far, None) {
        Err(RobotError::OutOfReach { reason }) => {
            assert!(reason.contains("outside the arm's reach"), "{reason}")
        }
        other => panic!("expected OutOfReach, got {other:?}"),
    }
}

#[test]
fn pose_only_outside_limits_is_a_typed_error() {
    // Configurations drawn beyond the joint limits: IK either finds in-limit solutions that reach
    // the same pose (the arm can often flip over) or says the pose is reachable only outside them.
    let r = irb120();
    let mut g = testkit::rng(12);
    let mut outside = 0;
    for _ in 0..2000 {
        let mut q = testkit::random_joints(&r, &mut g, 0.0);
        q[2] = rand::RngExt::random_range(&mut g, 1.3..3.0); // joint 3 beyond +70 deg
        let mut t = Isometry3::identity();
        for (j, &v) in r.joints.iter().zip(&q) {
            t = t * j.prev_to_joint * UnitQuaternion::from_axis_angle(&j.axis, v);
        }
        let pose = t * r.last_to_tool0;
        match r.ik(&pose, None) {
            Ok(sols) => {
                for s in sols {
                    assert!(r.within_limits(&s, 1e-12));
                    assert!((r.fk(&s).translation.vector - pose.translation.vector).norm() < 1e-9);
                }
            }
            Err(RobotError::OutsideLimits { reason }) => {
                assert!(reason.contains("joint_"), "{reason}");
                outside += 1;
            }
            Err(e) => panic!("unexpected {e}"),
        }
    }
    assert!(
        outside > 100,
        "only {outside} poses were reachable only outside the limits"
    );
}

const GOOD: &str = include_str!("../../robots/irb120_3_58.urdf");

#[test]
fn malformed_urdf_parse_failure() {
    let e = Robot::from_urdf_str("<robot name='x'><link name='a'>", "bad.urdf").unwrap_err();
    assert!(
        matches!(e, RobotError::Parse { ref path, .. } if path == "bad.urdf"),
        "{e}"
    );
    assert!(e.to_string().contains("bad.urdf"));
}

#[test]
fn malformed_urdf_branching_tree() {
    let extra = r#"<link name="camera"/><joint name="cam_mount" type="fixed"><parent link="link_3"/><child link="camera"/></joint></robot>"#;
    let text = GOOD.replace("</robot>", extra);
    match Robot::from_urdf_str(&text, "branchy.urdf").unwrap_err() {
        RobotError::Branching {
            path,
            link,
            count,
            joints,
        } => {
            assert_eq!(
                (path.as_str(), link.as_str(), count),
                ("branchy.urdf", "link_3", 2)
            );
            assert!(joints.contains("cam_mount") && joints.contains("joint_4"));
        }
        other => panic!("expected Branching, got {other:?}"),
    }
}

#[test]
fn malformed_urdf_missing_tip() {
    let text = GOOD
        .replace("<link name=\"tool0\"/>", "<link name=\"tool_zero\"/>")
        .replace("<child link=\"tool0\"/>", "<child link=\"tool_zero\"/>");
    match Robot::from_urdf_str(&text, "notip.urdf").unwrap_err() {
        RobotError::MissingTip { path, link, root } => {
            assert_eq!(
                (path.as_str(), link.as_str(), root.as_str()),
                ("notip.urdf", "tool0", "base_link")
            );
        }
        other => panic!("expected MissingTip, got {other:?}"),
    }
}

#[test]
fn malformed_urdf_joint_without_limits() {
    let start = GOOD.find("<joint name=\"joint_3\"").unwrap();
    let lim = start + GOOD[start..].find("<limit").unwrap();
    let end = lim + GOOD[lim..].find("/>").unwrap() + 2;
    let text = format!("{}{}", &GOOD[..lim], &GOOD[end..]);
    match Robot::from_urdf_str(&text, "nolimit.urdf").unwrap_err() {
        RobotError::MissingLimits { path, joint, .. } => {
            assert_eq!((path.as_str(), joint.as_str()), ("nolimit.urdf", "joint_3"));
        }
        other => panic!("expected MissingLimits, got {other:?}"),
    }
}

#[test]
fn unknown_robot_and_missing_file() {
    assert!(matches!(
        Robot::resolve("irb999"),
        Err(RobotError::UnknownRobot { .. })
    ));
    let e = Robot::resolve("/nonexistent/arm.urdf").unwrap_err();
    assert!(matches!(e, RobotError::Io { .. }), "{e}");
    assert!(e.to_string().contains("/nonexistent/arm.urdf"));
}

#[test]
fn robots_load_from_their_files() {
    let dir = env!("CARGO_MANIFEST_DIR");
    for f in ["robots/irb120_3_58.urdf", "robots/irb2600_12_165.urdf"] {
        let r = Robot::resolve(&format!("{dir}/{f}")).unwrap();
        assert_eq!(r.joints.len(), 6);
        assert!(
            r.links
                .iter()
                .all(|l| !l.visuals.is_empty() || l.name == "flange" || l.name == "tool0")
        );
    }
}
