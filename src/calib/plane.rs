//! The plane from any poses (beyond both papers: a flat plate or the table face, after Carlson et
//! al. 2015 and Sharifzadeh et al. 2020). Each profile sees the plane as a line in the laser plane:
//! a centroid c_i and a direction u_i (sensor x, z). With the plane {q : n.q = d} in the base frame,
//! flange pose (R_i, t_i) and flange_to_sensor (R, t):
//!
//!   n . R_i R u_i = 0                                   (1)  the line lies in the plane
//!   n . (R_i (R c_i + t) + t_i) = d                     (2)  and so does its centroid
//!
//! 1. For a given normal n, (1) is linear and homogeneous in R's first and third columns (u_i has
//!    no y): the smallest eigenvector of a 6x6 matrix, projected onto SO(3). The normal is found by
//!    a search over 2,000 directions of a hemisphere (n and -n are one plane), scored by (1).
//! 2. (2) is then linear in (t, d). The sign of the eigenvector leaves R or R turned 180 deg about
//!    y, which (1) cannot tell apart, and when every profile's centroid lies at one depth (2)
//!    cannot either: the turned sensor looks at the plane from behind. The robot decides: the
//!    sensor's apex must lie on the flange's side of the plane (an arm does not reach through it).
//!    Otherwise the better fit of (2).
//! 3. From the best three normals, the joint refinement over every point's distance from the plane
//!    (`refine::plane`) on a subsample; the physical, lowest-cost one is refined over every point.
//!    While that one fits the profiles clearly worse than their own lines, as many normals again
//!    are screened (`solve_from_starts`).
//!
//! A plane fixes, in each pose, only the sensor's offset along its normal and two tilts: the
//! observability check of the refinement refuses pose sets that leave a direction free, and the
//! error says which motion or second surface adds it.

use super::CalibError;
use super::refine::plane::{Plane, PlaneModel};
use super::refine::{Options, Problem, Refined, refine};
use crate::math::nearest_rotation;
use nalgebra::{Isometry3, Matrix3, Matrix4, Matrix6, Rotation3, Translation3, UnitQuaternion};
use nalgebra::{Vector2, Vector3, Vector4, Vector6};

const METHOD: &str = "plane";

/// The fewest profiles (poses) the plane is solved from.
pub const MIN_VIEWS: usize = 7;

/// One profile's view of the plane: the flange pose, the fitted line (a point on it and its unit
/// direction, sensor x, z) and the points on it.
#[derive(Debug, Clone, PartialEq)]
pub struct LineView {
    pub base_to_flange: Isometry3<f64>,
    pub centroid: Vector2<f64>,
    pub direction: Vector2<f64>,
    pub points: Vec<Vector2<f64>>,
}

#[derive(Debug, Clone)]
pub struct PlaneSolution {
    pub flange_to_sensor: Isometry3<f64>,
    pub plane: Plane,
    pub refined: Refined,
    pub problem: Problem<PlaneModel>,
}

/// A start of the plane's refinement: screened on a subsample of the points.
#[derive(Debug, Clone)]
pub struct Start {
    pub flange_to_sensor: Isometry3<f64>,
    pub plane: Plane,
    pub cost: f64,
    /// The sensor on the flange's side of the plane in every view.
    pub physical: bool,
}

/// `apex`: the sensor's laser apex in its own frame (which side of the plane the sensor is on).
pub fn solve(views: &[LineView], apex: &Vector3<f64>) -> Result<PlaneSolution, CalibError> {
    along_depth(solve_from_starts(views, apex, 3)?)
}

/// A solution across the plane refined again along the sensor's depth (`refine::AlongDepth`:
/// no pull from the noise). Only the plane method's own result: where the plane is a start (a
/// bar's, a disk's face) the specimen's own fit is along the depth, and from a start that missed
/// (a bar's wall taken for its face) this fit can wander where that one no longer recovers.
fn along_depth(sol: PlaneSolution) -> Result<PlaneSolution, CalibError> {
    let model = PlaneModel {
        across: false,
        ..sol.problem.model
    };
    refined(model, &sol.flange_to_sensor, &sol.plane)
}

/// `model` refined from (x, plane), as a solution.
fn refined(
    model: PlaneModel,
    x: &Isometry3<f64>,
    plane: &Plane,
) -> Result<PlaneSolution, CalibError> {
    let (refined, plane) =
        refine(&model, x, plane, &Options::default()).map_err(with_plane_advice)?;
    Ok(PlaneSolution {
        flange_to_sensor: refined.flange_to_sensor,
        plane,
        refined,
        problem: Problem {
            model,
            specimen: plane,
        },
    })
}

/// `solve` screening the best `count` normals, then as many again as tried so far each round (up
/// to `MAX_STARTS`) while the best fits the profiles clearly worse than their own lines do: with
/// four orientations of the disk's four-scan protocol the truth's basin ranked between the
/// ninth and sixteenth normal once (12,800 columns, exact data), and the best of the first eight
/// left 2.3 mm where each profile's line fits its points exactly. Only the rank of the starts
/// tried changes; each is refined as before and the lowest cost wins.
pub fn solve_from_starts(
    views: &[LineView],
    apex: &Vector3<f64>,
    count: usize,
) -> Result<PlaneSolution, CalibError> {
    let screening = Screening::new(views)?;
    let mut all: Vec<Start> = Vec::new();
    let mut tried = 0;
    loop {
        // The first `count`, then as many again each round.
        let more = if tried == 0 { count.max(1) } else { tried };
        match screening.starts(apex, tried, tried + more) {
            Ok(s) => all.extend(s),
            Err(e) if all.is_empty() => return Err(e),
            Err(_) => {}
        }
        tried = (tried + more).min(screening.len());
        // A physical solution beats one that puts the sensor behind the plane; among equals,
        // starts that reach one minimum end equal to rounding: keep the first (see ball_any).
        let mut best: Option<&Start> = None;
        for s in &all {
            let better = |b: &&Start| {
                (s.physical && !b.physical)
                    || (s.physical == b.physical && s.cost < b.cost * (1.0 - 1e-9))
            };
            if best.as_ref().is_none_or(better) {
                best = Some(s);
            }
        }
        let best = best.ok_or(CalibError::TooFewData {
            method: METHOD,
            what: "starts",
            got: 0,
            need: 1,
        })?;
        if tried >= screening.len() || fits_like_its_lines(views, best) {
            return refine_from(views, best);
        }
    }
}

/// The most starts `solve_from_starts` screens.
const MAX_STARTS: usize = 32;

/// Whether the solution's median profile lies on the plane within three times the median
/// profile's scatter about its own line (a line has fewer freedoms than a plane seen across
/// poses leaves it, and a robot's pose error also parts the two: then every start is screened,
/// the lowest cost still winning), or within rounding of the points' scale.
fn fits_like_its_lines(views: &[LineView], start: &Start) -> bool {
    let median = |mut v: Vec<f64>| {
        let n = v.len();
        if n == 0 {
            return 0.0;
        }
        *v.select_nth_unstable_by(n / 2, f64::total_cmp).1
    };
    let plane = median(
        (views.iter())
            .map(|v| view_rms(v, &start.flange_to_sensor, &start.plane))
            .collect(),
    );
    let line = median(
        views
            .iter()
            .map(|v| {
                let normal = Vector2::new(-v.direction.y, v.direction.x);
                let sq: f64 = (v.points.iter())
                    .map(|p| normal.dot(&(p - v.centroid)).powi(2))
                    .sum();
                (sq / v.points.len().max(1) as f64).sqrt()
            })
            .collect(),
    );
    let scale = median(
        (views.iter())
            .flat_map(|v| v.points.first().map(|p| p.norm()))
            .collect(),
    );
    plane <= 3.0 * line + 1e-9 * scale
}

/// One profile's RMS distance from `plane`, seen through `flange_to_sensor`.
fn view_rms(v: &LineView, flange_to_sensor: &Isometry3<f64>, plane: &Plane) -> f64 {
    let n = plane.normal();
    let x = v.base_to_flange * flange_to_sensor;
    let sq: f64 = v
        .points
        .iter()
        .map(|p| {
            let q = x.transform_point(&nalgebra::Point3::new(p.x, 0.0, p.y));
            (n.dot(&q.coords) - plane.offset).powi(2)
        })
        .sum();
    (sq / v.points.len().max(1) as f64).sqrt()
}

/// `solve_from_starts`, robust to a profile whose line is not on the plane (a bar's wall or the
/// table under it taken for its face, which no single profile can always tell): solve, leave out
/// the profiles whose points lie off the plane by more than five times the median profile's RMS
/// (at least 1 um), and solve again, until none is left out (at most three rounds). Returns
/// which views were kept.
pub fn solve_leaving_out(
    views: &[LineView],
    apex: &Vector3<f64>,
    count: usize,
) -> Result<(Vec<bool>, PlaneSolution), CalibError> {
    let mut kept = vec![true; views.len()];
    for _ in 0..3 {
        let used: Vec<LineView> = views
            .iter()
            .zip(&kept)
            .filter(|(_, k)| **k)
            .map(|(v, _)| v.clone())
            .collect();
        let sol = solve_from_starts(&used, apex, count)?;
        let all: Vec<f64> = (views.iter())
            .map(|v| view_rms(v, &sol.flange_to_sensor, &sol.plane))
            .collect();
        let next = within_five_medians(&all, &kept);
        if next == kept || next.iter().filter(|k| **k).count() < MIN_VIEWS {
            return Ok((kept, sol));
        }
        kept = next;
    }
    let used: Vec<LineView> = views
        .iter()
        .zip(&kept)
        .filter(|(_, k)| **k)
        .map(|(v, _)| v.clone())
        .collect();
    Ok((kept, solve_from_starts(&used, apex, count)?))
}

/// The views whose RMS (`rms`, one per view) is within five times the median of those `kept`
/// (at least 1 um): a leave-out round of the solvers that no single profile can fool.
pub fn within_five_medians(rms: &[f64], kept: &[bool]) -> Vec<bool> {
    let mut sorted: Vec<f64> = rms
        .iter()
        .zip(kept)
        .filter(|(_, k)| **k)
        .map(|(r, _)| *r)
        .collect();
    sorted.sort_by(f64::total_cmp);
    let limit = sorted
        .get(sorted.len() / 2)
        .map_or(f64::INFINITY, |m| (5.0 * m).max(1e-6));
    rms.iter().map(|r| *r <= limit).collect()
}

/// Starts screened when the plane is a specimen's face (a plate's or a disk's: shorter lines than
/// a table's, noisier directions): from seven poses of a 60 mm plate the best three missed the
/// truth's basin once in 200 trials (z noise 0.1 mm); eight found it.
pub const FACE_STARTS: usize = 8;

/// The plane of a specimen's face from views that each carry one (`face`): `solve_leaving_out`
/// with `FACE_STARTS`, returning the views kept.
pub fn solve_faces<'a, V>(
    views: &'a [V],
    face: impl Fn(&V) -> &LineView,
    apex: &Vector3<f64>,
) -> Result<(Vec<&'a V>, PlaneSolution), CalibError> {
    let faces: Vec<LineView> = views.iter().map(|v| face(v).clone()).collect();
    let (kept, plane) = solve_leaving_out(&faces, apex, FACE_STARTS)?;
    let views = views
        .iter()
        .zip(&kept)
        .filter(|(_, k)| **k)
        .map(|(v, _)| v)
        .collect();
    Ok((views, plane))
}

/// Every profile's points against the plane from a screened start.
pub fn refine_from(views: &[LineView], start: &Start) -> Result<PlaneSolution, CalibError> {
    let keep = points_per_view(views, usize::MAX);
    let model = model_of(views, &|v| super::stride_for(v.points.len(), keep), true);
    refined(model, &start.flange_to_sensor, &start.plane)
}

/// Points per view the fits keep (at most `most`; fewer past `super::POINT_BUDGET`).
fn points_per_view(views: &[LineView], most: usize) -> usize {
    let total = views.iter().map(|v| v.points.len()).sum();
    super::points_per_profile(total, views.len(), most)
}

/// The points of every profile, every `stride`-th.
fn model_of(views: &[LineView], stride: &dyn Fn(&LineView) -> usize, across: bool) -> PlaneModel {
    PlaneModel {
        across,
        points: views
            .iter()
            .flat_map(|v| {
                v.points
                    .iter()
                    .step_by(stride(v))
                    .map(move |p| (v.base_to_flange, *p))
            })
            .collect(),
    }
}

/// Steps 1-3 up to the screening: the normals ranked by (1) over a hemisphere, and each start
/// refined on at most 64 points per profile (their spread along the line is what fixes the tilts).
pub struct Screening<'a> {
    views: std::borrow::Cow<'a, [LineView]>,
    /// The best normals at least 10 deg apart, best first (at most `MAX_STARTS`).
    normals: Vec<Vector3<f64>>,
    screen: PlaneModel,
}

impl<'a> Screening<'a> {
    pub fn new(views: &'a [LineView]) -> Result<Screening<'a>, CalibError> {
        // Each profile gives two equations for nine unknowns, but from six poses the equations
        // can have a second exact solution (two random setups of six: both had one, 175 deg
        // away): seven.
        if views.len() < MIN_VIEWS {
            return Err(CalibError::TooFewData {
                method: METHOD,
                what: "profiles of the plane (each at its own orientation)",
                got: views.len(),
                need: MIN_VIEWS,
            });
        }
        let views = screening_views(views);
        let mut ranked: Vec<(f64, Vector3<f64>)> = hemisphere(2000)
            .map(|n| (rotation_cost(&views, &n).0, n))
            .collect();
        ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut normals: Vec<Vector3<f64>> = Vec::new();
        for (_, n) in &ranked {
            if normals.len() == MAX_STARTS {
                break;
            }
            if !normals
                .iter()
                .any(|m| m.dot(n).abs() > 10f64.to_radians().cos())
            {
                normals.push(*n);
            }
        }
        let keep = points_per_view(&views, 64);
        let screen = model_of(&views, &|v| super::stride_for(v.points.len(), keep), true);
        Ok(Screening {
            views,
            normals,
            screen,
        })
    }

    /// The starts from the normals ranked `from` up to `to`, each refined: side by side (the
    /// starts are independent; read back in order, the same result on any number of threads).
    pub fn starts(
        &self,
        apex: &Vector3<f64>,
        from: usize,
        to: usize,
    ) -> Result<Vec<Start>, CalibError> {
        use rayon::prelude::*;
        let views = &self.views[..];
        let to = to.min(self.normals.len());
        let refined: Vec<_> = self.normals[from.min(to)..to]
            .par_iter()
            .map(|n| {
                let (x, plane) = start_from(views, n, apex);
                refine(&self.screen, &x, &plane, &Options::default())
            })
            .collect();
        let mut out = Vec::new();
        let mut first_err = None;
        for r in refined {
            // A start can sit where the pose set looks degenerate though the truth is not (a
            // rank-deficient Jacobian at a wild start): skipped, unless every start is.
            let (refined, plane) = match r {
                Ok(r) => r,
                Err(e) => {
                    first_err.get_or_insert(with_plane_advice(e));
                    continue;
                }
            };
            out.push(Start {
                physical: behind(views, &refined.flange_to_sensor, &plane, apex) == 0,
                flange_to_sensor: refined.flange_to_sensor,
                plane,
                cost: refined.cost,
            });
        }
        match first_err {
            Some(e) if out.is_empty() => Err(e),
            _ => Ok(out),
        }
    }

    /// How many normals there are to start from.
    pub fn len(&self) -> usize {
        self.normals.len()
    }

    pub fn is_empty(&self) -> bool {
        self.normals.is_empty()
    }
}

/// Views the screening of starts takes at most: it only has to find the basin, which a few
/// hundred views spread over the pose set show as well as a continuous scan's thousands; the
/// refinement from the best start then takes them all.
const SCREENING_VIEWS: usize = 512;

/// At most `SCREENING_VIEWS` of `views`, evenly spread (all of them when they are fewer).
fn screening_views(views: &[LineView]) -> std::borrow::Cow<'_, [LineView]> {
    if views.len() <= SCREENING_VIEWS {
        return std::borrow::Cow::Borrowed(views);
    }
    let stride = views.len().div_ceil(SCREENING_VIEWS);
    std::borrow::Cow::Owned(views.iter().step_by(stride).cloned().collect())
}

/// What a plane cannot fix, and what adds it.
fn with_plane_advice(e: CalibError) -> CalibError {
    match e {
        CalibError::Unobservable {
            method,
            ratio,
            weakest,
            ..
        } => CalibError::Unobservable {
            method,
            ratio,
            fix: format!(
                "a plane fixes, per pose, only the sensor's offset along its normal and two tilts, \
                 so the {weakest} is left free: tilt the sensor against the plane about two \
                 different axes (10-30 deg each way) and turn it about the plane's normal between \
                 poses, or add a second, non-parallel surface"
            ),
            weakest,
        },
        other => other,
    }
}

/// Directions spread over the upper hemisphere (z >= 0), Fibonacci spiral.
fn hemisphere(n: usize) -> impl Iterator<Item = Vector3<f64>> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n).map(move |i| {
        let z = 1.0 - (i as f64 + 0.5) / n as f64;
        let rho = (1.0 - z * z).sqrt();
        let phi = golden * i as f64;
        Vector3::new(rho * phi.cos(), rho * phi.sin(), z)
    })
}

/// Step 1 for normal `n`: R from (1), and the sum of squared (1) residuals with it.
fn rotation_cost(views: &[LineView], n: &Vector3<f64>) -> (f64, Rotation3<f64>) {
    let mut g = Matrix6::zeros();
    let rows: Vec<Vector6<f64>> = views
        .iter()
        .map(|v| {
            let w = v.base_to_flange.rotation.inverse() * n;
            let (ux, uz) = (v.direction.x, v.direction.y);
            Vector6::new(w.x * ux, w.y * ux, w.z * ux, w.x * uz, w.y * uz, w.z * uz)
        })
        .collect();
    for r in &rows {
        g += r * r.transpose();
    }
    let eig = nalgebra::SymmetricEigen::new(g);
    let k = eig.eigenvalues.imin();
    let v = eig.eigenvectors.column(k);
    let (r1, r3) = (
        Vector3::new(v[0], v[1], v[2]),
        Vector3::new(v[3], v[4], v[5]),
    );
    let r = nearest_rotation(&Matrix3::from_columns(&[r1, r3.cross(&r1), r3]));
    let cost = views
        .iter()
        .map(|v| {
            let u = Vector3::new(v.direction.x, 0.0, v.direction.y);
            (n.dot(&(v.base_to_flange.rotation * (r * u)))).powi(2)
        })
        .sum();
    (cost, r)
}

/// How many views put the sensor's apex on the other side of the plane from the flange.
fn behind(views: &[LineView], x: &Isometry3<f64>, plane: &Plane, apex: &Vector3<f64>) -> usize {
    let n = plane.normal();
    views
        .iter()
        .filter(|v| {
            let a = (v.base_to_flange * x).transform_point(&(*apex).into());
            let side_apex = n.dot(&a.coords) - plane.offset;
            let side_flange = n.dot(&v.base_to_flange.translation.vector) - plane.offset;
            side_apex * side_flange < 0.0
        })
        .count()
}

/// Steps 1-2 for normal `n`: the transform and the plane to refine from.
fn start_from(
    views: &[LineView],
    n: &Vector3<f64>,
    apex: &Vector3<f64>,
) -> (Isometry3<f64>, Plane) {
    let (_, r) = rotation_cost(views, n);
    let flipped = r * Rotation3::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI);
    let candidate = |rot: Rotation3<f64>| {
        let (t, d, cost) = position(views, n, &rot);
        let x = Isometry3::from_parts(
            Translation3::from(t),
            UnitQuaternion::from_rotation_matrix(&rot),
        );
        let plane = Plane::new(n, d);
        (behind(views, &x, &plane, apex), cost, x, plane)
    };
    let (a, b) = (candidate(r), candidate(flipped));
    let pick = if (a.0, a.1) <= (b.0, b.1) { a } else { b };
    (pick.2, pick.3)
}

/// (2) in least squares for (t, d) given n and R, with its sum of squared residuals.
fn position(views: &[LineView], n: &Vector3<f64>, r: &Rotation3<f64>) -> (Vector3<f64>, f64, f64) {
    let mut a = Matrix4::zeros();
    let mut rhs = Vector4::zeros();
    let rows: Vec<(Vector4<f64>, f64)> = views
        .iter()
        .map(|v| {
            let w = v.base_to_flange.rotation.inverse() * n;
            let c = Vector3::new(v.centroid.x, 0.0, v.centroid.y);
            let b = -n.dot(&v.base_to_flange.translation.vector)
                - n.dot(&(v.base_to_flange.rotation * (r * c)));
            (Vector4::new(w.x, w.y, w.z, -1.0), b)
        })
        .collect();
    for (row, b) in &rows {
        a += row * row.transpose();
        rhs += row * *b;
    }
    // Poses at one orientation leave (t, d) singular: the minimum-norm start, which the
    // refinement's observability check then refuses.
    let x = a
        .pseudo_inverse(1e-12 * a.norm())
        .map(|inv| inv * rhs)
        .unwrap_or_else(|_| Vector4::zeros());
    let cost = rows.iter().map(|(row, b)| (row.dot(&x) - b).powi(2)).sum();
    (Vector3::new(x[0], x[1], x[2]), x[3], cost)
}
