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
use crate::sim::{Rig, check_reachable};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector2, Vector3};
use rand::RngExt;

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
        v.at_least(
            "plane.poses",
            p.poses,
            crate::calib::plane::MIN_VIEWS,
            "at least 7 poses, each at its own orientation",
        )?;
        if p.poses > 10_000 {
            return Err(v.bad("plane.poses", p.poses, "at most 10000 poses"));
        }
        let [lo, hi] = p.tilt_deg;
        if !(lo >= 0.0 && hi >= lo && hi < 75.0) {
            return Err(v.bad(
                "plane.tilt_deg",
                format!("{:?}", p.tilt_deg),
                "give [min, max] with 0 <= min <= max < 75 (deg from the plane's normal)",
            ));
        }
        if p.aim_mm.iter().any(|x| !x.is_finite()) {
            return Err(v.bad("plane.aim_mm", format!("{:?}", p.aim_mm), "must be finite"));
        }
        v.non_negative("plane.spread_mm", p.spread_mm)?;
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
        let rig = &common.rig;
        let mut g = rng::stream(sc.seed, &[tag::PLAN, 4]);
        let (lo, hi) = (p.tilt_deg[0].to_radians(), p.tilt_deg[1].to_radians());
        let mut poses = Vec::with_capacity(p.poses);
        for i in 0..p.poses {
            // Draw until the robot reaches the pose (a pose set is only useful when it can be
            // driven); a hundred misses in a row mean the aim or the tilts are out of reach.
            let mut last = None;
            let found = (0..100).find_map(|_| {
                let f = draw_pose(&mut g, rig, table.height_m, p.aim_mm, p.spread_mm, lo, hi);
                match check_reachable(&rig.robot, i, &f) {
                    Ok(()) => Some(f),
                    Err(e) => {
                        last = Some(e);
                        None
                    }
                }
            });
            match found {
                Some(f) => poses.push(f),
                None => {
                    return Err(v.bad(
                        "plane.aim_mm",
                        format!("{:?}", p.aim_mm),
                        format!(
                            "pose {i}: 100 draws were out of the robot's reach (last: {}); aim \
                             nearer the robot or narrow plane.tilt_deg",
                            last.map_or_else(String::new, |e| e.to_string())
                        ),
                    ));
                }
            }
        }
        Ok(Box::new(PlanePlan {
            poses,
            scene: Scene::new(Some(table)),
            height: table.height_m,
        }))
    }

    fn calibrate(&self, c: &Captures, sensor: &SensorModel) -> Result<Calibration, Error> {
        calibrate(c, sensor).map(|(cal, _)| cal)
    }

    fn calibrate_any_pose(
        &self,
        c: &Captures,
        sensor: &SensorModel,
    ) -> Result<(Calibration, Refined), Error> {
        calibrate(c, sensor)
    }

    fn needs_radius(&self) -> bool {
        false
    }

    fn uses_group_signs(&self) -> bool {
        false
    }
}

/// A flange pose whose sensor looks at the table at `tilt` in [lo, hi] from its normal, the middle
/// of its range on the table within `spread` of `aim`, turned at random about the normal and about
/// the laser's axis.
fn draw_pose(
    g: &mut crate::rng::Rng,
    rig: &Rig,
    height: f64,
    aim_mm: [f64; 2],
    spread_mm: f64,
    lo: f64,
    hi: f64,
) -> Isometry3<f64> {
    let tilt = lo + (hi - lo) * g.random::<f64>();
    let (azimuth, roll) = (
        std::f64::consts::TAU * g.random::<f64>(),
        std::f64::consts::TAU * g.random::<f64>(),
    );
    let (r, a) = (
        spread_mm * 1e-3 * g.random::<f64>().sqrt(),
        std::f64::consts::TAU * g.random::<f64>(),
    );
    let aim = Point3::new(
        aim_mm[0] * 1e-3 + r * a.cos(),
        aim_mm[1] * 1e-3 + r * a.sin(),
        height,
    );
    // The laser travels along the sensor's z times dir_z; it should point down, tilted.
    let ray = -Vector3::new(
        tilt.sin() * azimuth.cos(),
        tilt.sin() * azimuth.sin(),
        tilt.cos(),
    );
    let z_axis = ray * rig.sensor.dir_z;
    let rot = UnitQuaternion::rotation_between(&Vector3::z(), &z_axis).unwrap_or_else(|| {
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
    }) * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), roll);
    // The aim lands up to 35 % of the range before or beyond its middle: profiles at one depth
    // leave the sensor turned 180 deg about y nearly as good a fit (see calib::plane).
    let s = &rig.sensor;
    let depth = 0.5 * (s.depth_near + s.depth_far)
        + 0.35 * (s.depth_far - s.depth_near) * (2.0 * g.random::<f64>() - 1.0);
    let at = Vector3::new(0.0, 0.0, s.apex_z + s.dir_z * depth);
    let base_to_sensor = Isometry3::from_parts(Translation3::from(aim.coords - rot * at), rot);
    base_to_sensor * rig.flange_to_sensor.inverse()
}

/// The plane method's plan on one rig: its flange poses and the table.
#[derive(Debug)]
pub struct PlanePlan {
    pub poses: Vec<Isometry3<f64>>,
    pub scene: Scene,
    /// The table face's height (base z, m).
    pub height: f64,
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
        Ok(Captures {
            method: Kind::Plane,
            sensor: rig.sensor.name.clone(),
            specimen_kind: SpecimenType::Plane,
            specimen_radius: None,
            edge_sense: None,
            truth: Some(rig.flange_to_sensor),
            groups,
            profiles,
        })
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
    let pts = features::valid_points(prof);
    let too_few = |n: usize| {
        CaptureError::from(features::FeatureError::TooFewPoints {
            found: n,
            need: MIN_POINTS,
        })
    };
    if pts.len() < MIN_POINTS {
        return Err(too_few(pts.len()));
    }
    let segs = features::split_and_merge(&pts, cfg);
    let s = segs
        .iter()
        .max_by_key(|s| s.last - s.first)
        .ok_or_else(|| too_few(0))?;
    if s.last + 1 - s.first < MIN_POINTS {
        return Err(too_few(s.last + 1 - s.first));
    }
    let points: Vec<Vector2<f64>> = pts[s.first..=s.last].iter().map(|p| p.1).collect();
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
    };
    Ok((cal, sol.refined))
}
