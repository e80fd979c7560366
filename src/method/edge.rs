//! The straight-edge method (Xu et al.): rotation groups of translations along an arc, every
//! profile crossing the specimen's edge. Its `[edge]` scenario section, plan, simulation, edge-point
//! features and solve (Eqs. 9-24), the Table 3 ball check, and the edge-point refinement model.

use super::{Kind, Method, Plan, Sim};
use crate::calib::bar::BarView;
use crate::calib::edge::{EdgeCapture, EdgeProblem};
use crate::calib::refine::Problem;
use crate::calib::refine::Refined;
use crate::calib::refine::edge::{EdgeLine, EdgeModel};
use crate::captures::{CaptureError, Captures, Group, ProfileData, Role};
use crate::error::Error;
use crate::features::{self, EdgeSense, SplitMerge};
use crate::metrics::{Metric, Metrics};
use crate::rng::{self, tag};
use crate::scene::SpecimenType;
use crate::scene::{FormError, FormTolerance, Scene};
use crate::schema::{Common, Scenario, ScenarioError, Source, Validator};
use crate::sensor::SensorModel;
use crate::sim::ball::BallTarget;
use crate::sim::edge::{EdgeGroupPlan, EdgePlanSpec, EdgeTarget};
use crate::sim::poses::Aim;
use crate::sim::{Rig, flange_pose};
use nalgebra::{Isometry3, Point3, Vector2, Vector3};

/// The straight-edge method.
pub struct Edge;

impl Method for Edge {
    fn kind(&self) -> Kind {
        Kind::Edge
    }

    fn validate(&self, sc: &Scenario, v: &Validator) -> Result<(), ScenarioError> {
        let e = v.section(sc.edge.as_ref(), Kind::Edge)?;
        if let Some(sp) = &e.specimen {
            sp.kind_checked("edge.specimen", v)?;
        }
        super::check_any_pose_source(sc, Kind::Edge, e.source, v)?;
        if super::check_free_poses(
            sc,
            Kind::Edge,
            e.poses.as_ref(),
            crate::calib::plane::MIN_VIEWS,
            "edge.rotations, edge.translations and the arc",
            v,
        )? {
            return Ok(());
        }
        v.at_least(
            "edge.rotations",
            e.rotations,
            2,
            "at least 2 rotation groups",
        )?;
        v.at_least(
            "edge.translations",
            e.translations,
            3,
            "at least 3 translations per group",
        )?;
        if !(e.arc_radius_mm > 0.0 && e.arc_span_deg > 0.0 && e.arc_span_deg < 180.0) {
            return Err(v.bad(
                "edge.arc_span_deg",
                e.arc_span_deg,
                "the arc needs a radius > 0 and a span in (0, 180) deg: a straight line makes the rotation equations degenerate",
            ));
        }
        if !(e.arc_heading_deg > 0.0 && e.arc_heading_deg < 90.0) {
            return Err(v.bad(
                "edge.arc_heading_deg",
                e.arc_heading_deg,
                "must be in (0, 90): along the edge the profile never changes, straight across it the points do not spread along the edge",
            ));
        }
        if !(e.tilt_deg > 0.0 && e.tilt_deg <= 45.0) {
            return Err(v.bad("edge.tilt_deg", e.tilt_deg, "must be in (0, 45]"));
        }
        v.non_negative("edge.sigma_mm", e.sigma_mm)
    }

    fn plan(
        &self,
        sc: &Scenario,
        common: &Common,
        v: &Validator,
    ) -> Result<Box<dyn Plan>, ScenarioError> {
        let e = v.section(sc.edge.as_ref(), Kind::Edge)?;
        let rig = &common.rig;
        let (spec, pose, scene) = common.own(e.specimen.as_ref(), "edge.specimen", v)?;
        if !spec.is_edge() {
            return Err(v.bad(
                "edge.specimen.kind",
                spec.name(),
                "the edge method needs parallel-bar, scale or knife-blade",
            ));
        }
        let target = EdgeTarget::from_pose(&pose, spec.edge_length().unwrap_or(f64::INFINITY));
        let espec = EdgePlanSpec {
            rotations: e.rotations,
            translations: e.translations,
            tilt: e.tilt_deg.to_radians(),
            arc_radius: e.arc_radius_mm * 1e-3,
            arc_span: e.arc_span_deg.to_radians(),
            arc_heading: e.arc_heading_deg.to_radians(),
            edge_z: e
                .edge_z_mm
                .map(|z| z * 1e-3)
                .unwrap_or(rig.sensor.range_centre().z),
        };
        let (plans, free) = match &e.poses {
            None => (
                crate::sim::edge::plan(rig, &target, &espec)
                    .map_err(|er| v.bad("edge", "..", er.to_string()))?,
                Vec::new(),
            ),
            Some(ps) => {
                let source = ps.source("edge.poses", crate::calib::plane::MIN_VIEWS, v)?;
                // Aimed at the edge; the laser plane moved up to 30 mm (or a third of the
                // edge) across itself, so that the crossings spread along the edge.
                let aim = Aim {
                    point: target.point,
                    normal: target.up.into_inner(),
                    off_plane: (target.half_length / 1.5).min(0.03),
                    crossing: Some(target.dir.into_inner()),
                    // A ridge's or groove's faces in one order along every profile.
                    sense: spec
                        .kind
                        .specimen_type()
                        .two_faces()
                        .map(|_| target.up.cross(&target.dir)),
                };
                let mut g = rng::stream(sc.seed, &[tag::PLAN, 5]);
                let poses = crate::sim::poses::poses(rig, &aim, &source, &mut g)
                    .map_err(|er| v.bad("edge.poses", "..", er.to_string()))?;
                (Vec::new(), poses)
            }
        };
        let validation = e.validation.as_ref().map(|val| BallCheck {
            ball: BallTarget {
                centre: Point3::from(Vector3::from(val.position_mm) * 1e-3),
                radius: val.ball_radius_mm * 1e-3,
            },
            groups: val.groups,
            translations: val.translations,
            sigma: val.sigma_mm * 1e-3,
        });
        if e.source != Source::Raycast && spec.edge_radius > 0.0 {
            return Err(v.bad(
                "edge.specimen.edge_radius_mm",
                spec.edge_radius * 1e3,
                "a rounded edge needs edge.source = \"raycast\": where the profile's \
                 corner lands on the round depends on the profile, which only the \
                 ray-cast sensor sees",
            ));
        }
        Ok(Box::new(EdgePlan {
            target,
            plans,
            free,
            passing: match &e.poses {
                Some(ps) => ps.passing("edge.poses", v)?,
                None => None,
            },
            scene,
            raycast: e.source == Source::Raycast,
            sigma: e.sigma_mm * 1e-3,
            validation,
            form: e.specimen.as_ref().unwrap_or(&sc.specimen).form(),
            sense: crate::sim::edge::sense(rig, &target),
        }))
    }

    fn calibrate(&self, c: &Captures, sensor: &SensorModel) -> Result<super::Calibration, Error> {
        calibrate(c, sensor)
    }

    /// The edge point's noise falls mostly along the laser line (where the top face's line
    /// ends), the fit weighs its distance from the edge in both directions alike.
    fn closed_form_noise_moves(
        &self,
        c: &Captures,
        sensor: &SensorModel,
        sd: f64,
    ) -> Option<Vec<crate::calib::refine::honest::Moved>> {
        noise_moves(c, sensor, sd)
    }

    fn closed_form_recast(
        &self,
        c: &Captures,
        sensor: &SensorModel,
        _cal: &super::Calibration,
        twists: &dyn Fn(&Isometry3<f64>) -> Option<Vec<nalgebra::Vector6<f64>>>,
    ) -> Option<Vec<nalgebra::Vector6<f64>>> {
        recast(c, sensor, twists)
    }

    fn calibrate_any_pose(
        &self,
        c: &Captures,
        sensor: &SensorModel,
        censored_iterations: usize,
    ) -> Result<(super::Calibration, Refined), Error> {
        any_pose(c, sensor, censored_iterations)
    }

    fn profile_features(
        &self,
        c: &Captures,
        sensor: &SensorModel,
    ) -> Vec<Option<super::ProfileFeature>> {
        // With the sense recorded, the closed form's edge point; without it (free poses, real
        // files), the any-pose estimator's reading: the top face and its edges in both senses.
        let cfg = edge_config(sensor);
        super::each_profile(c, |g, p| match (&p.data, c.edge_sense) {
            (ProfileData::Raw(prof), _) if c.specimen_kind.two_faces().is_some() => {
                let outside = c.specimen_kind.two_faces() == Some(true);
                let t = features::two_faces(prof, sensor, outside, None, &cfg).ok()?;
                Some(super::ProfileFeature {
                    features: vec![t.corner],
                    surface: t.faces.concat(),
                })
            }
            (ProfileData::Raw(prof), None) => {
                let bar = features::bar_profile(prof, sensor, &cfg).ok()?;
                Some(super::ProfileFeature {
                    features: bar.edges.iter().map(|e| e.point).collect(),
                    surface: bar.face,
                })
            }
            (data, sense) => {
                let sense = sense.unwrap_or(EdgeSense::Falling);
                let e = point_of(g, data, sensor, sense, &cfg).ok()?.ok()?;
                Some(super::ProfileFeature {
                    features: vec![e.end.point],
                    surface: e.face,
                })
            }
        })
    }

    fn fit_mapped(
        &self,
        features: &[Vec<Point3<f64>>],
        surface: &[Vec<Point3<f64>>],
    ) -> Option<super::view::Fitted> {
        super::view::fit_bar(features, surface)
    }

    fn needs_radius(&self) -> bool {
        false
    }

    fn uses_group_signs(&self) -> bool {
        false
    }
}

/// The edge paper's Table 3 check: a precision ball scanned with the estimate.
#[derive(Debug, Clone, Copy)]
pub struct BallCheck {
    pub ball: BallTarget,
    pub groups: usize,
    pub translations: usize,
    /// z noise on its arcs, metres.
    pub sigma: f64,
}

/// The edge method's plan on one rig.
#[derive(Debug)]
pub struct EdgePlan {
    pub target: EdgeTarget,
    /// The paper's protocol, or (when not empty) `free` flange poses, one profile each.
    pub plans: Vec<EdgeGroupPlan>,
    pub free: Vec<Isometry3<f64>>,
    /// Scanning on the move through the free poses (`[edge.poses] scan_speed_mm_s`).
    pub passing: Option<crate::sim::poses::Passing>,
    pub scene: Scene,
    pub raycast: bool,
    /// Noise on the edge point's x and z (analytic), metres.
    pub sigma: f64,
    pub validation: Option<BallCheck>,
    pub form: FormTolerance,
    /// Which way the profiles cross the edge.
    pub sense: EdgeSense,
}

impl Plan for EdgePlan {
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
        let p = &self.plans[0];
        flange_pose(&p.r_tcp, &p.tcps[p.tcps.len() / 2])
    }

    fn truth_checks(&self, rig: &Rig, estimate: &Isometry3<f64>, validation_seed: u64) -> Metrics {
        let radius = self.validation.and_then(|v| {
            let mut vr = rng::stream(validation_seed, &[tag::SPECIMEN]);
            crate::sim::edge::ball_radius_check(
                rig,
                estimate,
                &v.ball,
                v.groups,
                v.translations,
                v.sigma,
                0.1e-3,
                &mut vr,
            )
        });
        Metrics::default().with(Metric::SphereRadius, radius.map(|x| x * 1e3))
    }

    fn simulate(&self, rig: &Rig, sim: &mut Sim) -> Result<Captures, Error> {
        let (spec, frame) = &self.scene.specimens[0];
        let form = FormError::draw(spec, &self.form, sim.specimen_rng);
        let scene = crate::scene::with_form(std::borrow::Cow::Borrowed(&self.scene), form);
        let noisy = !rig.sensor.noise.is_off();
        let Sim { rng, mover, .. } = sim;
        let (mut groups, mut profiles) = (Vec::new(), Vec::new());
        for (g, f) in self.free.iter().enumerate() {
            let pose = rig.base_to_sensor(&mover.actual(&rig.robot, f));
            groups.push(Group {
                id: g,
                role: Role::Pose,
                sign: 0.0,
            });
            profiles.push(crate::captures::CaptureProfile {
                group: g,
                base_to_flange: *f,
                data: ProfileData::Raw(rig.sensor.profile(
                    &scene,
                    &pose,
                    noisy.then_some(&mut **rng),
                )),
            });
        }
        for (g, p) in self.plans.iter().enumerate() {
            groups.push(Group {
                id: g,
                role: Role::RotationGroup,
                sign: 0.0,
            });
            for t in &p.tcps {
                let f = flange_pose(&p.r_tcp, t);
                let pose = rig.base_to_sensor(&mover.actual(&rig.robot, &f));
                let data = if self.raycast {
                    ProfileData::Raw(
                        rig.sensor
                            .profile(&scene, &pose, noisy.then_some(&mut **rng)),
                    )
                } else {
                    let (nx, nz) = (
                        crate::rng::gauss(rng) * self.sigma,
                        crate::rng::gauss(rng) * self.sigma,
                    );
                    let q = crate::sim::edge::exact_point_formed(&pose, &self.target, frame, &form)
                        .ok_or(crate::sim::PlanError::ParallelToEdge { group: g })?;
                    ProfileData::EdgePoint(q + Vector2::new(nx, nz))
                };
                profiles.push(crate::captures::CaptureProfile {
                    group: g,
                    base_to_flange: f,
                    data,
                });
            }
        }
        let mut caps = Captures {
            orientation_tolerance_deg: crate::calib::ORIENTATION_TOLERANCE_DEG,
            feature_sigma: (!self.raycast).then_some(self.sigma),
            // A rig whose scenario draws a bow states its tolerance, over the edge's length.
            judging: crate::captures::Judging {
                straightness: self.form.straightness,
                edge_length: (self.form.straightness > 0.0)
                    .then(|| spec.edge_length())
                    .flatten(),
                ..Default::default()
            },
            method: Kind::Edge,
            sensor: rig.sensor.name.clone(),
            specimen_kind: spec.kind.specimen_type(),
            specimen_radius: None,
            edge_sense: Some(self.sense),
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

/// The edge point of one capture: given, or extracted from the raw profile.
/// With a raw profile, also the top face's points (for `edge-full`).
type EdgeFeature = features::EdgeProfile;

fn point_of(
    g: &Group,
    data: &ProfileData,
    sensor: &SensorModel,
    sense: EdgeSense,
    cfg: &SplitMerge,
) -> Result<Result<EdgeFeature, features::FeatureError>, CaptureError> {
    match data {
        ProfileData::EdgePoint(q) => Ok(Ok(features::EdgeProfile {
            end: features::EdgeEnd {
                point: *q,
                from: *q,
                to: *q,
            },
            face: Vec::new(),
            beyond: Vec::new(),
            other: None,
        })),
        ProfileData::Raw(prof) => Ok(features::edge_point_and_face(prof, sensor, sense, cfg)),
        _ => Err(CaptureError::WrongData {
            group: g.id,
            method: Kind::Edge,
            need: "an edge point or raw points",
        }),
    }
}

/// The angle a ridge's or groove's faces meet at in most profiles: the median over the profiles
/// of their best pair's (most points). A profile whose best pair is another corner (the plate
/// the target stands on, a chamfer) then takes its pair at that angle instead. None without raw
/// profiles.
fn faces_angle(c: &Captures, sensor: &SensorModel, outside: bool, cfg: &SplitMerge) -> Option<f64> {
    let mut a: Vec<f64> = c
        .profiles
        .iter()
        .filter_map(|p| match &p.data {
            ProfileData::Raw(prof) => features::two_faces(prof, sensor, outside, None, cfg)
                .ok()
                .map(|t| t.angle),
            _ => None,
        })
        .collect();
    if a.is_empty() {
        return None;
    }
    a.sort_by(f64::total_cmp);
    Some(a[a.len() / 2])
}

/// A ridge's or groove's edge point: where its two faces' lines meet (no face for `edge-full`,
/// whose model is a bar's).
/// A ridge's or groove's corner as the closed form's edge point, and the two faces' points.
fn corner_of(
    prof: &crate::sensor::Profile,
    sensor: &SensorModel,
    outside: bool,
    angle: Option<f64>,
    cfg: &SplitMerge,
) -> Result<(EdgeFeature, [Vec<Vector2<f64>>; 2]), features::FeatureError> {
    let t = features::two_faces(prof, sensor, outside, angle, cfg)?;
    let feature = features::EdgeProfile {
        end: features::EdgeEnd {
            point: t.corner,
            from: t.corner,
            to: t.corner,
        },
        face: Vec::new(),
        beyond: Vec::new(),
        other: None,
    };
    Ok((feature, t.faces))
}

/// A ridge's or groove's two faces from any poses (`calib::faces`).
fn two_face_view(
    g: &Group,
    p: &crate::captures::CaptureProfile,
    sensor: &SensorModel,
    outside: bool,
    angle: Option<f64>,
    cfg: &SplitMerge,
) -> Result<Result<crate::calib::faces::FacesView, CaptureError>, CaptureError> {
    let ProfileData::Raw(prof) = &p.data else {
        return Err(CaptureError::WrongData {
            group: g.id,
            method: Kind::Edge,
            need: "raw points (points_mm): the any-pose estimator fits both faces",
        });
    };
    Ok(features::two_faces(prof, sensor, outside, angle, cfg)
        .map_err(CaptureError::from)
        .and_then(|t| {
            let [a, b] = t.faces;
            Ok(crate::calib::faces::FacesView {
                faces: [
                    super::face_view(p.base_to_flange, a)?,
                    super::face_view(p.base_to_flange, b)?,
                ],
            })
        }))
}

/// Edges are small features: a fine tolerance for an exact sensor, else the noise's.
fn edge_config(sensor: &SensorModel) -> SplitMerge {
    let tuned = SplitMerge::for_sensor(sensor);
    let exact = sensor.noise.is_off() && sensor.z_quantum.is_none();
    SplitMerge {
        split_tol: if exact { 0.1e-3 } else { tuned.split_tol },
        jump: tuned.jump.max(0.5e-3),
        min_points: 4,
    }
}

/// One raw profile of the bar from any pose: its face's line and the edges at the face's ends.
fn bar_view(
    g: &Group,
    p: &crate::captures::CaptureProfile,
    sensor: &SensorModel,
    cfg: &SplitMerge,
) -> Result<Result<BarView, CaptureError>, CaptureError> {
    let ProfileData::Raw(prof) = &p.data else {
        return Err(CaptureError::WrongData {
            group: g.id,
            method: Kind::Edge,
            need: "raw points (points_mm): the any-pose estimator fits the bar's face",
        });
    };
    Ok(features::bar_profile(prof, sensor, cfg)
        .map_err(CaptureError::from)
        .and_then(|bar| {
            Ok(BarView {
                face: super::face_view(p.base_to_flange, bar.face)?,
                edges: bar.edges.iter().map(|e| (e.from, e.to)).collect(),
            })
        }))
}

/// The bar's face and edges from any poses, whatever the groups (`calib::bar`).
fn any_pose(
    c: &Captures,
    sensor: &SensorModel,
    censored_iterations: usize,
) -> Result<(super::Calibration, Refined), Error> {
    let cfg = edge_config(sensor);
    if let Some(outside) = c.specimen_kind.two_faces() {
        let angle = faces_angle(c, sensor, outside, &cfg);
        let (views, reports) = super::free_views(c, Kind::Edge, |g, p| {
            two_face_view(g, p, sensor, outside, angle, &cfg)
        })?;
        let (kept, sol) = crate::calib::faces::solve(&views, &sensor.apex().coords)?;
        let mut reports = reports;
        super::leave_out_views(
            &mut reports,
            &kept,
            "its faces lie off the two planes the others share (more than 5 times the median \
             profile's RMS): a third surface taken for a face, or the pose off",
        );
        let cal = super::any_pose_calibration(
            &sol.refined,
            None,
            reports,
            std::sync::Arc::new(sol.problem),
        );
        return Ok((cal, sol.refined));
    }
    let (views, reports) = super::free_views(c, Kind::Edge, |g, p| bar_view(g, p, sensor, &cfg))?;
    let sol = crate::calib::bar::solve(&views, &sensor.apex().coords, censored_iterations)?;
    let cal = super::any_pose_calibration(
        &sol.refined,
        None,
        reports,
        std::sync::Arc::new(sol.problem),
    );
    Ok((cal, sol.refined))
}

/// `edge-full`: the top face's points, and per profile and edge the side wall's points below it
/// (`super::wall_points`) or else the edge itself, against the bar (`refine::bar`), from the
/// closed form: the face's plane fitted to its points mapped with the closed form's transform, the
/// edge's line the closed form's. The face's other end, where profiles show it as an edge (at
/// least 3 within `WALL_TOL` of their median), is the bar's second edge, with its own offset: it
/// adds the wall the first edge's tilt hides. An edge where the face just stops is its censored
/// interval between columns (as `edge-any-pose`'s): the mid-column point drifted with the noise
/// (t_z off by 0.003-0.007 mm at z noise 0.05-0.2 mm when weighted by its spread). None without
/// face points (a file of edge points).
fn full_profile(
    sol: &crate::calib::edge::EdgeSolution,
    profiles: &[(Isometry3<f64>, features::EdgeProfile)],
    face: Vec<(Isometry3<f64>, Vector2<f64>)>,
    apex: &Point3<f64>,
) -> Option<std::sync::Arc<dyn crate::calib::refine::Refinable>> {
    use crate::calib::refine::bar::{Bar, BarModel, EdgeSeen, WallSeen};
    if face.len() < 3 {
        return None;
    }
    let x = sol.flange_to_sensor;
    let in_base = |f: &Isometry3<f64>, p: &Vector2<f64>| {
        (f * x).transform_point(&Point3::new(p.x, 0.0, p.y)).coords
    };
    let centroid = face
        .iter()
        .map(|(f, p)| in_base(f, p))
        .sum::<Vector3<f64>>()
        / face.len() as f64;
    let scatter: nalgebra::Matrix3<f64> = face
        .iter()
        .map(|(f, p)| {
            let d = in_base(f, p) - centroid;
            d * d.transpose()
        })
        .sum();
    let eig = scatter.symmetric_eigen();
    let mut n = super::toward_sensors(
        eig.eigenvectors.column(eig.eigenvalues.imin()).into_owned(),
        &centroid,
        profiles.iter().map(|(f, _)| *f),
        &x,
        apex,
    );
    // The edge's direction made exactly perpendicular to the normal.
    let dir = (sol.edge_direction - n * n.dot(&sol.edge_direction)).try_normalize(1e-9)?;
    n = (n - dir * n.dot(&dir)).normalize();
    let frame = nalgebra::Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_columns(&[
        dir,
        n.cross(&dir),
        n,
    ]));
    let across = n.cross(&dir);
    let first = across.dot(&sol.edge_point);
    // The second edge: the median of the other ends' offsets, and the ends near it.
    let mut others: Vec<f64> = profiles
        .iter()
        .filter_map(|(f, e)| {
            e.other
                .as_ref()
                .map(|(o, _)| across.dot(&in_base(f, &o.point)))
        })
        .collect();
    others.sort_by(f64::total_cmp);
    let second = others.get(others.len() / 2).copied().filter(|o| {
        (o - first).abs() > super::WALL_TOL
            && others
                .iter()
                .filter(|p| (*p - o).abs() <= super::WALL_TOL)
                .count()
                >= 3
    });
    let specimen = Bar {
        frame,
        offset: n.dot(&centroid),
        edge_offsets: [first, second.unwrap_or(first)],
    };
    let (mut edges, mut walls) = (Vec::new(), Vec::new());
    for (f, e) in profiles {
        let base_to_sensor = f * x;
        let other = e
            .other
            .as_ref()
            .filter(|(o, _)| {
                second.is_some_and(|s| {
                    (across.dot(&in_base(f, &o.point)) - s).abs() <= super::WALL_TOL
                })
            })
            .map(|(o, past)| (1, o, past));
        for (edge, end, past) in std::iter::once((0, &e.end, &e.beyond)).chain(other) {
            let wall = super::wall_points(past, &base_to_sensor, |p| {
                (
                    n.dot(p) - specimen.offset,
                    across.dot(p) - specimen.edge_offsets[edge],
                    across,
                )
            });
            if wall.len() >= super::WALL_MIN_POINTS {
                walls.extend(wall.into_iter().map(|(point, weight)| WallSeen {
                    base_to_flange: *f,
                    point,
                    weight,
                    edge,
                }));
            } else {
                edges.push(EdgeSeen {
                    base_to_flange: *f,
                    from: end.from,
                    to: end.to,
                    edge,
                });
            }
        }
    }
    let model = BarModel {
        face,
        edges,
        n_edges: if second.is_some() { 2 } else { 1 },
        walls,
    };
    Some(std::sync::Arc::new(Problem { model, specimen }))
}

/// Edge points per rotation group, the Kronecker solve, the paper's Tables 1-2 figures, and the
/// refinement problem.
/// A file of one `pose` group per profile (as `lasercal import` writes it, or a scenario's free
/// poses) regrouped for the closed form: the profiles at one flange orientation (within the
/// file's orientation tolerance, in file order) form a rotation group, a label the poses
/// determine. Each group keeps the id of its first profile's group. Files with rotation groups
/// are returned as they are.
fn inferred_groups(c: &Captures) -> std::borrow::Cow<'_, Captures> {
    if c.groups.is_empty() || c.groups.iter().any(|g| g.role != Role::Pose) {
        return std::borrow::Cow::Borrowed(c);
    }
    let tol = c.orientation_tolerance_deg.to_radians();
    let mut out = c.clone();
    // (the group's first orientation, its id)
    let mut found: Vec<(nalgebra::UnitQuaternion<f64>, usize)> = Vec::new();
    for p in out.profiles.iter_mut() {
        let r = p.base_to_flange.rotation;
        p.group = match found.iter().find(|(q, _)| q.angle_to(&r) <= tol) {
            Some(&(_, id)) => id,
            None => {
                found.push((r, p.group));
                p.group
            }
        };
    }
    out.groups = found
        .iter()
        .map(|&(_, id)| Group {
            id,
            role: Role::RotationGroup,
            sign: 0.0,
        })
        .collect();
    std::borrow::Cow::Owned(out)
}

/// The closed form's edge points, group by group, and what the variants built on it keep.
struct Built<'a> {
    problem: EdgeProblem,
    /// Each edge point with the flange pose that saw it, in `problem`'s order.
    points: Vec<(Isometry3<f64>, Vector2<f64>)>,
    /// The profile each edge point came from, in the same order.
    sources: Vec<&'a crate::captures::CaptureProfile>,
    /// A ridge's or groove's faces' angle (`faces_angle`).
    angle: Option<f64>,
    profiles: Vec<(Isometry3<f64>, features::EdgeProfile)>,
    face: Vec<(Isometry3<f64>, Vector2<f64>)>,
    two_faces: Vec<(usize, Isometry3<f64>, [Vec<Vector2<f64>>; 2])>,
    reports: Vec<super::GroupReport>,
    missed: usize,
}

/// Edge points from every group (`c` with its groups inferred): the closed form's problem.
fn build<'a>(c: &'a Captures, sensor: &SensorModel) -> Result<Built<'a>, Error> {
    let sense = c.edge_sense.unwrap_or(EdgeSense::Falling);
    let cfg = edge_config(sensor);
    let angle = c
        .specimen_kind
        .two_faces()
        .and_then(|outside| faces_angle(c, sensor, outside, &cfg));
    let mut missed = 0;
    let (mut per_group, mut reports) = (Vec::new(), Vec::new());
    // A two-face target's faces, for the full-profile variant (each used profile's).
    let mut two_faces = Vec::new();
    let keep = super::face_points(c.profiles.len());
    for g in &c.groups {
        let (mut caps, mut pts, mut profiles, mut face) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut report = super::GroupReport::new(g.id);
        for p in c.group_profiles(g.id) {
            let point = match (&p.data, c.specimen_kind.two_faces()) {
                (ProfileData::Raw(prof), Some(outside)) => Ok(corner_of(
                    prof, sensor, outside, angle, &cfg,
                )
                .map(|(e, faces)| {
                    two_faces.push((g.id, p.base_to_flange, faces));
                    e
                })),
                (data, _) => point_of(g, data, sensor, sense, &cfg),
            }?;
            report.count(&point);
            match point {
                Ok(mut seen) => {
                    let q = seen.end.point;
                    let points = std::mem::take(&mut seen.face);
                    // Face points for edge-full, as many per profile as disk-full keeps (64 gave
                    // 1.6-2x the rotation error on the comparison rig's bar).
                    let stride = crate::calib::stride_for(points.len(), keep);
                    face.extend(
                        points
                            .into_iter()
                            .step_by(stride)
                            .map(|f| (p.base_to_flange, f)),
                    );
                    pts.push(((p.base_to_flange, q), p));
                    profiles.push((p.base_to_flange, seen));
                    caps.push(EdgeCapture {
                        r_tcp: p.base_to_flange.rotation.to_rotation_matrix(),
                        t_tcp: p.base_to_flange.translation.vector,
                        p_in_sensor: q,
                    })
                }
                Err(_) => missed += 1,
            }
        }
        per_group.push((caps, pts, profiles, face));
        reports.push(report);
    }
    // A group with fewer than 3 edge points gives no rotation equations: left out, if 2 remain.
    super::leave_out_thin_groups(&mut reports, 3, 2, Kind::Edge)?;
    let (mut groups, mut points, mut sources, mut profiles, mut face) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for ((caps, pts, e, f), r) in per_group.into_iter().zip(&reports) {
        if !r.left_out {
            groups.push(caps);
            for (point, source) in pts {
                points.push(point);
                sources.push(source);
            }
            profiles.extend(e);
            face.extend(f);
        }
    }
    // The side wall is the plane through the edge perpendicular to the face on a bar or a
    // plate, not on a knife's bevel, whose back is no second edge either.
    if !matches!(
        c.specimen_kind,
        SpecimenType::ParallelBar | SpecimenType::Scale | SpecimenType::Step
    ) {
        for (_, e) in &mut profiles {
            e.beyond.clear();
            e.other = None;
        }
    }
    Ok(Built {
        problem: EdgeProblem {
            groups,
            orientation_tolerance_deg: c.orientation_tolerance_deg,
        },
        points,
        sources,
        angle,
        profiles,
        face,
        two_faces,
        reports,
        missed,
    })
}

/// The closed form's response to errors that move each profile's actual flange pose, its edge
/// points re-cast from there (`Method::closed_form_recast`): each is where the laser plane cuts
/// the edge, a line fixed in the base (the closed form's), so it moves as the moved plane's cut
/// of that line does (`recast::plane_cut_move`); the closed form is solved again from the moved
/// points (`super::recast_responses`).
fn recast(
    c: &Captures,
    sensor: &SensorModel,
    twists: &dyn Fn(&Isometry3<f64>) -> Option<Vec<nalgebra::Vector6<f64>>>,
) -> Option<Vec<nalgebra::Vector6<f64>>> {
    use crate::calib::recast::plane_cut_move;
    let c = &*inferred_groups(c);
    let Built {
        problem, points, ..
    } = build(c, sensor).ok()?;
    if points.len() != problem.groups.iter().map(Vec::len).sum::<usize>() {
        return None;
    }
    let sol = crate::calib::edge::solve(&problem).ok()?;
    let at = sol.flange_to_sensor;
    let mut moves: Vec<Vec<Vector2<f64>>> = Vec::with_capacity(points.len());
    for (f, q) in &points {
        let tangent = (f * at).rotation.inverse() * sol.edge_direction;
        moves.push(
            twists(f)?
                .iter()
                .map(|xi| plane_cut_move(&at, q, &tangent, xi))
                .collect::<Option<_>>()?,
        );
    }
    let errors = moves.first()?.len();
    if moves.iter().any(|m| m.len() != errors) {
        return None;
    }
    super::recast_responses(errors, |e, h| {
        let mut moved = problem.clone();
        for (capture, m) in moved.groups.iter_mut().flatten().zip(&moves) {
            capture.p_in_sensor += m[e] * h;
        }
        crate::calib::edge::solve(&moved)
            .ok()
            .map(|s| s.flange_to_sensor)
    })
}

/// How the closed form and its edge points' fit move under the stated noise `sd` (m) on the
/// profiles' depths (`Method::closed_form_noise_moves`): each edge point's covariance from
/// `verdict::NOISE_DRAWS` draws of its own profile's depths (a hundredth of each, the point found
/// again and the move scaled back; sd on x and z where the file gives the point), and along
/// each of its two principal directions a move of
/// that variance: the closed form solved again and the fit's Gauss-Newton step taken again with
/// the point moved a micrometre. None: a profile neither raw nor an edge point, or a solve
/// that failed.
fn noise_moves(
    c: &Captures,
    sensor: &SensorModel,
    sd: f64,
) -> Option<Vec<crate::calib::refine::honest::Moved>> {
    use crate::calib::refine::{Refinable, fit_step, honest::Moved};
    if !(sd > 0.0) {
        return None;
    }
    let c = &*inferred_groups(c);
    let Built {
        problem,
        points,
        sources,
        angle,
        ..
    } = build(c, sensor).ok()?;
    if points.len() != sources.len()
        || points.len() != problem.groups.iter().map(Vec::len).sum::<usize>()
    {
        return None;
    }
    let sol = crate::calib::edge::solve(&problem).ok()?;
    let at = sol.flange_to_sensor;
    let specimen = EdgeLine::new(sol.edge_point.into(), &sol.edge_direction);
    let (sense, cfg) = (
        c.edge_sense.unwrap_or(EdgeSense::Falling),
        edge_config(sensor),
    );
    let found = |prof: &crate::sensor::Profile| match c.specimen_kind.two_faces() {
        Some(outside) => corner_of(prof, sensor, outside, angle, &cfg)
            .ok()
            .map(|(e, _)| e.end.point),
        None => features::edge_point_and_face(prof, sensor, sense, &cfg)
            .ok()
            .map(|e| e.end.point),
    };
    let (h, step) = (1e-2, 1e-6);
    let fit_at = fit_step(
        &Problem {
            model: EdgeModel {
                points: points.clone(),
            },
            specimen,
        } as &dyn Refinable,
        &at,
    );
    let draws = super::verdict::NOISE_DRAWS;
    let mut out = Vec::with_capacity(2 * points.len());
    for (i, (src, (_, q))) in sources.iter().zip(&points).enumerate() {
        let cov = match &src.data {
            ProfileData::Raw(prof) => {
                let mut cov = nalgebra::Matrix2::zeros();
                for m in 0..draws {
                    let mut g = rng::stream(super::verdict::NOISE_SEED, &[i as u64, m]);
                    let mut moved = prof.clone();
                    for p in moved.points.iter_mut().flatten() {
                        p.z += h * sd * rng::gauss(&mut g);
                    }
                    let w = (found(&moved)? - q) / h;
                    cov += w * w.transpose() / draws as f64;
                }
                cov
            }
            // A profiler that reports the edge point: the noise on its x and z.
            ProfileData::EdgePoint(_) => nalgebra::Matrix2::identity() * (sd * sd),
            _ => return None,
        };
        let eig = nalgebra::SymmetricEigen::new(cov);
        for (k, &variance) in eig.eigenvalues.iter().enumerate() {
            if !(variance > 0.0) {
                continue;
            }
            let e: Vector2<f64> = eig.eigenvectors.column(k).into_owned();
            let closed = |s: f64| {
                let mut moved = problem.clone();
                moved.groups.iter_mut().flatten().nth(i)?.p_in_sensor += e * s;
                crate::calib::edge::solve(&moved)
                    .ok()
                    .map(|r| r.flange_to_sensor)
            };
            let fit = |s: f64| {
                let mut moved = points.clone();
                moved[i].1 += e * s;
                let p = Problem {
                    model: EdgeModel { points: moved },
                    specimen,
                };
                fit_step(&p as &dyn Refinable, &at)
            };
            // Forward differences (the solves are smooth; a micrometre against lever arms of a
            // decimetre): half the solves of central ones.
            out.push(Moved {
                // Both steps from the same transform: their difference is the fit's move.
                fit: (fit(step) - fit_at) / step,
                closed: super::verdict::step_between(&at, &closed(step)?) / step,
                variance,
            });
        }
    }
    out.iter()
        .all(|m| m.fit.iter().chain(m.closed.iter()).all(|v| v.is_finite()))
        .then_some(out)
}

fn calibrate(c: &Captures, sensor: &SensorModel) -> Result<super::Calibration, Error> {
    let c = &*inferred_groups(c);
    let Built {
        problem,
        points,
        sources: _,
        angle: _,
        profiles,
        face,
        two_faces,
        reports,
        missed,
    } = build(c, sensor)?;
    let sol = crate::calib::edge::solve(&problem)?;
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let full_profile = if c.specimen_kind.two_faces().is_some() {
        // Both faces' points from the closed form's transform (`calib::faces`), the profiles of
        // the groups it kept.
        let kept: Vec<usize> = reports
            .iter()
            .filter(|r| !r.left_out)
            .map(|r| r.group)
            .collect();
        let views: Vec<crate::calib::faces::FacesView> = two_faces
            .into_iter()
            .filter(|(g, _, _)| kept.contains(g))
            .filter_map(|(_, f, [a, b])| {
                Some(crate::calib::faces::FacesView {
                    faces: [super::face_view(f, a).ok()?, super::face_view(f, b).ok()?],
                })
            })
            .collect();
        crate::calib::faces::problem_at(&views, &sol.flange_to_sensor)
            .map(|p| std::sync::Arc::new(p) as std::sync::Arc<dyn crate::calib::refine::Refinable>)
    } else {
        full_profile(&sol, &profiles, face, &sensor.apex())
    };
    Ok(super::Calibration {
        full_profile,
        refinable: Some(std::sync::Arc::new(Problem {
            model: EdgeModel { points },
            specimen: EdgeLine::new(sol.edge_point.into(), &sol.edge_direction),
        })),
        flange_to_sensor: sol.flange_to_sensor,
        centre_in_base: None,
        figures: Metrics::default()
            .with(
                Metric::EdgeAngleDev,
                Some(mean(&sol.group_angle_dev).to_degrees()),
            )
            .with(Metric::EdgeDistance, Some(mean(&sol.point_distances) * 1e3)),
        status: sol.status,
        missed,
        groups: reports,
    })
}
