//! The ball two-step method (Chen et al. 2018, Sec. IV-A and V-D): a rotation set at one flange
//! orientation fixes R_sensor, a translation set fixes T_sensor. Its `[ball]` scenario section,
//! plan, simulation, arc features and solve, with the arc-point refinement model.

use super::{Kind, Method, Plan, Sim};
use crate::calib::ball::{BallCapture, BallProblem, centre_from_arc};
use crate::calib::refine::Problem;
use crate::calib::refine::ball::BallModel;
use crate::captures::{CaptureError, CaptureProfile, Captures, Group, ProfileData, Role};
use crate::error::Error;
use crate::features::{self, SplitMerge};
use crate::math::rot_zyx;
use crate::metrics::{Metric, Metrics};
use crate::scene::{FormError, FormTolerance, Scene, SpecimenKind, SpecimenType};
use crate::schema::{Common, Scenario, ScenarioError, Source, Validator};
use crate::sensor::SensorModel;
use crate::sim::ball::{BallPlan, BallTarget, Pose};
use crate::sim::{Rig, flange_pose};
use nalgebra::{Isometry3, Point3, Vector3};

/// The ball two-step method.
pub struct Ball;

impl Method for Ball {
    fn kind(&self) -> Kind {
        Kind::Ball
    }

    fn validate(&self, sc: &Scenario, v: &Validator) -> Result<(), ScenarioError> {
        let b = v.section(sc.ball.as_ref(), Kind::Ball)?;
        let kind = match &b.specimen {
            Some(sp) => sp.kind_checked("ball.specimen", v)?,
            None => sc.specimen_kind(v)?,
        };
        if !matches!(kind, SpecimenKind::BallOnPost { .. }) {
            return Err(v.bad(
                "specimen.kind",
                format!("\"{}\"", sc.specimen.kind),
                "the ball method needs a ball (here or in [ball.specimen])",
            ));
        }
        if !super::check_free_poses(
            sc,
            Kind::Ball,
            b.poses.as_ref(),
            6,
            "ball.rotation_tcp_mm and the translation set",
            v,
        )? && b.rotation_tcp_mm.len() < 4
        {
            return Err(v.bad(
                "ball.rotation_tcp_mm",
                format!("{} positions", b.rotation_tcp_mm.len()),
                "R_sensor needs at least 4 captures at one orientation",
            ));
        }
        if b.poses.is_none()
            && (b.translation_tcp_mm.len() < 3
                || b.translation_tcp_mm.len() != b.translation_rpy_rad.len())
        {
            return Err(v.bad(
                "ball.translation_tcp_mm",
                format!(
                    "{} positions, {} orientations",
                    b.translation_tcp_mm.len(),
                    b.translation_rpy_rad.len()
                ),
                "T_sensor needs at least 3 captures, one orientation each",
            ));
        }
        v.non_negative("ball.sigma_mm", b.sigma_mm)?;
        if !(b.x_step_mm >= 1e-3) || b.arcs == 0 || b.arcs > 10_000 {
            return Err(v.bad(
                "ball.x_step_mm",
                b.x_step_mm,
                "x_step_mm must be at least 0.001 mm and arcs from 1 to 10000",
            ));
        }
        Ok(())
    }

    fn plan(
        &self,
        sc: &Scenario,
        common: &Common,
        v: &Validator,
    ) -> Result<Box<dyn Plan>, ScenarioError> {
        let b = v.section(sc.ball.as_ref(), Kind::Ball)?;
        let (spec, pose, scene) = common.own(b.specimen.as_ref(), "ball.specimen", v)?;
        let radius = spec.ball_radius().ok_or_else(|| {
            v.bad(
                "ball.specimen.kind",
                spec.name(),
                "the ball method needs a ball specimen",
            )
        })?;
        // An analytic arc holds one point per x_step across the ball: bounded before sampling.
        let samples = 2.0 * radius / (b.x_step_mm * 1e-3);
        if b.source != Source::Raycast && !(samples <= 1e6) {
            return Err(v.bad(
                "ball.x_step_mm",
                b.x_step_mm,
                format!(
                    "{samples:.3e} points per arc across a ball of radius {} mm (at most 1e6); \
                     take a coarser step",
                    radius * 1e3
                ),
            ));
        }
        let target = BallTarget {
            centre: pose * Point3::origin(),
            radius,
        };
        let rr = b.rotation_rpy_rad;
        let plan = BallPlan {
            rotation_set: b
                .rotation_tcp_mm
                .iter()
                .map(|t| Pose {
                    r_tcp: rot_zyx(rr[0], rr[1], rr[2]),
                    t_tcp: Vector3::from(*t) * 1e-3,
                })
                .collect(),
            translation_set: b
                .translation_tcp_mm
                .iter()
                .zip(&b.translation_rpy_rad)
                .map(|(t, r)| Pose {
                    r_tcp: rot_zyx(r[0], r[1], r[2]),
                    t_tcp: Vector3::from(*t) * 1e-3,
                })
                .collect(),
            arcs: b.arcs,
        };
        crate::sim::ball::check(&common.rig, &target, &plan)
            .map_err(|e| v.bad("ball.rotation_tcp_mm", "..", e.to_string()))?;
        let free = match &b.poses {
            Some(ps) => {
                let source = ps.source("ball.poses", 6, v)?;
                let aim = crate::sim::poses::Aim {
                    point: target.centre,
                    normal: Vector3::z(),
                    off_plane: 0.7 * radius,
                    crossing: None,
                    sense: None,
                };
                let mut g = crate::rng::stream(sc.seed, &[crate::rng::tag::PLAN, 2]);
                crate::sim::poses::poses(&common.rig, &aim, &source, &mut g)
                    .map_err(|e| v.bad("ball.poses", "..", e.to_string()))?
            }
            None => Vec::new(),
        };
        let section = b.specimen.as_ref().unwrap_or(&sc.specimen);
        Ok(Box::new(BallPlanned {
            target,
            plan,
            scene,
            raycast: b.source == Source::Raycast,
            sigma: b.sigma_mm * 1e-3,
            x_step: b.x_step_mm * 1e-3,
            radius_tolerance: section.radius_tolerance_mm.unwrap_or(0.0) * 1e-3,
            form: section.form(),
            free,
            passing: match &b.poses {
                Some(ps) => ps.passing("ball.poses", v)?,
                None => None,
            },
        }))
    }

    fn calibrate(&self, c: &Captures, sensor: &SensorModel) -> Result<super::Calibration, Error> {
        calibrate(c, sensor)
    }

    fn closed_form_recast(
        &self,
        c: &Captures,
        sensor: &SensorModel,
        cal: &super::Calibration,
        twists: &dyn Fn(&Isometry3<f64>) -> Option<Vec<nalgebra::Vector6<f64>>>,
    ) -> Option<Vec<nalgebra::Vector6<f64>>> {
        recast(c, sensor, cal, twists)
    }

    fn calibrate_any_pose(
        &self,
        c: &Captures,
        sensor: &SensorModel,
        _censored_iterations: usize,
    ) -> Result<(super::Calibration, crate::calib::refine::Refined), Error> {
        any_pose(c, sensor)
    }

    fn profile_features(
        &self,
        c: &Captures,
        sensor: &SensorModel,
    ) -> Vec<Option<super::ProfileFeature>> {
        let cfg = SplitMerge::for_sensor(sensor);
        super::each_profile(c, |g, p| {
            let circle = circle_of(g, p, c.specimen_radius?, &cfg).ok()?;
            let surface = match &p.data {
                ProfileData::Raw(prof) => features::arc_points(prof, &circle),
                ProfileData::Arc(a) => a.to_vec(),
                // A circle given as such: the laser plane's whole section of the sphere.
                _ => (0..72)
                    .map(|k| {
                        let t = k as f64 * std::f64::consts::TAU / 72.0;
                        circle.centre + circle.radius * nalgebra::Vector2::new(t.cos(), t.sin())
                    })
                    .collect(),
            };
            Some(super::ProfileFeature {
                features: vec![circle.centre],
                surface,
            })
        })
    }

    fn fit_mapped(
        &self,
        features: &[Vec<Point3<f64>>],
        surface: &[Vec<Point3<f64>>],
    ) -> Option<super::view::Fitted> {
        super::view::fit_ball(features, surface)
    }

    fn needs_radius(&self) -> bool {
        true
    }

    fn uses_group_signs(&self) -> bool {
        true
    }
}

/// The ball method's plan on one rig.
#[derive(Debug)]
pub struct BallPlanned {
    pub target: BallTarget,
    pub plan: BallPlan,
    pub scene: Scene,
    pub raycast: bool,
    /// z noise on arc points and the arc sampling step (analytic), metres.
    pub sigma: f64,
    pub x_step: f64,
    /// Standard deviation of the true radius (metres).
    pub radius_tolerance: f64,
    pub form: FormTolerance,
    /// Free poses (`[ball.poses]`) instead of the protocol: flange poses, one group each.
    pub free: Vec<Isometry3<f64>>,
    /// Scanning on the move through the free poses (`[ball.poses] scan_speed_mm_s`).
    pub passing: Option<crate::sim::poses::Passing>,
}

impl Plan for BallPlanned {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn scene(&self) -> &Scene {
        &self.scene
    }

    fn first_flange_pose(&self) -> Isometry3<f64> {
        if let Some(f) = self.free.first() {
            return *f;
        }
        let p = &self.plan.rotation_set[0];
        flange_pose(&p.r_tcp, &p.t_tcp)
    }

    fn true_centre(&self) -> Option<Point3<f64>> {
        Some(self.target.centre)
    }

    fn simulate(&self, rig: &Rig, sim: &mut Sim) -> Result<Captures, Error> {
        let target = BallTarget {
            radius: self.target.radius + sim.radius_z * self.radius_tolerance,
            ..self.target
        };
        let (spec, frame) = &self.scene.specimens[0];
        let form = FormError::draw(spec, &self.form, sim.specimen_rng);
        let scene = crate::scene::with_form(
            crate::scene::with_radius(&self.scene, target.radius, self.radius_tolerance),
            form,
        );
        let noisy = !rig.sensor.noise.is_off();
        let Sim { rng, mover, .. } = sim;
        let mut actual = |f: &Isometry3<f64>| mover.actual(&rig.robot, f);
        // The paper's protocol (one rotation group, translation groups), or free poses (one
        // group each, for ball-any-pose).
        let free: Vec<(Role, Pose, usize)> = self
            .free
            .iter()
            .map(|f| {
                let p = Pose {
                    r_tcp: f.rotation.to_rotation_matrix(),
                    t_tcp: f.translation.vector,
                };
                (Role::Pose, p, 1)
            })
            .collect();
        let poses: Vec<(Role, Pose, usize)> = if free.is_empty() {
            let rotation = self
                .plan
                .rotation_set
                .iter()
                .map(|p| (Role::Rotation, *p, 1));
            let translation = self
                .plan
                .translation_set
                .iter()
                .map(|p| (Role::Translation, *p, self.plan.arcs.max(1)));
            rotation.chain(translation).collect()
        } else {
            free
        };
        let mut groups = if self.free.is_empty() {
            vec![Group {
                id: 0,
                role: Role::Rotation,
                sign: 0.0,
            }]
        } else {
            Vec::new()
        };
        let mut profiles = Vec::new();
        let mut next_id = groups.len();
        for (role, p, m) in poses {
            let f = flange_pose(&p.r_tcp, &p.t_tcp);
            let sign = crate::sim::ball::sign(&rig.base_to_sensor(&f), &target);
            let id = if role == Role::Rotation {
                groups[0].sign = sign;
                0
            } else {
                groups.push(Group {
                    id: next_id,
                    role,
                    sign,
                });
                next_id += 1;
                next_id - 1
            };
            for _ in 0..m {
                let pose = rig.base_to_sensor(&actual(&f));
                let data = if self.raycast {
                    ProfileData::Raw(
                        rig.sensor
                            .profile(&scene, &pose, noisy.then_some(&mut **rng)),
                    )
                } else {
                    ProfileData::Arc(crate::sim::ball::analytic_arc_formed(
                        rig,
                        &target,
                        Some((frame, &form)),
                        &pose,
                        self.x_step,
                        self.sigma,
                        0.9,
                        rng,
                    ))
                };
                profiles.push(CaptureProfile {
                    group: id,
                    base_to_flange: f,
                    data,
                });
            }
        }
        let mut caps = Captures {
            orientation_tolerance_deg: crate::calib::ORIENTATION_TOLERANCE_DEG,
            feature_sigma: (!self.raycast).then_some(self.sigma),
            judging: crate::captures::Judging {
                radius_tolerance: self.radius_tolerance,
                ..Default::default()
            },
            method: Kind::Ball,
            sensor: rig.sensor.name.clone(),
            specimen_kind: SpecimenType::Ball,
            specimen_radius: Some(self.target.radius),
            edge_sense: None,
            truth: Some(rig.flange_to_sensor),
            groups,
            profiles,
            timing: None,
            kinematic: None,
        };
        if let Some(m) = self.passing.as_ref().filter(|_| !self.free.is_empty()) {
            m.apply(&mut caps);
        }
        Ok(caps)
    }
}

/// The circle of one capture's arc: given, fitted to its points, or extracted from the profile.
fn circle_of(
    g: &Group,
    p: &CaptureProfile,
    radius: f64,
    cfg: &SplitMerge,
) -> Result<features::Circle, CaptureError> {
    let circle = match &p.data {
        ProfileData::Circle(ci) => Ok(*ci),
        ProfileData::Arc(a) => {
            features::fit_circle(a).ok_or(CaptureError::NoCircle { points: a.len() })
        }
        ProfileData::Raw(prof) => features::ball_arc(prof, radius, cfg).map_err(CaptureError::from),
        _ => {
            return Err(CaptureError::WrongData {
                group: g.id,
                method: Kind::Ball,
                need: "a circle or raw points",
            });
        }
    };
    circle.map_err(|e| CaptureError::InGroup {
        group: g.id,
        source: Box::new(e),
    })
}

/// The closed form's problem from the captures: each capture's ball centre from its arc's
/// circle, with the flange pose it was seen from (the rotation set's first, then the
/// translation set's, in the problem's order), and the arc-point refinement model where every
/// capture kept its arc points.
struct Built {
    problem: BallProblem,
    poses: Vec<Isometry3<f64>>,
    arc_points: Option<BallModel>,
}

/// Arc circles and their centres per group (the labels inferred where the file gives none).
fn build(c: &Captures, sensor: &SensorModel) -> Result<Built, Error> {
    let inferred;
    let c = if c.groups.iter().all(|g| g.sign == 0.0)
        && c.groups.iter().all(|g| g.role != Role::Rotation)
    {
        inferred = inferred_labels(c, sensor)?;
        &inferred
    } else {
        c
    };
    let cfg = SplitMerge::for_sensor(sensor);
    let radius = c
        .specimen_radius
        .ok_or(CaptureError::MissingRadius { method: Kind::Ball })?;
    let (mut rotation_set, mut translation_set) = (Vec::new(), Vec::new());
    let (mut rotation_poses, mut translation_poses) = (Vec::new(), Vec::new());
    let mut arc_points = Some(BallModel::new(radius));
    for g in &c.groups {
        let mut centres = Vec::new();
        for p in c.group_profiles(g.id) {
            let circle = circle_of(g, p, radius, &cfg)?;
            match (&p.data, &mut arc_points) {
                (ProfileData::Arc(a), Some(all)) => all.add_shared(&p.base_to_flange, a.clone()),
                (ProfileData::Raw(prof), Some(all)) => {
                    all.add(&p.base_to_flange, features::arc_points(prof, &circle))
                }
                _ => arc_points = None,
            }
            if g.sign != 1.0 && g.sign != -1.0 {
                return Err(CaptureError::MissingSign {
                    group: g.id,
                    method: Kind::Ball,
                }
                .into());
            }
            centres.push((p, centre_from_arc(&circle, radius, g.sign)));
        }
        let capture = |f: &Isometry3<f64>, q: Vector3<f64>| BallCapture {
            r_tcp: f.rotation.to_rotation_matrix(),
            t_tcp: f.translation.vector,
            q_in_sensor: q,
        };
        match g.role {
            Role::Rotation => {
                for (p, q) in &centres {
                    rotation_set.push(capture(&p.base_to_flange, *q));
                    rotation_poses.push(p.base_to_flange);
                }
            }
            Role::Translation => {
                let Some((p, _)) = centres.first() else {
                    continue;
                };
                let q =
                    centres.iter().map(|(_, q)| *q).sum::<Vector3<f64>>() / centres.len() as f64;
                translation_set.push(capture(&p.base_to_flange, q));
                translation_poses.push(p.base_to_flange);
            }
            _ => return Err(CaptureError::WrongRole { group: g.id }.into()),
        }
    }
    rotation_poses.extend(translation_poses);
    Ok(Built {
        problem: BallProblem {
            orientation_tolerance_deg: c.orientation_tolerance_deg,
            rotation_set,
            translation_set,
        },
        poses: rotation_poses,
        arc_points,
    })
}

/// Arc circles and their centres per group, the two-step solve, and the refinement problem (when
/// every capture kept its arc points).
fn calibrate(c: &Captures, sensor: &SensorModel) -> Result<super::Calibration, Error> {
    let Built {
        problem,
        arc_points,
        ..
    } = build(c, sensor)?;
    let sol = crate::calib::ball::solve(&problem)?;
    Ok(super::Calibration {
        full_profile: None,
        refinable: arc_points.map(|model| {
            std::sync::Arc::new(Problem {
                model,
                specimen: sol.centre_in_base,
            }) as std::sync::Arc<dyn crate::calib::refine::Refinable>
        }),
        flange_to_sensor: sol.flange_to_sensor,
        centre_in_base: Some(sol.centre_in_base),
        figures: Metrics::default().with(Metric::Accuracy, Some(sol.spread * 1e3)),
        status: sol.status,
        missed: 0,
        groups: Vec::new(),
    })
}

/// The closed form's response to errors that move each capture's actual flange pose, its arcs
/// re-cast from there (`Method::closed_form_recast`). A turn or shift of the actual flange moves
/// the ball's centre in the sensor frame (q^i) as the rigid motion says, with the ball where
/// the closed form put it; the arc's circle is the plane's section of the sphere at that centre,
/// so moving q^i is the re-cast to first order (the circle's noise is the same draw). The
/// closed form is solved again from the moved centres (`super::recast_responses`).
fn recast(
    c: &Captures,
    sensor: &SensorModel,
    cal: &super::Calibration,
    twists: &dyn Fn(&Isometry3<f64>) -> Option<Vec<nalgebra::Vector6<f64>>>,
) -> Option<Vec<nalgebra::Vector6<f64>>> {
    let Built { problem, poses, .. } = build(c, sensor).ok()?;
    let centre = Point3::from(cal.centre_in_base?);
    let at = crate::calib::ball::solve(&problem).ok()?.flange_to_sensor;
    let per_pose: Vec<Vec<nalgebra::Vector6<f64>>> =
        poses.iter().map(twists).collect::<Option<_>>()?;
    let errors = per_pose.first()?.len();
    if per_pose.iter().any(|t| t.len() != errors) {
        return None;
    }
    super::recast_responses(errors, |e, h| {
        let mut moved = problem.clone();
        let captures = moved
            .rotation_set
            .iter_mut()
            .chain(moved.translation_set.iter_mut());
        for ((cap, f), t) in captures.zip(&poses).zip(&per_pose) {
            // The ball's centre as this pose saw it (the closed form's centre and result).
            let q = (at.inverse() * (f.inverse() * centre)).coords;
            cap.q_in_sensor += crate::calib::recast::point_move(&at, &q, &t[e]) * h;
        }
        crate::calib::ball::solve(&moved)
            .ok()
            .map(|s| s.flange_to_sensor)
    })
}

/// The any-pose estimator (`calib::ball_any`): every profile's arc, whatever its group's role; the
/// sides of the laser plane inferred. A profile without an arc is counted in its group's report
/// and left out; the hand-given signs, where the file has them, are not used.
/// The two-step protocol's labels for captures that give none (free poses, an import): the
/// profiles at the orientation most of them share (four or more, within the orientation
/// tolerance) are the rotation set, the rest translation poses, each its own group; each
/// profile's side of the laser plane (s_i) is where `ball-any-pose`'s centre lies from it, a
/// label the data determine. Without four profiles at one orientation the closed form cannot run
/// and says so.
fn inferred_labels(c: &Captures, sensor: &SensorModel) -> Result<Captures, Error> {
    let flanges: Vec<&nalgebra::Isometry3<f64>> =
        c.profiles.iter().map(|p| &p.base_to_flange).collect();
    let tol = c.orientation_tolerance_deg.to_radians();
    let shared = |i: usize| {
        flanges
            .iter()
            .filter(|f| f.rotation.angle_to(&flanges[i].rotation) <= tol)
            .count()
    };
    let (most, count) = (0..flanges.len())
        .map(|i| (i, shared(i)))
        .max_by_key(|&(i, n)| (n, std::cmp::Reverse(i)))
        .unwrap_or((0, 0));
    if count < 4 {
        return Err(CaptureError::MissingSign {
            group: c.groups.first().map_or(0, |g| g.id),
            method: Kind::Ball,
        }
        .into());
    }
    let (any, _) = any_pose(c, sensor)?;
    let centre =
        any.centre_in_base
            .map(nalgebra::Point3::from)
            .ok_or(CaptureError::MissingSign {
                group: 0,
                method: Kind::Ball,
            })?;
    let rotation = flanges[most].rotation;
    let mut out = c.clone();
    out.groups = Vec::with_capacity(c.profiles.len());
    for (i, p) in out.profiles.iter_mut().enumerate() {
        let in_sensor = (p.base_to_flange * any.flange_to_sensor).inverse_transform_point(&centre);
        let role = if p.base_to_flange.rotation.angle_to(&rotation) <= tol {
            Role::Rotation
        } else {
            Role::Translation
        };
        out.groups.push(Group {
            id: i,
            role,
            sign: if in_sensor.y < 0.0 { -1.0 } else { 1.0 },
        });
        p.group = i;
    }
    Ok(out)
}

fn any_pose(
    c: &Captures,
    sensor: &SensorModel,
) -> Result<(super::Calibration, crate::calib::refine::Refined), Error> {
    let cfg = SplitMerge::for_sensor(sensor);
    let radius = c
        .specimen_radius
        .ok_or(CaptureError::MissingRadius { method: Kind::Ball })?;
    let mut views = Vec::new();
    let mut reports = Vec::new();
    for g in &c.groups {
        let mut report = super::GroupReport::new(g.id);
        for p in c.group_profiles(g.id) {
            let view = circle_of(g, p, radius, &cfg).and_then(|circle| {
                let points = match &p.data {
                    ProfileData::Arc(a) => a.clone(),
                    ProfileData::Raw(prof) => features::arc_points(prof, &circle).into(),
                    _ => {
                        return Err(CaptureError::NoRawFeatures { method: Kind::Ball });
                    }
                };
                Ok(crate::calib::ball_any::ArcView {
                    base_to_flange: p.base_to_flange,
                    circle_centre: circle.centre,
                    circle_radius: circle.radius,
                    points,
                })
            });
            if matches!(view, Err(CaptureError::NoRawFeatures { .. })) {
                return Err(CaptureError::NoRawFeatures { method: Kind::Ball }.into());
            }
            report.count(&view);
            if let Ok(v) = view {
                views.push(v);
            }
        }
        reports.push(report);
    }
    let sol = crate::calib::ball_any::solve(&views, radius)?;
    let missed = reports.iter().map(|r| r.profiles - r.used).sum();
    let cal = super::Calibration {
        flange_to_sensor: sol.flange_to_sensor,
        centre_in_base: Some(sol.centre_in_base.coords),
        figures: Metrics::default(),
        status: sol.refined.status,
        missed,
        groups: reports,
        refinable: Some(std::sync::Arc::new(sol.problem)),
        full_profile: None,
    };
    Ok((cal, sol.refined))
}
