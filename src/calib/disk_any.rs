//! The disk from any poses (beyond the disk paper, whose closed form needs scans of parallel
//! translations at one orientation): every profile that crosses the disk's face, whatever its
//! pose; no groups, no scan signs, no start.
//!
//! 1. The face is a plane: `calib::plane` solves it from the chords' lines (seven poses or more,
//!    eight starts screened, profiles off the plane left out), which fixes flange_to_sensor.
//! 2. Mapped into the face's plane with it, the chords' ends lie on the rim: an algebraic circle
//!    fit (Kasa) of their middles gives the centre.
//! 3. Face points and rim refined together (`refine::disk` with censored rim intervals: where
//!    the face stops, the rim lies between its last column and the next, and exact data give the
//!    exact answer).

use super::CalibError;
use super::plane::LineView;
use super::refine::disk::{DiskModel, DiskPose, face_weights};
use super::refine::{Options, Problem, Refined, refine};
use nalgebra::{Isometry3, Matrix3, Point3, Vector2, Vector3};

const METHOD: &str = "disk any-pose";

/// One profile of the disk: its face's line and, at each end, where the rim can lie (two points
/// on the line, sensor x, z).
#[derive(Debug, Clone, PartialEq)]
pub struct DiskView {
    pub face: LineView,
    pub rim: Vec<(Vector2<f64>, Vector2<f64>)>,
}

#[derive(Debug, Clone)]
pub struct DiskAnySolution {
    pub flange_to_sensor: Isometry3<f64>,
    pub disk: DiskPose,
    pub refined: Refined,
    pub problem: Problem<DiskModel>,
}

/// `weight` gives a face point's (sensor x, z) weight in the refinement (a noise that varies
/// with depth scaled to one spread; 1 for none).
pub fn solve(
    views: &[DiskView],
    radius: f64,
    apex: &Vector3<f64>,
    weight: &dyn Fn(&Vector2<f64>) -> f64,
    max_iterations: usize,
) -> Result<DiskAnySolution, CalibError> {
    let (views, plane) = super::plane::solve_faces(views, |v| &v.face, apex)?;
    let x = plane.flange_to_sensor;
    let n = plane.plane.normal();
    let (e1, e2) = (
        plane.plane.frame * Vector3::x(),
        plane.plane.frame * Vector3::y(),
    );
    let rims: Vec<(Isometry3<f64>, Vector2<f64>, Vector2<f64>)> = views
        .iter()
        .flat_map(|v| v.rim.iter().map(|(a, b)| (v.face.base_to_flange, *a, *b)))
        .collect();
    let in_plane: Vec<Vector2<f64>> = rims
        .iter()
        .map(|(f, a, b)| {
            let m = (a + b) / 2.0;
            let q = (f * x).transform_point(&Point3::new(m.x, 0.0, m.y));
            Vector2::new(e1.dot(&q.coords), e2.dot(&q.coords))
        })
        .collect();
    let centre = kasa_centre(&in_plane).ok_or(CalibError::TooFewData {
        method: METHOD,
        what: "rim crossings spread around the disk",
        got: in_plane.len(),
        need: 3,
    })?;
    let centre = e1 * centre.x + e2 * centre.y + n * plane.plane.offset;
    // Past the point budget, every profile's face thinned evenly (`super::POINT_BUDGET`).
    let total = views.iter().map(|v| v.face.points.len()).sum();
    let keep = super::points_per_profile(total, views.len(), usize::MAX);
    let face: Vec<(Isometry3<f64>, Vector2<f64>)> = views
        .iter()
        .flat_map(|v| {
            let stride = super::stride_for(v.face.points.len(), keep);
            v.face
                .points
                .iter()
                .step_by(stride)
                .map(move |p| (v.face.base_to_flange, *p))
        })
        .collect();
    let model = DiskModel {
        radius,
        ends: Vec::new(),
        face_weights: face_weights(&face, weight),
        // A rim's spread (the column step, the noise) scaled as the face points around it.
        rim_weights: if (rims.iter()).all(|(_, a, b)| weight(&((a + b) / 2.0)) == 1.0) {
            Vec::new()
        } else {
            (rims.iter())
                .map(|(_, a, b)| weight(&((a + b) / 2.0)))
                .collect()
        },
        face,
        rims,
        end_weights: Vec::new(),
        walls: Vec::new(),
    };
    let disk = DiskPose::new(Point3::from(centre), &n);
    let opts = Options {
        max_iterations,
        ..Options::default()
    };
    let (refined, disk) = refine(&model, &x, &disk, &opts)?;
    Ok(DiskAnySolution {
        flange_to_sensor: refined.flange_to_sensor,
        disk,
        refined,
        problem: Problem {
            model,
            specimen: disk,
        },
    })
}

/// The centre of the circle through 2-D points by Kasa's algebraic fit, x^2 + y^2 + D x + E y + F
/// = 0 in least squares; None for fewer than three points or points on a line.
fn kasa_centre(p: &[Vector2<f64>]) -> Option<Vector2<f64>> {
    if p.len() < 3 {
        return None;
    }
    // Centred for conditioning.
    let m = p.iter().sum::<Vector2<f64>>() / p.len() as f64;
    let (mut a, mut b) = (Matrix3::zeros(), Vector3::zeros());
    for q in p {
        let d = q - m;
        let row = Vector3::new(d.x, d.y, 1.0);
        a += row * row.transpose();
        b -= row * d.norm_squared();
    }
    let sol = a.cholesky()?.solve(&b);
    let c = Vector2::new(-sol.x / 2.0, -sol.y / 2.0);
    c.iter().all(|v| v.is_finite()).then_some(m + c)
}
