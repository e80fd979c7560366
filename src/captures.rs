//! Captures: what a real robot and sensor give (flange poses, profiles or the features extracted
//! from them, grouped by orientation or scan), and the one path from captures to a calibration.
//! Simulated trials and capture files from real rigs both go through `calibrate`.

use crate::calib::ball::{BallCapture, BallProblem, centre_from_arc};
use crate::calib::disk::{DiskChord, DiskProblem, DiskScan};
use crate::calib::edge::{EdgeCapture, EdgeProblem};
use crate::calib::{Status, refine};
use crate::features::{self, Circle, EdgeSense, SplitMerge};
use crate::sensor::{Profile, SensorModel};
use nalgebra::{Isometry3, Vector2, Vector3};

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
    Arc(Vec<Vector2<f64>>),
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
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    Scan,
    Rotation,
    Translation,
    RotationGroup,
}

impl Role {
    pub fn name(&self) -> &'static str {
        match self {
            Role::Scan => "scan",
            Role::Rotation => "rotation",
            Role::Translation => "translation",
            Role::RotationGroup => "rotation-group",
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
    pub method: String,
    /// Sensor preset: its column geometry places feature ends between columns.
    pub sensor: String,
    /// Specimen kind and its known size (metres): the disk or ball radius.
    pub specimen_kind: String,
    pub specimen_radius: Option<f64>,
    pub edge_sense: Option<EdgeSense>,
    pub truth: Option<Isometry3<f64>>,
    pub groups: Vec<Group>,
    pub profiles: Vec<CaptureProfile>,
}

/// A calibration from captures, with the method's own figures.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    pub flange_to_sensor: Isometry3<f64>,
    pub centre_in_base: Option<Vector3<f64>>,
    pub accuracy: Option<f64>,
    pub edge_angle_dev: Option<f64>,
    pub edge_distance: Option<f64>,
    pub status: Status,
    /// Profiles in which the feature was not found.
    pub missed: usize,
    /// The raw features with their flange poses and the closed-form specimen pose: what the joint
    /// refinement starts from (None when the captures hold only reduced features, e.g. circles).
    pub features: Option<(refine::Data, refine::SpecimenEstimate)>,
}

/// Unit normal of the plane through the chord ends, seen through `flange_to_sensor`.
fn plane_normal(
    ends: &[(Isometry3<f64>, Vector2<f64>)],
    flange_to_sensor: &Isometry3<f64>,
) -> Vector3<f64> {
    let pts: Vec<Vector3<f64>> = ends
        .iter()
        .map(|(f, p)| (f * flange_to_sensor * nalgebra::Point3::new(p.x, 0.0, p.y)).coords)
        .collect();
    let mean = pts.iter().sum::<Vector3<f64>>() / pts.len().max(1) as f64;
    let cov = pts
        .iter()
        .map(|p| (p - mean) * (p - mean).transpose())
        .sum::<nalgebra::Matrix3<f64>>();
    let eig = nalgebra::SymmetricEigen::new(cov);
    let k = eig.eigenvalues.imin();
    let n: Vector3<f64> = eig.eigenvectors.column(k).into_owned();
    if n.z < 0.0 { -n } else { n }
}

/// Refine a calibration jointly over its raw features (see `calib::refine`).
pub fn refine(cal: &Calibration, opts: &refine::Options) -> Result<refine::Refined, String> {
    let (data, specimen) = cal.features.as_ref().ok_or(
        "the joint refinement needs the raw features (chord ends, arc points or edge points); \
         these captures hold reduced ones (ball circles): record arc_mm or points_mm",
    )?;
    refine::refine(data, &cal.flange_to_sensor, specimen, opts).map_err(|e| e.to_string())
}

fn group_profiles(c: &Captures, id: usize) -> Vec<&CaptureProfile> {
    c.profiles.iter().filter(|p| p.group == id).collect()
}

/// Calibrate with the captures' method, extracting features from raw profiles with `sensor`.
pub fn calibrate(c: &Captures, sensor: &SensorModel) -> Result<Calibration, String> {
    let cfg = SplitMerge::for_sensor(sensor);
    let mut missed = 0;
    match c.method.as_str() {
        "disk" => {
            let radius = c
                .specimen_radius
                .ok_or("the disk method needs the disk radius")?;
            let mut scans = Vec::new();
            let mut ends = Vec::new();
            for g in &c.groups {
                let ps = group_profiles(c, g.id);
                let (Some(first), Some(last)) = (ps.first(), ps.last()) else {
                    continue;
                };
                let (t0, t1) = (
                    first.base_to_flange.translation.vector,
                    last.base_to_flange.translation.vector,
                );
                let span = t1 - t0;
                let mut chords = Vec::new();
                for p in &ps {
                    let flange = p.base_to_flange;
                    let u = if span.norm_squared() > 0.0 {
                        (p.base_to_flange.translation.vector - t0).dot(&span) / span.norm_squared()
                    } else {
                        0.0
                    };
                    let chord = match &p.data {
                        ProfileData::Chord { a, b } => Ok(features::Chord { a: *a, b: *b }),
                        ProfileData::Raw(prof) => {
                            if c.specimen_kind == "disk-paper" {
                                features::disk_chord_intensity(prof, sensor, cfg.min_points)
                            } else {
                                features::disk_chord_step(prof, sensor, radius, &cfg)
                            }
                        }
                        _ => {
                            return Err(format!(
                                "group {}: a disk capture needs a chord or raw points",
                                g.id
                            ));
                        }
                    };
                    match chord {
                        Ok(ch) => {
                            ends.push((flange, ch.a));
                            ends.push((flange, ch.b));
                            chords.push(DiskChord {
                                u,
                                a: ch.a,
                                b: ch.b,
                            })
                        }
                        Err(_) => missed += 1,
                    }
                }
                scans.push(DiskScan {
                    r_tcp: first.base_to_flange.rotation.to_rotation_matrix(),
                    t_start: t0,
                    t_end: t1,
                    s: g.sign,
                    chords,
                });
            }
            let mut problem = DiskProblem::new(radius, scans);
            problem.min_scan_angle = 0.5f64.to_radians();
            let sol = crate::calib::disk::solve(&problem).map_err(|e| e.to_string())?;
            let normal = plane_normal(&ends, &sol.flange_to_sensor);
            Ok(Calibration {
                features: Some((
                    refine::Data::Disk { radius, ends },
                    refine::SpecimenEstimate::Disk {
                        centre: sol.centre_in_base.into(),
                        normal,
                    },
                )),
                flange_to_sensor: sol.flange_to_sensor,
                centre_in_base: Some(sol.centre_in_base),
                accuracy: Some(sol.accuracy),
                edge_angle_dev: None,
                edge_distance: None,
                status: sol.status,
                missed,
            })
        }
        "ball" => {
            let radius = c
                .specimen_radius
                .ok_or("the ball method needs the ball radius")?;
            let (mut rotation_set, mut translation_set) = (Vec::new(), Vec::new());
            let mut arc_points = Some(Vec::new());
            for g in &c.groups {
                let ps = group_profiles(c, g.id);
                let mut centres = Vec::new();
                for p in &ps {
                    let circle = match &p.data {
                        ProfileData::Circle(ci) => Ok(*ci),
                        ProfileData::Arc(a) => features::fit_circle(a)
                            .ok_or_else(|| format!("an arc of {} points has no circle", a.len())),
                        ProfileData::Raw(prof) => {
                            features::ball_arc(prof, radius, &cfg).map_err(|e| e.to_string())
                        }
                        _ => {
                            return Err(format!(
                                "group {}: a ball capture needs a circle or raw points",
                                g.id
                            ));
                        }
                    };
                    match (&circle, &p.data, &mut arc_points) {
                        (Ok(_), ProfileData::Arc(a), Some(all)) => {
                            all.extend(a.iter().map(|q| (p.base_to_flange, *q)))
                        }
                        (Ok(ci), ProfileData::Raw(prof), Some(all)) => all.extend(
                            features::arc_points(prof, ci)
                                .into_iter()
                                .map(|q| (p.base_to_flange, q)),
                        ),
                        _ => arc_points = None,
                    }
                    match circle {
                        Ok(ci) => centres.push((p, centre_from_arc(&ci, radius, g.sign))),
                        Err(e) => return Err(format!("group {}: {e}", g.id)),
                    }
                }
                match g.role {
                    Role::Rotation => {
                        rotation_set.extend(centres.iter().map(|(p, q)| BallCapture {
                            r_tcp: p.base_to_flange.rotation.to_rotation_matrix(),
                            t_tcp: p.base_to_flange.translation.vector,
                            q_in_sensor: *q,
                        }))
                    }
                    Role::Translation => {
                        let Some((p, _)) = centres.first() else {
                            continue;
                        };
                        let q = centres.iter().map(|(_, q)| *q).sum::<Vector3<f64>>()
                            / centres.len() as f64;
                        translation_set.push(BallCapture {
                            r_tcp: p.base_to_flange.rotation.to_rotation_matrix(),
                            t_tcp: p.base_to_flange.translation.vector,
                            q_in_sensor: q,
                        });
                    }
                    _ => {
                        return Err(format!(
                            "group {}: a ball group is a rotation or a translation group",
                            g.id
                        ));
                    }
                }
            }
            let sol = crate::calib::ball::solve(&BallProblem {
                rotation_set,
                translation_set,
            })
            .map_err(|e| e.to_string())?;
            Ok(Calibration {
                features: arc_points.map(|points| {
                    (
                        refine::Data::Ball { radius, points },
                        refine::SpecimenEstimate::Ball {
                            centre: sol.centre_in_base.into(),
                        },
                    )
                }),
                flange_to_sensor: sol.flange_to_sensor,
                centre_in_base: Some(sol.centre_in_base),
                accuracy: Some(sol.spread),
                edge_angle_dev: None,
                edge_distance: None,
                status: sol.status,
                missed,
            })
        }
        "edge" => {
            let sense = c.edge_sense.unwrap_or(EdgeSense::Falling);
            let tuned = SplitMerge::for_sensor(sensor);
            let exact = sensor.noise.is_off() && sensor.z_quantum.is_none();
            // Edges are small features: a fine tolerance for an exact sensor, else the noise's.
            let ecfg = SplitMerge {
                split_tol: if exact { 0.1e-3 } else { tuned.split_tol },
                jump: tuned.jump.max(0.5e-3),
                min_points: 4,
            };
            let mut groups = Vec::new();
            let mut points = Vec::new();
            for g in &c.groups {
                let mut caps = Vec::new();
                for p in group_profiles(c, g.id) {
                    let point = match &p.data {
                        ProfileData::EdgePoint(q) => Ok(*q),
                        ProfileData::Raw(prof) => features::edge_point(prof, sensor, sense, &ecfg)
                            .map_err(|e| e.to_string()),
                        _ => {
                            return Err(format!(
                                "group {}: an edge capture needs an edge point or raw points",
                                g.id
                            ));
                        }
                    };
                    match point {
                        Ok(q) => {
                            points.push((p.base_to_flange, q));
                            caps.push(EdgeCapture {
                                r_tcp: p.base_to_flange.rotation.to_rotation_matrix(),
                                t_tcp: p.base_to_flange.translation.vector,
                                p_in_sensor: q,
                            })
                        }
                        Err(_) => missed += 1,
                    }
                }
                groups.push(caps);
            }
            let sol =
                crate::calib::edge::solve(&EdgeProblem { groups }).map_err(|e| e.to_string())?;
            let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
            Ok(Calibration {
                features: Some((
                    refine::Data::Edge { points },
                    refine::SpecimenEstimate::Edge {
                        point: sol.edge_point.into(),
                        dir: sol.edge_direction,
                    },
                )),
                flange_to_sensor: sol.flange_to_sensor,
                centre_in_base: None,
                accuracy: None,
                edge_angle_dev: Some(mean(&sol.group_angle_dev)),
                edge_distance: Some(mean(&sol.point_distances)),
                status: sol.status,
                missed,
            })
        }
        m => Err(format!("unknown method '{m}': use disk, ball or edge")),
    }
}
