//! Closed-form inverse kinematics for ortho-parallel arms with a spherical wrist (both ABB arms).
//!
//! The parameters are read off the URDF, not typed in: joint 1 about z, joints 2-3 about y in the arm
//! plane, joint 4 about x, 5 about y, 6 about x, the wrist centre where axes 4-6 meet.

use super::{Joint, Joints, Robot, RobotError};
use crate::math::wrap_pi;
use nalgebra::{Isometry3, Matrix3, Rotation3, Vector3};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

const GEOM_TOL: f64 = 1e-9;

/// Arm geometry in the arm plane (metres). With q1 = 0 the arm plane is the base x-z plane and the
/// wrist centre sits at x = a1 + c2 sin q2 + c3 cos q23 + d sin q23, z = c1 + c2 cos q2 - c3 sin q23
/// + d cos q23.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OpwParams {
    /// Shoulder offset along the arm plane's x.
    pub a1: f64,
    /// Shoulder height above the base.
    pub c1: f64,
    /// Upper-arm length (joint 2 to joint 3).
    pub c2: f64,
    /// Forearm length along x of link 3 (joint 3 to the wrist centre).
    pub c3: f64,
    /// Forearm offset along z of link 3 (the elbow offset).
    pub d: f64,
    /// Wrist centre to flange along axis 6.
    pub c4: f64,
    /// Pose of tool0 in link 6.
    pub link6_to_tool0: Isometry3<f64>,
}

fn check_axis(j: &Joint, want: Vector3<f64>, path: &str) -> Result<(), RobotError> {
    let rot_ok = (j.prev_to_joint.rotation.angle()).abs() < GEOM_TOL;
    if !rot_ok || (j.axis.into_inner() - want).norm() > GEOM_TOL {
        return Err(RobotError::NotOrthoParallel {
            path: path.to_string(),
            reason: format!(
                "joint '{}' turns about {:?} with origin rpy angle {:.3e}; expected axis {:?} and no \
                 origin rotation",
                j.name,
                j.axis.as_ref().as_slice(),
                j.prev_to_joint.rotation.angle(),
                want.as_slice()
            ),
        });
    }
    Ok(())
}

fn check_zero(v: f64, what: &str, j: &Joint, path: &str) -> Result<(), RobotError> {
    if v.abs() > GEOM_TOL {
        return Err(RobotError::NotOrthoParallel {
            path: path.to_string(),
            reason: format!("joint '{}' origin has {what} = {v} m; expected 0", j.name),
        });
    }
    Ok(())
}

impl OpwParams {
    pub(crate) fn from_chain(
        joints: &[Joint],
        last_to_tool0: &Isometry3<f64>,
        path: &str,
    ) -> Result<OpwParams, RobotError> {
        let axes = [
            Vector3::z(),
            Vector3::y(),
            Vector3::y(),
            Vector3::x(),
            Vector3::y(),
            Vector3::x(),
        ];
        for (j, a) in joints.iter().zip(axes) {
            check_axis(j, a, path)?;
        }
        let t: Vec<Vector3<f64>> = joints
            .iter()
            .map(|j| j.prev_to_joint.translation.vector)
            .collect();
        check_zero(t[0].x, "x", &joints[0], path)?;
        check_zero(t[0].y, "y", &joints[0], path)?;
        check_zero(t[1].y, "y", &joints[1], path)?;
        check_zero(t[2].x, "x", &joints[2], path)?;
        check_zero(t[2].y, "y", &joints[2], path)?;
        check_zero(t[3].y, "y", &joints[3], path)?;
        check_zero(t[4].y, "y", &joints[4], path)?;
        check_zero(t[4].z, "z", &joints[4], path)?;
        check_zero(t[5].y, "y", &joints[5], path)?;
        check_zero(t[5].z, "z", &joints[5], path)?;
        let p = OpwParams {
            a1: t[1].x,
            c1: t[0].z + t[1].z,
            c2: t[2].z,
            c3: t[3].x + t[4].x,
            d: t[3].z,
            c4: t[5].x,
            link6_to_tool0: *last_to_tool0,
        };
        if p.c2 <= 0.0 || p.c3.hypot(p.d) <= 0.0 {
            return Err(RobotError::NotOrthoParallel {
                path: path.to_string(),
                reason: format!(
                    "upper arm {} m or forearm {} m is not positive",
                    p.c2,
                    p.c3.hypot(p.d)
                ),
            });
        }
        Ok(p)
    }
}

/// Rx(a) Ry(b) Rx(c) = m: both branches (b > 0 and b < 0); at the wrist singularity (sin b = 0)
/// only a + c is determined and `a` is taken from `a_hint`.
fn wrist_xyx(m: &Matrix3<f64>, a_hint: f64) -> Vec<[f64; 3]> {
    let sb = m[(0, 1)].hypot(m[(0, 2)]);
    if sb < 1e-12 {
        // b = 0: Rx(a + c); b = pi: Rx(a) Ry(pi) Rx(c) = Ry(pi) Rx(c - a).
        if m[(0, 0)] > 0.0 {
            let sum = m[(2, 1)].atan2(m[(1, 1)]);
            vec![[a_hint, 0.0, sum - a_hint]]
        } else {
            let diff = m[(2, 1)].atan2(-m[(1, 1)]);
            vec![[a_hint, PI, diff + a_hint]]
        }
    } else {
        let b = sb.atan2(m[(0, 0)]);
        let a = m[(1, 0)].atan2(-m[(2, 0)]);
        let c = m[(0, 1)].atan2(m[(0, 2)]);
        vec![[a, b, c], [a + PI, -b, c + PI]]
    }
}

impl Robot {
    /// Every joint solution within limits that puts tool0 at `base_to_tool0`, nearest `seed` first
    /// when a seed is given (the seed also fixes the free angle at a singularity).
    pub fn ik(
        &self,
        base_to_tool0: &Isometry3<f64>,
        seed: Option<&Joints>,
    ) -> Result<Vec<Joints>, RobotError> {
        let p = &self.opw;
        let base_to_link6 = base_to_tool0 * p.link6_to_tool0.inverse();
        let r06 = base_to_link6.rotation.to_rotation_matrix();
        let w = base_to_link6.translation.vector - r06 * Vector3::new(p.c4, 0.0, 0.0);
        let hint = seed.copied().unwrap_or([0.0; 6]);

        let rho = w.x.hypot(w.y);
        let shoulder: Vec<(f64, f64)> = if rho < 1e-12 {
            vec![(hint[0], 0.0)]
        } else {
            let q1 = w.y.atan2(w.x);
            vec![(q1, rho), (q1 + PI, -rho)]
        };
        let l3 = p.c3.hypot(p.d);
        let phi = p.d.atan2(p.c3);
        let mut raw: Vec<Joints> = Vec::with_capacity(8);
        let mut reach_excess = f64::INFINITY;
        for (q1, r) in shoulder {
            let (px, pz) = (r - p.a1, w.z - p.c1);
            let s2 = px * px + pz * pz;
            let k = (s2 - p.c2 * p.c2 - l3 * l3) / (2.0 * p.c2 * l3);
            let s = s2.sqrt();
            reach_excess = reach_excess.min((s - (p.c2 + l3)).max((p.c2 - l3).abs() - s));
            if k.abs() > 1.0 + 1e-12 {
                continue;
            }
            let k = k.clamp(-1.0, 1.0);
            let d0 = k.acos();
            let elbows: &[f64] = if d0 < 1e-12 || PI - d0 < 1e-12 {
                &[d0]
            } else {
                &[d0, -d0]
            };
            for &delta in elbows {
                // (px, pz) = e^{i beta} (c2 + l3 e^{-i delta}); beta = pi/2 - q2.
                let beta = pz.atan2(px) - (-l3 * delta.sin()).atan2(p.c2 + l3 * delta.cos());
                let q2 = FRAC_PI_2 - beta;
                let q23 = delta - beta + phi;
                let q3 = q23 - q2;
                let r03 = Rotation3::from_axis_angle(&Vector3::z_axis(), q1)
                    * Rotation3::from_axis_angle(&Vector3::y_axis(), q23);
                let r36 = r03.transpose() * r06;
                for [q4, q5, q6] in wrist_xyx(r36.matrix(), hint[3]) {
                    raw.push([q1, q2, q3, q4, q5, q6].map(wrap_pi));
                }
            }
        }
        if raw.is_empty() {
            return Err(RobotError::OutOfReach {
                reason: format!(
                    "the wrist centre ({:.1}, {:.1}, {:.1}) mm lies {:.1} mm outside the arm's reach",
                    w.x * 1e3,
                    w.y * 1e3,
                    w.z * 1e3,
                    reach_excess * 1e3
                ),
            });
        }
        let mut out: Vec<Joints> = Vec::new();
        for q in &raw {
            self.expand_turns(q, 0, *q, &mut out);
        }
        if out.is_empty() {
            let worst = raw
                .iter()
                .map(|q| self.limit_violation(q))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap_or((String::new(), 0.0));
            return Err(RobotError::OutsideLimits {
                reason: format!(
                    "{} geometric solution(s) exist, the closest one misses the limits of {} by {:.2} deg",
                    raw.len(),
                    worst.0,
                    worst.1.to_degrees()
                ),
            });
        }
        // Remove duplicates from singular branches.
        out.sort_by(|a, b| {
            a.iter()
                .zip(b)
                .map(|(x, y)| x.total_cmp(y))
                .find(|o| o.is_ne())
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        out.dedup_by(|a, b| a.iter().zip(b.iter()).all(|(x, y)| (x - y).abs() < 1e-9));
        if let Some(s) = seed {
            out.sort_by(|a, b| joint_distance(a, s).total_cmp(&joint_distance(b, s)));
        }
        Ok(out)
    }

    /// The solution nearest `seed` (Euclidean distance in joint space).
    pub fn ik_nearest(
        &self,
        base_to_tool0: &Isometry3<f64>,
        seed: &Joints,
    ) -> Result<Joints, RobotError> {
        Ok(self.ik(base_to_tool0, Some(seed))?[0])
    }

    /// Add every 2*pi multiple of each joint value that stays within limits.
    fn expand_turns(&self, base: &Joints, k: usize, mut cur: Joints, out: &mut Vec<Joints>) {
        if k == 6 {
            out.push(cur);
            return;
        }
        let j = &self.joints[k];
        let tol = 1e-12;
        let n_lo = ((j.lower_rad - tol - base[k]) / TAU).ceil() as i64;
        let n_hi = ((j.upper_rad + tol - base[k]) / TAU).floor() as i64;
        for n in n_lo..=n_hi {
            cur[k] = base[k] + n as f64 * TAU;
            self.expand_turns(base, k + 1, cur, out);
        }
    }

    /// The joint whose limit a configuration misses by most, and by how much (radians).
    fn limit_violation(&self, q: &Joints) -> (String, f64) {
        let mut worst = (String::new(), 0.0);
        for (j, &v) in self.joints.iter().zip(q) {
            // Distance to the range over all 2*pi turns of v.
            let lo = (j.lower_rad - v).rem_euclid(TAU);
            let miss = if v + lo <= j.upper_rad {
                0.0
            } else {
                (v + lo - j.upper_rad).min(TAU - lo)
            };
            if miss > worst.1 {
                worst = (j.name.clone(), miss);
            }
        }
        worst
    }
}

/// Euclidean distance between two joint vectors (radians).
pub fn joint_distance(a: &Joints, b: &Joints) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}
