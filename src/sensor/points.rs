//! A profiler known only by its points: no rays, no range, no field of view, only the frame the
//! points are given in and which way its z axis points. Most public recordings are such (a list of
//! x, z per profile from a profiler nobody names); the surface-fitting estimators need nothing
//! more, and the closed forms place a feature's end halfway to the next point.

use super::{RaySpacing, Resample, SensorError, SensorGeometry, SensorModel};
use nalgebra::Point3;

/// Where a points-only sensor's depth starts: a virtual apex this far before the nearest point,
/// so that the "rays" (the grid's slot lines x = const) are parallel and every point is in front.
const VIRTUAL_APEX: f64 = 1.0;

/// The uniform x grid every point of these profiles lies on, to a tenth of its pitch (a profiler's
/// resampled output): the pitch from the smallest steps between neighbouring points, the offset
/// from the points' phases. Any length unit; the grid comes back in it. None when there is no
/// such grid.
pub fn uniform_grid(profiles: &[Vec<f64>]) -> Option<Resample> {
    let mut steps = steps(profiles);
    steps.sort_by(f64::total_cmp);
    let smallest = *steps.first()?;
    // Neighbouring slots are the common case: the steps within 1.5x the smallest are one pitch.
    let ones: Vec<f64> = steps
        .into_iter()
        .take_while(|d| *d < 1.5 * smallest)
        .collect();
    let pitch = ones[ones.len() / 2];
    // The offset: the mean phase of the points on a circle of one pitch (no wrap-around trouble).
    let (mut c, mut s) = (0.0, 0.0);
    for x in profiles.iter().flatten() {
        let a = std::f64::consts::TAU * x / pitch;
        c += a.cos();
        s += a.sin();
    }
    let offset = s.atan2(c) / std::f64::consts::TAU * pitch;
    let on_grid = profiles.iter().flatten().all(|x| {
        let m = (x - offset) / pitch;
        (m - m.round()).abs() <= 0.1
    });
    on_grid.then_some(Resample { pitch, offset })
}

/// The positive steps between neighbouring x values of each profile.
fn steps(profiles: &[Vec<f64>]) -> Vec<f64> {
    profiles
        .iter()
        .flat_map(|xs| {
            xs.windows(2)
                .map(|w| (w[1] - w[0]).abs())
                .filter(|d| *d > 0.0)
                .collect::<Vec<_>>()
        })
        .collect()
}

/// Each point's slot on a grid: the nearest, or the next free one when an earlier point of the
/// profile took it (two points within a tenth of a pitch of one slot). `xs` sorted.
pub fn slots(xs: &[f64], grid: &Resample) -> Vec<i64> {
    let mut last = i64::MIN;
    xs.iter()
        .map(|x| {
            let k = ((x - grid.offset) / grid.pitch).round() as i64;
            last = k.max(last.saturating_add(1));
            last
        })
        .collect()
}

impl SensorModel {
    /// A sensor known only by its points (sensor-frame x, z in metres, one list per profile) and
    /// the direction of its z axis (`dir_z` +1: z grows away from the sensor, -1: toward it).
    /// Its columns are the slots of the x grid the points lie on (measured from them), or, when
    /// they lie on none, each point's place in its list (the profiler's own column order, `None`
    /// where it found nothing). Its range is the points' z extent. It has no rays: the features
    /// end one point step past a face's last point (`features`); it states no noise (the caller
    /// measures it from the profiles) and cannot ray-cast.
    pub fn points_only(
        profiles: &[Vec<Option<[f64; 2]>>],
        dir_z: f64,
    ) -> Result<SensorModel, SensorError> {
        let name = "points only";
        let bad =
            |field: &'static str, value: f64, reason: &'static str| SensorError::BadGeometry {
                name: name.into(),
                field,
                value,
                reason,
            };
        let xs: Vec<Vec<f64>> = profiles
            .iter()
            .map(|p| {
                let mut x: Vec<f64> = p.iter().flatten().map(|q| q[0]).collect();
                x.sort_by(f64::total_cmp);
                x
            })
            .collect();
        let all = || profiles.iter().flatten().flatten();
        let n = all().count();
        if n < 2 || all().any(|q| !q[0].is_finite() || !q[1].is_finite()) {
            return Err(bad(
                "points",
                n as f64,
                "a sensor known by its points needs at least two finite points",
            ));
        }
        let (zlo, zhi) = all().fold((f64::INFINITY, f64::NEG_INFINITY), |a, q| {
            (a.0.min(q[1]), a.1.max(q[1]))
        });
        // The range is what the points show: a face that would run on past its nearest or
        // farthest point may have left the range unseen (`features::disk_profile`).
        let apex_z = if dir_z > 0.0 {
            zlo - VIRTUAL_APEX
        } else {
            zhi + VIRTUAL_APEX
        };
        let depth_far = VIRTUAL_APEX + (zhi - zlo).max(1e-9);
        let toward = if dir_z > 0.0 { "away from" } else { "toward" };
        let reach = all().fold(0.0f64, |a, q| a.max(q[0].abs()));
        let (grid, columns, step) = match uniform_grid(&xs) {
            // A resampling profiler's output: each point in its slot of the grid, in x order.
            Some(g) => {
                let slots = (2.0 * (reach + 2.0 * g.pitch) / g.pitch).ceil();
                if !(slots < super::MAX_COLUMNS as f64) {
                    return Err(bad(
                        "points",
                        2.0 * reach * 1e3,
                        "the points span more than 65,536 steps of their grid (mm across the \
                         profiles given): split the recording, or declare the sensor's geometry",
                    ));
                }
                (Some(g), 2, g.pitch)
            }
            // Off any grid (a fan's own rays): each point keeps its place in its list, the
            // profiler's column order, and the step is the points' median spacing.
            None => {
                let mut s = steps(&xs);
                s.sort_by(f64::total_cmp);
                let Some(&step) = s.get(s.len() / 2) else {
                    return Err(bad(
                        "points",
                        n as f64,
                        "every profile's points share one x: no line to measure along",
                    ));
                };
                let longest = profiles.iter().map(Vec::len).max().unwrap_or(0);
                if longest > super::MAX_COLUMNS {
                    return Err(bad(
                        "points",
                        longest as f64,
                        "a profile of more than 65,536 entries",
                    ));
                }
                (None, longest.max(2), step)
            }
        };
        let mut model = SensorModel::from_geometry(SensorGeometry {
            name: format!(
                "{name} (z {toward} the sensor; {})",
                if grid.is_some() {
                    format!("x on the profiles' grid of {:.4} mm", step * 1e3)
                } else {
                    format!("points in their given order, {:.4} mm apart", step * 1e3)
                }
            ),
            frame: format!("the points' own frame, z {toward} the sensor"),
            apex_z,
            dir_z: dir_z.signum(),
            depth_near: VIRTUAL_APEX,
            depth_far,
            tan_half_fov: (reach + 2.0 * step) / depth_far,
            columns,
            spacing: RaySpacing::EqualTan,
            x_reversed: false,
            z_quantum: None,
            camera: Point3::new(0.0, 0.0, apex_z),
            resample: grid,
        })?;
        model.points_only = true;
        model.point_step = step;
        Ok(model)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_uniform_grid_is_measured_and_its_points_keep_their_slots() {
        let p = |x0: f64, n: usize| -> Vec<Option<[f64; 2]>> {
            (0..n)
                .map(|i| Some([x0 + i as f64 * 5e-5, -0.02 + i as f64 * 1e-6]))
                .collect()
        };
        let profiles = vec![p(0.04135, 400), p(0.03, 100)];
        let s = SensorModel::points_only(&profiles, -1.0).unwrap();
        let g = s.resampling().unwrap();
        assert!((g.pitch - 5e-5).abs() < 1e-12, "{g:?}");
        for q in profiles.iter().flatten().flatten() {
            let u = s.column_of(q[0], q[1]).unwrap();
            assert!((u - u.round()).abs() < 1e-6 && u >= 0.0 && u < s.columns as f64);
            assert!(s.sees(q[0], q[1]), "{q:?}");
        }
        assert_eq!(s.end_offset_columns(0.5), 0.5);
        assert_eq!(s.x_step_at_depth(0.5), g.pitch);
        assert!(
            s.name.contains("toward") && s.name.contains("0.0500 mm"),
            "{}",
            s.name
        );
    }

    #[test]
    fn points_off_any_grid_keep_their_places_in_the_list() {
        // Steps growing along the line, as an equal-angle fan's raw points, one missing.
        let mut pts: Vec<Option<[f64; 2]>> = (0..300)
            .map(|i| Some([0.01 * (i as f64 * 0.004).sinh(), 0.1]))
            .collect();
        pts[7] = None;
        let s = SensorModel::points_only(&[pts.clone()], 1.0).unwrap();
        assert!(
            s.resampling().is_none() && s.columns == 300,
            "{}",
            s.columns
        );
        assert!(s.name.contains("given order"), "{}", s.name);
        let step = s.x_step_at_depth(1.0);
        assert!(step > 4e-5 && step < 6e-5, "{step}");
    }

    #[test]
    fn a_grids_slots_stay_in_order_when_two_points_share_one() {
        let grid = Resample {
            pitch: 1e-4,
            offset: 0.0,
        };
        assert_eq!(slots(&[0.0, 0.2e-4, 1e-4, 3e-4], &grid), vec![0, 1, 2, 3]);
    }

    #[test]
    fn too_few_or_unbounded_points_are_refused() {
        assert!(SensorModel::points_only(&[vec![Some([0.0, 0.0])]], 1.0).is_err());
        let nan = vec![Some([0.0, 0.0]), Some([f64::NAN, 0.0])];
        assert!(SensorModel::points_only(&[nan], 1.0).is_err());
        let wide = vec![Some([0.0, 0.0]), Some([1e-9, 0.0]), Some([50.0, 0.0])];
        let e = SensorModel::points_only(&[wide], 1.0).unwrap_err();
        assert!(e.to_string().contains("65,536"), "{e}");
    }
}
