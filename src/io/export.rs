//! A calibration result in the formats ROS users expect: YAML (easy_handeye's layout, metres,
//! quaternion x, y, z, w with w >= 0, the covariance in ROS's order and frame), a URDF fixed
//! joint, and a ROS 2 `static_transform_publisher` command. Each reads back to the same transform (tests).

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

/// The order of the YAML covariance's rows and columns, written beside it: ROS's
/// (geometry_msgs/PoseWithCovariance), all in the parent (flange) frame.
pub const COVARIANCE_ORDER: &str = "x y z (m), then rotation about x y z (rad), all along the parent (flange) frame's axes, as geometry_msgs/PoseWithCovariance";

/// The change of variables from lasercal's covariance (rotation about the sensor's axes, then
/// translation along the flange's) to ROS's (translation, then rotation, both in the flange
/// frame): a rotation w about the sensor's axes is R w about the flange's (R = flange_to_sensor).
fn to_ros_order(x: &Isometry3<f64>) -> Matrix6<f64> {
    let r = x.rotation.to_rotation_matrix().into_inner();
    let mut t = Matrix6::zeros();
    t.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&nalgebra::Matrix3::identity());
    t.fixed_view_mut::<3, 3>(3, 0).copy_from(&r);
    t
}

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

/// easy_handeye's calibration parameters (its loader passes them as keyword arguments: only
/// these keys).
#[derive(Serialize, Deserialize, Debug)]
struct Parameters {
    namespace: String,
    move_group_namespace: String,
    move_group: String,
    eye_on_hand: bool,
    robot_base_frame: Option<String>,
    robot_effector_frame: String,
    tracking_base_frame: String,
    tracking_marker_frame: Option<String>,
}

/// The frames under `parameters:` as the current easy_handeye loader reads them, and at the top
/// level as its older versions did.
#[derive(Serialize, Deserialize, Debug)]
struct YamlFile {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    parameters: Option<Parameters>,
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
    let t = x.translation.vector;
    // q and -q are one rotation; w >= 0 as ROS tools print it.
    let q = if x.rotation.w < 0.0 {
        -x.rotation.into_inner()
    } else {
        x.rotation.into_inner()
    };
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
        parameters: Some(Parameters {
            namespace: "/lasercal_eye_on_hand/".into(),
            move_group_namespace: "/".into(),
            move_group: "manipulator".into(),
            eye_on_hand: true,
            robot_base_frame: None,
            robot_effector_frame: e.parent_frame.clone(),
            tracking_base_frame: e.child_frame.clone(),
            tracking_marker_frame: None,
        }),
        eye_on_hand: true,
        robot_effector_frame: e.parent_frame.clone(),
        tracking_base_frame: e.child_frame.clone(),
        transformation: transformation(&e.flange_to_sensor),
        covariance: e
            .covariance
            .filter(|c| c.iter().all(|v| v.is_finite()))
            .map(|c| {
                let t = to_ros_order(&e.flange_to_sensor);
                let c = t * c * t.transpose();
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
    let flange_to_sensor = Isometry3::from_parts(
        Translation3::new(t.x, t.y, t.z),
        UnitQuaternion::from_quaternion(q),
    );
    let covariance = match &f.covariance {
        None => None,
        Some(rows) if rows.len() == 6 && rows.iter().all(|r| r.len() == 6) => {
            // Back from ROS's order and frame (`to_ros_order` is orthogonal).
            let t = to_ros_order(&flange_to_sensor);
            Some(t.transpose() * Matrix6::from_fn(|r, k| rows[r][k]) * t)
        }
        Some(_) => {
            return Err(FormatError::Field {
                file: file.into(),
                at: "covariance".into(),
                message: "the covariance must be 6 rows of 6 numbers".into(),
            });
        }
    };
    let (parent_frame, child_frame) = match f.parameters {
        Some(p) => (p.robot_effector_frame, p.tracking_base_frame),
        None => (f.robot_effector_frame, f.tracking_base_frame),
    };
    Ok(Exported {
        parent_frame,
        child_frame,
        flange_to_sensor,
        covariance,
    })
}

/// A flange-to-sensor transform from a file another tool wrote: an easy_handeye-style YAML
/// (metres, quaternion), a JSON file holding a 4x4 matrix in mm (`lasercal calibrate --json`'s
/// `flange_to_sensor`, or the only 4x4 array in it, as a calibration tool's `HTM`), or text of 16
/// (or 12: the top three rows) numbers, a 4x4 row-major matrix in mm.
pub fn read_transform(text: &str, file: &str) -> Result<Isometry3<f64>, FormatError> {
    let bad = |message: String| FormatError::Field {
        file: file.into(),
        at: "the whole file".into(),
        message,
    };
    if text.contains("transformation") && !text.trim_start().starts_with('{') {
        return Ok(from_yaml(text, file)?.flange_to_sensor);
    }
    let rows = if let Ok(v) = serde_json::from_str::<serde_json::Value>(text) {
        match v.get("flange_to_sensor").and_then(matrix4) {
            Some(m) => m,
            None => {
                let mut all = Vec::new();
                matrices4(&v, &mut all);
                match all.as_slice() {
                    [m] => *m,
                    [] => {
                        return Err(bad(
                            "no 4x4 matrix in it: give `flange_to_sensor` as 4 rows \
                                        of 4 numbers, mm"
                                .into(),
                        ));
                    }
                    more => {
                        return Err(bad(format!(
                            "{} 4x4 matrices in it: put the one to compare under \
                             `flange_to_sensor`",
                            more.len()
                        )));
                    }
                }
            }
        }
    } else {
        let v: Vec<f64> = text
            .split(|c: char| c.is_whitespace() || c == ',' || c == ';' || c == '[' || c == ']')
            .filter(|s| !s.is_empty())
            .map(|s| s.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| {
                bad(format!(
                    "not a transform: want an easy_handeye YAML, a JSON file with a 4x4 matrix, \
                     or 16 numbers (a 4x4 matrix, mm); {e}"
                ))
            })?;
        let v = match v.len() {
            16 => v,
            12 => v.into_iter().chain([0.0, 0.0, 0.0, 1.0]).collect(),
            n => {
                return Err(bad(format!(
                    "{n} numbers: give 16 (a 4x4 matrix, row by row, mm) or 12 (its top three rows)"
                )));
            }
        };
        std::array::from_fn(|i| std::array::from_fn(|j| v[4 * i + j]))
    };
    super::captures::transform_of(&rows, file, "the matrix")
}

/// A JSON value that is 4 rows of 4 numbers.
fn matrix4(v: &serde_json::Value) -> Option<[[f64; 4]; 4]> {
    let rows = v.as_array().filter(|r| r.len() == 4)?;
    let mut m = [[0.0; 4]; 4];
    for (i, r) in rows.iter().enumerate() {
        let r = r.as_array().filter(|r| r.len() == 4)?;
        for (j, x) in r.iter().enumerate() {
            m[i][j] = x.as_f64()?;
        }
    }
    Some(m)
}

/// Every 4x4 matrix in a JSON value.
fn matrices4(v: &serde_json::Value, out: &mut Vec<[[f64; 4]; 4]>) {
    if let Some(m) = matrix4(v) {
        out.push(m);
        return;
    }
    match v {
        serde_json::Value::Array(a) => a.iter().for_each(|x| matrices4(x, out)),
        serde_json::Value::Object(o) => o.values().for_each(|x| matrices4(x, out)),
        _ => {}
    }
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
