//! A calibration result in the formats ROS users expect: YAML (easy_handeye's keys, metres,
//! quaternion x, y, z, w, with the covariance), a URDF fixed joint, and a ROS 2
//! `static_transform_publisher` command. Each reads back to the same transform (tests).

use crate::error::FormatError;
use nalgebra::{Isometry3, Matrix6, Quaternion, Translation3, UnitQuaternion};
use serde::{Deserialize, Serialize};

/// What is exported: the transform between two named frames and its covariance.
#[derive(Debug, Clone, PartialEq)]
pub struct Exported {
    /// The flange frame (the robot's tool0 / end effector link).
    pub parent_frame: String,
    /// The sensor frame.
    pub child_frame: String,
    pub flange_to_sensor: Isometry3<f64>,
    /// Rotation about the sensor's x, y, z (rad), translation along the flange's x, y, z (m).
    pub covariance: Option<Matrix6<f64>>,
}

/// The order of the covariance's rows and columns, written beside it.
pub const COVARIANCE_ORDER: &str =
    "rx ry rz (rad, about the sensor's axes), tx ty tz (m, along the flange's axes)";

#[derive(Serialize, Deserialize, Debug, PartialEq)]
struct Transformation {
    x: f64,
    y: f64,
    z: f64,
    qx: f64,
    qy: f64,
    qz: f64,
    qw: f64,
}

#[derive(Serialize, Deserialize, Debug)]
struct YamlFile {
    eye_on_hand: bool,
    robot_effector_frame: String,
    tracking_base_frame: String,
    transformation: Transformation,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    covariance: Option<Vec<Vec<f64>>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    covariance_order: Option<String>,
}

/// A frame name fit for YAML, URDF and a shell command: letters, digits, `_`, `-`, `/`, `.`.
pub fn check_frame(name: &str, what: &str) -> Result<(), FormatError> {
    let ok = !name.is_empty()
        && name.len() <= 200
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '/' | '.'));
    if ok {
        Ok(())
    } else {
        Err(FormatError::Field {
            file: "command line".into(),
            at: what.into(),
            message: format!(
                "{name:?}: a frame name is 1-200 letters, digits, '_', '-', '/' or '.'"
            ),
        })
    }
}

fn transformation(x: &Isometry3<f64>) -> Transformation {
    let (t, q) = (x.translation.vector, x.rotation);
    Transformation {
        x: t.x,
        y: t.y,
        z: t.z,
        qx: q.i,
        qy: q.j,
        qz: q.k,
        qw: q.w,
    }
}

/// easy_handeye's YAML (eye on hand: the effector is the parent, the tracking frame the sensor).
pub fn to_yaml(e: &Exported) -> Result<String, FormatError> {
    let file = YamlFile {
        eye_on_hand: true,
        robot_effector_frame: e.parent_frame.clone(),
        tracking_base_frame: e.child_frame.clone(),
        transformation: transformation(&e.flange_to_sensor),
        covariance: e
            .covariance
            .filter(|c| c.iter().all(|v| v.is_finite()))
            .map(|c| {
                (0..6)
                    .map(|r| (0..6).map(|k| c[(r, k)]).collect())
                    .collect()
            }),
        covariance_order: e.covariance.map(|_| COVARIANCE_ORDER.to_string()),
    };
    serde_norway::to_string(&file).map_err(|err| FormatError::Field {
        file: "yaml".into(),
        at: "transformation".into(),
        message: err.to_string(),
    })
}

/// Read an easy_handeye-style YAML back (`file` names it in errors).
pub fn from_yaml(text: &str, file: &str) -> Result<Exported, FormatError> {
    let f: YamlFile = serde_norway::from_str(text).map_err(|err| FormatError::Field {
        file: file.into(),
        at: "the YAML".into(),
        message: err.to_string(),
    })?;
    let t = &f.transformation;
    let q = Quaternion::new(t.qw, t.qx, t.qy, t.qz);
    let all = [t.x, t.y, t.z, t.qw, t.qx, t.qy, t.qz];
    if !all.iter().all(|v| v.is_finite()) || !(q.norm() > 0.5 && q.norm() < 1.5) {
        return Err(FormatError::Field {
            file: file.into(),
            at: "transformation".into(),
            message: "the translation must be finite and the quaternion of unit length".into(),
        });
    }
    let covariance = match &f.covariance {
        None => None,
        Some(rows) if rows.len() == 6 && rows.iter().all(|r| r.len() == 6) => {
            Some(Matrix6::from_fn(|r, k| rows[r][k]))
        }
        Some(_) => {
            return Err(FormatError::Field {
                file: file.into(),
                at: "covariance".into(),
                message: "the covariance must be 6 rows of 6 numbers".into(),
            });
        }
    };
    Ok(Exported {
        parent_frame: f.robot_effector_frame,
        child_frame: f.tracking_base_frame,
        flange_to_sensor: Isometry3::from_parts(
            Translation3::new(t.x, t.y, t.z),
            UnitQuaternion::from_quaternion(q),
        ),
        covariance,
    })
}

/// A URDF fragment: the sensor link and the fixed joint that places it on the flange (rpy as
/// URDF reads it: R = Rz(yaw) Ry(pitch) Rx(roll)).
pub fn to_urdf(e: &Exported) -> String {
    let t = e.flange_to_sensor.translation.vector;
    let (r, p, y) = e.flange_to_sensor.rotation.euler_angles();
    format!(
        "<!-- lasercal: flange_to_sensor, calibrated -->\n\
         <link name=\"{c}\"/>\n\
         <joint name=\"{pa}_to_{c}\" type=\"fixed\">\n  \
         <parent link=\"{pa}\"/>\n  \
         <child link=\"{c}\"/>\n  \
         <origin xyz=\"{:.12} {:.12} {:.12}\" rpy=\"{:.15} {:.15} {:.15}\"/>\n\
         </joint>\n",
        t.x,
        t.y,
        t.z,
        r,
        p,
        y,
        c = e.child_frame,
        pa = e.parent_frame
    )
}

/// The ROS 2 command that publishes the transform (Humble and later: named arguments).
pub fn ros2_command(e: &Exported) -> String {
    let t = transformation(&e.flange_to_sensor);
    format!(
        "ros2 run tf2_ros static_transform_publisher --x {:.12} --y {:.12} --z {:.12} --qx {:.15} \
         --qy {:.15} --qz {:.15} --qw {:.15} --frame-id {} --child-frame-id {}",
        t.x, t.y, t.z, t.qx, t.qy, t.qz, t.qw, e.parent_frame, e.child_frame
    )
}
