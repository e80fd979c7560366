//! The verdict's sums of a disk model of chord ends alone (the closed form's figures), eight
//! ends at a time.
//!
//! Row by row (`Model::eval`, then `Sums::of`) each end costs two Jacobian rows formed through
//! 3 x 3 products, written across eleven columns of a tall J, and a cluster number per row.
//! Here each end's two rows come from its pose's F_R R, F_R and origin in lanes of eight ends,
//! straight into a block in the first-level cache that `add_rows` sums pair of columns by pair
//! of columns (as `add_block`, four pairs side by side), and each pose's score is added per run
//! of its ends. The same sums as the rows' to rounding
//! (`tests::lanes_sum_what_the_rows_sum`).

use super::disk::{DiskModel, DiskPose};
use super::{Sums, Transform, finish, honest, pairs, tiles};
use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Vector3};

/// Columns: rotation 3, translation 3, the disk's centre 3 and normal 2.
const P: usize = 11;
/// Chunks of eight ends (sixteen rows) per block: their inputs and rows, about 25 kB, stay in
/// the first-level cache while every pair of columns is summed over them.
const BLOCK_CHUNKS: usize = 8;

/// Eight ends: their poses' F_R R and F_R (row-major), F (R t) + F_t, the end (x, z) in the
/// sensor, its weight on the rim residual and 1 (0: a lane past the last end).
#[derive(Clone, Copy, Default)]
struct Chunk {
    frr: [[f64; 8]; 9],
    fr: [[f64; 8]; 9],
    origin: [[f64; 8]; 3],
    x: [f64; 8],
    z: [f64; 8],
    weight: [f64; 8],
    live: [f64; 8],
}

/// The disk at the estimate: centre, normal and the normal's two derivatives.
struct Disk {
    centre: Vector3<f64>,
    n: Vector3<f64>,
    dn: [Vector3<f64>; 2],
    radius: f64,
}

/// Eight ends' two rows each (0: the plane rows, 1: the rim rows), their Jacobian column by
/// column over the lanes and the residuals: a block is a run of these, read pair of columns by
/// pair of columns by `add_rows`.
#[derive(Clone, Copy)]
struct Rows {
    j: [[[f64; 8]; P]; 2],
    r: [[f64; 8]; 2],
}

/// `Model::sums` of `m` when it holds chord ends alone and more poses than keep their grams
/// (`honest::MAX_JACKKNIFE`); None otherwise (the rows' path sums it).
pub(super) fn sums(m: &DiskModel, x: &Transform, s: &DiskPose) -> Option<Sums> {
    let ends_only = m.face.is_empty() && m.rims.is_empty() && m.walls.is_empty();
    if !ends_only || m.ends.is_empty() {
        return None;
    }
    let super::disk_scans::Layout {
        runs,
        poses,
        starts,
    } = super::disk_scans::layout(&m.ends);
    let by_scans = m.ends.len() >= super::disk_scans::SCAN_MIN_ENDS * runs.len();
    let scanned = match by_scans {
        true => super::disk_scans::clusters(&m.ends, &runs, &starts, poses),
        false => None,
    };
    // The scans' poses are numbered in order, none seen again: the last is the largest.
    let g_scanned = scanned
        .as_ref()
        .map(|c| c.last().map_or(0, |&k| k as usize + 1));
    let clusters = scanned.unwrap_or_else(|| {
        let flanges: Vec<&Isometry3<f64>> = m.ends.iter().map(|(f, _)| f).collect();
        honest::clusters(&flanges, flanges.len())
    });
    let g =
        g_scanned.unwrap_or_else(|| clusters.iter().map(|&c| c as usize + 1).max().unwrap_or(0));
    if g <= honest::MAX_JACKKNIFE {
        return None;
    }
    if by_scans {
        return Some(super::disk_scans::sums(m, x, s, &clusters, g, &runs));
    }
    let disk = Disk {
        centre: s.centre,
        n: s.q * Vector3::z(),
        dn: [-(s.q * Vector3::y()), s.q * Vector3::x()],
        radius: m.radius,
    };
    let pairs = pairs(P);
    let (mut ata, mut meat) = (vec![[0.0; 8]; pairs.len()], vec![[0.0; 8]; pairs.len()]);
    let (mut atr, mut rss) = ([[0.0; 8]; P], [0.0; 8]);
    let mut scores = vec![0.0; P * g];
    let chunks_max = m.ends.len().div_ceil(8).min(BLOCK_CHUNKS);
    let mut block = vec![Chunk::default(); chunks_max];
    let empty = Rows {
        j: [[[0.0; 8]; P]; 2],
        r: [[0.0; 8]; 2],
    };
    let mut rows = vec![empty; chunks_max];
    let mut poses = Poses { x, last: None };
    for first in (0..m.ends.len()).step_by(8 * BLOCK_CHUNKS) {
        let ends = first..(first + 8 * BLOCK_CHUNKS).min(m.ends.len());
        let chunks = ends.len().div_ceil(8);
        for (k, chunk) in block[..chunks].iter_mut().enumerate() {
            let start = ends.start + 8 * k;
            poses.fill(chunk, m, start..(start + 8).min(ends.end));
        }
        let rows = &mut rows[..chunks];
        sum_block(
            &block[..chunks],
            &disk,
            rows,
            (&mut atr, &mut rss),
            (&clusters[ends], &mut scores),
        );
        add_rows((&mut ata, &mut meat), &pairs, rows);
    }
    Some(Sums {
        ata: finish(&ata, &pairs, P, |_, _| 0.0),
        atr: DVector::from_fn(P, |k, _| atr[k].iter().sum()),
        meat: finish(&meat, &pairs, P, |_, _| 0.0),
        scores: DMatrix::from_vec(g, P, scores),
        grams: DMatrix::zeros(P, 0),
        rss: rss.iter().sum(),
        n: 2 * m.ends.len(),
    })
}

/// A flange pose with its F_R, F_R R and F (R t) + F_t.
type PoseProducts<'a> = (&'a Isometry3<f64>, Matrix3<f64>, Matrix3<f64>, Vector3<f64>);

/// Each end's pose products, formed once per run of ends seen from one pose.
struct Poses<'a> {
    x: &'a Transform,
    last: Option<PoseProducts<'a>>,
}

impl<'a> Poses<'a> {
    /// Chunk `c` of ends `ends` of `m` (at most eight); spare lanes dead (`live` 0).
    fn fill(&mut self, c: &mut Chunk, m: &'a DiskModel, ends: std::ops::Range<usize>) {
        c.live = [0.0; 8];
        c.weight = [0.0; 8];
        for (l, e) in ends.enumerate() {
            let (f, p) = &m.ends[e];
            let (fr, frr, origin) = match self.last {
                Some((g, fr, frr, o)) if std::ptr::eq(g, f) || g == f => (fr, frr, o),
                _ => {
                    let fr = *f.rotation.to_rotation_matrix().matrix();
                    let frr = fr * self.x.rot.matrix();
                    let o = fr * self.x.t + f.translation.vector;
                    self.last = Some((f, fr, frr, o));
                    (fr, frr, o)
                }
            };
            for r in 0..3 {
                for k in 0..3 {
                    c.frr[3 * r + k][l] = frr[(r, k)];
                    c.fr[3 * r + k][l] = fr[(r, k)];
                }
                c.origin[r][l] = origin[r];
            }
            c.x[l] = p.x;
            c.z[l] = p.y;
            c.weight[l] = m.end_weights.get(e).copied().unwrap_or(1.0);
            c.live[l] = 1.0;
        }
    }
}

/// One block's rows into `rows`; their J^T r and r^T r into the lanes, and each end's score
/// into its cluster's row.
#[multiversion::multiversion(targets("x86_64+avx512f", "x86_64+avx2"))]
fn sum_block(
    block: &[Chunk],
    disk: &Disk,
    rows: &mut [Rows],
    (atr, rss): (&mut [[f64; 8]; P], &mut [f64; 8]),
    (clusters, scores): (&[u32], &mut [f64]),
) {
    let mut run = (clusters[0], [0.0; P]);
    for (k, (chunk, o)) in block.iter().zip(rows.iter_mut()).enumerate() {
        lanes(chunk, disk, o);
        // Each end's J^T r, for J^T r and for its pose's score.
        let t: [[f64; 8]; P] = std::array::from_fn(|c| {
            std::array::from_fn(|l| o.j[0][c][l] * o.r[0][l] + o.j[1][c][l] * o.r[1][l])
        });
        for (a, t) in atr.iter_mut().zip(&t) {
            for (a, t) in a.iter_mut().zip(t) {
                *a += t;
            }
        }
        for (l, s) in rss.iter_mut().enumerate() {
            *s += o.r[0][l] * o.r[0][l] + o.r[1][l] * o.r[1][l];
        }
        let cl = &clusters[(8 * k).min(clusters.len())..(8 * k + 8).min(clusters.len())];
        add_scores(scores, &mut run, cl, &t, k == 0);
    }
    add_run(scores, &run);
}

/// Up to eight ends' J^T r `t` (clusters `cl`) into their poses' rows of `scores`, the pose
/// whose ends may go on into the next chunk held in `run` (`fresh`: nothing summed in it yet).
/// The rule (a chord's two ends per pose, a pose per chord): lane pairs summed side by side,
/// four poses' scores added at once; the same sums as by runs. Otherwise a pose's ends are
/// summed in registers and added to its row once per run. Shared by `disk_scans`.
#[inline(always)]
pub(super) fn add_scores(
    scores: &mut [f64],
    run: &mut (u32, [f64; P]),
    cl: &[u32],
    t: &[[f64; 8]; P],
    fresh: bool,
) {
    if four_new_poses(cl, run, fresh) {
        add_run(scores, run);
        // Each pose's two ends, lanes 2p and 2p + 1: one aligned pair each (a lane-swapped
        // sum of the whole chunk read `t`, which its caller had just stored, at odd offsets
        // that the stores could not forward).
        let pair: [[f64; 4]; P] =
            std::array::from_fn(|c| std::array::from_fn(|p| t[c][2 * p] + t[c][2 * p + 1]));
        let g = scores.len() / P;
        // Numbered in a row: side by side in each column.
        if let Some(first) = in_a_row(cl, g) {
            for (c, column) in scores.chunks_exact_mut(g.max(1)).enumerate() {
                for (p, s) in column[first..first + 4].iter_mut().enumerate() {
                    *s += pair[c][p];
                }
            }
        } else {
            for (c, column) in scores.chunks_exact_mut(g.max(1)).enumerate() {
                for p in 0..4 {
                    column[cl[2 * p] as usize] += pair[c][p];
                }
            }
        }
        *run = (cl[7], [0.0; P]);
        return;
    }
    for (l, &cl) in cl.iter().enumerate() {
        if run.0 != cl {
            add_run(scores, run);
            *run = (cl, [0.0; P]);
        }
        for (s, t) in run.1.iter_mut().zip(t) {
            *s += t[l];
        }
    }
}

/// Eight ends (`cl`: their clusters) that are four new poses, two ends each (the rule: a
/// chord's two ends per pose, a pose per chord), the first not the pose `run` holds unless
/// nothing is summed in it yet (`fresh`).
#[inline(always)]
pub(super) fn four_new_poses(cl: &[u32], run: &(u32, [f64; P]), fresh: bool) -> bool {
    cl.len() == 8 && (fresh || cl[0] != run.0) && pairs_of_ends(cl)
}

/// Four poses numbered in a row from `cl[0]` (a scan's chords, as a rule), all below `g`: the
/// first one's number.
#[inline(always)]
pub(super) fn in_a_row(cl: &[u32], g: usize) -> Option<usize> {
    let first = *cl.first()? as usize;
    let row = (0..4).all(|p| cl.get(2 * p).is_some_and(|&c| c as usize == first + p));
    (row && first + 4 <= g).then_some(first)
}

/// Eight ends' clusters in four runs of two.
#[inline(always)]
fn pairs_of_ends(cl: &[u32]) -> bool {
    (0..4).all(|p| cl[2 * p] == cl[2 * p + 1]) && (0..3).all(|p| cl[2 * p + 1] != cl[2 * p + 2])
}

/// J^T J and sum r_i^2 J_i^T J_i (`add_block`'s pairs, four side by side) over a block of
/// `Rows`: each chunk's plane rows, then its rim rows, as a column-major block holds them. One
/// pass for both: each product of two columns is formed once.
#[multiversion::multiversion(targets("x86_64+avx512f", "x86_64+avx2"))]
fn add_rows(
    (ata, meat): (&mut [[f64; 8]], &mut [[f64; 8]]),
    pairs: &[(usize, usize)],
    rows: &[Rows],
) {
    for tile in tiles(pairs) {
        let (i, c) = (tile.start, pairs[tile.start].0);
        let ds = |t: usize| pairs[i + t].1;
        let acc = (&mut ata[tile.clone()], &mut meat[tile.clone()]);
        match tile.len() {
            4 => rows_tile::<4>(acc, rows, c, std::array::from_fn(ds)),
            3 => rows_tile::<3>(acc, rows, c, std::array::from_fn(ds)),
            2 => rows_tile::<2>(acc, rows, c, std::array::from_fn(ds)),
            _ => rows_tile::<1>(acc, rows, c, std::array::from_fn(ds)),
        }
    }
}

/// `T` pairs (c, ds[t]) over a block of `Rows`: eight partial sums each of the product and of
/// the product times the row's squared residual, in row order.
#[inline(always)]
fn rows_tile<const T: usize>(
    (ata, meat): (&mut [[f64; 8]], &mut [[f64; 8]]),
    rows: &[Rows],
    c: usize,
    ds: [usize; T],
) {
    let mut a: [[f64; 8]; T] = std::array::from_fn(|t| ata[t]);
    let mut m: [[f64; 8]; T] = std::array::from_fn(|t| meat[t]);
    for r in rows {
        for (half, res) in r.j.iter().zip(&r.r) {
            let x = &half[c];
            let rr: [f64; 8] = std::array::from_fn(|k| res[k] * res[k]);
            for t in 0..T {
                let y = &half[ds[t]];
                for k in 0..8 {
                    let xy = x[k] * y[k];
                    a[t][k] += xy;
                    m[t][k] += xy * rr[k];
                }
            }
        }
    }
    ata[..T].copy_from_slice(&a);
    meat[..T].copy_from_slice(&m);
}

/// A run's scores into its cluster's row (`scores`: g x P, column-major).
#[inline(always)]
pub(super) fn add_run(scores: &mut [f64], (cl, sums): &(u32, [f64; P])) {
    let g = scores.len() / P;
    for (column, s) in scores.chunks_exact_mut(g.max(1)).zip(sums) {
        column[*cl as usize] += s;
    }
}

/// Eight ends' rows, as `disk::Geometry::plane_row` and `rim_row` form them from
/// q = F_R R p + F (R t) + F_t with p = (x, 0, z): the rotation columns g^T dq/dw =
/// -(F_R R)^T g x p, written out for p's zero y.
#[inline(always)]
fn lanes(c: &Chunk, d: &Disk, o: &mut Rows) {
    for l in 0..8 {
        let (x, z) = (c.x[l], c.z[l]);
        let q: [f64; 3] =
            std::array::from_fn(|r| c.frr[3 * r][l] * x + c.frr[3 * r + 2][l] * z + c.origin[r][l]);
        let v: [f64; 3] = std::array::from_fn(|r| q[r] - d.centre[r]);
        let dot = |a: &[f64; 3], b: &Vector3<f64>| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let h = dot(&v, &d.n);
        let w: [f64; 3] = std::array::from_fn(|r| v[r] - d.n[r] * h);
        let wn = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
        let scale = if wn > 0.0 { c.weight[l] / wn } else { 0.0 };
        let g = Vector3::new(w[0] * scale, w[1] * scale, w[2] * scale);
        // Both rows: the transform's six columns from the gradient in the base frame.
        let row = |out: &mut [[f64; 8]; P], g: &Vector3<f64>| {
            let a: [f64; 3] = std::array::from_fn(|k| {
                c.frr[k][l] * g[0] + c.frr[3 + k][l] * g[1] + c.frr[6 + k][l] * g[2]
            });
            out[0][l] = -a[1] * z;
            out[1][l] = a[0] * z - a[2] * x;
            out[2][l] = a[1] * x;
            for k in 0..3 {
                out[3 + k][l] = c.fr[k][l] * g[0] + c.fr[3 + k][l] * g[1] + c.fr[6 + k][l] * g[2];
                out[6 + k][l] = -g[k];
            }
        };
        row(&mut o.j[0], &d.n);
        row(&mut o.j[1], &g);
        let live = c.live[l];
        o.j[0][9][l] = dot(&v, &d.dn[0]);
        o.j[0][10][l] = dot(&v, &d.dn[1]);
        o.j[1][9][l] = -h * g.dot(&d.dn[0]);
        o.j[1][10][l] = -h * g.dot(&d.dn[1]);
        o.r[0][l] = h * live;
        o.r[1][l] = c.weight[l] * (wn - d.radius) * live;
        for half in 0..2 {
            for k in 0..P {
                o.j[half][k][l] *= live;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Model, Sums, eval, testing};
    use super::*;
    use nalgebra::{UnitQuaternion, Vector2};

    /// 83 poses (more than keep their grams) of two ends each, one pose of three, odd weights:
    /// 167 ends, the last chunk part dead; the ends anywhere near the rim (the sums need no
    /// consistent geometry).
    fn model() -> (DiskModel, Transform, DiskPose) {
        let (mut m, x, disk) = testing::disk_rig();
        for k in 0..83 {
            let a = k as f64;
            let f = Isometry3::from_parts(
                Vector3::new(-0.2 + 0.001 * a, -0.3, 0.36 + 0.01 * (0.3 * a).sin()).into(),
                UnitQuaternion::from_euler_angles(
                    3.0 + 0.1 * (0.7 * a).sin(),
                    0.2,
                    -2.0 + 0.01 * a,
                ),
            );
            for e in 0..if k == 40 { 3 } else { 2 } {
                let side = if e % 2 == 0 { -1.0 } else { 1.0 };
                m.ends.push((
                    f,
                    Vector2::new(
                        side * (0.04 + 0.001 * (a * 1.7).cos()),
                        0.3 + 0.002 * a.sin(),
                    ),
                ));
                m.end_weights.push(1.0 + 0.1 * (a + e as f64).cos());
            }
        }
        (m, x, disk)
    }

    #[test]
    fn lanes_sum_what_the_rows_sum() {
        let (m, x, disk) = model();
        let fast = sums(&m, &x, &disk).expect("ends alone, 83 poses");
        let clusters = m.clusters();
        let g = clusters.iter().map(|&k| k as usize + 1).max().unwrap();
        let (r, j) = eval(&m, &x, &disk, &[], true);
        let rows = Sums::of(&r, &j, &clusters, g);
        assert_eq!((g, fast.scores.nrows(), fast.n), (83, 83, 2 * 167));
        testing::same_sums(&fast, &rows);
    }

    #[test]
    fn few_poses_or_face_points_go_the_rows_way() {
        let (mut m, x, disk) = model();
        let mut few = m.clone();
        few.ends.truncate(128);
        assert!(sums(&few, &x, &disk).is_none());
        m.face.push(m.ends[0]);
        assert!(sums(&m, &x, &disk).is_none());
    }
}
