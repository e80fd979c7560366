//! URDF to serial chain: the one place that knows urdf-rs types.

use super::RobotError;
use crate::math::pose_from_xyz_rpy;
use nalgebra::{Isometry3, Unit, Vector3};
use std::collections::HashMap;

/// An actuated (revolute) joint of the chain.
#[derive(Debug, Clone)]
pub struct Joint {
    pub name: String,
    /// Joint frame in the previous actuated joint's child-link frame (fixed joints in between folded in).
    pub prev_to_joint: Isometry3<f64>,
    /// Rotation axis in the joint frame.
    pub axis: Unit<Vector3<f64>>,
    pub lower_rad: f64,
    pub upper_rad: f64,
    pub max_speed_rad_s: f64,
}

/// A link of the chain, with what a viewer and the dynamics need.
#[derive(Debug, Clone)]
pub struct Link {
    pub name: String,
    /// Number of actuated joints between the root and this link.
    pub after_joints: usize,
    /// This link's frame in the child-link frame of actuated joint `after_joints` (root frame if 0).
    pub offset: Isometry3<f64>,
    pub visuals: Vec<Visual>,
    pub inertial: Option<Inertial>,
}

/// Visual geometry of a link, in the link frame (metres).
#[derive(Debug, Clone)]
pub struct Visual {
    pub link_to_geometry: Isometry3<f64>,
    pub geometry: Geometry,
    pub rgba: Option<[f64; 4]>,
}

#[derive(Debug, Clone, PartialEq)]
pub enum Geometry {
    Box {
        size: [f64; 3],
    },
    /// Cylinder along the geometry frame's z axis, centred on its origin.
    Cylinder {
        radius: f64,
        length: f64,
    },
    Sphere {
        radius: f64,
    },
    Mesh {
        filename: String,
    },
}

/// Mass properties of a link (kg, m, kg m^2).
#[derive(Debug, Clone)]
pub struct Inertial {
    pub link_to_com: Isometry3<f64>,
    pub mass_kg: f64,
    /// ixx, iyy, izz, ixy, ixz, iyz about the centre of mass, in the `link_to_com` frame.
    pub inertia: [f64; 6],
}

pub(crate) struct Chain {
    pub name: String,
    pub joints: Vec<Joint>,
    pub links: Vec<Link>,
    pub last_to_tip: Isometry3<f64>,
}

fn pose(p: &urdf_rs::Pose) -> Isometry3<f64> {
    pose_from_xyz_rpy(*p.xyz, *p.rpy)
}

/// Deepest element nesting a URDF may have (a robot's is 3-4 deep); deeper input would
/// overflow the XML parser's stack.
pub const MAX_NESTING: usize = 64;
/// Most links a serial chain may walk through (a 6-axis arm has 7-12).
pub const MAX_CHAIN_LINKS: usize = 256;
/// Joint limits beyond this many degrees either way would make IK list every 360 deg turn.
pub const MAX_LIMIT_DEG: f64 = 1080.0;

/// The element nesting depth of XML text, counted over its tags (comments, declarations and
/// self-closing tags do not nest); stops counting past `MAX_NESTING`.
fn nesting(text: &str) -> usize {
    let (mut depth, mut deepest) = (0usize, 0usize);
    let b = text.as_bytes();
    let mut i = 0;
    while let Some(k) = b[i..].iter().position(|&c| c == b'<') {
        let s = i + k;
        let end = match b[s..].iter().position(|&c| c == b'>') {
            Some(e) => s + e,
            None => break,
        };
        let tag = &b[s + 1..end];
        if tag.starts_with(b"/") {
            depth = depth.saturating_sub(1);
        } else if !(tag.starts_with(b"?") || tag.starts_with(b"!") || tag.ends_with(b"/")) {
            depth += 1;
            deepest = deepest.max(depth);
            if deepest > MAX_NESTING {
                break;
            }
        }
        i = end + 1;
    }
    deepest
}

/// Parse URDF text into the chain from the root link to `tip`.
pub(crate) fn parse_serial_chain(text: &str, path: &str, tip: &str) -> Result<Chain, RobotError> {
    if nesting(text) > MAX_NESTING {
        return Err(RobotError::Parse {
            path: path.to_string(),
            message: format!(
                "elements nested more than {MAX_NESTING} deep; a URDF's robot, link, joint and \
                 their children nest 4 deep"
            ),
        });
    }
    let robot = urdf_rs::read_from_string(text).map_err(|e| RobotError::Parse {
        path: path.to_string(),
        message: e.to_string(),
    })?;

    let mut children: HashMap<&str, Vec<&urdf_rs::Joint>> = HashMap::new();
    for j in &robot.joints {
        children.entry(j.parent.link.as_str()).or_default().push(j);
    }
    // Check in file order so the message names the first offender.
    for link in &robot.links {
        if let Some(js) = children.get(link.name.as_str())
            && js.len() > 1
        {
            return Err(RobotError::Branching {
                path: path.to_string(),
                link: link.name.clone(),
                count: js.len(),
                joints: js
                    .iter()
                    .map(|j| j.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
    }
    let is_child: std::collections::HashSet<&str> =
        robot.joints.iter().map(|j| j.child.link.as_str()).collect();
    let root = robot
        .links
        .iter()
        .find(|l| !is_child.contains(l.name.as_str()))
        .ok_or_else(|| RobotError::Parse {
            path: path.to_string(),
            message: "no root link: every link is the child of a joint".into(),
        })?;
    let by_name: HashMap<&str, &urdf_rs::Link> =
        robot.links.iter().map(|l| (l.name.as_str(), l)).collect();

    let mut joints = Vec::new();
    let mut links = Vec::new();
    let mut offset = Isometry3::identity();
    let mut current = root.name.as_str();
    let mut seen = std::collections::HashSet::new();
    loop {
        if !seen.insert(current) {
            return Err(RobotError::Parse {
                path: path.to_string(),
                message: format!(
                    "the chain from '{}' loops back to link '{current}'; a serial arm's joints \
                     lead from the root to the tip without a cycle",
                    root.name
                ),
            });
        }
        if seen.len() > MAX_CHAIN_LINKS {
            return Err(RobotError::Parse {
                path: path.to_string(),
                message: format!(
                    "the chain from '{}' passes more than {MAX_CHAIN_LINKS} links before '{tip}'",
                    root.name
                ),
            });
        }
        let l = by_name.get(current).ok_or_else(|| RobotError::Parse {
            path: path.to_string(),
            message: format!("a joint names link '{current}', which is not defined"),
        })?;
        links.push(convert_link(l, joints.len(), offset));
        if current == tip {
            break;
        }
        let Some(j) = children.get(current).and_then(|v| v.first()) else {
            return Err(RobotError::MissingTip {
                path: path.to_string(),
                link: tip.to_string(),
                root: root.name.clone(),
            });
        };
        let numbers = j
            .origin
            .xyz
            .iter()
            .chain(j.origin.rpy.iter())
            .chain(j.axis.xyz.iter());
        if !numbers.copied().all(f64::is_finite) {
            return Err(RobotError::Parse {
                path: path.to_string(),
                message: format!(
                    "joint '{}' has an origin or axis that is not a finite number (xyz {:?}, \
                     rpy {:?}, axis {:?})",
                    j.name, *j.origin.xyz, *j.origin.rpy, *j.axis.xyz
                ),
            });
        }
        match j.joint_type {
            urdf_rs::JointType::Fixed => offset *= pose(&j.origin),
            urdf_rs::JointType::Revolute => {
                let lim = &j.limit;
                let bound = MAX_LIMIT_DEG.to_radians();
                let usable = lim.lower.is_finite()
                    && lim.upper.is_finite()
                    && lim.lower < lim.upper
                    && lim.lower >= -bound
                    && lim.upper <= bound
                    && lim.velocity.is_finite()
                    && lim.velocity > 0.0;
                if !usable {
                    return Err(RobotError::MissingLimits {
                        path: path.to_string(),
                        joint: j.name.clone(),
                        lower: lim.lower,
                        upper: lim.upper,
                        velocity: lim.velocity,
                    });
                }
                let axis = Vector3::from(*j.axis.xyz);
                if axis.norm() < 1e-9 {
                    return Err(RobotError::Parse {
                        path: path.to_string(),
                        message: format!("joint '{}' has a zero axis", j.name),
                    });
                }
                joints.push(Joint {
                    name: j.name.clone(),
                    prev_to_joint: offset * pose(&j.origin),
                    axis: Unit::new_normalize(axis),
                    lower_rad: lim.lower,
                    upper_rad: lim.upper,
                    max_speed_rad_s: lim.velocity,
                });
                offset = Isometry3::identity();
            }
            ref other => {
                return Err(RobotError::UnsupportedJoint {
                    path: path.to_string(),
                    joint: j.name.clone(),
                    kind: format!("{other:?}").to_lowercase(),
                });
            }
        }
        current = j.child.link.as_str();
    }
    if joints.len() != 6 {
        return Err(RobotError::WrongDof {
            path: path.to_string(),
            root: root.name.clone(),
            tip: tip.to_string(),
            count: joints.len(),
        });
    }
    Ok(Chain {
        name: robot.name.clone(),
        joints,
        links,
        last_to_tip: offset,
    })
}

fn convert_link(l: &urdf_rs::Link, after_joints: usize, offset: Isometry3<f64>) -> Link {
    let visuals = l
        .visual
        .iter()
        .map(|v| Visual {
            link_to_geometry: pose(&v.origin),
            geometry: match &v.geometry {
                urdf_rs::Geometry::Box { size } => Geometry::Box { size: **size },
                urdf_rs::Geometry::Cylinder { radius, length }
                | urdf_rs::Geometry::Capsule { radius, length } => Geometry::Cylinder {
                    radius: *radius,
                    length: *length,
                },
                urdf_rs::Geometry::Sphere { radius } => Geometry::Sphere { radius: *radius },
                urdf_rs::Geometry::Mesh { filename, .. } => Geometry::Mesh {
                    filename: filename.clone(),
                },
            },
            rgba: v
                .material
                .as_ref()
                .and_then(|m| m.color.as_ref())
                .map(|c| c.rgba.0),
        })
        .collect();
    let i = &l.inertial;
    let inertial = (i.mass.value > 0.0).then(|| Inertial {
        link_to_com: pose(&i.origin),
        mass_kg: i.mass.value,
        inertia: [
            i.inertia.ixx,
            i.inertia.iyy,
            i.inertia.izz,
            i.inertia.ixy,
            i.inertia.ixz,
            i.inertia.iyz,
        ],
    });
    Link {
        name: l.name.clone(),
        after_joints,
        offset,
        visuals,
        inertial,
    }
}
