//! Data collection for the ball two-step method (disk paper Sec. IV-A, V-D): captures at one
//! orientation (for R_sensor) and at other orientations (for T_sensor), each giving an arc.

use super::{PlanError, Rig, check_reachable, flange_pose};
use crate::calib::ball::{BallCapture, BallProblem, centre_from_arc};
use crate::features::fit_circle;
use crate::rng::gauss;
use nalgebra::{Isometry3, Point3, Rotation3, Vector2, Vector3};

/// The ball as the simulator knows it (base frame, metres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BallTarget {
    pub centre: Point3<f64>,
    pub radius: f64,
}

/// A flange pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    pub r_tcp: Rotation3<f64>,
    pub t_tcp: Vector3<f64>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct BallPlan {
    pub rotation_set: Vec<Pose>,
    pub translation_set: Vec<Pose>,
    /// m: arcs per translation-set capture (their centres are averaged).
    pub arcs: usize,
}

/// Check every pose: reachable, and the laser plane cuts the ball.
pub fn check(rig: &Rig, ball: &BallTarget, plan: &BallPlan) -> Result<(), PlanError> {
    for (i, p) in plan
        .rotation_set
        .iter()
        .chain(&plan.translation_set)
        .enumerate()
    {
        check_reachable(&rig.robot, i, &flange_pose(&p.r_tcp, &p.t_tcp))?;
        let c = rig
            .base_to_sensor(&flange_pose(&p.r_tcp, &p.t_tcp))
            .inverse_transform_point(&ball.centre);
        if c.y.abs() >= ball.radius * 0.98 {
            return Err(PlanError::BadScan {
                scan: i,
                reason: format!(
                    "the laser plane passes {:.1} mm from the ball centre and barely touches the ball",
                    c.y * 1e3
                ),
            });
        }
    }
    Ok(())
}

/// s_i for a capture: the sign of the ball centre's y in the sensor frame.
pub fn sign(base_to_sensor: &Isometry3<f64>, ball: &BallTarget) -> f64 {
    if base_to_sensor.inverse_transform_point(&ball.centre).y >= 0.0 {
        1.0
    } else {
        -1.0
    }
}

/// The arc the sensor sees, sampled every `x_step` in x over the central `fraction` of the circle of
/// intersection (the side facing the sensor), with Gaussian noise of `sigma` on z (Sec. V-D).
pub fn analytic_arc(
    rig: &Rig,
    ball: &BallTarget,
    base_to_sensor: &Isometry3<f64>,
    x_step: f64,
    sigma: f64,
    fraction: f64,
    rng: &mut crate::rng::Rng,
) -> Vec<Vector2<f64>> {
    analytic_arc_formed(
        rig,
        ball,
        None,
        base_to_sensor,
        x_step,
        sigma,
        fraction,
        rng,
    )
}

/// `analytic_arc` on a ball with an optional form error (the ball's frame and the error): each
/// point lies on the real surface, r = R + delta(u), found by fixed-point iteration on u.
/// Collected into `C` directly (a capture's shared points: one allocation, no copy).
#[allow(clippy::too_many_arguments)]
pub fn analytic_arc_formed<C: FromIterator<Vector2<f64>>>(
    rig: &Rig,
    ball: &BallTarget,
    form: Option<(&Isometry3<f64>, &crate::scene::FormError)>,
    base_to_sensor: &Isometry3<f64>,
    x_step: f64,
    sigma: f64,
    fraction: f64,
    rng: &mut crate::rng::Rng,
) -> C {
    let c = base_to_sensor.inverse_transform_point(&ball.centre);
    let rd2 = ball.radius * ball.radius - c.y * c.y;
    if rd2 <= 0.0 {
        return std::iter::empty().collect();
    }
    let rd = rd2.sqrt();
    let half = rd * fraction;
    let (k0, k1) = (
        ((c.x - half) / x_step).ceil() as i64,
        ((c.x + half) / x_step).floor() as i64,
    );
    (k0..=k1)
        .map(|k| {
            let x = k as f64 * x_step;
            let dz = (rd2 - (x - c.x).powi(2)).max(0.0).sqrt();
            // The branch nearer the sensor: toward -dir_z.
            let mut z = c.z - rig.sensor.dir_z * dz;
            if let Some((frame, f)) = form.filter(|(_, f)| !f.is_none()) {
                let sensor_to_ball = base_to_sensor.inverse() * frame;
                for _ in 0..6 {
                    let u = (nalgebra::Point3::new(x, 0.0, z) - c).normalize();
                    let u_ball = sensor_to_ball.inverse_transform_vector(&u);
                    let r =
                        ball.radius + f.displacement(&nalgebra::Point3::from(u_ball)).dot(&u_ball);
                    let d2 = r * r - c.y * c.y - (x - c.x).powi(2);
                    z = c.z - rig.sensor.dir_z * d2.max(0.0).sqrt();
                }
            }
            Vector2::new(x, z + gauss(rng) * sigma)
        })
        .collect()
}

fn capture_from_arcs(
    ball: &BallTarget,
    p: &Pose,
    s: f64,
    arcs: &[Vec<Vector2<f64>>],
) -> Result<BallCapture, PlanError> {
    let mut q = Vector3::zeros();
    for a in arcs {
        let c = fit_circle(a).ok_or(PlanError::NoCircle { points: a.len() })?;
        q += centre_from_arc(&c, ball.radius, s);
    }
    Ok(BallCapture {
        r_tcp: p.r_tcp,
        t_tcp: p.t_tcp,
        q_in_sensor: q / arcs.len() as f64,
    })
}

/// The method's input from analytic arcs: one arc per rotation-set capture, `plan.arcs` per
/// translation-set capture.
pub fn analytic_problem(
    rig: &Rig,
    ball: &BallTarget,
    plan: &BallPlan,
    x_step: f64,
    sigma: f64,
    rng: &mut crate::rng::Rng,
) -> Result<BallProblem, PlanError> {
    let mut one = |p: &Pose, m: usize| {
        let pose = rig.base_to_sensor(&flange_pose(&p.r_tcp, &p.t_tcp));
        let arcs: Vec<Vec<Vector2<f64>>> = (0..m)
            .map(|_| analytic_arc(rig, ball, &pose, x_step, sigma, 0.9, rng))
            .collect();
        capture_from_arcs(ball, p, sign(&pose, ball), &arcs)
    };
    let rotation_set = plan
        .rotation_set
        .iter()
        .map(|p| one(p, 1))
        .collect::<Result<_, _>>()?;
    let translation_set = plan
        .translation_set
        .iter()
        .map(|p| one(p, plan.arcs.max(1)))
        .collect::<Result<_, _>>()?;
    Ok(BallProblem {
        orientation_tolerance_deg: crate::calib::ORIENTATION_TOLERANCE_DEG,
        rotation_set,
        translation_set,
    })
}
