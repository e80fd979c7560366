//! The plane method (beyond both papers): free poses looking at a flat face (the table's in the
//! simulator), one profile each, calibrated from any poses (`calib::plane`). Its `[plane]` scenario
//! section, pose generation, simulation and line features.

use super::{Calibration, GroupReport, Kind, Method, Plan, Sim};
use crate::calib::refine::Refined;
use crate::captures::{CaptureError, CaptureProfile, Captures, Group, ProfileData, Role};
use crate::error::Error;
use crate::features::{self, SplitMerge};
use crate::metrics::Metrics;
use crate::rng::{self, tag};
use crate::scene::{Scene, SpecimenType};
use crate::schema::{Common, Scenario, ScenarioError, Validator};
use crate::sensor::SensorModel;
use crate::sim::Rig;
use crate::sim::poses::Aim;
use nalgebra::{Isometry3, Point3, Vector2, Vector3};

/// The plane method.
pub struct PlaneMethod;

/// Fewest points a profile's line needs.
const MIN_POINTS: usize = 20;

impl Method for PlaneMethod {
    fn kind(&self) -> Kind {
        Kind::Plane
    }

    fn validate(&self, sc: &Scenario, v: &Validator) -> Result<(), ScenarioError> {
        let p = v.section(sc.plane.as_ref(), Kind::Plane)?;
        p.poses
            .source("plane.poses", crate::calib::plane::MIN_VIEWS, v)?;
        if p.aim_mm.iter().any(|x| !x.is_finite()) {
            return Err(v.bad("plane.aim_mm", format!("{:?}", p.aim_mm), "must be finite"));
        }
        if sc.table.is_none() {
            return Err(v.bad(
                "table",
                "(missing)",
                "the plane method calibrates against the table's face: give [table] height_mm",
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
        let p = v.section(sc.plane.as_ref(), Kind::Plane)?;
        let table = common
            .table
            .ok_or_else(|| v.bad("table", "(missing)", "the plane method needs [table]"))?;
        let source = p
            .poses
            .source("plane.poses", crate::calib::plane::MIN_VIEWS, v)?;
        let aim = Aim {
            point: Point3::new(p.aim_mm[0] * 1e-3, p.aim_mm[1] * 1e-3, table.height_m),
            normal: Vector3::z(),
            off_plane: 0.0,
            crossing: None,
            sense: None,
        };
        let mut g = rng::stream(sc.seed, &[tag::PLAN, 4]);
        let poses = crate::sim::poses::poses(&common.rig, &aim, &source, &mut g)
            .map_err(|e| v.bad("plane.poses", "..", e.to_string()))?;
        Ok(Box::new(PlanePlan {
            poses,
            scene: Scene::new(Some(table)),
            height: table.height_m,
            passing: p.poses.passing("plane.poses", v)?,
        }))
    }

    fn calibrate(&self, c: &Captures, sensor: &SensorModel) -> Result<Calibration, Error> {
        calibrate(c, sensor).map(|(cal, _)| cal)
    }

    fn calibrate_any_pose(
        &self,
        c: &Captures,
        sensor: &SensorModel,
        _censored_iterations: usize,
    ) -> Result<(Calibration, Refined), Error> {
        calibrate(c, sensor)
    }

    fn profile_features(
        &self,
        c: &Captures,
        sensor: &SensorModel,
    ) -> Vec<Option<super::ProfileFeature>> {
        let cfg = SplitMerge::for_sensor(sensor);
        super::each_profile(c, |g, p| {
            let (centroid, dir, points) = line_of(g, &p.data, &cfg).ok()?;
            // The line's ends: its first and last points projected onto it.
            let end = |q: &Vector2<f64>| centroid + dir * (q - centroid).dot(&dir);
            let features = match (points.first(), points.last()) {
                (Some(a), Some(b)) => vec![end(a), end(b)],
                _ => Vec::new(),
            };
            Some(super::ProfileFeature {
                features,
                surface: points,
            })
        })
    }

    fn fit_mapped(
        &self,
        features: &[Vec<Point3<f64>>],
        surface: &[Vec<Point3<f64>>],
    ) -> Option<super::view::Fitted> {
        super::view::fit_flat(features, surface)
    }

    fn needs_radius(&self) -> bool {
        false
    }

    fn uses_group_signs(&self) -> bool {
        false
    }
}

/// The plane method's plan on one rig: its flange poses and the table.
#[derive(Debug)]
pub struct PlanePlan {
    pub poses: Vec<Isometry3<f64>>,
    pub scene: Scene,
    /// The table face's height (base z, m).
    pub height: f64,
    /// Scanning on the move through the poses (`[plane.poses] scan_speed_mm_s`).
    pub passing: Option<crate::sim::poses::Passing>,
}

impl Plan for PlanePlan {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn scene(&self) -> &Scene {
        &self.scene
    }

    fn first_flange_pose(&self) -> Isometry3<f64> {
        self.poses[0]
    }

    fn simulate(&self, rig: &Rig, sim: &mut Sim) -> Result<Captures, Error> {
        let noisy = !rig.sensor.noise.is_off();
        let Sim { rng, mover, .. } = sim;
        let mut groups = Vec::with_capacity(self.poses.len());
        let mut profiles = Vec::with_capacity(self.poses.len());
        for (i, f) in self.poses.iter().enumerate() {
            let pose = rig.base_to_sensor(&mover.actual(&rig.robot, f));
            groups.push(Group {
                id: i,
                role: Role::Pose,
                sign: 0.0,
            });
            profiles.push(CaptureProfile {
                group: i,
                base_to_flange: *f,
                data: ProfileData::Raw(rig.sensor.profile(
                    &self.scene,
                    &pose,
                    noisy.then_some(&mut **rng),
                )),
            });
        }
        let mut caps = Captures {
            orientation_tolerance_deg: crate::calib::ORIENTATION_TOLERANCE_DEG,
            feature_sigma: None,
            judging: crate::captures::Judging::default(),
            method: Kind::Plane,
            sensor: rig.sensor.name.clone(),
            specimen_kind: SpecimenType::Plane,
            specimen_radius: None,
            edge_sense: None,
            truth: Some(rig.flange_to_sensor),
            groups,
            profiles,
            timing: None,
            kinematic: None,
        };
        if let Some(m) = &self.passing {
            m.apply(&mut caps);
        }
        Ok(caps)
    }
}

/// The line of one profile: the largest straight segment's points, their centroid and direction.
fn line_of(
    g: &Group,
    data: &ProfileData,
    cfg: &SplitMerge,
) -> Result<(Vector2<f64>, Vector2<f64>, Vec<Vector2<f64>>), CaptureError> {
    let ProfileData::Raw(prof) = data else {
        return Err(CaptureError::WrongData {
            group: g.id,
            method: Kind::Plane,
            need: "raw points (points_mm)",
        });
    };
    let too_few = |n: usize| {
        CaptureError::from(features::FeatureError::TooFewPoints {
            found: n,
            need: MIN_POINTS,
        })
    };
    let points = features::largest_segment(prof, cfg);
    if points.len() < MIN_POINTS {
        return Err(too_few(points.len()));
    }
    let centroid = points.iter().sum::<Vector2<f64>>() / points.len() as f64;
    let line = features::Line2::fit(&points).ok_or_else(|| too_few(points.len()))?;
    Ok((centroid, line.dir.normalize(), points))
}

/// Every profile's line, whatever its group; the plane from any poses.
fn calibrate(c: &Captures, sensor: &SensorModel) -> Result<(Calibration, Refined), Error> {
    let cfg = SplitMerge::for_sensor(sensor);
    let mut views = Vec::new();
    let mut reports = Vec::new();
    for g in &c.groups {
        let mut report = GroupReport::new(g.id);
        for p in c.group_profiles(g.id) {
            let line = line_of(g, &p.data, &cfg);
            if let Err(e @ CaptureError::WrongData { .. }) = &line {
                return Err(e.clone().into());
            }
            report.count(&line);
            if let Ok((centroid, direction, points)) = line {
                views.push(crate::calib::plane::LineView {
                    base_to_flange: p.base_to_flange,
                    centroid,
                    direction,
                    points,
                });
            }
        }
        // A group is one pose here: without its line it adds nothing.
        report.left_out = report.used == 0;
        reports.push(report);
    }
    super::leave_out_thin_groups(&mut reports, 1, crate::calib::plane::MIN_VIEWS, Kind::Plane)?;
    let sol = crate::calib::plane::solve(&views, &sensor.apex().coords)?;
    let missed = reports.iter().map(|r| r.profiles - r.used).sum();
    let cal = Calibration {
        flange_to_sensor: sol.flange_to_sensor,
        centre_in_base: None,
        figures: Metrics::default(),
        status: sol.refined.status,
        missed,
        groups: reports,
        refinable: Some(std::sync::Arc::new(sol.problem)),
        full_profile: None,
    };
    Ok((cal, sol.refined))
}
