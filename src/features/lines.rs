//! Split-and-merge line extraction on an ordered profile (Nguyen et al. 2007, the disk paper's
//! ref. [20]), with total-least-squares line fits.

use nalgebra::Vector2;

/// An infinite 2D line: a point on it and a unit direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Line2 {
    pub point: Vector2<f64>,
    pub dir: Vector2<f64>,
}

impl Line2 {
    /// Total-least-squares fit (principal axis of the points). None for fewer than 2 points.
    pub fn fit(pts: &[Vector2<f64>]) -> Option<Line2> {
        if pts.len() < 2 {
            return None;
        }
        let n = pts.len() as f64;
        let c = pts.iter().sum::<Vector2<f64>>() / n;
        let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
        for p in pts {
            let d = p - c;
            sxx += d.x * d.x;
            sxy += d.x * d.y;
            syy += d.y * d.y;
        }
        // Principal direction of [[sxx, sxy], [sxy, syy]] in closed form.
        let theta = 0.5 * (2.0 * sxy).atan2(sxx - syy);
        Some(Line2 {
            point: c,
            dir: Vector2::new(theta.cos(), theta.sin()),
        })
    }

    /// Signed distance of `p` from the line (positive to the left of `dir`).
    pub fn distance(&self, p: &Vector2<f64>) -> f64 {
        let d = p - self.point;
        self.dir.x * d.y - self.dir.y * d.x
    }

    /// Intersection with another line; None when (nearly) parallel.
    pub fn intersect(&self, other: &Line2) -> Option<Vector2<f64>> {
        let den = self.dir.x * other.dir.y - self.dir.y * other.dir.x;
        if den.abs() < 1e-12 {
            return None;
        }
        let d = other.point - self.point;
        let t = (d.x * other.dir.y - d.y * other.dir.x) / den;
        Some(self.point + self.dir * t)
    }

    /// Angle between the two lines' directions, in [0, pi/2].
    pub fn angle_to(&self, other: &Line2) -> f64 {
        let c = self.dir.dot(&other.dir).abs().min(1.0);
        c.acos()
    }
}

/// A run of profile points fitted by one line: indices into the point list, inclusive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    pub first: usize,
    pub last: usize,
    pub line: Line2,
}

/// Tuning of the extraction (metres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SplitMerge {
    /// A point farther than this from its segment's line splits the segment.
    pub split_tol: f64,
    /// Neighbouring points farther apart than this start a new run (a step or a gap).
    pub jump: f64,
    /// Segments with fewer points are dropped.
    pub min_points: usize,
}

impl SplitMerge {
    /// Tolerances scaled to a sensor's noise and quantisation: a face is split only where it bends
    /// by more than noise can explain (4 sigma at the far end of the range plus one z step), and a
    /// jump must exceed that twice over.
    pub fn for_sensor(sensor: &crate::sensor::SensorModel) -> SplitMerge {
        let d = SplitMerge::default();
        let n = &sensor.noise;
        let factor = if n.dark_noise_factor > 1.0 {
            n.dark_noise_factor
        } else {
            1.0
        };
        let noise = 4.0 * n.z_sigma_near.max(n.z_sigma_far) * factor
            + sensor.z_quantum.unwrap_or(0.0)
            + 2.0 * n.x_sigma;
        SplitMerge {
            split_tol: d.split_tol.max(noise),
            jump: d.jump.max(2.0 * noise),
            min_points: d.min_points,
        }
    }
}

impl Default for SplitMerge {
    fn default() -> Self {
        SplitMerge {
            split_tol: 0.3e-3,
            jump: 1.0e-3,
            min_points: 4,
        }
    }
}

/// Runs of points whose neighbours lie within `jump` of each other (and whose columns are at most
/// `max_gap` apart): index ranges into `pts`.
pub fn runs(pts: &[(usize, Vector2<f64>)], jump: f64, max_gap: usize) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    if pts.is_empty() {
        return out;
    }
    let mut start = 0;
    for i in 1..pts.len() {
        let gap = pts[i].0 - pts[i - 1].0;
        let dist = (pts[i].1 - pts[i - 1].1).norm();
        // A dropped column stretches the allowed distance proportionally.
        if gap > max_gap + 1 || dist > jump * gap as f64 {
            out.push((start, i - 1));
            start = i;
        }
    }
    out.push((start, pts.len() - 1));
    out
}

/// Split-and-merge over ordered points tagged with their column: split at jumps, then recursively
/// at the farthest point from the chord, then merge neighbours that one line fits.
pub fn split_and_merge(pts: &[(usize, Vector2<f64>)], cfg: &SplitMerge) -> Vec<Segment> {
    let mut pieces: Vec<(usize, usize)> = Vec::new();
    // Bridge up to 12 dropped columns when the points on either side are as close as that many
    // samples allow: a face with dropout stays one face (at 3, dropout 0.2 broke the disk's faces
    // into pieces and the longest piece made a chord up to 28 mm short). A step or a shadow is
    // farther than `jump` per column and still ends the run.
    for (a, b) in runs(pts, cfg.jump, 12) {
        split(pts, a, b, cfg.split_tol, &mut pieces);
    }
    // Merge: adjacent pieces in the same run that one line fits as well as noise allows.
    let mut merged: Vec<(usize, usize)> = Vec::new();
    for (a, b) in pieces {
        if let Some(last) = merged.last_mut()
            && last.1 + 1 == a
            && (pts[a].1 - pts[last.1].1).norm() <= cfg.jump
            && (max_dev(pts, last.0, b).1 <= cfg.split_tol
                || !bends(pts, last.0, last.1, b, cfg.split_tol))
        {
            last.1 = b;
            continue;
        }
        merged.push((a, b));
    }
    merged
        .into_iter()
        .filter(|(a, b)| b - a + 1 >= cfg.min_points)
        .filter_map(|(a, b)| {
            let v: Vec<Vector2<f64>> = pts[a..=b].iter().map(|p| p.1).collect();
            Line2::fit(&v).map(|line| Segment {
                first: a,
                last: b,
                line,
            })
        })
        .collect()
}

/// Index and distance of the point of `pts[a..=b]` farthest from the line through its ends.
fn max_dev(pts: &[(usize, Vector2<f64>)], a: usize, b: usize) -> (usize, f64) {
    let (p, q) = (pts[a].1, pts[b].1);
    let d = q - p;
    let len = d.norm();
    let mut best = (a, 0.0);
    if len == 0.0 {
        return best;
    }
    for (i, pt) in pts.iter().enumerate().take(b + 1).skip(a) {
        let r = pt.1 - p;
        let dist = (d.x * r.y - d.y * r.x).abs() / len;
        if dist > best.1 {
            best = (i, dist);
        }
    }
    best
}

/// Residual sum of squares of the least-squares line through `pts[a..=b]`.
fn rss(pts: &[(usize, Vector2<f64>)], a: usize, b: usize) -> f64 {
    let v: Vec<Vector2<f64>> = pts[a..=b].iter().map(|p| p.1).collect();
    match Line2::fit(&v) {
        Some(line) => v.iter().map(|p| line.distance(p).powi(2)).sum(),
        None => 0.0,
    }
}

/// Whether `pts[a..=b]` bends at `i` by more than noise can explain: two lines (split at `i`) fit
/// better than one by more than 16 noise variances (`tol` is four noise standard deviations).
/// Without a bend the gain is about two variances (chi-square, two degrees of freedom), so a long
/// noisy face stays whole; the line through the stretch's two end points, which split-and-merge
/// uses to find where to split, carries the end points' own noise and alone would split it.
fn bends(pts: &[(usize, Vector2<f64>)], a: usize, i: usize, b: usize, tol: f64) -> bool {
    let var = (tol / 4.0).powi(2);
    rss(pts, a, b) - rss(pts, a, i) - rss(pts, i, b) > 16.0 * var
}

fn split(
    pts: &[(usize, Vector2<f64>)],
    a: usize,
    b: usize,
    tol: f64,
    out: &mut Vec<(usize, usize)>,
) {
    if b <= a + 1 {
        out.push((a, b));
        return;
    }
    let (i, d) = max_dev(pts, a, b);
    if d > tol && i > a && i < b && bends(pts, a, i, b, tol) {
        split(pts, a, i, tol, out);
        split(pts, i, b, tol, out);
        // The split point belongs to both halves; give it to the first only.
        if let Some(pos) = out.iter().rposition(|s| s.0 == i) {
            out[pos].0 = i + 1;
            if out[pos].0 > out[pos].1 {
                out.remove(pos);
            }
        }
    } else {
        out.push((a, b));
    }
}
