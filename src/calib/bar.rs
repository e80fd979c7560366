//! A straight edge from any poses (beyond both papers): a bar's or plate's top face and the one or
//! two parallel edges the profiles cross, as the public peer's plate method uses a plate and its
//! edges, but with no protocol, no start and no labels from the user.
//!
//! 1. The face alone is a plane: `calib::plane` solves it from the face's lines (seven poses or
//!    more, eight starts screened), which fixes flange_to_sensor; profiles whose face lies off
//!    it (a wall or the table taken for the face) are left out and the plane solved again.
//! 2. Mapped into the base frame with it, the edge points lie on one or two parallel lines in the
//!    face: a search over in-plane directions finds the one along which their offsets fall into
//!    the tightest one or two clusters, so which edge each point is on is inferred from the data.
//! 3. The face points and the edges refined together (`refine::bar`).

use super::CalibError;
use super::plane::LineView;
use super::refine::bar::{Bar, BarModel, EdgeSeen};
use super::refine::{Options, Problem, Refined, refine};
use nalgebra::{Isometry3, Rotation3, Vector2, Vector3};

const METHOD: &str = "edge any-pose";

/// One profile of the bar: its face's line and the edges at the face's ends (from, to: where each
/// can lie, sensor x, z; equal at a corner).
#[derive(Debug, Clone, PartialEq)]
pub struct BarView {
    pub face: LineView,
    pub edges: Vec<(Vector2<f64>, Vector2<f64>)>,
}

#[derive(Debug, Clone)]
pub struct BarSolution {
    pub flange_to_sensor: Isometry3<f64>,
    pub bar: Bar,
    pub refined: Refined,
    pub problem: Problem<BarModel>,
}

/// The bar from any views; the last fit stops after `max_iterations` (`CENSORED_ITERATIONS`
/// for a result; fewer where only its fit's size is wanted, as a cause search's refits).
pub fn solve(
    views: &[BarView],
    apex: &Vector3<f64>,
    max_iterations: usize,
) -> Result<BarSolution, CalibError> {
    let (views, plane) = super::plane::solve_faces(views, |v| &v.face, apex)?;
    with_edges(&views, &plane, max_iterations)
}

/// Steps 2-3 from the plane's solution.
fn with_edges(
    views: &[&BarView],
    plane: &super::plane::PlaneSolution,
    max_iterations: usize,
) -> Result<BarSolution, CalibError> {
    let x = plane.flange_to_sensor;
    let n = plane.plane.normal();
    // In-plane coordinates of every edge's middle.
    let (e1, e2) = (
        plane.plane.frame * Vector3::x(),
        plane.plane.frame * Vector3::y(),
    );
    let seen: Vec<(Isometry3<f64>, Vector2<f64>, Vector2<f64>, Vector2<f64>)> = views
        .iter()
        .flat_map(|v| {
            v.edges.iter().map(move |(a, b)| {
                let mid = (a + b) / 2.0;
                let q = (v.face.base_to_flange * x)
                    .transform_point(&nalgebra::Point3::new(mid.x, 0.0, mid.y));
                (
                    v.face.base_to_flange,
                    *a,
                    *b,
                    Vector2::new(e1.dot(&q.coords), e2.dot(&q.coords)),
                )
            })
        })
        .collect();
    if seen.len() < 3 {
        return Err(CalibError::TooFewData {
            method: METHOD,
            what: "edge crossings (profiles whose face ends at the edge)",
            got: seen.len(),
            need: 3,
        });
    }
    let in_plane: Vec<Vector2<f64>> = seen.iter().map(|s| s.3).collect();
    let (angle, labels, offsets) = edge_lines(&in_plane);
    let n_edges = if labels.contains(&1) { 2 } else { 1 };
    let dir = e1 * angle.cos() + e2 * angle.sin();
    let frame =
        Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_columns(&[dir, n.cross(&dir), n]));
    let model = BarModel {
        face: views
            .iter()
            .flat_map(|v| {
                v.face
                    .points
                    .iter()
                    .map(move |p| (v.face.base_to_flange, *p))
            })
            .collect(),
        edges: seen
            .iter()
            .zip(&labels)
            .map(|(s, &edge)| EdgeSeen {
                base_to_flange: s.0,
                from: s.1,
                to: s.2,
                edge,
            })
            .collect(),
        n_edges,
        walls: Vec::new(),
    };
    // Offsets along the frame's y = n x dir, which is the search's across direction.
    let bar = Bar {
        frame,
        offset: plane.plane.offset,
        edge_offsets: offsets,
    };
    let opts = Options {
        max_iterations,
        ..Options::default()
    };
    let (refined, bar) = refine(&model, &x, &bar, &opts)?;
    Ok(BarSolution {
        flange_to_sensor: refined.flange_to_sensor,
        bar,
        refined,
        problem: Problem {
            model,
            specimen: bar,
        },
    })
}

/// The edges' direction in the plane (angle from its first axis) and which of one or two
/// parallel lines each point lies on, with the lines' offsets across: over 360 directions, the
/// offsets split at their widest gap into two clusters, scored by the spread within clusters.
/// One line when the widest gap is not ten times the spread within.
fn edge_lines(p: &[Vector2<f64>]) -> (f64, Vec<usize>, [f64; 2]) {
    let split = |angle: f64| {
        let across = Vector2::new(-angle.sin(), angle.cos());
        let mut o: Vec<(f64, usize)> = p
            .iter()
            .enumerate()
            .map(|(i, q)| (across.dot(q), i))
            .collect();
        o.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (cut, gap) = (1..o.len())
            .map(|k| (k, o[k].0 - o[k - 1].0))
            .fold((0, 0.0), |b, c| if c.1 > b.1 { c } else { b });
        let spread = |s: &[(f64, usize)]| {
            let m = s.iter().map(|v| v.0).sum::<f64>() / s.len().max(1) as f64;
            (s.iter().map(|v| (v.0 - m).powi(2)).sum::<f64>(), m)
        };
        let (lo, hi) = (spread(&o[..cut]), spread(&o[cut..]));
        let one = spread(&o);
        let within = ((lo.0 + hi.0) / p.len() as f64).sqrt();
        let two = cut > 0 && gap > 10.0 * within.max(1e-9);
        let mut labels = vec![0; p.len()];
        if two {
            for &(_, i) in &o[cut..] {
                labels[i] = 1;
            }
        }
        // Scored as two clusters even for one line (its noise then splits anywhere): smooth in
        // the angle, and as small at one line's direction.
        let score = lo.0 + hi.0;
        let offsets = if two { [lo.1, hi.1] } else { [one.1, one.1] };
        (score, labels, offsets)
    };
    let mut best = (f64::INFINITY, 0.0);
    for k in 0..360 {
        let a = std::f64::consts::PI * k as f64 / 360.0;
        let s = split(a).0;
        if s < best.0 {
            best = (s, a);
        }
    }
    // Refine the angle by golden-section search within one step of the best.
    let step = std::f64::consts::PI / 360.0;
    let (mut lo, mut hi) = (best.1 - step, best.1 + step);
    let g = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..60 {
        let (a, b) = (hi - g * (hi - lo), lo + g * (hi - lo));
        if split(a).0 < split(b).0 {
            hi = b;
        } else {
            lo = a;
        }
    }
    let angle = 0.5 * (lo + hi);
    let (_, labels, offsets) = split(angle);
    (angle, labels, offsets)
}
