//! The calibration specimens of both papers, each in its own frame.

use super::{ConvexPlanes, CylinderZ, Part, PartShape, Sheet, Surface};
use nalgebra::{Isometry3, Point3, Translation3, Vector3};
use parry3d_f64::shape::Ball;

/// Specimen geometry in metres. Frames:
/// - disks: origin at the disk centre, z along the disk normal (out of the top face);
/// - ball: origin at the ball centre;
/// - edges: origin on the straight edge, x along it; the body lies at y < 0, the edge's top face
///   faces +z, so a profile crossing toward +y runs over the top face and drops off at the edge.
#[derive(Debug, Clone, PartialEq)]
pub enum SpecimenKind {
    /// A disk on top of a cylinder of the same radius (disk paper Fig. 2a): a step at the rim.
    DiskOnCylinder { radius: f64, height: f64 },
    /// A white disk on a square of black paper (Fig. 2b): one plane, told apart by intensity.
    DiskOnPaper { radius: f64, paper_half: f64 },
    /// A ball on a thinner post below it.
    BallOnPost {
        radius: f64,
        post_radius: f64,
        post_height: f64,
    },
    /// A machinist's parallel bar (cuboid).
    ParallelBar {
        length: f64,
        width: f64,
        height: f64,
    },
    /// A straight scale (thin plate).
    Scale {
        length: f64,
        width: f64,
        thickness: f64,
    },
    /// A knife blade: a thin plate whose edge is a symmetric bevel of width `bevel`.
    KnifeBlade {
        length: f64,
        width: f64,
        thickness: f64,
        bevel: f64,
    },
    /// A roof: two faces rising from a base `width` wide to the ridge, `height` above it (the
    /// edge line; frame origin on it, the base at z = -height).
    Ridge {
        length: f64,
        width: f64,
        height: f64,
    },
    /// A V groove `width` wide at the top and `height` deep, cut along a block three times as
    /// wide (the groove's bottom is the edge line; frame origin on it, the block's flat top at
    /// z = height, its bottom 10 mm below the groove's).
    VGroove {
        length: f64,
        width: f64,
        height: f64,
    },
    /// A step: a top face (the body at y < 0) ending at the edge line, a riser `height` down,
    /// and a lower face beyond it (y from 0 to `width`); the upper block is `width` wide. Two
    /// parallel faces at different heights, read as a bar's edge.
    Step {
        length: f64,
        width: f64,
        height: f64,
    },
    /// A fillet joint's inside corner: two plates at right angles (a floor and a wall, 10 mm
    /// thick), each face `width` long from the corner line. Frame: origin on the corner line, z
    /// along the bisector of the faces (they rise at 45 deg either side), so rpy_deg = [45, 0, 0]
    /// lays one face level.
    Fillet { length: f64, width: f64 },
}

/// Which specimen, without its sizes: the name scenario and capture files use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SpecimenType {
    DiskCylinder,
    DiskPaper,
    Ball,
    ParallelBar,
    Scale,
    KnifeBlade,
    /// A flat face: in the simulator, the table's (the plane method's specimen).
    Plane,
    /// Two faces meeting at an outside angle along a straight line: a roof, a ridge, a knife's
    /// edge (the edge method's two-face estimator).
    Ridge,
    /// Two faces meeting at an inside angle: a V groove.
    VGroove,
    /// Two parallel faces at different heights joined by a riser: its top edge is the line.
    Step,
    /// Two faces at right angles meeting at an inside corner: a fillet joint (T or corner joint).
    Fillet,
}

impl SpecimenType {
    /// The specimens a scenario's `[specimen]` can place (the plane is the table's face).
    pub const ALL: [SpecimenType; 10] = [
        SpecimenType::DiskCylinder,
        SpecimenType::DiskPaper,
        SpecimenType::Ball,
        SpecimenType::ParallelBar,
        SpecimenType::Scale,
        SpecimenType::KnifeBlade,
        SpecimenType::Ridge,
        SpecimenType::VGroove,
        SpecimenType::Step,
        SpecimenType::Fillet,
    ];

    pub fn name(self) -> &'static str {
        match self {
            SpecimenType::DiskCylinder => "disk-cylinder",
            SpecimenType::DiskPaper => "disk-paper",
            SpecimenType::Ball => "ball",
            SpecimenType::ParallelBar => "parallel-bar",
            SpecimenType::Scale => "scale",
            SpecimenType::KnifeBlade => "knife-blade",
            SpecimenType::Plane => "plane",
            SpecimenType::Ridge => "ridge",
            SpecimenType::VGroove => "v-groove",
            SpecimenType::Step => "step",
            SpecimenType::Fillet => "fillet",
        }
    }

    /// The line targets read as two faces meeting at a corner (`features::two_faces`): true for
    /// a ridge (outside angle), false for a groove; None for the others.
    pub fn two_faces(self) -> Option<bool> {
        match self {
            SpecimenType::Ridge => Some(true),
            SpecimenType::VGroove | SpecimenType::Fillet => Some(false),
            _ => None,
        }
    }

    /// The disk and ball specimens (those with a radius).
    pub fn has_radius(self) -> bool {
        matches!(
            self,
            SpecimenType::DiskCylinder | SpecimenType::DiskPaper | SpecimenType::Ball
        )
    }
}

impl std::fmt::Display for SpecimenType {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A name that names no specimen.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "unknown specimen \"{name}\"; known: disk-cylinder, disk-paper, ball, parallel-bar, scale, knife-blade, ridge, v-groove"
)]
pub struct UnknownSpecimen {
    pub name: String,
}

impl std::str::FromStr for SpecimenType {
    type Err = UnknownSpecimen;
    fn from_str(s: &str) -> Result<SpecimenType, UnknownSpecimen> {
        SpecimenType::ALL
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| UnknownSpecimen { name: s.into() })
    }
}

impl SpecimenKind {
    /// Which specimen this is.
    pub fn specimen_type(&self) -> SpecimenType {
        match self {
            SpecimenKind::DiskOnCylinder { .. } => SpecimenType::DiskCylinder,
            SpecimenKind::DiskOnPaper { .. } => SpecimenType::DiskPaper,
            SpecimenKind::BallOnPost { .. } => SpecimenType::Ball,
            SpecimenKind::ParallelBar { .. } => SpecimenType::ParallelBar,
            SpecimenKind::Scale { .. } => SpecimenType::Scale,
            SpecimenKind::KnifeBlade { .. } => SpecimenType::KnifeBlade,
            SpecimenKind::Ridge { .. } => SpecimenType::Ridge,
            SpecimenKind::VGroove { .. } => SpecimenType::VGroove,
            SpecimenKind::Step { .. } => SpecimenType::Step,
            SpecimenKind::Fillet { .. } => SpecimenType::Fillet,
        }
    }

    /// The name scenario files and capture files use.
    pub fn name(&self) -> &'static str {
        self.specimen_type().name()
    }

    /// A disk on a cylinder or on paper.
    pub fn is_disk(&self) -> bool {
        matches!(
            self,
            SpecimenKind::DiskOnCylinder { .. } | SpecimenKind::DiskOnPaper { .. }
        )
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Specimen {
    pub kind: SpecimenKind,
    /// Surface reflectance (0..1) of the specimen body.
    pub reflectance: f64,
    /// Radius to which the straight edge of a parallel bar or scale is rounded (metres; 0 sharp).
    /// Modelled as a fillet of `FILLET_FACETS` tangent planes (within 0.2 % of the radius).
    pub edge_radius: f64,
}

/// Facets of a rounded edge.
pub const FILLET_FACETS: usize = 16;

impl Specimen {
    pub fn new(kind: SpecimenKind) -> Specimen {
        let reflectance = match kind {
            SpecimenKind::BallOnPost { .. } => 0.6,
            SpecimenKind::KnifeBlade { .. } => 0.7,
            _ => 0.8,
        };
        Specimen {
            kind,
            reflectance,
            edge_radius: 0.0,
        }
    }

    /// Short name used in scenario files and the CLI.
    pub fn name(&self) -> &'static str {
        self.kind.name()
    }

    /// Disk radius, for disk specimens.
    pub fn disk_radius(&self) -> Option<f64> {
        match self.kind {
            SpecimenKind::DiskOnCylinder { radius, .. }
            | SpecimenKind::DiskOnPaper { radius, .. } => Some(radius),
            _ => None,
        }
    }

    /// Ball radius, for the ball.
    pub fn ball_radius(&self) -> Option<f64> {
        match self.kind {
            SpecimenKind::BallOnPost { radius, .. } => Some(radius),
            _ => None,
        }
    }

    /// True for the straight-edge specimens.
    pub fn is_edge(&self) -> bool {
        matches!(
            self.kind,
            SpecimenKind::ParallelBar { .. }
                | SpecimenKind::Scale { .. }
                | SpecimenKind::KnifeBlade { .. }
                | SpecimenKind::Ridge { .. }
                | SpecimenKind::VGroove { .. }
                | SpecimenKind::Step { .. }
                | SpecimenKind::Fillet { .. }
        )
    }

    /// The analytic shapes, in the specimen frame.
    pub fn parts(&self) -> Vec<Part> {
        let uniform = Surface::Uniform {
            reflectance: self.reflectance,
            specular: false,
        };
        let at = |x: f64, y: f64, z: f64| {
            Isometry3::from_parts(Translation3::new(x, y, z), Default::default())
        };
        let rho = self.edge_radius.min(
            0.5 * match self.kind {
                SpecimenKind::Scale { thickness, .. } => thickness,
                _ => f64::INFINITY,
            },
        );
        let bar = |length: f64, width: f64, height: f64| {
            let h = Vector3::new(length / 2.0, width / 2.0, height / 2.0);
            let mut planes = ConvexPlanes::cuboid(h);
            if rho > 0.0 {
                // The edge (part frame y = w/2, z = h/2) rounded: planes tangent to the fillet
                // circle about (w/2 - rho, h/2 - rho), normals between +z and +y.
                let c = Vector3::new(0.0, h.y - rho, h.z - rho);
                for k in 0..FILLET_FACETS {
                    let a = (k as f64 + 0.5) / FILLET_FACETS as f64 * std::f64::consts::FRAC_PI_2;
                    let n = Vector3::new(0.0, a.sin(), a.cos());
                    planes.planes.push((n, n.dot(&c) + rho));
                }
            }
            Part {
                specimen_to_part: at(0.0, -width / 2.0, -height / 2.0),
                shape: PartShape::Planes(planes),
                surface: uniform,
                bound_radius: h.norm() * (1.0 + 1e-9),
            }
        };
        match self.kind {
            SpecimenKind::DiskOnCylinder { radius, height } => vec![Part {
                specimen_to_part: Isometry3::identity(),
                shape: PartShape::Cylinder(CylinderZ {
                    radius,
                    z_min: -height,
                    z_max: 0.0,
                }),
                surface: uniform,
                bound_radius: radius.hypot(height) * (1.0 + 1e-9),
            }],
            SpecimenKind::DiskOnPaper { radius, paper_half } => vec![Part {
                specimen_to_part: Isometry3::identity(),
                shape: PartShape::Sheet(Sheet { half: paper_half }),
                surface: Surface::DiskOnPaper {
                    radius,
                    disk: self.reflectance,
                    paper: 0.05,
                },
                bound_radius: paper_half * std::f64::consts::SQRT_2 * (1.0 + 1e-9),
            }],
            SpecimenKind::BallOnPost {
                radius,
                post_radius,
                post_height,
            } => vec![
                Part {
                    specimen_to_part: Isometry3::identity(),
                    shape: PartShape::Ball(Ball::new(radius)),
                    surface: Surface::Uniform {
                        reflectance: self.reflectance,
                        specular: true,
                    },
                    bound_radius: radius * (1.0 + 1e-9),
                },
                Part {
                    specimen_to_part: Isometry3::identity(),
                    shape: PartShape::Cylinder(CylinderZ {
                        radius: post_radius,
                        z_min: -radius - post_height,
                        z_max: -0.5 * radius,
                    }),
                    surface: uniform,
                    bound_radius: post_radius.hypot(radius + post_height) * (1.0 + 1e-9),
                },
            ],
            SpecimenKind::ParallelBar {
                length,
                width,
                height,
            } => vec![bar(length, width, height)],
            SpecimenKind::Scale {
                length,
                width,
                thickness,
            } => vec![bar(length, width, thickness)],
            SpecimenKind::KnifeBlade {
                length,
                width,
                thickness,
                bevel,
            } => knife_blade(length, width, thickness, bevel, uniform),
            SpecimenKind::Ridge {
                length,
                width,
                height,
            } => ridge(length, width, height, uniform),
            SpecimenKind::VGroove {
                length,
                width,
                height,
            } => v_groove(length, width, height, uniform),
            SpecimenKind::Step {
                length,
                width,
                height,
            } => step(length, width, height, uniform),
            SpecimenKind::Fillet { length, width } => fillet(length, width, uniform),
        }
    }

    /// Length of the straight edge, for edge specimens.
    pub fn edge_length(&self) -> Option<f64> {
        match self.kind {
            SpecimenKind::ParallelBar { length, .. }
            | SpecimenKind::Scale { length, .. }
            | SpecimenKind::KnifeBlade { length, .. }
            | SpecimenKind::Ridge { length, .. }
            | SpecimenKind::VGroove { length, .. }
            | SpecimenKind::Step { length, .. }
            | SpecimenKind::Fillet { length, .. } => Some(length),
            _ => None,
        }
    }

    /// The straight edge in the specimen frame: a point on it and its unit direction.
    pub fn edge_line(&self) -> Option<(Point3<f64>, Vector3<f64>)> {
        self.is_edge().then(|| (Point3::origin(), Vector3::x()))
    }
}

/// A convex part of `planes` in the specimen frame, contained in the sphere of `far`'s length
/// about its origin (`Part::bound_radius`).
fn planes_part(planes: Vec<(Vector3<f64>, f64)>, uniform: Surface, far: Vector3<f64>) -> Part {
    Part {
        specimen_to_part: Isometry3::identity(),
        shape: PartShape::Planes(ConvexPlanes { planes }),
        surface: uniform,
        bound_radius: far.norm() * (1.0 + 1e-9),
    }
}

/// `SpecimenKind::KnifeBlade`'s part.
fn knife_blade(length: f64, width: f64, thickness: f64, bevel: f64, uniform: Surface) -> Vec<Part> {
    // Edge line at y = z = 0; body y in [-width, 0], z in [-t/2, t/2]; bevel faces meet at
    // the edge.
    let t2 = thickness / 2.0;
    let top = Vector3::new(0.0, t2, bevel).normalize();
    let bottom = Vector3::new(0.0, t2, -bevel).normalize();
    let planes = vec![
        (Vector3::x(), length / 2.0),
        (-Vector3::x(), length / 2.0),
        (-Vector3::y(), width),
        (Vector3::z(), t2),
        (-Vector3::z(), t2),
        (top, 0.0),
        (bottom, 0.0),
    ];
    vec![planes_part(
        planes,
        uniform,
        Vector3::new(length / 2.0, width, t2),
    )]
}

/// `SpecimenKind::Ridge`'s part.
fn ridge(length: f64, width: f64, height: f64, uniform: Surface) -> Vec<Part> {
    // The faces through the ridge (y = z = 0) down to the base's edges at
    // y = +-width/2, z = -height.
    let w2 = width / 2.0;
    let planes = vec![
        (Vector3::x(), length / 2.0),
        (-Vector3::x(), length / 2.0),
        (-Vector3::z(), height),
        (Vector3::new(0.0, height, w2).normalize(), 0.0),
        (Vector3::new(0.0, -height, w2).normalize(), 0.0),
    ];
    vec![planes_part(
        planes,
        uniform,
        Vector3::new(length / 2.0, w2, height),
    )]
}

/// `SpecimenKind::VGroove`'s parts.
fn v_groove(length: f64, width: f64, height: f64, uniform: Surface) -> Vec<Part> {
    // Two convex halves of a block 3 x `width` wide (its bottom 10 mm below the
    // groove's), each with one face of the groove rising from the bottom line
    // (y = z = 0) to the block's flat top (z = height) at y = +-width/2, as two plates
    // with a groove between them.
    let (w2, base) = (1.5 * width, height + 0.01);
    let half = |side: f64| {
        let planes = vec![
            (Vector3::x(), length / 2.0),
            (-Vector3::x(), length / 2.0),
            (-Vector3::z(), 0.01),
            (Vector3::z(), height),
            (Vector3::new(0.0, side, 0.0), w2),
            (Vector3::new(0.0, -side, 0.0), 0.0),
            (
                Vector3::new(0.0, -side * height, width / 2.0).normalize(),
                0.0,
            ),
        ];
        planes_part(planes, uniform, Vector3::new(length / 2.0, w2, base))
    };
    vec![half(1.0), half(-1.0)]
}

/// `SpecimenKind::Step`'s parts.
fn step(length: f64, width: f64, height: f64, uniform: Surface) -> Vec<Part> {
    // The upper block and the lower plate, both 10 mm thick below their faces.
    let block = |y: (f64, f64), z: (f64, f64)| {
        let planes = vec![
            (Vector3::x(), length / 2.0),
            (-Vector3::x(), length / 2.0),
            (Vector3::y(), y.1),
            (-Vector3::y(), -y.0),
            (Vector3::z(), z.1),
            (-Vector3::z(), -z.0),
        ];
        let far = Vector3::new(length / 2.0, y.0.abs().max(y.1.abs()), z.0.abs());
        planes_part(planes, uniform, far)
    };
    let bottom = -height - 0.01;
    vec![
        block((-width, 0.0), (bottom, 0.0)),
        block((0.0, width), (bottom, -height)),
    ]
}

/// `SpecimenKind::Fillet`'s parts.
fn fillet(length: f64, width: f64, uniform: Surface) -> Vec<Part> {
    // Plate a: its face u_b = 0 for u_a in [0, width], 10 mm behind it; plate b the
    // same with a and b swapped (u_a, u_b: along the faces, at 45 deg to z).
    let (ua, ub) = (
        Vector3::new(0.0, 1.0, 1.0) / 2f64.sqrt(),
        Vector3::new(0.0, -1.0, 1.0) / 2f64.sqrt(),
    );
    let plate = |along: Vector3<f64>, normal: Vector3<f64>| {
        let planes = vec![
            (Vector3::x(), length / 2.0),
            (-Vector3::x(), length / 2.0),
            (along, width),
            (-along, 0.0),
            (normal, 0.0),
            (-normal, 0.01),
        ];
        planes_part(planes, uniform, Vector3::new(length / 2.0, width, 0.01))
    };
    vec![plate(ua, ub), plate(ub, ua)]
}
