//! Captures: what a real robot and sensor give (flange poses, profiles or the features extracted
//! from them, grouped by orientation or scan). Simulated trials and capture files from real rigs
//! both become `Captures`; `method::calibrate` turns them into a calibration.

use crate::features::{Circle, EdgeSense, FeatureError};
use crate::id::Kind;
use crate::scene::SpecimenType;
use crate::sensor::Profile;
use nalgebra::{Isometry3, Vector2};
use thiserror::Error;

/// Points (sensor x, z) shared by the captures and the models fitted to them: a model holds
/// them without a copy.
pub type SharedPoints = std::sync::Arc<[Vector2<f64>]>;

/// What one profile record holds: the raw profile, or a feature already extracted from it.
#[derive(Debug, Clone, PartialEq)]
pub enum ProfileData {
    Raw(Profile),
    Chord {
        a: Vector2<f64>,
        b: Vector2<f64>,
    },
    Circle(Circle),
    /// The points of a ball arc (sensor x, z), its circle found by the calibration.
    Arc(SharedPoints),
    EdgePoint(Vector2<f64>),
}

#[derive(Debug, Clone, PartialEq)]
pub struct CaptureProfile {
    pub group: usize,
    pub base_to_flange: Isometry3<f64>,
    pub data: ProfileData,
}

/// The role of a group: a disk scan, the ball's rotation set or one of its translation-set poses,
/// or an edge rotation group.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Role {
    Scan,
    Rotation,
    Translation,
    RotationGroup,
    /// One free pose (any-pose estimators, the plane).
    Pose,
}

impl Role {
    pub const ALL: [Role; 5] = [
        Role::Scan,
        Role::Rotation,
        Role::Translation,
        Role::RotationGroup,
        Role::Pose,
    ];

    pub fn name(&self) -> &'static str {
        match self {
            Role::Scan => "scan",
            Role::Rotation => "rotation",
            Role::Translation => "translation",
            Role::RotationGroup => "rotation-group",
            Role::Pose => "pose",
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Group {
    pub id: usize,
    pub role: Role,
    /// s_i (disk paper Eq. 3 and Sec. IV-A): +1 or -1; 0 where not used.
    pub sign: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Captures {
    pub method: Kind,
    /// Sensor preset: its column geometry places feature ends between columns.
    pub sensor: String,
    /// Specimen kind and its known size (metres): the disk or ball radius.
    pub specimen_kind: SpecimenType,
    pub specimen_radius: Option<f64>,
    pub edge_sense: Option<EdgeSense>,
    pub truth: Option<Isometry3<f64>>,
    pub groups: Vec<Group>,
    pub profiles: Vec<CaptureProfile>,
    /// How far apart (deg) a protocol's "one orientation" captures may be (a controller's
    /// jitter): `calib::ORIENTATION_TOLERANCE_DEG` unless the file or the user says otherwise.
    pub orientation_tolerance_deg: f64,
    /// The stated noise (metres, one standard deviation) of features given as such (chord ends,
    /// arc points, edge points of an analytic source or a file): what the verdict's residual
    /// test compares with. None for raw profiles, whose noise the sensor's model states.
    pub feature_sigma: Option<f64>,
    /// What the verdict judges a result against (tolerance, the robot's accuracy).
    pub judging: Judging,
    /// The arm that took the poses and its kinematic error, where stated: the verdict's bound
    /// then carries that error through each pose's joint configuration.
    pub kinematic: Option<Kinematic>,
    /// Scanning on the move: the controller's pose log and each profile's time stamp, when the
    /// profiles were placed by time (None: each at a stated pose).
    pub timing: Option<Timing>,
}

/// The controller's log of flange poses and each profile's time stamp on the profiler's clock
/// (a capture file's `pose_stream` and `t_s`); every profile's `base_to_flange` is the log's pose
/// at its stamp plus `offset_s`.
#[derive(Debug, Clone, PartialEq)]
pub struct Timing {
    /// (controller time s, flange pose), the times strictly increasing.
    pub stream: Vec<(f64, Isometry3<f64>)>,
    /// Each profile's time stamp (s, the profiler's clock), in profile order.
    pub stamps: Vec<f64>,
    /// Seconds added to a stamp to put it on the controller's clock (the stated offset).
    pub offset_s: f64,
    /// Whether the refined, full-profile and any-pose estimators estimate the offset's error
    /// with the transform (`calib::refine::timed`) rather than hold the stated offset.
    pub estimate_offset: bool,
    /// With it, whether the profiler's clock may also run at another rate (a drift, estimated
    /// as one more parameter).
    pub estimate_drift: bool,
}

/// What the verdict judges a result against: the user's tolerance on the 95 % error bound, and
/// the robot's pose accuracy that the residual test allows beside the sensor's noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Judging {
    /// Largest acceptable 95 % bound on the rotation (deg) and the translation (mm).
    pub tolerance_deg: f64,
    pub tolerance_mm: f64,
    /// One standard deviation of a measured point's offset that the robot's pose error makes
    /// (metres): what the residuals may show beyond the sensor's noise before the model is
    /// called inconsistent with the data.
    pub robot_accuracy: f64,
    /// One standard deviation per axis of the robot's pose error that is each pose's own
    /// (metres; a repeatability, ISO 9283's RP being about 3.6 times it; 0: none stated): unlike
    /// `robot_accuracy`, which the bound takes as common to the poses a set spans, this moves
    /// every pose independently, so the fit averages it over the poses.
    pub robot_repeatability: f64,
    /// The mounting as drawn (the CAD model's flange-to-sensor): a result further from it than
    /// `method::verdict::NOMINAL_DEG` / `NOMINAL_MM` is suspect. A sensor mirrored in x fits its
    /// data as well as the right one, turned 180 deg about z; only the drawing tells them apart.
    pub nominal: Option<Isometry3<f64>>,
    /// The flange's largest speed (m/s) at the time of a profile placed by its time stamp on a
    /// pose stream (None: every profile at a stated pose): an error in the profiles' clock offset
    /// moves them this far per second of it, which no residual shows.
    pub scan_speed: Option<f64>,
    /// One standard deviation of the disk's or ball's true radius about the stated one (metres;
    /// a certificate's standard uncertainty; 0: taken as exact). The fit holds the radius as
    /// stated, so its error moves the result by a bias no residual shows: the bound adds it.
    pub radius_tolerance: f64,
    /// A straight edge's straightness tolerance (metres, peak to valley: the most the edge
    /// bows across itself over `edge_length`; 0: taken as straight). The fit holds the edge
    /// straight, so a bow moves the result by a bias the residuals barely show: the bound adds it.
    pub straightness: f64,
    /// The length the straightness applies to (metres; None: the span the profiles see).
    pub edge_length: Option<f64>,
}

impl Judging {
    /// Defaults: a tolerance of 0.5 deg / 0.5 mm; an industrial arm's absolute accuracy of
    /// 0.5 mm where a file does not state its robot's (a simulated rig states its own).
    pub const DEFAULT_TOLERANCE_DEG: f64 = 0.5;
    pub const DEFAULT_TOLERANCE_MM: f64 = 0.5;
    pub const DEFAULT_ROBOT_ACCURACY_MM: f64 = 0.5;

    /// The robot's whole pose error at one pose (metres, one sd per axis): the common accuracy
    /// and the pose's own repeatability together, what the residuals may show beyond the noise.
    pub fn robot_error(&self) -> f64 {
        self.robot_accuracy.hypot(self.robot_repeatability)
    }
}

impl Default for Judging {
    fn default() -> Judging {
        Judging {
            tolerance_deg: Judging::DEFAULT_TOLERANCE_DEG,
            tolerance_mm: Judging::DEFAULT_TOLERANCE_MM,
            robot_accuracy: Judging::DEFAULT_ROBOT_ACCURACY_MM * 1e-3,
            robot_repeatability: 0.0,
            nominal: None,
            scan_speed: None,
            radius_tolerance: 0.0,
            straightness: 0.0,
            edge_length: None,
        }
    }
}

impl Captures {
    /// The profiles of group `id`, in file order.
    pub fn group_profiles(&self, id: usize) -> Vec<&CaptureProfile> {
        // Counted first: collected from a filter, the list grew by doubling (a reallocation
        // every doubling, per group and calibration).
        let n = self.profiles.iter().filter(|p| p.group == id).count();
        let mut out = Vec::with_capacity(n);
        out.extend(self.profiles.iter().filter(|p| p.group == id));
        out
    }

    /// These captures without group `id`: its entry, its profiles and their time stamps (a
    /// profile's stamp is found by its index, so the stamps must lose the same entries).
    pub fn without_group(&self, id: usize) -> Captures {
        let keep: Vec<bool> = self.profiles.iter().map(|p| p.group != id).collect();
        let mut c = self.clone_without_profiles();
        c.groups = self.groups.iter().filter(|g| g.id != id).cloned().collect();
        c.profiles = (self.profiles.iter().zip(&keep))
            .filter(|(_, k)| **k)
            .map(|(p, _)| p.clone())
            .collect();
        c.timing = self.timing.clone();
        // Not one per profile: nothing to keep aligned (`with_clock` skips them).
        if let Some(t) = c.timing.as_mut().filter(|t| t.stamps.len() == keep.len()) {
            let mut kept = keep.iter();
            t.stamps.retain(|_| kept.next() == Some(&true));
        }
        c
    }

    /// Everything but the groups, profiles and timing (the caller's to fill: cloning the
    /// profiles to drop some copied every point of a file's raw profiles).
    fn clone_without_profiles(&self) -> Captures {
        Captures {
            method: self.method,
            sensor: self.sensor.clone(),
            specimen_kind: self.specimen_kind,
            specimen_radius: self.specimen_radius,
            edge_sense: self.edge_sense,
            truth: self.truth,
            groups: Vec::new(),
            profiles: Vec::new(),
            orientation_tolerance_deg: self.orientation_tolerance_deg,
            feature_sigma: self.feature_sigma,
            judging: self.judging,
            kinematic: self.kinematic.clone(),
            timing: None,
        }
    }
}

/// An arm's kinematic error as a user states it: one standard deviation of each joint origin's
/// offset along each axis (a link-length error) and of each joint's zero, the same for every
/// joint (`sim::disturb::RobotError` draws the same). Unlike the stated accuracy, which the bound
/// takes as the same at every pose, this error moves each pose by its own joint configuration:
/// a few scans at few configurations share most of it (docs/verdict.md).
#[derive(Debug, Clone)]
pub struct Kinematic {
    /// The arm as the file names it (a built-in arm's name or a URDF's path).
    pub robot_name: String,
    pub robot: std::sync::Arc<crate::robot::Robot>,
    /// Joint origin offset, metres, per axis.
    pub link_sd: f64,
    /// Joint zero offset, radians.
    pub joint_zero_sd: f64,
    /// Whether the errors are assumed (`Kinematic::assumed`), not stated.
    pub assumed: bool,
    /// Whether the captures state the errors, zero included (a calibrated arm: nothing to
    /// assume), or name the arm alone.
    pub errors_stated: bool,
    /// Each pose's error twists (`Kinematic::new`).
    twists: std::sync::Arc<Twists>,
    /// The joint values given with a pose, by `pose_key` (written back with it).
    given: std::sync::Arc<std::collections::HashMap<[u64; 7], crate::robot::Joints>>,
    /// Where no pose's joints are given: the error twists of the arm's other configurations
    /// for the same poses (each of the first pose's other inverse kinematics solutions, the
    /// rest reached from it as `twists` are), those that differ from `twists`.
    others: std::sync::Arc<Vec<Twists>>,
}

impl PartialEq for Kinematic {
    fn eq(&self, o: &Kinematic) -> bool {
        self.robot_name == o.robot_name
            && self.link_sd == o.link_sd
            && self.joint_zero_sd == o.joint_zero_sd
            && self.assumed == o.assumed
            && self.errors_stated == o.errors_stated
    }
}

impl Kinematic {
    /// The arm's error stated for `poses`, each with its joint values where the controller
    /// logged them (radians): the others' configurations as a controller reaches them moving
    /// through the poses in order (the inverse kinematics' solution nearest the last, from all
    /// joints at zero), and each pose's error twists. Err: the index of the first pose the arm
    /// cannot reach, and why.
    pub fn new<'a>(
        robot_name: String,
        robot: std::sync::Arc<crate::robot::Robot>,
        link_sd: f64,
        joint_zero_sd: f64,
        poses: impl IntoIterator<Item = (&'a Isometry3<f64>, Option<crate::robot::Joints>)>,
    ) -> Result<Kinematic, (usize, crate::robot::RobotError)> {
        let mut q = [0.0; 6];
        let mut twists = Twists::default();
        let mut given = std::collections::HashMap::new();
        let mut order: Vec<&Isometry3<f64>> = Vec::new();
        for (i, (f, joints)) in poses.into_iter().enumerate() {
            let key = crate::calib::refine::honest::pose_key(f);
            if twists.contains_key(&key) {
                continue;
            }
            q = match joints {
                Some(j) => {
                    given.insert(key, j);
                    j
                }
                None => robot.ik_nearest(f, &q).map_err(|e| (i, e))?,
            };
            twists.insert(key, robot.error_twists(&q));
            order.push(f);
        }
        let others = if given.is_empty() && (link_sd > 0.0 || joint_zero_sd > 0.0) {
            other_configurations(&robot, &order, &twists)
        } else {
            Vec::new()
        };
        Ok(Kinematic {
            robot_name,
            robot,
            link_sd,
            joint_zero_sd,
            assumed: false,
            errors_stated: link_sd > 0.0 || joint_zero_sd > 0.0,
            twists: std::sync::Arc::new(twists),
            given: std::sync::Arc::new(given),
            others: std::sync::Arc::new(others),
        })
    }

    /// The error twists of the arm's other configurations for the poses (none where the joints
    /// were given), for `twists_at`'s place: a controller may have reached the poses in any of
    /// them, and the file does not say which.
    pub fn other_configurations(&self) -> &[Twists] {
        &self.others
    }

    /// The joint values given with pose `f` (a controller's log), if any.
    pub fn joints_given(&self, f: &Isometry3<f64>) -> Option<crate::robot::Joints> {
        self.given
            .get(&crate::calib::refine::honest::pose_key(f))
            .copied()
    }

    /// Whether any error is stated (an arm named alone only checks the poses' reach).
    pub fn is_stated(&self) -> bool {
        self.link_sd > 0.0 || self.joint_zero_sd > 0.0
    }

    /// An uncalibrated arm's error of point standard deviation `accuracy` (metres, as
    /// `point_sd` counts it), for an arm named without one: joint origins and zeros in the
    /// ratio `ASSUMED_LINK_PER_ZERO`, at this arm's configurations for the same poses (the
    /// other configurations not followed). None where `accuracy` is not positive.
    pub fn assumed(&self, accuracy: f64) -> Option<Kinematic> {
        self.assumed_split(accuracy, assumed_link_share(&self.robot))
    }

    /// `assumed` with the share `link_share` (0 to 1) of the accuracy's variance (as
    /// `point_sd` counts it) in the joint origins, the rest in the zeros: the split the poses'
    /// steps show (`Honest::error_split`). None where `accuracy` is not positive or the share
    /// is outside 0 to 1.
    pub fn assumed_split(&self, accuracy: f64, link_share: f64) -> Option<Kinematic> {
        let (link_unit, zero_unit) = point_variances(&self.robot, 1.0, 1.0);
        let link = (link_share * accuracy * accuracy / link_unit).sqrt();
        let zero = ((1.0 - link_share) * accuracy * accuracy / zero_unit).sqrt();
        let fine = |v: f64| v >= 0.0 && v.is_finite();
        (accuracy > 0.0 && (0.0..=1.0).contains(&link_share) && fine(link) && fine(zero)).then(
            || Kinematic {
                link_sd: link,
                joint_zero_sd: zero,
                assumed: true,
                others: std::sync::Arc::new(Vec::new()),
                ..self.clone()
            },
        )
    }

    /// The share of `point_sd`'s variance in the joint origins (the rest in the zeros).
    pub fn link_share(&self) -> f64 {
        let (l, z) = point_variances(&self.robot, self.link_sd, self.joint_zero_sd);
        l / (l + z)
    }

    /// About one standard deviation of a point's offset along one direction that this error
    /// makes (metres), as `sim::disturb::RobotError::point_sd` counts it: the part of a stated
    /// accuracy that the kinematic error already explains.
    pub fn point_sd(&self) -> f64 {
        point_sd_of(&self.robot, self.link_sd, self.joint_zero_sd)
    }

    /// Each error's standard deviation, in `robot::Robot::error_twists`' order.
    pub fn sds(&self) -> Vec<f64> {
        self.zero_errors()
            .into_iter()
            .map(|zero| {
                if zero {
                    self.joint_zero_sd
                } else {
                    self.link_sd
                }
            })
            .collect()
    }

    /// Which errors, in `robot::Robot::error_twists`' order, are joint zeros (the rest joint
    /// origins).
    pub fn zero_errors(&self) -> Vec<bool> {
        let per = crate::robot::kinematics::ERRORS_PER_JOINT;
        (0..self.robot.joints.len() * per)
            .map(|e| e % per == per - 1)
            .collect()
    }

    /// Pose `f`'s error twists: from the configurations `new` found, or (a pose between them,
    /// as a pose stream interpolates) the solution nearest all joints at zero.
    pub fn twists_at(&self, f: &Isometry3<f64>) -> Option<Vec<nalgebra::Vector6<f64>>> {
        match self.twists.get(&crate::calib::refine::honest::pose_key(f)) {
            Some(t) => Some(t.clone()),
            None => {
                let q = self.robot.ik_nearest(f, &[0.0; 6]).ok()?;
                Some(self.robot.error_twists(&q))
            }
        }
    }
}

/// Most other configurations `Kinematic::new` follows (an arm has at most eight inverse
/// kinematics solutions a pose, more with joints that turn past a full turn).
const MAX_OTHER_CONFIGURATIONS: usize = 8;

/// The error twists of `poses` (distinct, in order) reached from each of the first pose's
/// inverse kinematics solutions but the nearest to all joints at zero (`assumed`' start), each
/// next pose's solution nearest the last; those whose twists differ from `assumed` somewhere
/// (a joint turned by a full turn is the same arm). A configuration that loses a pose (out of
/// the joints' limits) is left out.
fn other_configurations(
    robot: &crate::robot::Robot,
    poses: &[&Isometry3<f64>],
    assumed: &Twists,
) -> Vec<Twists> {
    let Some(first) = poses.first() else {
        return Vec::new();
    };
    let Ok(starts) = robot.ik(first, Some(&[0.0; 6])) else {
        return Vec::new();
    };
    let mut out: Vec<Twists> = Vec::new();
    for start in starts.into_iter().skip(1) {
        let mut q = start;
        let mut twists = Twists::default();
        let mut reached = true;
        for (i, f) in poses.iter().enumerate() {
            if i > 0 {
                match robot.ik_nearest(f, &q) {
                    Ok(next) => q = next,
                    Err(_) => {
                        reached = false;
                        break;
                    }
                }
            }
            twists.insert(
                crate::calib::refine::honest::pose_key(f),
                robot.error_twists(&q),
            );
        }
        // Twists equal to rounding (1e-9 of a unit twist): the same arm.
        let alike = |a: &Twists, b: &Twists| {
            a.iter().all(|(k, t)| {
                b.get(k).is_some_and(|u| {
                    t.iter()
                        .zip(u)
                        .all(|(x, y)| (x - y).norm() <= 1e-9 * (1.0 + y.norm()))
                })
            })
        };
        if reached && !alike(&twists, assumed) && !out.iter().any(|o| alike(&twists, o)) {
            out.push(twists);
            if out.len() >= MAX_OTHER_CONFIGURATIONS {
                break;
            }
        }
    }
    out
}

/// One standard deviation of a point's offset along one direction (metres) that link errors
/// `link_sd` (per axis) and angle errors `angle_sd` (rad) at each joint make: each joint's link
/// error whole along any direction, its angle error over half the arm's reach (the sum of its
/// link lengths, a joint's typical distance from the flange) spread over three directions. An
/// allowance, not a model of the arm.
pub fn point_sd_of(robot: &crate::robot::Robot, link_sd: f64, angle_sd: f64) -> f64 {
    let (l, a) = point_variances(robot, link_sd, angle_sd);
    (l + a).sqrt()
}

/// `point_sd_of`'s variance in its two parts: the link errors' and the angle errors'.
fn point_variances(robot: &crate::robot::Robot, link_sd: f64, angle_sd: f64) -> (f64, f64) {
    let reach: f64 = robot
        .joints
        .iter()
        .map(|j| j.prev_to_joint.translation.vector.norm())
        .sum();
    let n = robot.joints.len() as f64;
    let lever = reach / 2.0;
    (
        n * link_sd * link_sd,
        n * angle_sd * angle_sd * lever * lever / 3.0,
    )
}

/// The share of an assumed arm error's variance in its joint origins at the ratio
/// `ASSUMED_LINK_PER_ZERO` (`point_sd_of`'s parts): where the steps show no split, the one
/// `Kinematic::assumed` takes.
pub fn assumed_link_share(robot: &crate::robot::Robot) -> f64 {
    let (l, z) = point_variances(robot, ASSUMED_LINK_PER_ZERO, 1.0);
    l / (l + z)
}

/// An uncalibrated arm's joint origin error (m, per axis) per radian of joint zero error, where
/// the error is assumed (`Kinematic::assumed`): 0.1 mm per 0.01 deg, the ratio of the
/// independent kit's uncalibrated arm and of `scenarios/ball-causes.toml` (0.05 mm, 0.005 deg).
pub const ASSUMED_LINK_PER_ZERO: f64 = 1e-4 / (0.01 * std::f64::consts::PI / 180.0);

/// Each pose's kinematic error twists (`Kinematic::new`).
pub type Twists = std::collections::HashMap<[u64; 7], Vec<nalgebra::Vector6<f64>>>;

/// Captures that a method cannot use as they are.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum CaptureError {
    #[error("the {method} method needs the {method} radius")]
    MissingRadius { method: Kind },
    #[error("group {group}: a {method} capture needs {need}")]
    WrongData {
        group: usize,
        method: Kind,
        need: &'static str,
    },
    #[error("group {group}: a ball group is a rotation or a translation group")]
    WrongRole { group: usize },
    #[error("an arc of {points} points has no circle")]
    NoCircle { points: usize },
    #[error(
        "{method}: the joint refinement needs the raw features (chord ends, arc points, edge \
         points or profile points); these captures hold only reduced ones: record points_mm \
         (or, for a ball, arc_mm)"
    )]
    NoRawFeatures { method: Kind },
    #[error(
        "{method}: {kept} groups with at least {per_feature} features each, {need} needed by the \
         closed form's protocol (`{method}-any-pose` takes any poses): {groups}"
    )]
    TooFewGroups {
        method: Kind,
        kept: usize,
        need: usize,
        per_feature: usize,
        groups: String,
    },
    #[error("the {method} method has no any-pose estimator")]
    NoAnyPose { method: Kind },
    #[error(
        "{method}-full refines over every profile point: it needs raw profiles (points_mm), \
         these captures hold features only"
    )]
    NoFullProfile { method: Kind },
    #[error(
        "group {group}: the {method} closed form needs its sign s_i (+1 or -1: the ball's side of \
         the laser plane, the disk scan's direction); give it, or use {method}-any-pose, which \
         does without it"
    )]
    MissingSign { group: usize, method: Kind },
    #[error(transparent)]
    Feature(#[from] FeatureError),
    #[error("group {group}: {source}")]
    InGroup {
        group: usize,
        #[source]
        source: Box<CaptureError>,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Poses an IRB 120 reached with its wrist flipped (joint 5 negative, joints 4 and 6 half a
    /// turn from the solution nearest zero): without their joints, the assumed configurations
    /// are the unflipped ones and the flipped ones are among the others; with them, none.
    #[test]
    fn without_joints_the_arms_other_configurations_are_followed() {
        let robot = std::sync::Arc::new(crate::robot::Robot::resolve("irb120").unwrap());
        let joints: Vec<crate::robot::Joints> = (0..5)
            .map(|i| {
                let t = i as f64 * 0.05;
                [0.2 + t, 0.1 - t, 0.2, 2.5 - t, -0.6 - t, 2.0 + t]
            })
            .collect();
        let poses: Vec<Isometry3<f64>> = joints.iter().map(|q| robot.fk(q)).collect();
        let k = Kinematic::new(
            "irb120".into(),
            robot.clone(),
            1e-4,
            1e-4,
            poses.iter().map(|p| (p, None)),
        )
        .unwrap();
        let key = crate::calib::refine::honest::pose_key;
        let true_twists = |t: &Twists| {
            poses.iter().zip(&joints).all(|(p, q)| {
                t[&key(p)]
                    .iter()
                    .zip(robot.error_twists(q))
                    .all(|(a, b)| (a - b).norm() < 1e-9)
            })
        };
        assert!(
            !true_twists(&k.twists),
            "the flipped wrist is not the assumed one"
        );
        let others = k.other_configurations();
        assert!(!others.is_empty() && others.len() <= MAX_OTHER_CONFIGURATIONS);
        assert!(others.iter().all(|o| o.len() == poses.len()));
        assert!(others.iter().any(true_twists), "{} others", others.len());
        let given = Kinematic::new(
            "irb120".into(),
            robot.clone(),
            1e-4,
            1e-4,
            poses.iter().zip(&joints).map(|(p, q)| (p, Some(*q))),
        )
        .unwrap();
        assert!(given.other_configurations().is_empty());
        assert!(true_twists(&given.twists));
    }

    /// An arm named without its errors: the assumed error has the stated point sd, the ratio
    /// of origins to zeros, the same configurations and none of the others; no accuracy, none.
    #[test]
    fn an_assumed_error_has_the_stated_accuracy() {
        let robot = std::sync::Arc::new(crate::robot::Robot::resolve("irb120").unwrap());
        let poses: Vec<Isometry3<f64>> = (0..4)
            .map(|i| robot.fk(&[0.1 * i as f64, 0.2, 0.1, 0.3, -0.8, 0.5]))
            .collect();
        let named = Kinematic::new(
            "irb120".into(),
            robot.clone(),
            0.0,
            0.0,
            poses.iter().map(|p| (p, None)),
        )
        .unwrap();
        assert!(!named.is_stated() && !named.errors_stated);
        let k = named.assumed(0.3e-3).unwrap();
        assert!(k.assumed && k.is_stated() && !k.errors_stated);
        assert!(
            (k.point_sd() / 0.3e-3 - 1.0).abs() < 1e-12,
            "{}",
            k.point_sd()
        );
        assert!((k.link_sd / k.joint_zero_sd / ASSUMED_LINK_PER_ZERO - 1.0).abs() < 1e-12);
        // The kit's uncalibrated arm: 0.1 mm and 0.01 deg.
        assert!((ASSUMED_LINK_PER_ZERO * 0.01f64.to_radians() - 1e-4).abs() < 1e-15);
        assert!(k.other_configurations().is_empty());
        for p in &poses {
            assert_eq!(k.twists_at(p), named.twists_at(p));
        }
        assert!(named.assumed(0.0).is_none());
        // Another split keeps the accuracy and takes the share asked for, at both ends too.
        assert!((k.link_share() - assumed_link_share(&robot)).abs() < 1e-12);
        for share in [0.0, 0.25, 0.9, 1.0] {
            let s = named.assumed_split(0.3e-3, share).unwrap();
            assert!((s.point_sd() / 0.3e-3 - 1.0).abs() < 1e-12);
            assert!((s.link_share() - share).abs() < 1e-12, "{share}");
        }
        assert!(named.assumed_split(0.3e-3, 1.5).is_none());
        assert!(named.assumed_split(0.3e-3, f64::NAN).is_none());
    }
}
