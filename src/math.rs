//! Small geometry helpers shared by every module (pure math, no I/O).

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// R = Rz(rz) * Ry(ry) * Rx(rx): the "ZYX Euler" reading of the disk paper's Tables I and III
/// (the same composition as URDF rpy).
pub fn rot_zyx(rx: f64, ry: f64, rz: f64) -> Rotation3<f64> {
    Rotation3::from_euler_angles(rx, ry, rz)
}

/// Pose from a position in metres and an R = Rz*Ry*Rx orientation in radians.
pub fn pose_from_xyz_rpy(xyz: [f64; 3], rpy: [f64; 3]) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(xyz[0], xyz[1], xyz[2]),
        UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
    )
}

/// Quaternion as [w, x, y, z] with w >= 0 (the sign ABB RAPID and most tools print).
pub fn quat_wxyz(q: &UnitQuaternion<f64>) -> [f64; 4] {
    let c = q.coords; // x, y, z, w
    let s = if c[3] < 0.0 { -1.0 } else { 1.0 };
    [s * c[3], s * c[0], s * c[1], s * c[2]]
}

/// Angle in radians of the rotation that takes `a` to `b`.
pub fn rotation_angle_between(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> f64 {
    a.angle_to(b)
}

/// Nearest proper rotation to a 3x3 matrix (SVD with the determinant guard against reflections).
pub fn nearest_rotation(m: &Matrix3<f64>) -> Rotation3<f64> {
    let svd = m.svd(true, true);
    match (svd.u, svd.v_t) {
        (Some(u), Some(v_t)) => {
            let d = (u * v_t).determinant().signum();
            Rotation3::from_matrix_unchecked(
                u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t,
            )
        }
        // nalgebra always returns U and V when asked; a non-finite input gets no rotation.
        _ => Rotation3::from_matrix_unchecked(Matrix3::from_element(f64::NAN)),
    }
}

/// Wrap an angle into (-pi, pi].
pub fn wrap_pi(a: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    let mut x = a % two_pi;
    if x <= -std::f64::consts::PI {
        x += two_pi;
    } else if x > std::f64::consts::PI {
        x -= two_pi;
    }
    x
}

/// Pose as a 4x4 row-major matrix with the translation in millimetres (the papers' unit).
pub fn pose_to_rows_mm(p: &Isometry3<f64>) -> [[f64; 4]; 4] {
    let m = p.to_homogeneous();
    let mut out = [[0.0; 4]; 4];
    for (r, row) in out.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = m[(r, c)] * if c == 3 && r < 3 { 1000.0 } else { 1.0 };
        }
    }
    out
}

/// The pose at time `t` from a stream of timed poses (times strictly increasing): linear in
/// position and spherical in rotation (the shorter way) between the two samples around `t`, a
/// sample itself at its own time. None outside the stream's first and last times: a profile
/// the controller logged no pose around is not placed by extrapolation.
pub fn pose_at(stream: &[(f64, Isometry3<f64>)], t: f64) -> Option<Isometry3<f64>> {
    let (first, last) = (stream.first()?, stream.last()?);
    if !(t >= first.0 && t <= last.0) {
        return None;
    }
    // The first sample later than t; t lies in [its predecessor's time, its time).
    let k = stream.partition_point(|(s, _)| *s <= t);
    if k == 0 || k == stream.len() {
        return Some(if k == 0 { first.1 } else { last.1 });
    }
    let ((ta, a), (tb, b)) = (stream[k - 1], stream[k]);
    let u = (t - ta) / (tb - ta);
    if u == 0.0 {
        return Some(a);
    }
    let translation = a.translation.vector.lerp(&b.translation.vector, u);
    // Two samples of one stream are never half a turn apart; were they, the nearer one holds.
    // nalgebra's slerp of two nearby rotations leaves |q| off 1 by up to 1e-10 (a turn of that
    // many radians in every point it maps): normalised again.
    let rotation = a
        .rotation
        .try_slerp(&b.rotation, u, 1e-12)
        .map(|q| UnitQuaternion::new_normalize(q.into_inner()))
        .unwrap_or(if u < 0.5 { a.rotation } else { b.rotation });
    Some(Isometry3::from_parts(
        Translation3::from(translation),
        rotation,
    ))
}

/// The flange's velocity at time `t` on `pose_at`'s interpolation of `stream`, in the moving
/// frame (a body twist): angular (rad/s) and linear (m/s) such that the pose at `t + h` is the
/// pose at `t` times (exp(h angular), h linear) to first order in `h`. The interpolation is
/// piecewise, so this is the velocity of the segment holding `t` (the later one at a sample's
/// own time); zero at the stream's ends and outside it.
pub fn velocity_at(stream: &[(f64, Isometry3<f64>)], t: f64) -> (Vector3<f64>, Vector3<f64>) {
    let zero = (Vector3::zeros(), Vector3::zeros());
    let (Some(first), Some(last)) = (stream.first(), stream.last()) else {
        return zero;
    };
    if !(t >= first.0 && t < last.0) {
        return zero;
    }
    let k = stream.partition_point(|(s, _)| *s <= t);
    let ((ta, a), (tb, b)) = (stream[k - 1], stream[k]);
    let dt = tb - ta;
    // Slerp turns about one axis fixed in the moving frame at a constant rate: a^-1 b's.
    let turn = (a.rotation.inverse() * b.rotation).scaled_axis() / dt;
    let Some(here) = pose_at(stream, t) else {
        return zero;
    };
    let linear = here.rotation.inverse() * ((b.translation.vector - a.translation.vector) / dt);
    (turn, linear)
}

/// Partial sums per quantity in `lane_sums`: lane l takes items l, l + 8, ...
const LANES: usize = 8;

/// The sums over `items` of each of the `K` quantities `terms` gives an item, kept as eight
/// partial sums each: one running sum is a chain of dependent adds no compiler may reorder,
/// eight of them vectorise (inline this into a function built for the wider vector units). The
/// order is fixed (lanes, then the lanes in order, then the items past the last whole eight),
/// so the bits do not depend on the vector unit.
#[inline(always)]
pub fn lane_sums<T, const K: usize>(items: &[T], terms: impl Fn(&T) -> [f64; K]) -> [f64; K] {
    let mut acc = [[0.0f64; LANES]; K];
    let groups = items.chunks_exact(LANES);
    let tail = groups.remainder();
    for g in groups {
        for l in 0..LANES {
            let t = terms(&g[l]);
            for k in 0..K {
                acc[k][l] += t[k];
            }
        }
    }
    let mut out = acc.map(|lanes| lanes.iter().sum::<f64>());
    for item in tail {
        let t = terms(item);
        for k in 0..K {
            out[k] += t[k];
        }
    }
    out
}

/// The standard normal distribution function (Abramowitz and Stegun 7.1.26: within 1.5e-7). By
/// hand: one function, not worth a crate.
pub fn normal_cdf(x: f64) -> f64 {
    let z = x.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * z);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erf = 1.0 - poly * (-z * z).exp();
    if x >= 0.0 {
        0.5 * (1.0 + erf)
    } else {
        0.5 * (1.0 - erf)
    }
}
