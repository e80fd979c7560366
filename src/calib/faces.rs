//! A line target with two faces from any poses (beyond both papers): a ridge or roof (a knife's
//! edge is a sharp one), a V groove, a step's face and wall. Each profile sees both faces, as two
//! lines meeting at a corner; in the base frame they lie on two planes whose intersection is the
//! target's line. No protocol, no start and no labels from the user.
//!
//! 1. One face alone is a plane: `calib::plane` solves it from each profile's first face (the one
//!    at lower sensor x), which fixes flange_to_sensor; profiles whose first face lies off it (the
//!    laser crossing the line the other way, so that the faces swap) are left out and the plane
//!    solved again.
//! 2. With that transform, every profile's faces are labelled by the plane they fit: the first
//!    plane's, or the second's, which is fitted to the rest (the smallest eigenvector of their
//!    scatter).
//! 3. Both faces' points refined together (`refine::faces`), relabelled once more from the result.

use super::CalibError;
use super::plane::LineView;
use super::refine::faces::FacesModel;
use super::refine::plane::Plane;
use super::refine::{Options, Problem, Refined, refine};
use nalgebra::{Isometry3, Matrix3, Point3, Vector3};

const METHOD: &str = "two-face any-pose";

/// One profile's two faces (each a line view: its points and their line), lower sensor x first.
#[derive(Debug, Clone, PartialEq)]
pub struct FacesView {
    pub faces: [LineView; 2],
}

#[derive(Debug, Clone)]
pub struct FacesSolution {
    pub flange_to_sensor: Isometry3<f64>,
    pub planes: [Plane; 2],
    pub refined: Refined,
    pub problem: Problem<FacesModel>,
}

impl FacesSolution {
    /// The line where the faces meet (base frame): a point on it and its direction.
    pub fn line(&self) -> Option<(Point3<f64>, Vector3<f64>)> {
        meet(&self.planes)
    }
}

/// The line two planes share: a point (nearest the origin) and the direction; None when parallel.
fn meet(p: &[Plane; 2]) -> Option<(Point3<f64>, Vector3<f64>)> {
    let (n0, n1) = (p[0].normal(), p[1].normal());
    let dir = n0.cross(&n1);
    if dir.norm() < 1e-9 {
        return None;
    }
    let m = Matrix3::from_rows(&[n0.transpose(), n1.transpose(), dir.transpose()]);
    let q = m.try_inverse()? * Vector3::new(p[0].offset, p[1].offset, 0.0);
    Some((Point3::from(q), dir.normalize()))
}

/// Solve, then leave out the profiles whose faces lie off the two planes by more than five times
/// the median profile's RMS (at least 1 um): a third surface taken for a face (the plate a ridge
/// stands on), which no single profile can always tell. Refit from the result until none is left
/// out (at most three rounds). Returns which views were kept.
pub fn solve(
    views: &[FacesView],
    apex: &Vector3<f64>,
) -> Result<(Vec<bool>, FacesSolution), CalibError> {
    let (_, first) = super::plane::solve_faces(views, |v| &v.faces[0], apex)?;
    let mut sol = from_start(views, &first.flange_to_sensor, &first.plane)?;
    let mut kept = vec![true; views.len()];
    for _ in 0..3 {
        let rms: Vec<f64> = views
            .iter()
            .map(|v| view_rms(v, &sol.flange_to_sensor, &sol.planes))
            .collect();
        let next = super::plane::within_five_medians(&rms, &kept);
        if next == kept || next.iter().filter(|k| **k).count() < super::plane::MIN_VIEWS {
            break;
        }
        kept = next;
        let used: Vec<FacesView> = views
            .iter()
            .zip(&kept)
            .filter(|(_, k)| **k)
            .map(|(v, _)| v.clone())
            .collect();
        sol = from_start(&used, &sol.flange_to_sensor, &sol.planes[0])?;
    }
    Ok((kept, sol))
}

/// The two-face refinement problem with the transform held at `x` (another estimator's result,
/// such as the edge paper's closed form on a ridge): the first faces' plane, each view's faces
/// labelled by it, the second plane through the rest, the first refitted to its own. The
/// full-profile variant refines it. None with fewer than three points on a face.
pub fn problem_at(views: &[FacesView], x: &Isometry3<f64>) -> Option<Problem<FacesModel>> {
    let first = fit_plane(views, x, &vec![false; views.len()], 0)?;
    let labels = label(views, x, &first, None);
    let second = fit_plane(views, x, &labels, 1)?;
    let first = fit_plane(views, x, &labels, 0)?;
    Some(Problem {
        model: model_of(views, &labels),
        specimen: [first, second],
    })
}

/// A view's RMS distance from the two planes, its faces on the planes they fit best.
fn view_rms(v: &FacesView, x: &Isometry3<f64>, planes: &[Plane; 2]) -> f64 {
    let t = v.faces[0].base_to_flange * x;
    let sq = |face: &LineView, p: &Plane| -> f64 {
        let n = p.normal();
        face.points
            .iter()
            .map(|q| {
                (n.dot(&t.transform_point(&Point3::new(q.x, 0.0, q.y)).coords) - p.offset).powi(2)
            })
            .sum()
    };
    let [a, b] = &v.faces;
    let best = (sq(a, &planes[0]) + sq(b, &planes[1])).min(sq(a, &planes[1]) + sq(b, &planes[0]));
    (best / (a.points.len() + b.points.len()).max(1) as f64).sqrt()
}

/// Steps 2-3 from a transform and the first face's plane.
pub fn from_start(
    views: &[FacesView],
    x: &Isometry3<f64>,
    first: &Plane,
) -> Result<FacesSolution, CalibError> {
    let x = *x;
    let first_plane = *first;
    let labels = label(views, &x, &first_plane, None);
    let second = fit_plane(views, &x, &labels, 1).ok_or(CalibError::TooFewData {
        method: METHOD,
        what: "points on the second face",
        got: 0,
        need: 3,
    })?;
    let planes = [first_plane, second];
    let (refined, planes, labels) = refine_faces(views, &x, planes, &labels)?;
    // Relabelled from the joint result: once more if any face changed sides.
    let again = label(
        views,
        &refined.flange_to_sensor,
        &planes[0],
        Some(&planes[1]),
    );
    let (refined, planes, labels) = if again != labels {
        refine_faces(views, &refined.flange_to_sensor, planes, &again)?
    } else {
        (refined, planes, labels)
    };
    let model = model_of(views, &labels);
    Ok(FacesSolution {
        flange_to_sensor: refined.flange_to_sensor,
        planes,
        refined,
        problem: Problem {
            model,
            specimen: planes,
        },
    })
}

/// Each view's faces' planes: `swap` true when its first face is on plane 1. With one plane known,
/// a view's faces go the way whose first face fits plane 0 better.
fn label(views: &[FacesView], x: &Isometry3<f64>, p0: &Plane, p1: Option<&Plane>) -> Vec<bool> {
    views
        .iter()
        .map(|v| {
            let rms = |face: &LineView, p: &Plane| {
                let n = p.normal();
                let t = v.faces[0].base_to_flange * x;
                let sq: f64 = face
                    .points
                    .iter()
                    .map(|q| {
                        (n.dot(&t.transform_point(&Point3::new(q.x, 0.0, q.y)).coords) - p.offset)
                            .powi(2)
                    })
                    .sum();
                sq / face.points.len().max(1) as f64
            };
            let (a, b) = (&v.faces[0], &v.faces[1]);
            match p1 {
                None => rms(b, p0) < rms(a, p0),
                Some(p1) => rms(a, p1) + rms(b, p0) < rms(a, p0) + rms(b, p1),
            }
        })
        .collect()
}

/// The plane through the points of face `k` (after labels), from their scatter.
fn fit_plane(views: &[FacesView], x: &Isometry3<f64>, swap: &[bool], k: usize) -> Option<Plane> {
    let pts: Vec<Vector3<f64>> = views
        .iter()
        .zip(swap)
        .flat_map(|(v, &s)| {
            let face = &v.faces[if s { 1 - k } else { k }];
            let t = v.faces[0].base_to_flange * x;
            face.points
                .iter()
                .map(move |q| t.transform_point(&Point3::new(q.x, 0.0, q.y)).coords)
        })
        .collect();
    if pts.len() < 3 {
        return None;
    }
    let c = pts.iter().sum::<Vector3<f64>>() / pts.len() as f64;
    let scatter: Matrix3<f64> = pts.iter().map(|p| (p - c) * (p - c).transpose()).sum();
    let eig = scatter.symmetric_eigen();
    let n = eig.eigenvectors.column(eig.eigenvalues.imin()).into_owned();
    Some(Plane::new(&n, n.dot(&c)))
}

fn model_of(views: &[FacesView], swap: &[bool]) -> FacesModel {
    FacesModel {
        points: views
            .iter()
            .zip(swap)
            .flat_map(|(v, &s)| {
                (0..2).flat_map(move |k| {
                    let plane = if s { 1 - k } else { k };
                    v.faces[k]
                        .points
                        .iter()
                        .map(move |p| (v.faces[k].base_to_flange, *p, plane))
                })
            })
            .collect(),
    }
}

fn refine_faces(
    views: &[FacesView],
    x: &Isometry3<f64>,
    planes: [Plane; 2],
    swap: &[bool],
) -> Result<(Refined, [Plane; 2], Vec<bool>), CalibError> {
    let (refined, planes) = refine(&model_of(views, swap), x, &planes, &Options::default())?;
    Ok((refined, planes, swap.to_vec()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_planes_meet_on_their_common_line() {
        let a = Plane::new(&Vector3::new(0.0, 1.0, 1.0).normalize(), 0.3);
        let b = Plane::new(&Vector3::new(0.0, -1.0, 1.0).normalize(), 0.3);
        let (q, d) = meet(&[a, b]).unwrap();
        for p in [&a, &b] {
            assert!((p.normal().dot(&q.coords) - p.offset).abs() < 1e-12);
            assert!(p.normal().dot(&d).abs() < 1e-12);
        }
        assert!(meet(&[a, a]).is_none());
    }
}
