//! What a profile would have held had the flange that took it stood elsewhere: first-order moves,
//! in the sensor frame, of base-fixed points and of where the laser plane cuts base-fixed curves,
//! per unit of a flange twist. A closed form's response to a pose's actual error
//! (`method::Method::closed_form_recast`) re-casts its features with these.

use nalgebra::{Isometry3, Vector2, Vector3, Vector6};

/// How a base-fixed point, at `p_in_sensor` as the recorded pose sees it, moves in the sensor
/// frame per unit of the flange twist `twist` ([w rad; v m], the flange's own frame): the flange
/// f exp(xi) sees it at X^-1 exp(-xi) X p, so dp = -R_X^T (w x (X p) + v) to first order.
pub fn point_move(
    flange_to_sensor: &Isometry3<f64>,
    p_in_sensor: &Vector3<f64>,
    twist: &Vector6<f64>,
) -> Vector3<f64> {
    let p_in_flange = flange_to_sensor * nalgebra::Point3::from(*p_in_sensor);
    let (w, v) = (twist.fixed_rows::<3>(0), twist.fixed_rows::<3>(3));
    -(flange_to_sensor.rotation.inverse() * (w.cross(&p_in_flange.coords) + v))
}

/// How the point where the laser plane (the sensor's y = 0) cuts a base-fixed curve moves in
/// the plane ((x, z), m) per unit of the flange twist: `p` the cut as recorded (sensor frame,
/// y = 0), `tangent` the curve's direction there (sensor frame). The curve's point moves as
/// `point_move` and slides along the curve back into the plane. None where the curve runs
/// within the plane (its tangent's y below 1e-9 of its length), where the cut is not unique.
pub fn plane_cut_move(
    flange_to_sensor: &Isometry3<f64>,
    p: &Vector2<f64>,
    tangent: &Vector3<f64>,
    twist: &Vector6<f64>,
) -> Option<Vector2<f64>> {
    if !(tangent.y.abs() > 1e-9 * tangent.norm()) {
        return None;
    }
    let d = point_move(flange_to_sensor, &Vector3::new(p.x, 0.0, p.y), twist);
    let moved = d - tangent * (d.y / tangent.y);
    Some(Vector2::new(moved.x, moved.z))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Point3, UnitQuaternion};

    /// The moves are the derivatives of the exact geometry: the base-fixed point seen from the
    /// moved flange, and a base-fixed line's cut with the moved laser plane.
    #[test]
    fn the_moves_are_the_moved_flanges_view() {
        let x = Isometry3::new(Vector3::new(0.01, 0.05, 0.3), Vector3::new(0.2, -0.1, 2.9));
        let twist = Vector6::new(0.3, -0.5, 0.2, 0.4, 0.1, -0.7);
        let h = 1e-7;
        let moved_flange = Isometry3::new(
            twist.fixed_rows::<3>(3).into_owned() * h,
            twist.fixed_rows::<3>(0).into_owned() * h,
        );
        // Sensor frame of the moved flange, from the recorded one's: X^-1 exp(-xi) X.
        let seen = x.inverse() * moved_flange.inverse() * x;
        let p = Vector3::new(0.02, 0.0, 0.25);
        let exact = ((seen * Point3::from(p)).coords - p) / h;
        let d = point_move(&x, &p, &twist);
        assert!((d - exact).norm() < 1e-6 * exact.norm(), "{d} vs {exact}");

        // A line through p with direction t: its cut with the moved plane y = 0.
        let t = UnitQuaternion::from_euler_angles(0.3, 0.2, 0.1) * Vector3::new(0.2, 1.0, -0.3);
        let (a, b) = (seen * Point3::from(p), seen.rotation * t);
        let s = -a.y / b.y;
        let cut = a.coords + b * s;
        let exact = (Vector2::new(cut.x, cut.z) - Vector2::new(p.x, p.z)) / h;
        let d = plane_cut_move(&x, &Vector2::new(p.x, p.z), &t, &twist).unwrap();
        assert!((d - exact).norm() < 1e-6 * exact.norm(), "{d} vs {exact}");
        // A curve lying in the plane has no unique cut.
        let flat = Vector3::new(1.0, 0.0, 0.5);
        assert!(plane_cut_move(&x, &Vector2::new(p.x, p.z), &flat, &twist).is_none());
    }
}
