//! A bar's or plate's refinement model (beyond both papers): every top-face point against the face,
//! and every edge the profiles cross against one of the face's one or two parallel edges.
//!
//! Specimen parameters: the bar's frame Q (x along the edges, z the face's normal),
//! Q <- Q exp([a, b, c]) (3); the face's offset d along Q z (1); each edge's offset o_k along Q y
//! (1 or 2). Residuals along the surface normals: a face point q, n.q - d; an edge, (Q y).q - o_k
//! at the corner where a wall was seen. Where the face ends without a wall the edge lies somewhere
//! between the face's last column and the next: the residual is zero while the edge's line passes
//! between the two, else the nearer one's offset (a censored measurement: no bias from guessing
//! where in the gap the edge is, so exact data give the exact answer).

use super::slant::{self, SlantNoise, Slanted};
use super::{Model, Transform, depth_in_base, exp, transform_columns};
use nalgebra::{DMatrix, DVector, Isometry3, Rotation3, Vector2, Vector3};

/// One edge seen in one profile: the flange pose, the edge's interval on the face (sensor x, z;
/// equal ends at a corner) and which of the bar's edges it is (0 or 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeSeen {
    pub base_to_flange: Isometry3<f64>,
    pub from: Vector2<f64>,
    pub to: Vector2<f64>,
    pub edge: usize,
}

/// A point of the side wall below edge `edge` (`edge-full`): the wall is the plane through the
/// edge perpendicular to the face, the point's residual its distance from it times `weight`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallSeen {
    pub base_to_flange: Isometry3<f64>,
    pub point: Vector2<f64>,
    pub weight: f64,
    pub edge: usize,
}

#[derive(Debug, Clone, PartialEq)]
pub struct BarModel {
    /// Top-face points (sensor x, z) with the flange pose each was seen from.
    pub face: Vec<(Isometry3<f64>, Vector2<f64>)>,
    pub edges: Vec<EdgeSeen>,
    /// How many distinct edges the profiles cross (1 or 2).
    pub n_edges: usize,
    /// Points of the side walls (`edge-full`).
    pub walls: Vec<WallSeen>,
}

/// The bar: its frame (x along the edges, z the face's normal), the face's offset and the edges'.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bar {
    pub frame: Rotation3<f64>,
    pub offset: f64,
    pub edge_offsets: [f64; 2],
}

impl Model for BarModel {
    type Specimen = Bar;

    fn name(&self) -> &'static str {
        "bar refinement"
    }
    fn n_specimen_params(&self) -> usize {
        4 + self.n_edges
    }
    fn n_features(&self) -> usize {
        self.face.len() + self.edges.len() + self.walls.len()
    }
    fn residuals_per_feature(&self) -> usize {
        1
    }

    fn residual_flanges(&self) -> Vec<&Isometry3<f64>> {
        let face = self.face.iter().map(|(f, _)| f);
        let edges = self.edges.iter().map(|e| &e.base_to_flange);
        let walls = self.walls.iter().map(|w| &w.base_to_flange);
        face.chain(edges).chain(walls).collect()
    }

    fn map_poses(&self, to: &mut dyn FnMut(&Isometry3<f64>) -> Isometry3<f64>) -> BarModel {
        BarModel {
            face: super::moved(&self.face, to),
            edges: self
                .edges
                .iter()
                .map(|e| EdgeSeen {
                    base_to_flange: to(&e.base_to_flange),
                    ..*e
                })
                .collect(),
            n_edges: self.n_edges,
            walls: self
                .walls
                .iter()
                .map(|w| WallSeen {
                    base_to_flange: to(&w.base_to_flange),
                    ..*w
                })
                .collect(),
        }
    }

    fn without_poses(&self, drop: &dyn Fn(&Isometry3<f64>) -> bool) -> BarModel {
        BarModel {
            face: super::kept(&self.face, drop),
            edges: self
                .edges
                .iter()
                .filter(|e| !drop(&e.base_to_flange))
                .copied()
                .collect(),
            n_edges: self.n_edges,
            walls: self
                .walls
                .iter()
                .filter(|w| !drop(&w.base_to_flange))
                .copied()
                .collect(),
        }
    }

    fn eval(
        &self,
        x: &Transform,
        s: &Bar,
        _labels: &[f64],
        r: &mut DVector<f64>,
        mut j: Option<&mut DMatrix<f64>>,
    ) {
        let mut seer = x.seer();
        let (ex, ey, ez) = (
            s.frame * Vector3::x(),
            s.frame * Vector3::y(),
            s.frame * Vector3::z(),
        );
        let jac = j.is_some();
        for (i, (f, p)) in self.face.iter().enumerate() {
            let (qb, dq_dw, dq_dt) = seer.point(f, p, jac);
            let a = ez.dot(&qb) - s.offset;
            let depth = seer.along_depth(f, &ez, jac);
            r[i] = a * depth.scale;
            if let Some(j) = j.as_deref_mut() {
                depth.transform_columns(j, i, &ez, &dq_dw, &dq_dt, a);
                // Q exp([w]) z: dn/da = -Q y, dn/db = Q x, dn/dc = 0.
                j[(i, 6)] = depth.column(-ey.dot(&qb), a, &-ey);
                j[(i, 7)] = depth.column(ex.dot(&qb), a, &ex);
                j[(i, 9)] = -depth.scale;
            }
        }
        let n = self.face.len();
        for (i, e) in self.edges.iter().enumerate() {
            let row = n + i;
            let o = s.edge_offsets[e.edge];
            let mut across = |p: &Vector2<f64>| {
                let (qb, _, _) = seer.point(&e.base_to_flange, p, false);
                ey.dot(&qb) - o
            };
            let (sa, sb) = (across(&e.from), across(&e.to));
            // Within the gap: no residual (and no gradient).
            if e.from != e.to && sa * sb <= 0.0 {
                r[row] = 0.0;
                continue;
            }
            let p = if sa.abs() <= sb.abs() { &e.from } else { &e.to };
            let (qb, dq_dw, dq_dt) = seer.point(&e.base_to_flange, p, jac);
            r[row] = ey.dot(&qb) - o;
            if let Some(j) = j.as_deref_mut() {
                transform_columns(j, row, &ey, &dq_dw, &dq_dt);
                // Q exp([w]) y: dy/da = Q z, dy/db = 0, dy/dc = -Q x.
                j[(row, 6)] = ez.dot(&qb);
                j[(row, 8)] = -ex.dot(&qb);
                j[(row, 10 + e.edge)] = -1.0;
            }
        }
        let n = n + self.edges.len();
        for (i, wall) in self.walls.iter().enumerate() {
            let (row, w) = (n + i, wall.weight);
            let (qb, dq_dw, dq_dt) = seer.point(&wall.base_to_flange, &wall.point, jac);
            r[row] = w * (ey.dot(&qb) - s.edge_offsets[wall.edge]);
            if let Some(j) = j.as_deref_mut() {
                transform_columns(j, row, &(ey * w), &dq_dw, &dq_dt);
                j[(row, 6)] = w * ez.dot(&qb);
                j[(row, 8)] = -w * ex.dot(&qb);
                j[(row, 10 + wall.edge)] = -w;
            }
        }
    }

    /// The walls' weights from the residuals: the face's points fix the noise, the walls' its
    /// part across a wall (`slant`).
    fn reweighted(&self, x: &Transform, s: &Bar) -> Option<(BarModel, SlantNoise)> {
        if self.walls.len() < slant::MIN_WALL_POINTS {
            return None;
        }
        let (ey, ez) = (s.frame * Vector3::y(), s.frame * Vector3::z());
        let slanted = |f: &Isometry3<f64>, p: &Vector2<f64>, n: &Vector3<f64>, offset: f64| {
            let (qb, _, _) = x.point_in_base(f, p, false);
            Slanted {
                residual: n.dot(&qb) - offset,
                u: n.dot(&depth_in_base(x, f)).powi(2),
            }
        };
        let face: Vec<Slanted> = self
            .face
            .iter()
            .map(|(f, p)| slanted(f, p, &ez, s.offset))
            .collect();
        let walls: Vec<Slanted> = self
            .walls
            .iter()
            .map(|w| slanted(&w.base_to_flange, &w.point, &ey, s.edge_offsets[w.edge]))
            .collect();
        let noise = slant::estimate(&face, &walls)?;
        let mut model = self.clone();
        model.walls = (self.walls.iter().zip(&walls))
            .filter(|(_, sl)| noise.fits(sl))
            .map(|(w, sl)| WallSeen {
                weight: noise.weight(sl.u),
                ..*w
            })
            .collect();
        Some((model, noise))
    }

    fn step(&self, s: &Bar, dx: &[f64]) -> Bar {
        let mut edge_offsets = s.edge_offsets;
        for (k, o) in edge_offsets.iter_mut().enumerate().take(self.n_edges) {
            *o += dx[4 + k];
        }
        Bar {
            frame: s.frame * exp(&Vector3::new(dx[0], dx[1], dx[2])),
            offset: s.offset + dx[3],
            edge_offsets,
        }
    }
}
