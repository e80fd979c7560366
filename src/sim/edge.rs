//! Data collection for the straight-edge method (Xu et al., Sec. 3-4): a grid of flange rotations x
//! translations; within a rotation group the translations follow a circular arc; every profile
//! crosses the same edge in the same sense.

use super::ball::{BallTarget, analytic_arc};
use super::{PlanError, Rig, check_reachable};
use crate::calib::edge::{EdgeCapture, EdgeProblem};
use crate::features::{self, EdgeSense};
use crate::rng::gauss;
use nalgebra::{
    Isometry3, Point3, Rotation3, Translation3, Unit, UnitQuaternion, Vector2, Vector3,
};

/// The straight edge as the simulator knows it (base frame): a point, the edge direction, the
/// direction from the specimen body out over the edge, and the top face's normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeTarget {
    pub point: Point3<f64>,
    pub dir: Unit<Vector3<f64>>,
    pub outward: Unit<Vector3<f64>>,
    pub up: Unit<Vector3<f64>>,
    /// Half the edge's length: the profiles must cross it within +- this of `point`.
    pub half_length: f64,
}

impl EdgeTarget {
    /// From an edge specimen's pose (its frame: x along the edge, body at y < 0, top face +z) and
    /// the edge's length.
    pub fn from_pose(base_to_specimen: &Isometry3<f64>, length: f64) -> EdgeTarget {
        let r = base_to_specimen.rotation;
        EdgeTarget {
            point: base_to_specimen * Point3::origin(),
            dir: Unit::new_normalize(r * Vector3::x()),
            outward: Unit::new_normalize(r * Vector3::y()),
            up: Unit::new_normalize(r * Vector3::z()),
            half_length: length / 2.0,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct EdgePlanSpec {
    /// Rotation groups (the paper: 25) and translations per group (10).
    pub rotations: usize,
    pub translations: usize,
    /// Largest tilt of a group from the nominal orientation (radians).
    pub tilt: f64,
    /// The circular arc of the translations: radius (m) and span (radians).
    pub arc_radius: f64,
    pub arc_span: f64,
    /// Angle of the arc's chord from the edge direction toward `outward` (radians, 0 < h < pi/2).
    pub arc_heading: f64,
    /// Sensor z at which the laser line crosses the edge.
    pub edge_z: f64,
}

/// One rotation group: the flange rotation and its translations.
#[derive(Debug, Clone, PartialEq)]
pub struct EdgeGroupPlan {
    pub r_tcp: Rotation3<f64>,
    pub tcps: Vec<Vector3<f64>>,
}

/// The nominal sensor orientation: laser plane across the edge (sensor y along it), looking at the
/// top face.
fn nominal(rig: &Rig, e: &EdgeTarget) -> Rotation3<f64> {
    let z = if rig.sensor.dir_z < 0.0 {
        e.up.into_inner()
    } else {
        -e.up.into_inner()
    };
    let y = e.dir.into_inner();
    let x = y.cross(&z);
    Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_columns(&[x, y, z]))
}

/// Which way the profiles cross the edge.
pub fn sense(rig: &Rig, e: &EdgeTarget) -> EdgeSense {
    if (nominal(rig, e) * Vector3::x()).dot(&e.outward) > 0.0 {
        EdgeSense::Falling
    } else {
        EdgeSense::Rising
    }
}

/// Plan the grid without the reachability check.
pub fn plan_unchecked(
    rig: &Rig,
    e: &EdgeTarget,
    spec: &EdgePlanSpec,
) -> Result<Vec<EdgeGroupPlan>, PlanError> {
    if spec.rotations < 2 || spec.translations < 3 {
        return Err(PlanError::BadScan {
            scan: 0,
            reason: format!(
                "{} rotations x {} translations: the edge method needs at least 2 x 3",
                spec.rotations, spec.translations
            ),
        });
    }
    let r0 = nominal(rig, e);
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let sensor_to_flange = rig.flange_to_sensor.inverse();
    let mut out = Vec::with_capacity(spec.rotations);
    for g in 0..spec.rotations {
        // Group 0 is the nominal pose; the others tilt about axes spread by the golden angle, with
        // tilts spread over (0.4 .. 1) x tilt, some spin about the view axis mixed in.
        let rot = if g == 0 {
            Rotation3::identity()
        } else {
            let phi = g as f64 * golden;
            let frac = 0.4 + 0.6 * ((g as f64 * 0.618_034) % 1.0);
            let axis =
                Unit::new_normalize(Vector3::new(phi.cos(), phi.sin(), 0.5 * (2.0 * phi).sin()));
            Rotation3::from_axis_angle(&axis, spec.tilt * frac)
        };
        let r_bs = r0 * rot;
        let mut tcps = Vec::with_capacity(spec.translations);
        for k in 0..spec.translations {
            let th =
                -spec.arc_span / 2.0 + spec.arc_span * k as f64 / (spec.translations - 1) as f64;
            // The arc's chord runs at `arc_heading` from the edge: a move along the edge spreads the
            // points along it (the PCA direction needs that) but never changes the profile, which
            // only a move across it does (the rotation equations need that); the bow of the arc
            // (toward `up`) keeps the profile points off a single line.
            let chord = e.dir.into_inner() * spec.arc_heading.cos()
                + e.outward.into_inner() * spec.arc_heading.sin();
            let delta = chord * (spec.arc_radius * th.sin())
                + e.up.into_inner() * (spec.arc_radius * (1.0 - th.cos()));
            let origin = e.point.coords + delta - r_bs * Vector3::new(0.0, 0.0, spec.edge_z);
            let base_to_sensor = Isometry3::from_parts(
                Translation3::from(origin),
                UnitQuaternion::from_rotation_matrix(&r_bs),
            );
            let base_to_flange = base_to_sensor * sensor_to_flange;
            tcps.push(base_to_flange.translation.vector);
        }
        let r_tcp = (r_bs * sensor_to_flange.rotation.to_rotation_matrix()).into_inner();
        out.push(EdgeGroupPlan {
            r_tcp: Rotation3::from_matrix_unchecked(r_tcp),
            tcps,
        });
    }
    Ok(out)
}

/// Plan the grid and check, at every pose, that the robot reaches it and the sensor sees the edge
/// crossing inside its measurement range and field of view.
pub fn plan(
    rig: &Rig,
    e: &EdgeTarget,
    spec: &EdgePlanSpec,
) -> Result<Vec<EdgeGroupPlan>, PlanError> {
    let plans = plan_unchecked(rig, e, spec)?;
    let s = &rig.sensor;
    for (g, p) in plans.iter().enumerate() {
        for (k, t) in p.tcps.iter().enumerate() {
            let pose = super::flange_pose(&p.r_tcp, t);
            check_reachable(&rig.robot, g, &pose)?;
            let q =
                exact_point(&rig.base_to_sensor(&pose), e).ok_or_else(|| PlanError::BadScan {
                    scan: g,
                    reason: "the laser plane is parallel to the edge".into(),
                })?;
            let along =
                (rig.base_to_sensor(&pose) * Point3::new(q.x, 0.0, q.y) - e.point).dot(&e.dir);
            if along.abs() > e.half_length * 0.95 {
                return Err(PlanError::BadScan {
                    scan: g,
                    reason: format!(
                        "translation {k}: the laser crosses the edge line {:.1} mm from the specimen's middle, beyond its {:.0} mm length; use a longer specimen or a smaller arc_radius_mm / arc_heading_deg",
                        along * 1e3,
                        e.half_length * 2e3
                    ),
                });
            }
            let depth = s.depth(&Point3::new(q.x, 0.0, q.y));
            if depth < s.depth_near
                || depth > s.depth_far
                || s.tan_of(q.x, q.y).abs() > s.tan_half_fov
            {
                let (zlo, zhi) = s.z_range();
                return Err(PlanError::BadScan {
                    scan: g,
                    reason: format!(
                        "translation {k}: the edge crosses the laser line at ({:.1}, {:.1}) mm, outside the sensor's view (z {:.0}..{:.0} mm, |x| <= {:.0}% of depth); reduce arc_radius_mm, arc_span_deg or tilt_deg, or lower arc_heading_deg",
                        q.x * 1e3,
                        q.y * 1e3,
                        zlo * 1e3,
                        zhi * 1e3,
                        s.tan_half_fov * 100.0
                    ),
                });
            }
        }
    }
    Ok(plans)
}

/// Where the laser plane (sensor y = 0) meets the edge line, in the sensor's (x, z).
pub fn exact_point(base_to_sensor: &Isometry3<f64>, e: &EdgeTarget) -> Option<Vector2<f64>> {
    let p = base_to_sensor.inverse_transform_point(&e.point);
    let d = base_to_sensor.inverse_transform_vector(&e.dir);
    if d.y.abs() < 1e-12 {
        return None;
    }
    let q = p + d * (-p.y / d.y);
    Some(Vector2::new(q.x, q.z))
}

/// `exact_point` on an edge with a form error (`base_to_specimen`: the edge's frame): where the
/// laser plane meets the bowed edge, by Newton's method along it from the straight edge's point.
pub fn exact_point_formed(
    base_to_sensor: &Isometry3<f64>,
    e: &EdgeTarget,
    base_to_specimen: &Isometry3<f64>,
    form: &crate::scene::FormError,
) -> Option<Vector2<f64>> {
    let q = exact_point(base_to_sensor, e)?;
    if form.is_none() {
        return Some(q);
    }
    let sensor_to_specimen = base_to_sensor.inverse() * base_to_specimen;
    let edge = |x: f64| {
        let p = Point3::new(x, 0.0, 0.0);
        sensor_to_specimen * (p + form.displacement(&p))
    };
    let x = sensor_to_specimen
        .inverse_transform_point(&Point3::new(q.x, 0.0, q.y))
        .x;
    super::laser_plane_crossing(edge, x).map(|p| Vector2::new(p.x, p.z))
}

/// Exact edge points with Gaussian noise of `sigma` on x and z.
pub fn analytic_problem(
    rig: &Rig,
    e: &EdgeTarget,
    plans: &[EdgeGroupPlan],
    sigma: f64,
    rng: &mut crate::rng::Rng,
) -> Result<EdgeProblem, PlanError> {
    let mut groups = Vec::with_capacity(plans.len());
    for (g, p) in plans.iter().enumerate() {
        let mut caps = Vec::with_capacity(p.tcps.len());
        for t in &p.tcps {
            let pose = rig.base_to_sensor(&super::flange_pose(&p.r_tcp, t));
            let (nx, nz) = (gauss(rng) * sigma, gauss(rng) * sigma);
            let q = exact_point(&pose, e).ok_or(PlanError::ParallelToEdge { group: g })?;
            caps.push(EdgeCapture {
                r_tcp: p.r_tcp,
                t_tcp: *t,
                p_in_sensor: q + Vector2::new(nx, nz),
            });
        }
        groups.push(caps);
    }
    Ok(EdgeProblem {
        groups,
        orientation_tolerance_deg: crate::calib::ORIENTATION_TOLERANCE_DEG,
    })
}

/// The edge paper's Table 3 check: scan a precision ball with `groups` rotations x `translations`
/// translations around it, map the arc points to the base frame with `estimate`, fit a sphere, and
/// return its radius (metres).
pub fn ball_radius_check(
    rig: &Rig,
    estimate: &Isometry3<f64>,
    ball: &BallTarget,
    groups: usize,
    translations: usize,
    sigma: f64,
    x_step: f64,
    rng: &mut crate::rng::Rng,
) -> Option<f64> {
    // Look down at the ball from the sensor's working depth, tilted per group, stepping across it.
    let z_look = rig.sensor.range_centre().z;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let down = if rig.sensor.dir_z < 0.0 {
        Vector3::z()
    } else {
        -Vector3::z()
    };
    let r0 = Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_columns(&[
        Vector3::y().cross(&down),
        Vector3::y(),
        down,
    ]));
    let mut pts = Vec::new();
    for g in 0..groups {
        let phi = g as f64 * golden;
        let tilt = if g == 0 { 0.0 } else { 0.25 };
        let r = r0
            * Rotation3::from_axis_angle(
                &Unit::new_normalize(Vector3::new(phi.cos(), phi.sin(), 0.0)),
                tilt,
            );
        for k in 0..translations {
            let off = (k as f64 / (translations.max(2) - 1) as f64 - 0.5) * 1.2 * ball.radius;
            let origin = ball.centre.coords + r * Vector3::new(0.0, off, 0.0)
                - r * Vector3::new(0.0, 0.0, z_look - ball.radius * 0.0);
            let truth = Isometry3::from_parts(
                Translation3::from(origin),
                UnitQuaternion::from_rotation_matrix(&r),
            );
            // The robot reports flange poses; the estimate maps sensor points with them.
            let base_to_flange = truth * rig.flange_to_sensor.inverse();
            for p in analytic_arc(rig, ball, &truth, x_step, sigma, 0.9, rng) {
                pts.push((base_to_flange * estimate * Point3::new(p.x, 0.0, p.y)).coords);
            }
        }
    }
    features::fit_sphere(&pts).map(|s| s.radius)
}
