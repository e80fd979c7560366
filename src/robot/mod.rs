//! Robot arms: URDF loading (`urdf`), forward kinematics (`kinematics`) and closed-form inverse
//! kinematics for ortho-parallel arms with a spherical wrist (`ik`).

mod error;
pub mod ik;
pub mod kinematics;
pub mod urdf;

pub use error::RobotError;
pub use ik::OpwParams;
pub use urdf::{Geometry, Inertial, Joint, Link, Visual};

use nalgebra::Isometry3;

/// Joint values in radians, joint 1 first.
pub type Joints = [f64; 6];

/// Built-in arms: short name, file under `robots/`, and the file's text (embedded so the binary runs
/// from any directory).
pub const BUILTIN: &[(&str, &str, &str)] = &[
    (
        "irb120",
        "robots/irb120_3_58.urdf",
        include_str!("../../robots/irb120_3_58.urdf"),
    ),
    (
        "irb2600",
        "robots/irb2600_12_165.urdf",
        include_str!("../../robots/irb2600_12_165.urdf"),
    ),
];

/// A 6-axis serial arm loaded from URDF: its actuated joints, every link (for drawing and dynamics),
/// the fixed offset from the last joint to `tool0`, and its closed-form IK parameters.
#[derive(Debug, Clone)]
pub struct Robot {
    /// Name from the URDF's `<robot name=...>`.
    pub name: String,
    /// Where it came from: a file path or `robots/<file>` for a built-in arm.
    pub source: String,
    pub joints: Vec<Joint>,
    pub links: Vec<Link>,
    /// Pose of tool0 in the frame of the last actuated joint's child link.
    pub last_to_tool0: Isometry3<f64>,
    pub opw: OpwParams,
}

impl Robot {
    /// Load by short name (`irb120`, `irb2600`, also the file stem such as `irb120_3_58`) or by path
    /// to a `.urdf` file.
    pub fn resolve(name_or_path: &str) -> Result<Robot, RobotError> {
        // A built-in arm is parsed once per process: a sweep resolves it at every grid point,
        // on the one thread that feeds the trials.
        static PARSED: [std::sync::OnceLock<Robot>; BUILTIN.len()] =
            [const { std::sync::OnceLock::new() }; BUILTIN.len()];
        for ((short, file, text), parsed) in BUILTIN.iter().zip(&PARSED) {
            let stem = file.trim_start_matches("robots/").trim_end_matches(".urdf");
            if name_or_path == *short || name_or_path == stem || name_or_path == *file {
                if let Some(robot) = parsed.get() {
                    return Ok(robot.clone());
                }
                let robot = Robot::from_urdf_str(text, file)?;
                return Ok(parsed.get_or_init(|| robot).clone());
            }
        }
        let path = std::path::Path::new(name_or_path);
        if path.extension().is_some_and(|e| e == "urdf") || path.exists() {
            return Robot::from_file(path);
        }
        Err(RobotError::UnknownRobot {
            name: name_or_path.to_string(),
        })
    }

    /// Load a URDF file from disk.
    pub fn from_file(path: &std::path::Path) -> Result<Robot, RobotError> {
        let text = std::fs::read_to_string(path).map_err(|e| RobotError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        Robot::from_urdf_str(&text, &path.display().to_string())
    }

    /// Parse URDF text; `source` names the file in error messages.
    pub fn from_urdf_str(text: &str, source: &str) -> Result<Robot, RobotError> {
        let chain = urdf::parse_serial_chain(text, source, "tool0")?;
        let opw = OpwParams::from_chain(&chain.joints, &chain.last_to_tip, source)?;
        Ok(Robot {
            name: chain.name,
            source: source.to_string(),
            joints: chain.joints,
            links: chain.links,
            last_to_tool0: chain.last_to_tip,
            opw,
        })
    }

    /// Lower joint limits in radians.
    pub fn lower(&self) -> Joints {
        std::array::from_fn(|i| self.joints[i].lower_rad)
    }

    /// Upper joint limits in radians.
    pub fn upper(&self) -> Joints {
        std::array::from_fn(|i| self.joints[i].upper_rad)
    }

    /// Maximum joint speeds in rad/s.
    pub fn max_speed(&self) -> Joints {
        std::array::from_fn(|i| self.joints[i].max_speed_rad_s)
    }

    /// True when every joint value lies within its limits (inclusive, with `tol` radians of slack).
    pub fn within_limits(&self, q: &Joints, tol: f64) -> bool {
        self.joints
            .iter()
            .zip(q)
            .all(|(j, &v)| v >= j.lower_rad - tol && v <= j.upper_rad + tol)
    }
}

impl Robot {
    /// True when `v` radians lies within joint `j`'s limits.
    pub fn within_limits_one(&self, j: &Joint, v: f64) -> bool {
        v >= j.lower_rad - 1e-12 && v <= j.upper_rad + 1e-12
    }
}
