//! The verdict's sums of a disk model of chord ends alone, scan by scan.
//!
//! A straight scan keeps its flange's orientation bit for bit. Within it, an end's plane row is
//! a fixed 11 x 5 matrix of the scan (`plane_matrix`) times u = (x, z, v.X, v.Y, 1), and its rim
//! row a fixed 11 x 8 matrix (`rim_matrix`) times the rim direction's two coordinates in the
//! disk's plane (g = g1 X + g2 Y) times (1, x, z, h), where p = (x, 0, z) is the end in the
//! sensor, v = q - c its offset from the centre in the base and h = v.n. So J^T J over a scan is
//! A (sum u u^T) A^T + B (sum w w^T) B^T: 15 + 36 products per end instead of 2 x 66 over the
//! rows' eleven columns, and the same for the sandwich's middle term and each pose's score. The
//! same sums as the rows' to rounding (`tests::scans_sum_what_the_rows_sum`).

use super::Sums;
use super::Transform;
use super::disk::{DiskModel, DiskPose};
use super::disk_lanes::{add_run, add_scores, four_new_poses, in_a_row};
use nalgebra::{DMatrix, DVector, Isometry3, SMatrix, SVector, Vector2, Vector3};

/// Columns: rotation 3, translation 3, the disk's centre 3 and normal 2.
const P: usize = 11;
/// A plane row's short vector: (x, z, v.X, v.Y, 1).
const UP: usize = 5;
/// A rim row's: (g1, g2) times (1, x, z, h).
const UR: usize = 8;

/// Ends per run of one flange orientation, on average, from which the scans' way is taken: a
/// run's matrices and their products (about 2,000 multiplications) then cost less than the
/// products its ends save.
pub(super) const SCAN_MIN_ENDS: usize = 16;

/// How the ends follow their flanges: the runs of one orientation (first, end), each end's
/// pose number (a new one wherever its flange's bits change) and the end where each pose
/// starts. Found in one pass, each end's flange compared with the one before, bit for bit and
/// word by word: a pass for the runs and another for the poses read every end twice from
/// beyond the first-level cache (`verdict/disk_closed_form` 1-2 % slower, measured).
pub(super) struct Layout {
    pub runs: Vec<(usize, usize)>,
    pub poses: Vec<u32>,
    pub starts: Vec<usize>,
}

pub(super) fn layout(ends: &[(Isometry3<f64>, Vector2<f64>)]) -> Layout {
    let mut out = Layout {
        runs: Vec::new(),
        poses: Vec::with_capacity(ends.len()),
        starts: Vec::new(),
    };
    let Some((first, _)) = ends.first() else {
        return out;
    };
    let rotation = |f: &Isometry3<f64>| f.rotation.coords.map(f64::to_bits);
    let position = |f: &Isometry3<f64>| f.translation.vector.map(f64::to_bits);
    let differ = |a: &[u64], b: &[u64]| a.iter().zip(b).fold(0, |d, (x, y)| d | (x ^ y)) != 0;
    let (mut turn, mut at) = (rotation(first), position(first));
    let (mut start, mut pose) = (0, 0u32);
    out.starts.push(0);
    out.poses.push(0);
    for (i, (f, _)) in ends.iter().enumerate().skip(1) {
        let (r, p) = (rotation(f), position(f));
        let new_run = differ(r.as_slice(), turn.as_slice());
        if new_run {
            out.runs.push((start, i));
            (start, turn) = (i, r);
        }
        // Within a run the orientation is the same bits: the position tells the pose.
        if new_run || differ(p.as_slice(), at.as_slice()) {
            pose += 1;
            out.starts.push(i);
        }
        at = p;
        out.poses.push(pose);
    }
    out.runs.push((start, ends.len()));
    out
}

/// Most runs whose orientations `clusters` compares pairwise.
const MAX_RUNS_COMPARED: usize = 64;

/// `honest::clusters` of ends laid out in `runs`, `starts` and `poses` (`layout`) without its
/// table, where the data show that no pose comes back: each run's poses move strictly forward
/// along the run's first-to-last translation, and no two runs share an orientation. The
/// layout's pose numbers are then those the table gives (in order of first sight). None
/// otherwise.
pub(super) fn clusters(
    ends: &[(Isometry3<f64>, Vector2<f64>)],
    runs: &[(usize, usize)],
    starts: &[usize],
    poses: Vec<u32>,
) -> Option<Vec<u32>> {
    if runs.len() > MAX_RUNS_COMPARED {
        return None;
    }
    for (i, &(a, _)) in runs.iter().enumerate() {
        if runs[i + 1..]
            .iter()
            .any(|&(b, _)| ends[b].0.rotation == ends[a].0.rotation)
        {
            return None;
        }
    }
    let t = |e: usize| ends[e].0.translation.vector;
    let mut starts = starts.iter().peekable();
    for &(first, end) in runs {
        let along = t(end - 1) - t(first);
        let mut last = f64::NEG_INFINITY;
        while let Some(&e) = starts.next_if(|&&e| e < end) {
            let s = t(e).dot(&along);
            if !(s > last) {
                return None;
            }
            last = s;
        }
    }
    Some(poses)
}

/// The disk's axes at the estimate: normal n = Q z and the plane's X = Q x, Y = Q y (the
/// normal's derivatives are -Y and X).
struct Axes {
    n: Vector3<f64>,
    x: Vector3<f64>,
    y: Vector3<f64>,
}

/// A scan's products: (F_R R)^T and F_R^T applied to the disk's axes n, X, Y, and
/// F_R t - c on each axis (an end's offset from the centre less its flange's position).
struct Scan {
    frr_t: [Vector3<f64>; 3],
    fr_t: [Vector3<f64>; 3],
    offset: [f64; 3],
}

impl Scan {
    fn of(flange: &Isometry3<f64>, x: &Transform, centre: &Vector3<f64>, a: &Axes) -> Scan {
        let fr = *flange.rotation.to_rotation_matrix().matrix();
        let frr = fr * x.rot.matrix();
        let d = fr * x.t - centre;
        Scan {
            frr_t: [a.n, a.x, a.y].map(|v| frr.tr_mul(&v)),
            fr_t: [a.n, a.x, a.y].map(|v| fr.tr_mul(&v)),
            offset: [a.n, a.x, a.y].map(|v| d.dot(&v)),
        }
    }

    /// A in J_plane = A u (11 x 5).
    fn plane_matrix(&self, a: &Axes) -> SMatrix<f64, P, UP> {
        let (an, bn) = (self.frr_t[0], self.fr_t[0]);
        let mut m = SMatrix::<f64, P, UP>::zeros();
        // The rotation columns -(F_R R)^T n x p with p = (x, 0, z).
        m[(0, 1)] = -an[1];
        m[(1, 0)] = -an[2];
        m[(1, 1)] = an[0];
        m[(2, 0)] = an[1];
        for k in 0..3 {
            m[(3 + k, 4)] = bn[k];
            m[(6 + k, 4)] = -a.n[k];
        }
        // The normal's columns v.dn: dn = (-Y, X).
        m[(9, 3)] = -1.0;
        m[(10, 2)] = 1.0;
        m
    }

    /// B in J_rim = B w, w = (g1, g2, x g1, x g2, z g1, z g2, h g1, h g2) (11 x 8).
    fn rim_matrix(&self, a: &Axes) -> SMatrix<f64, P, UR> {
        let [_, ax, ay] = self.frr_t;
        let [_, bx, by] = self.fr_t;
        let mut m = SMatrix::<f64, P, UR>::zeros();
        m[(0, 4)] = -ax[1];
        m[(0, 5)] = -ay[1];
        m[(1, 4)] = ax[0];
        m[(1, 5)] = ay[0];
        m[(1, 2)] = -ax[2];
        m[(1, 3)] = -ay[2];
        m[(2, 2)] = ax[1];
        m[(2, 3)] = ay[1];
        for k in 0..3 {
            m[(3 + k, 0)] = bx[k];
            m[(3 + k, 1)] = by[k];
            m[(6 + k, 0)] = -a.x[k];
            m[(6 + k, 1)] = -a.y[k];
        }
        // -h g.dn: g.(-Y) = -g2, g.X = g1.
        m[(9, 7)] = 1.0;
        m[(10, 6)] = -1.0;
        m
    }
}

/// A scan's sums in lanes of eight ends: the short vectors' products, unweighted and weighted
/// by the squared residual (pairs i <= j row by row), J^T r and the squared residuals.
struct Lanes {
    plane: [[f64; 8]; 15],
    plane_meat: [[f64; 8]; 15],
    rim: [[f64; 8]; 36],
    rim_meat: [[f64; 8]; 36],
    atr: [[f64; 8]; P],
    rss: [f64; 8],
}

/// Eight ends' inputs: the end (x, z), its weight on the rim residual, 1 (0: a lane past the
/// run's last end) and its flange's position F_t.
#[derive(Default)]
struct Chunk {
    x: [f64; 8],
    z: [f64; 8],
    weight: [f64; 8],
    live: [f64; 8],
    t: [[f64; 8]; 3],
}

/// Eight ends' short vectors (K each) and squared residuals: what a run's products need.
#[derive(Clone, Copy)]
struct Short<const K: usize> {
    v: [[f64; 8]; K],
    rr: [f64; 8],
}

impl<const K: usize> Short<K> {
    const ZERO: Short<K> = Short {
        v: [[0.0; 8]; K],
        rr: [0.0; 8],
    };
}

/// `Model::sums` of `m` by scans; `clusters` one per end, `g` of them.
pub(super) fn sums(
    m: &DiskModel,
    x: &Transform,
    s: &DiskPose,
    clusters: &[u32],
    g: usize,
    runs: &[(usize, usize)],
) -> Sums {
    let axes = Axes {
        n: s.q * Vector3::z(),
        x: s.q * Vector3::x(),
        y: s.q * Vector3::y(),
    };
    let mut ata = SMatrix::<f64, P, P>::zeros();
    let mut meat = SMatrix::<f64, P, P>::zeros();
    let mut atr = SVector::<f64, P>::zeros();
    let mut rss = 0.0;
    let mut scores = vec![0.0; P * g];
    let mut chunks: Vec<Chunk> = Vec::new();
    let mut plane: Vec<Short<UP>> = Vec::new();
    let mut rim: Vec<Short<UR>> = Vec::new();
    for &(first, end) in runs {
        let scan = Scan::of(&m.ends[first].0, x, &s.centre, &axes);
        let a = scan.plane_matrix(&axes);
        let b = scan.rim_matrix(&axes);
        let mut lanes = Lanes {
            plane: [[0.0; 8]; 15],
            plane_meat: [[0.0; 8]; 15],
            rim: [[0.0; 8]; 36],
            rim_meat: [[0.0; 8]; 36],
            atr: [[0.0; 8]; P],
            rss: [0.0; 8],
        };
        // The run's inputs first: a chunk written lane by lane and read at once stalls the
        // loads (no store-to-load forwarding from eight narrow stores to one wide load).
        chunks.clear();
        chunks.resize_with((end - first).div_ceil(8), Chunk::default);
        for (start, c) in (first..end).step_by(8).zip(chunks.iter_mut()) {
            fill(c, m, start..(start + 8).min(end));
        }
        let mut run = (clusters[first], [0.0; P]);
        // Written in place: returned, each chunk's short vectors were copied twice.
        plane.resize(chunks.len(), Short::ZERO);
        rim.resize(chunks.len(), Short::ZERO);
        for (k, (start, chunk)) in (first..end).step_by(8).zip(&chunks).enumerate() {
            let stop = (start + 8).min(end);
            let shorts = (&mut plane[k], &mut rim[k]);
            let cl = &clusters[start..stop];
            // Four new poses numbered in a row, two ends each (a scan's chords, as a rule):
            // their scores go straight from the chunk's registers into their rows.
            let direct = four_new_poses(cl, &run, start == first)
                .then(|| in_a_row(cl, g))
                .flatten();
            if direct.is_some() {
                add_run(&mut scores, &run);
                run = (cl[7], [0.0; P]);
            }
            let into = direct.map(|at| (&mut scores[..], at));
            let score = add_chunk(
                &mut lanes,
                chunk,
                (&scan, &axes, &a, &b),
                m.radius,
                shorts,
                into,
            );
            if direct.is_none() {
                add_scores(&mut scores, &mut run, cl, &score, start == first);
            }
        }
        add_run(&mut scores, &run);
        add_run_products(&mut lanes, &plane[..chunks.len()], &rim[..chunks.len()]);
        let su = symmetric::<UP>(&lanes.plane);
        let mu = symmetric::<UP>(&lanes.plane_meat);
        let sw = symmetric::<UR>(&lanes.rim);
        let mw = symmetric::<UR>(&lanes.rim_meat);
        ata += a * su * a.transpose() + b * sw * b.transpose();
        meat += a * mu * a.transpose() + b * mw * b.transpose();
        atr += SVector::<f64, P>::from_fn(|c, _| lanes.atr[c].iter().sum());
        rss += lanes.rss.iter().sum::<f64>();
    }
    Sums {
        ata: DMatrix::from_column_slice(P, P, ata.as_slice()),
        atr: DVector::from_column_slice(atr.as_slice()),
        meat: DMatrix::from_column_slice(P, P, meat.as_slice()),
        scores: DMatrix::from_vec(g, P, scores),
        grams: DMatrix::zeros(P, 0),
        rss,
        n: 2 * m.ends.len(),
    }
}

/// A run's short-vector products v_i v_j over the pairs listed (row by row from `$at` of the
/// lanes), unweighted into `$sums` and weighted by the squared residuals into `$meat`. The
/// block's sums stay in registers over the run's chunks (summed chunk by chunk into memory,
/// each product cost two stores); the pairs are spelled out so that each is a fixed lane
/// operation (from a table, the compiler gathered across pairs instead).
macro_rules! add_block {
    ($sums:expr, $meat:expr, $at:expr, $shorts:expr, $n:literal; $(($i:literal, $j:literal)),+) => {{
        let mut s = [[0.0f64; 8]; $n];
        let mut m = [[0.0f64; 8]; $n];
        for c in $shorts {
            let mut k = 0;
            $(
                for l in 0..8 {
                    let p = c.v[$i][l] * c.v[$j][l];
                    s[k][l] += p;
                    m[k][l] += p * c.rr[l];
                }
                k += 1;
            )+
            debug_assert_eq!(k, $n);
        }
        for k in 0..$n {
            for l in 0..8 {
                $sums[$at + k][l] += s[k][l];
                $meat[$at + k][l] += m[k][l];
            }
        }
    }};
}

/// Every product of a run's plane and rim short vectors into the scan's lanes (pairs i <= j,
/// row by row, as `symmetric` reads them), in blocks small enough for their sums to stay in
/// registers.
#[multiversion::multiversion(targets("x86_64+avx512f", "x86_64+avx2"))]
fn add_run_products(o: &mut Lanes, plane: &[Short<UP>], rim: &[Short<UR>]) {
    add_block!(o.plane, o.plane_meat, 0, plane, 8;
        (0, 0), (0, 1), (0, 2), (0, 3), (0, 4), (1, 1), (1, 2), (1, 3));
    add_block!(o.plane, o.plane_meat, 8, plane, 7;
        (1, 4), (2, 2), (2, 3), (2, 4), (3, 3), (3, 4), (4, 4));
    add_block!(o.rim, o.rim_meat, 0, rim, 12;
        (0, 0), (0, 1), (0, 2), (0, 3), (0, 4), (0, 5), (0, 6), (0, 7),
        (1, 1), (1, 2), (1, 3), (1, 4));
    add_block!(o.rim, o.rim_meat, 12, rim, 12;
        (1, 5), (1, 6), (1, 7), (2, 2), (2, 3), (2, 4), (2, 5), (2, 6), (2, 7),
        (3, 3), (3, 4), (3, 5));
    add_block!(o.rim, o.rim_meat, 24, rim, 12;
        (3, 6), (3, 7), (4, 4), (4, 5), (4, 6), (4, 7), (5, 5), (5, 6), (5, 7),
        (6, 6), (6, 7), (7, 7));
}

/// The K x K symmetric matrix of lanes of sums over the pairs i <= j, row by row.
fn symmetric<const K: usize>(acc: &[[f64; 8]]) -> SMatrix<f64, K, K> {
    let mut out = SMatrix::<f64, K, K>::zeros();
    let mut k = 0;
    for i in 0..K {
        for j in i..K {
            let v: f64 = acc[k].iter().sum();
            out[(i, j)] = v;
            out[(j, i)] = v;
            k += 1;
        }
    }
    out
}

/// Ends `ends` (at most eight, one scan) into `c` (all zero); spare lanes stay dead.
fn fill(c: &mut Chunk, m: &DiskModel, ends: std::ops::Range<usize>) {
    for (l, e) in ends.enumerate() {
        let (f, p) = &m.ends[e];
        for k in 0..3 {
            c.t[k][l] = f.translation.vector[k];
        }
        c.x[l] = p.x;
        c.z[l] = p.y;
        c.weight[l] = m.end_weights.get(e).copied().unwrap_or(1.0);
        c.live[l] = 1.0;
    }
}

/// Eight ends' J^T r and squared residuals into the scan's sums, their short vectors into
/// `plane` and `rim` (for `add_run_products`); returns each end's J^T r (its share of its
/// pose's score: [A B] times its short vectors weighted by their residuals), and with `into`
/// (four new poses in a row from `at`) adds them to those poses' rows itself.
#[multiversion::multiversion(targets("x86_64+avx512f", "x86_64+avx2"))]
fn add_chunk(
    o: &mut Lanes,
    c: &Chunk,
    (scan, axes, a, b): (&Scan, &Axes, &SMatrix<f64, P, UP>, &SMatrix<f64, P, UR>),
    radius: f64,
    (plane, rim): (&mut Short<UP>, &mut Short<UR>),
    into: Option<(&mut [f64], usize)>,
) -> [[f64; 8]; P] {
    let [an, ax, ay] = scan.frr_t;
    let mut up = [[0.0; 8]; UP];
    let mut ur = [[0.0; 8]; UR];
    let (mut r0, mut r1) = ([0.0; 8], [0.0; 8]);
    for l in 0..8 {
        let (x, z, live) = (c.x[l], c.z[l], c.live[l]);
        // v = F_R R p + F_R t + F_t - c on n, X and Y.
        let on = |v: &Vector3<f64>| c.t[0][l] * v[0] + c.t[1][l] * v[1] + c.t[2][l] * v[2];
        let h = x * an[0] + z * an[2] + (on(&axes.n) + scan.offset[0]);
        let vx = x * ax[0] + z * ax[2] + (on(&axes.x) + scan.offset[1]);
        let vy = x * ay[0] + z * ay[2] + (on(&axes.y) + scan.offset[2]);
        let wn = (vx * vx + vy * vy).sqrt();
        let scale = if wn > 0.0 { c.weight[l] / wn } else { 0.0 } * live;
        let (g1, g2) = (vx * scale, vy * scale);
        let u = [x, z, vx, vy, 1.0];
        for k in 0..UP {
            up[k][l] = u[k] * live;
        }
        let w = [g1, g2, x * g1, x * g2, z * g1, z * g2, h * g1, h * g2];
        for k in 0..UR {
            ur[k][l] = w[k];
        }
        r0[l] = h * live;
        r1[l] = c.weight[l] * (wn - radius) * live;
    }
    let rr0: [f64; 8] = std::array::from_fn(|l| r0[l] * r0[l]);
    let rr1: [f64; 8] = std::array::from_fn(|l| r1[l] * r1[l]);
    for l in 0..8 {
        o.rss[l] += rr0[l] + rr1[l];
    }
    // Each end's J^T r = A (r0 u) + B (r1 w), over the entries `plane_matrix` and
    // `rim_matrix` set (the rest are zero).
    let tp: [[f64; 8]; UP] = std::array::from_fn(|k| std::array::from_fn(|l| up[k][l] * r0[l]));
    let tr: [[f64; 8]; UR] = std::array::from_fn(|k| std::array::from_fn(|l| ur[k][l] * r1[l]));
    (plane.v, plane.rr, rim.v, rim.rr) = (up, rr0, ur, rr1);
    let mut score = [[0.0; 8]; P];
    for l in 0..8 {
        score[0][l] = a[(0, 1)] * tp[1][l] + b[(0, 4)] * tr[4][l] + b[(0, 5)] * tr[5][l];
        score[1][l] = a[(1, 0)] * tp[0][l]
            + a[(1, 1)] * tp[1][l]
            + b[(1, 2)] * tr[2][l]
            + b[(1, 3)] * tr[3][l]
            + b[(1, 4)] * tr[4][l]
            + b[(1, 5)] * tr[5][l];
        score[2][l] = a[(2, 0)] * tp[0][l] + b[(2, 2)] * tr[2][l] + b[(2, 3)] * tr[3][l];
        for row in 3..9 {
            score[row][l] =
                a[(row, 4)] * tp[4][l] + b[(row, 0)] * tr[0][l] + b[(row, 1)] * tr[1][l];
        }
        score[9][l] = a[(9, 3)] * tp[3][l] + b[(9, 7)] * tr[7][l];
        score[10][l] = a[(10, 2)] * tp[2][l] + b[(10, 6)] * tr[6][l];
    }
    for (t, s) in o.atr.iter_mut().zip(&score) {
        for l in 0..8 {
            t[l] += s[l];
        }
    }
    // Four poses' scores at once into rows `at`.. of `scores` (g x P, column-major), from
    // registers: stored and read back lane by lane, they stalled (wide stores, narrow loads).
    if let Some((scores, at)) = into {
        let g = scores.len() / P;
        for (c, column) in scores.chunks_exact_mut(g.max(1)).enumerate() {
            for (p, s) in column[at..at + 4].iter_mut().enumerate() {
                *s += score[c][2 * p] + score[c][2 * p + 1];
            }
        }
    }
    score
}

#[cfg(test)]
mod tests {
    use super::super::{Model, eval, testing};
    use super::*;
    use nalgebra::UnitQuaternion;

    /// Four straight scans of 21 poses (more than keep their grams), two ends each, one pose of
    /// three and one scan's last pose seen again at its start (a cluster revisited), odd
    /// weights: 170 ends, the runs' last chunks part dead.
    fn model() -> (DiskModel, Transform, DiskPose) {
        let (mut m, x, disk) = testing::disk_rig();
        for scan in 0..4 {
            let b = scan as f64;
            let turn = UnitQuaternion::from_euler_angles(3.0 + 0.1 * b, 0.2 - 0.05 * b, -2.0 + b);
            let pose = |k: usize| {
                let a = k as f64;
                Isometry3::from_parts(
                    Vector3::new(-0.2 + 0.001 * a, -0.3 + 0.002 * b, 0.36 + 0.0004 * a).into(),
                    turn,
                )
            };
            let mut order: Vec<usize> = (0..21).collect();
            if scan == 2 {
                order.insert(0, 20);
            }
            for (i, &k) in order.iter().enumerate() {
                let a = k as f64;
                for e in 0..if scan == 1 && k == 7 { 3 } else { 2 } {
                    let side = if e % 2 == 0 { -1.0 } else { 1.0 };
                    m.ends.push((
                        pose(k),
                        Vector2::new(
                            side * (0.04 + 0.001 * (a * 1.7 + b).cos()),
                            0.3 + 0.002 * (a + i as f64).sin(),
                        ),
                    ));
                    m.end_weights.push(1.0 + 0.1 * (a + e as f64 + b).cos());
                }
            }
        }
        (m, x, disk)
    }

    #[test]
    fn scans_sum_what_the_rows_sum() {
        let (m, x, disk) = model();
        let runs = layout(&m.ends).runs;
        assert_eq!(runs.len(), 4);
        assert!(m.ends.len() >= SCAN_MIN_ENDS * runs.len());
        // The lanes' entry takes this way for these ends.
        let fast = super::super::disk_lanes::sums(&m, &x, &disk).expect("ends alone, 84 poses");
        let clusters = m.clusters();
        let g = clusters.iter().map(|&k| k as usize + 1).max().unwrap();
        let (r, j) = eval(&m, &x, &disk, &[], true);
        let rows = Sums::of(&r, &j, &clusters, g);
        assert_eq!((g, fast.scores.nrows(), fast.n), (84, 84, 2 * 171));
        testing::same_sums(&fast, &rows);
    }

    #[test]
    fn scans_number_their_poses_as_the_table_does() {
        let (m, _, _) = model();
        let table = |m: &DiskModel| {
            let flanges: Vec<&Isometry3<f64>> = m.ends.iter().map(|(f, _)| f).collect();
            super::super::honest::clusters(&flanges, flanges.len())
        };
        // Scan 2 comes back to its last pose: the table alone can tell.
        let scanned = |ends: &[(Isometry3<f64>, Vector2<f64>)]| {
            let l = layout(ends);
            clusters(ends, &l.runs, &l.starts, l.poses)
        };
        assert_eq!(scanned(&m.ends), None);
        let mut once = m.clone();
        once.ends.remove(2 * 21 + 1 + 2 * 21);
        once.ends.remove(2 * 21 + 1 + 2 * 21);
        let fast = scanned(&once.ends).expect("no pose comes back");
        assert_eq!(fast, table(&once));
        assert_eq!(fast.last(), Some(&83));
        // `disk_lanes::sums` counts the poses from the last number.
        assert_eq!(fast.iter().max(), fast.last());
        // A scan that steps back, or two scans of one orientation, go to the table.
        let mut back = once.clone();
        back.ends.swap(10, 12);
        back.ends.swap(11, 13);
        assert_eq!(scanned(&back.ends), None);
        let mut same = once.clone();
        let turn = same.ends[0].0.rotation;
        for (f, _) in same.ends.iter_mut().skip(2 * 21 + 1 + 2 * 21) {
            f.rotation = turn;
        }
        assert_eq!(scanned(&same.ends), None);
    }

    #[test]
    fn a_pose_per_orientation_goes_the_lanes_way() {
        let (mut m, _, _) = model();
        assert_eq!(layout(&m.ends).runs.len(), 4);
        for (k, (f, _)) in m.ends.iter_mut().enumerate() {
            f.rotation = UnitQuaternion::from_euler_angles(0.001 * (k / 2) as f64, 0.2, 0.3);
        }
        let runs = layout(&m.ends).runs;
        assert!(m.ends.len() < SCAN_MIN_ENDS * runs.len(), "{}", runs.len());
    }
}
