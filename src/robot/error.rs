use thiserror::Error;

/// Everything that can go wrong loading an arm or solving its kinematics.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum RobotError {
    #[error("{path}: cannot read the file: {message}")]
    Io { path: String, message: String },

    #[error("{path}: not a valid URDF ({message}); check the XML against the URDF spec")]
    Parse { path: String, message: String },

    #[error(
        "{path}: link '{link}' has {count} child joints ({joints}); lasercal needs a serial chain, \
         so remove the extra branches"
    )]
    Branching {
        path: String,
        link: String,
        count: usize,
        joints: String,
    },

    #[error(
        "{path}: no link named '{link}' is reachable from the root link '{root}'; add a fixed joint \
         from the last link to a link named '{link}'"
    )]
    MissingTip {
        path: String,
        link: String,
        root: String,
    },

    #[error(
        "{path}: joint '{joint}' has no usable <limit> (lower {lower}, upper {upper}, velocity \
         {velocity}); add <limit lower=\"..\" upper=\"..\" velocity=\"..\" effort=\"..\"/> in radians \
         with lower < upper, both within +-1080 deg (18.85 rad), and velocity > 0"
    )]
    MissingLimits {
        path: String,
        joint: String,
        lower: f64,
        upper: f64,
        velocity: f64,
    },

    #[error(
        "{path}: joint '{joint}' is of type '{kind}'; lasercal supports revolute and fixed joints only"
    )]
    UnsupportedJoint {
        path: String,
        joint: String,
        kind: String,
    },

    #[error(
        "{path}: the chain from '{root}' to '{tip}' has {count} revolute joints; lasercal drives \
         6-axis arms"
    )]
    WrongDof {
        path: String,
        root: String,
        tip: String,
        count: usize,
    },

    #[error(
        "{path}: not an ortho-parallel arm with a spherical wrist ({reason}); closed-form IK needs \
         axes z, y, y, x, y, x with offsets only in the arm plane"
    )]
    NotOrthoParallel { path: String, reason: String },

    #[error("unknown robot '{name}': use irb120, irb2600 or the path of a .urdf file")]
    UnknownRobot { name: String },

    #[error("link '{link}' is not part of robot '{robot}'")]
    UnknownLink { robot: String, link: String },

    #[error("pose out of reach: {reason}")]
    OutOfReach { reason: String },

    #[error("pose reachable only outside the joint limits: {reason}")]
    OutsideLimits { reason: String },
}
