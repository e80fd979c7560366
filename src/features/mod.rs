//! Features from one profile: disk chord endpoints, the ball's arc circle, and the straight-edge
//! point. Each works in the profile plane (sensor x, z) and knows the sensor's column rays, so the
//! ends of a surface are placed between columns at sub-sample precision.

pub mod circle;
pub mod lines;

pub use circle::{Circle, Sphere, fit_circle, fit_sphere};
pub use lines::{Line2, Segment, SplitMerge, split_and_merge};

use crate::sensor::{Profile, SensorModel};
use nalgebra::Vector2;
use thiserror::Error;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum FeatureError {
    #[error("the profile has {found} valid points; at least {need} are needed")]
    TooFewPoints { found: usize, need: usize },
    #[error("no chord of the disk in this profile: {reason}")]
    NoChord { reason: String },
    #[error(
        "the chord runs off the field of view at column {column}; move the sensor so the whole chord is seen"
    )]
    ChordTruncated { column: usize },
    #[error("no arc of the ball in this profile: {reason}")]
    NoArc { reason: String },
    #[error("no edge in this profile: {reason}")]
    NoEdge { reason: String },
}

/// A chord of the disk seen in one profile: endpoints (x, z) in the sensor frame, `a` toward -x
/// (as the analytic chords).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Chord {
    pub a: Vector2<f64>,
    pub b: Vector2<f64>,
}

impl Chord {
    /// From its ends at the lower and the higher column: on a sensor whose column 0 is at +x those
    /// run toward -x, so they swap.
    fn by_x(low_column: Vector2<f64>, high_column: Vector2<f64>, sensor: &SensorModel) -> Chord {
        if sensor.x_reversed {
            Chord {
                a: high_column,
                b: low_column,
            }
        } else {
            Chord {
                a: low_column,
                b: high_column,
            }
        }
    }
}

/// Valid points with their column index.
/// The profile's points on a found ball arc (within four RMS of its circle).
pub fn arc_points(profile: &Profile, circle: &Circle) -> Vec<Vector2<f64>> {
    let cut = 4.0 * circle.rms.max(1e-6);
    valid_points(profile)
        .into_iter()
        .map(|(_, p)| p)
        .filter(|p| ((p - circle.centre).norm() - circle.radius).abs() <= cut)
        .collect()
}

/// The z noise (m, one standard deviation) the profiles themselves show: each valid point's z
/// less the z its neighbours (columns k-1 and k+1, both valid) interpolate at its x, scaled by
/// the spread that difference has for independent z noise (sqrt(1 + w^2 + (1 - w)^2), w the
/// point's place between them); robustly, 1.4826 x the median, so that the few triples across
/// an edge or a jump do not count. (Along z, not across the chord: at a column step below the
/// noise the chord's own direction is noise.) At most about 20,000 triples, spread over the
/// profiles. None with fewer than 20.
pub fn measured_noise<'a>(profiles: impl IntoIterator<Item = &'a Profile>) -> Option<f64> {
    let profiles: Vec<&Profile> = profiles.into_iter().collect();
    let total: usize = profiles.iter().map(|p| p.points.len()).sum();
    let stride = total.div_ceil(20_000).max(1);
    let mut d = Vec::new();
    for p in profiles {
        for k in (1..p.points.len().saturating_sub(1)).step_by(stride) {
            let (Some(a), Some(b), Some(c)) = (p.points[k - 1], p.points[k], p.points[k + 1])
            else {
                continue;
            };
            let at = |q: crate::sensor::ProfilePoint| Vector2::new(q.x, q.z);
            d.extend(departure(&at(a), &at(b), &at(c)));
        }
    }
    robust_sd(d)
}

/// The z noise (m) a run of consecutive points of one surface shows (`measured_noise`'s
/// departures, each point against its two neighbours in the run). None with fewer than 20.
pub fn run_noise(points: &[Vector2<f64>]) -> Option<f64> {
    robust_sd(
        (points.windows(3))
            .filter_map(|t| departure(&t[0], &t[1], &t[2]))
            .collect(),
    )
}

/// |b.z less the z that a and c interpolate at b.x|, over the spread that difference has for
/// independent z noise; None where b does not lie between them in x.
fn departure(a: &Vector2<f64>, b: &Vector2<f64>, c: &Vector2<f64>) -> Option<f64> {
    let w = (b.x - a.x) / (c.x - a.x);
    (0.0..=1.0).contains(&w).then(|| {
        let dz = b.y - (a.y + w * (c.y - a.y));
        (dz / (1.0 + w * w + (1.0 - w) * (1.0 - w)).sqrt()).abs()
    })
}

/// 1.4826 x the median of `d` (absolute values); None with fewer than 20.
fn robust_sd(mut d: Vec<f64>) -> Option<f64> {
    if d.len() < 20 {
        return None;
    }
    let mid = d.len() / 2;
    let (_, median, _) = d.select_nth_unstable_by(mid, f64::total_cmp);
    Some(1.4826 * *median)
}

/// The points of the profile's longest straight segment (sensor x, z), in column order.
pub fn largest_segment(profile: &Profile, cfg: &SplitMerge) -> Vec<Vector2<f64>> {
    let pts = valid_points(profile);
    split_and_merge(&pts, cfg)
        .iter()
        .max_by_key(|s| s.last - s.first)
        .map(|s| pts[s.first..=s.last].iter().map(|p| p.1).collect())
        .unwrap_or_default()
}

pub fn valid_points(profile: &Profile) -> Vec<(usize, Vector2<f64>)> {
    profile
        .points
        .iter()
        .enumerate()
        .filter_map(|(k, p)| p.map(|p| (k, Vector2::new(p.x, p.z))))
        .collect()
}

/// The line along which (fractional) column `u` measures.
fn column_line(sensor: &SensorModel, u: f64) -> Line2 {
    let (p, d) = sensor.column_line(u);
    Line2 {
        point: Vector2::new(p[0], p[1]),
        dir: Vector2::new(d[0], d[1]),
    }
}

/// Where a surface along `line` whose last column is `k` ends toward its neighbour `k2`: on the
/// column line the sensor's expected end offset beyond `k` (half a sample for rays; see
/// `SensorModel::end_offset_columns`), plus `extra` columns.
fn end_between(sensor: &SensorModel, line: &Line2, k: usize, k2: usize) -> Option<Vector2<f64>> {
    end_beyond(sensor, line, k, k2, 0.0)
}

/// As `end_between`, `extra` columns farther (beyond 1, extrapolated with the spacing of the two).
fn end_beyond(
    sensor: &SensorModel,
    line: &Line2,
    k: usize,
    k2: usize,
    extra: f64,
) -> Option<Vector2<f64>> {
    let at_k = line.intersect(&column_line(sensor, k as f64))?;
    let offset = sensor.end_offset_columns(sensor.dir_z * (at_k.y - sensor.apex_z)) + extra;
    let u = k as f64 + offset * (k2 as f64 - k as f64);
    line.intersect(&column_line(sensor, u))
}

/// A face's end for a sensor known only by its points, which has no rays to say where the next
/// one met the face: from the last point's foot on the line, one face step on (the spacing of its
/// last two points, where the next ray would have met the face continued), the end `offset` steps
/// out. (The last point's foot, one step on, the end.)
fn end_without_rays(
    line: &Line2,
    last: &Vector2<f64>,
    before_last: &Vector2<f64>,
    offset: f64,
) -> (Vector2<f64>, Vector2<f64>, Vector2<f64>) {
    let u = line.dir.normalize();
    let foot = |p: &Vector2<f64>| line.point + u * (p - line.point).dot(&u);
    let at = foot(last);
    let step = at - foot(before_last);
    (at, at + step, at + step * offset)
}

/// True when the profile beyond end `forward` of segment `i` lies farther from the sensor than the
/// segment's line continued (a step down or a convex corner), or nothing lies beyond.
fn drops_away(
    sensor: &SensorModel,
    pts: &[(usize, Vector2<f64>)],
    s: &Segment,
    forward: bool,
    tol: f64,
) -> bool {
    let idx = if forward {
        s.last + 1
    } else {
        s.first.wrapping_sub(1)
    };
    let Some(&(k, p)) = pts.get(idx) else {
        return true;
    };
    if sensor.points_only {
        // No rays to continue the face along: beyond its end point, a step down or a corner
        // turning away lies no nearer the sensor than that point.
        let end = pts[if forward { s.last } else { s.first }].1;
        return sensor.dir_z * (p.y - end.y) >= -tol;
    }
    match s.line.intersect(&column_line(sensor, k as f64)) {
        Some(on_line) => {
            sensor.dir_z * (p.y - sensor.apex_z) >= sensor.dir_z * (on_line.y - sensor.apex_z) - tol
        }
        None => true,
    }
}

/// Whether profile point `p` (column, x, z) lies nearer the sensor than `line` continued to its
/// column's ray, by more than `tol`.
fn nearer_than_line(
    sensor: &SensorModel,
    line: &Line2,
    p: (usize, Vector2<f64>),
    tol: f64,
) -> bool {
    match line.intersect(&column_line(sensor, p.0 as f64)) {
        Some(on_line) => {
            sensor.dir_z * (p.1.y - sensor.apex_z)
                < sensor.dir_z * (on_line.y - sensor.apex_z) - tol
        }
        None => false,
    }
}

/// Refit a segment's ends: split-and-merge decides with a coarse tolerance, so a wall point just off
/// the face can join it, and a corner point goes to one side only. Fit the interior, then keep
/// exactly the neighbouring points within 4 RMS of that line (at least 1 nm; at most `tol`).
fn tighten(
    pts: &[(usize, Vector2<f64>)],
    s: &Segment,
    tol: f64,
    sensor: &SensorModel,
) -> (usize, usize, Line2) {
    let n = s.last + 1 - s.first;
    // A short segment (a wall seen in a few columns) may hold a neighbour's point at an end
    // within the split tolerance: fit without its ends too.
    let trim = if n > 8 {
        2
    } else if n >= 5 {
        1
    } else {
        0
    };
    let interior: Vec<Vector2<f64>> = pts[s.first + trim..=s.last - trim]
        .iter()
        .map(|p| p.1)
        .collect();
    let Some(line) = Line2::fit(&interior) else {
        return (s.first, s.last, s.line);
    };
    let rms = (interior
        .iter()
        .map(|p| line.distance(p).powi(2))
        .sum::<f64>()
        / interior.len() as f64)
        .sqrt();
    let thr = (4.0 * rms).clamp(1e-9, tol);
    // Across dropped columns too (as `lines::runs` bridges them), so dropout near an end does not
    // stop the face short.
    let ok = |i: usize, j: usize| {
        pts[j].0.abs_diff(pts[i].0) <= 13 && line.distance(&pts[j].1).abs() <= thr
    };
    let (mut first, mut last) = (s.first + trim, s.last - trim);
    while first > 0 && ok(first, first - 1) {
        first -= 1;
    }
    while last + 1 < pts.len() && ok(last, last + 1) {
        last += 1;
    }
    // On a resampled profile the slot where the face turns into a wall is a blend of the two (it
    // is interpolated between the last ray on the face and the first on the wall) and may still
    // pass 4 RMS: there, an end point that the profile continues beyond (off the line) must lie
    // within 2.5 RMS. (Tried on ray profiles too: better on the disk at high noise, worse on the
    // VLM350's 0.1 mm-quantised edges; not taken there.)
    let blend = |j: usize, beyond: Option<usize>| {
        sensor.resampling().is_some()
            && !sensor.points_only
            && beyond.is_some_and(|b| pts[b].0.abs_diff(pts[j].0) <= 13)
            && line.distance(&pts[j].1).abs() > (2.5 * rms).max(1e-9)
    };
    if last > s.last - trim && blend(last, (last + 1 < pts.len()).then_some(last + 1)) {
        last -= 1;
    }
    if first < s.first + trim && blend(first, first.checked_sub(1)) {
        first += 1;
    }
    let all: Vec<Vector2<f64>> = pts[first..=last].iter().map(|p| p.1).collect();
    (first, last, Line2::fit(&all).unwrap_or(line))
}

/// The face's end once wall points are told from it, at one end of a disk's face or of an edge's
/// top face where no corner is taken (`forward`: beyond `last`). Where a wall drops away past
/// the end (adjacent points, each farther from the face's line than the one before and beyond
/// the noise), its line, offset against column, tells the face's last points from wall points that the noise let in: at 0.25 mm of noise
/// `tighten`'s 4-RMS walk took the first wall points for the face, carrying a disk's ends outward
/// by up to nine columns on the side where its wall shows (on the comparison rig the refined
/// chords' result moved 0.016 deg with them). A point is the wall's where the wall's line explains
/// its offset better than the face's. (The rim placed at the two lines' corner instead was tried:
/// the wall's line, extrapolated, biased the closed form's result threefold at low noise.)
fn end_before_wall(
    pts: &[(usize, Vector2<f64>)],
    first: usize,
    last: usize,
    line: &Line2,
    sensor: &SensorModel,
    forward: bool,
) -> Option<WallEnds> {
    if sensor.points_only || sensor.resampling().is_some() || last < first + 8 {
        return None;
    }
    // Offset along each point's column from the face's line, positive away from the sensor.
    let off = |i: usize| -> Option<f64> {
        let (k, p) = pts[i];
        let q = line.intersect(&column_line(sensor, k as f64))?;
        Some(sensor.dir_z * (p.y - q.y))
    };
    // The noise where the face ends: its points next to the end (not the last few, which may be
    // the wall's). Over the whole face, a noise growing with depth read too low at a chord's
    // deeper end and too high at the other, and their thresholds moved the two ends apart.
    const LOCAL: usize = 64;
    const SKIP: usize = 4;
    let window = if last - first + 1 >= 2 * (LOCAL + SKIP) {
        if forward {
            last - SKIP - LOCAL + 1..=last - SKIP
        } else {
            first + SKIP..=first + SKIP + LOCAL - 1
        }
    } else {
        first..=last
    };
    let face: Vec<f64> = window.filter_map(off).collect();
    let sigma = (face.iter().map(|o| o * o).sum::<f64>() / face.len().max(1) as f64)
        .sqrt()
        .max(sensor.z_quantum.unwrap_or(0.0) / 12f64.sqrt())
        .max(1e-9);
    // The wall: adjacent columns past the end, each farther from the face's line than the one
    // before and beyond the noise; at most `RUN` of them.
    const RUN: usize = 6;
    let step = |i: usize| -> Option<usize> {
        if forward {
            (i + 1 < pts.len()).then_some(i + 1)
        } else {
            i.checked_sub(1)
        }
    };
    let mut run: Vec<(f64, f64)> = Vec::new();
    let (mut at, mut prev) = (if forward { last } else { first }, 0.0);
    while run.len() < RUN {
        let Some(next) = step(at) else { break };
        if pts[next].0.abs_diff(pts[at].0) != 1 {
            break;
        }
        let Some(o) = off(next) else { break };
        if o <= prev || o <= 3.0 * sigma {
            break;
        }
        run.push((pts[next].0 as f64, o));
        (at, prev) = (next, o);
    }
    if run.len() < 2 {
        return None;
    }
    // The wall's offset, linear in the column: o = a + b (k - mean).
    let n = run.len() as f64;
    let mean_k = run.iter().map(|r| r.0).sum::<f64>() / n;
    let mean_o = run.iter().map(|r| r.1).sum::<f64>() / n;
    let sxx: f64 = run.iter().map(|r| (r.0 - mean_k).powi(2)).sum();
    let b = run
        .iter()
        .map(|r| (r.0 - mean_k) * (r.1 - mean_o))
        .sum::<f64>()
        / sxx;
    // Away from the face (growing past the end) and clearly so.
    let outward = if forward { b } else { -b };
    if outward <= 3.0 * sigma / sxx.sqrt() {
        return None;
    }
    // A wall rises from the face's end: its line meets the face's within a few columns of it.
    // (The table far below, tilted, also falls away column by column, but meets the face's
    // line hundreds of columns off.)
    let corner = mean_k - mean_o / b;
    let from_end = (corner - pts[if forward { last } else { first }].0 as f64).abs();
    if !(from_end <= 3.0) {
        return None;
    }
    // The face's last points: the wall's where their offset passes the balanced threshold.
    let end_at = |t: f64| -> Option<usize> {
        let mut end = if forward { last } else { first };
        while end.abs_diff(if forward { first } else { last }) > 8 {
            if off(end)? <= t {
                break;
            }
            end = if forward { end - 1 } else { end + 1 };
        }
        Some(end)
    };
    Some(WallEnds {
        point: end_at(balanced_threshold(outward, sigma, Balance::Rates))?,
        interval: end_at(balanced_threshold(outward, sigma, Balance::Violations))?,
    })
}

/// The last face point of a censored interval: its own (`WallEnds::interval`), unless the column
/// past it lies off the sensor, then the point's end (which the callers have checked).
fn interval_end(
    pts: &[(usize, Vector2<f64>)],
    interval: usize,
    point: usize,
    forward: bool,
    sensor: &SensorModel,
) -> usize {
    let k = pts[interval].0;
    if (forward && k + 1 >= sensor.columns) || (!forward && k == 0) {
        point
    } else {
        interval
    }
}

/// Where a face ends before a wall, for the two uses of its end.
#[derive(Debug, Clone, Copy)]
struct WallEnds {
    /// The last face point of a feature placed half a column past it (chord ends, edge points).
    point: usize,
    /// The last face point of a censored interval (the rim or edge lies between it and the
    /// next point).
    interval: usize,
}

/// What `balanced_threshold` balances.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Balance {
    /// Where the end lies on average (every column it can move, out or in): at the face's last
    /// column, so that a point placed half a column past it is unbiased.
    Rates,
    /// How far, on average, the censored interval lies out and in: the fit's pull at the truth
    /// (a violated interval pulls by its distance) is then zero.
    Violations,
}

/// The offset from a face's line beyond which a point at its end is taken for the wall's, for a
/// wall falling `slope` per column and noise `sigma`: the wall's first point lies (1 - phi) slope
/// below the face (phi, the rim's place between the two columns, uniform), so one taken for the
/// face carries the end a column out, and the face's last point taken for the wall a column in.
/// `Balance::Rates`: the end's mean column is the face's last, and a point placed half a column
/// past it is unbiased. (Taking a point for the wall only where the wall's line explained it
/// better never erred inward and carried the ends on the wall's side outward by 0.02 columns at
/// z noise 0.12 mm: the refined chords' result 0.8 sd off, the same in every placement.)
/// `Balance::Violations`: a censored interval taken m columns in lies phi + m - 1 inside the rim,
/// one taken j out j - phi outside, and the wall's point is let in mostly where 1 - phi is small;
/// at the rates' threshold the intervals lay inward on average, and disk-any-pose's translation
/// along the flange's z was half its sd off on every sensor (1,280 to 12,800 columns; 89 %
/// covered at 12,800). So the mean distance is balanced. Both count every column the end can
/// move (the rates' first form counted one either way: 0.08 columns out where the wall falls 1.5
/// sigma per column).
fn balanced_threshold(slope: f64, sigma: f64, balance: Balance) -> f64 {
    if !(slope > 0.0 && sigma > 0.0) {
        return 0.0;
    }
    // The threshold in sigmas depends on slope / sigma alone: tabulated once on a log grid
    // (each entry a bisection over phi and the wall's columns, too slow for every profile's
    // ends), read by linear interpolation in log(slope / sigma). Below the grid the wall cannot
    // be told from the noise anyway (`end_before_wall` needs it 3 sigma clear), above it the
    // threshold grows as slowly as the noise's tail.
    const N: usize = 128;
    const RATIO: (f64, f64) = (0.25, 1000.0);
    static TABLES: std::sync::OnceLock<[Vec<f64>; 2]> = std::sync::OnceLock::new();
    let tables = TABLES.get_or_init(|| {
        let at =
            |k: usize| (RATIO.0.ln() + (RATIO.1 / RATIO.0).ln() * k as f64 / (N - 1) as f64).exp();
        [Balance::Rates, Balance::Violations]
            .map(|b| (0..N).map(|k| threshold_in_sigmas(at(k), b)).collect())
    });
    let table = &tables[usize::from(balance == Balance::Violations)];
    let x = ((slope / sigma).ln() - RATIO.0.ln()) / (RATIO.1 / RATIO.0).ln() * (N - 1) as f64;
    let x = x.clamp(0.0, (N - 1) as f64);
    let k = (x.floor() as usize).min(N - 2);
    let f = x - k as f64;
    sigma * (table[k] * (1.0 - f) + table[k + 1] * f)
}

/// `balanced_threshold` in sigmas for a wall falling `ratio` sigmas per column.
fn threshold_in_sigmas(ratio: f64, balance: Balance) -> f64 {
    // What lies inward less what lies outward (mean columns, or mean distances), over phi: falls
    // with t. The end is the farthest point within t of the face's line. With the rim phi past
    // the last face column and the wall's j-th point (j - phi) ratio below the face, the end lies
    // j >= 1 columns out when the wall's j-th is the farthest within t, or m >= 1 in when every
    // point past it is beyond t (the face's each with probability q).
    let gap = |t: f64| {
        const PHI: usize = 32;
        let q = crate::math::normal_cdf(-t).min(0.999);
        // Wall points past t + 8 sigma are never within it.
        let columns = (((t + 8.0) / ratio).ceil() as usize + 1).min(64);
        (0..PHI)
            .map(|i| {
                let phi = 1.0 - (i as f64 + 0.5) / PHI as f64;
                // P(end >= j) = 1 - prod_{i >= j} (1 - p_i), p_i: the wall's i-th within t.
                let (mut none_beyond, mut out) = (1.0, 0.0);
                for j in (1..=columns).rev() {
                    none_beyond *= 1.0 - crate::math::normal_cdf(t - (j as f64 - phi) * ratio);
                    out += 1.0 - none_beyond;
                }
                match balance {
                    // E[end] = sum_j P(end >= j) - sum_m P(end <= -m).
                    Balance::Rates => none_beyond * q / (1.0 - q) - out,
                    // Out: end - phi; in: phi + m - 1.
                    Balance::Violations => {
                        none_beyond * (phi * q + q * q / (1.0 - q))
                            - (out - phi * (1.0 - none_beyond))
                    }
                }
            })
            .sum::<f64>()
            / PHI as f64
    };
    let (mut lo, mut hi) = (0.0, 6.0);
    if gap(lo) <= 0.0 {
        return lo;
    }
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if gap(mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Chord of a disk on a cylinder (a step at the rim): split-and-merge; the chord is the segment, no
/// longer than the disk's diameter, beyond both of whose ends the profile falls away from the
/// sensor (the table and the cylinder wall lie below the disk); among several, the one with most
/// points. Its ends are placed between columns.
pub fn disk_chord_step(
    profile: &Profile,
    sensor: &SensorModel,
    disk_radius: f64,
    cfg: &SplitMerge,
) -> Result<Chord, FeatureError> {
    disk_chord_and_face(profile, sensor, disk_radius, cfg).map(|(chord, _)| chord)
}

/// `disk_chord_step` with the points of the disk's face the chord was fitted to (what the
/// full-profile refinement uses).
pub fn disk_chord_and_face(
    profile: &Profile,
    sensor: &SensorModel,
    disk_radius: f64,
    cfg: &SplitMerge,
) -> Result<(Chord, Vec<Vector2<f64>>), FeatureError> {
    disk_profile(profile, sensor, disk_radius, cfg).map(|d| (d.chord, d.face))
}

/// A disk's chord, its face points, and where on the face's line the rim can lie at each end:
/// between the face's last column and the next column with a point (what the any-pose
/// estimator uses, without guessing where in the gap the rim is).
#[derive(Debug, Clone, PartialEq)]
pub struct DiskProfile {
    pub chord: Chord,
    pub face: Vec<Vector2<f64>>,
    pub rim: [(Vector2<f64>, Vector2<f64>); 2],
    /// The valid points beyond each end of the face (toward the chord's `a`, then `b`), nearest
    /// first, at most `BEYOND` each: where the cylinder's wall shows, if it does (the
    /// full-profile refinement tells wall from table with its estimate of the disk).
    pub beyond: [Vec<Vector2<f64>>; 2],
}

/// Points beyond each end of a disk's face that `disk_profile` keeps.
pub const BEYOND: usize = 128;

pub fn disk_profile(
    profile: &Profile,
    sensor: &SensorModel,
    disk_radius: f64,
    cfg: &SplitMerge,
) -> Result<DiskProfile, FeatureError> {
    let pts = valid_points(profile);
    if pts.len() < cfg.min_points {
        return Err(FeatureError::TooFewPoints {
            found: pts.len(),
            need: cfg.min_points,
        });
    }
    let segs = split_and_merge(&pts, cfg);
    let max_len = 2.0 * disk_radius * 1.02 + 4.0 * sensor.x_step_at_depth(sensor.depth_far);
    let best = segs
        .iter()
        .enumerate()
        .filter(|(_, s)| (pts[s.last].1 - pts[s.first].1).norm() <= max_len)
        .filter(|(_, s)| {
            drops_away(sensor, &pts, s, false, cfg.split_tol)
                && drops_away(sensor, &pts, s, true, cfg.split_tol)
        })
        .max_by_key(|(_, s)| s.last - s.first)
        .ok_or_else(|| FeatureError::NoChord {
            reason: format!(
                "none of {} line segments is a plateau shorter than the disk diameter",
                segs.len()
            ),
        })?
        .0;
    // The rim lies between the last column on the disk and the next one, whatever is beyond (the
    // cylinder wall is curved, so a corner with it would not be exact).
    let (first, last, line) = tighten(&pts, &segs[best], cfg.split_tol, sensor);
    let ends = [false, true].map(|fwd| end_before_wall(&pts, first, last, &line, sensor, fwd));
    // The rim's censored intervals start from their own last face points (`Balance`).
    let rim_ends = [
        ends[0].map_or(first, |e| e.interval),
        ends[1].map_or(last, |e| e.interval),
    ];
    let (first, last, line) = match ends {
        [None, None] => (first, last, line),
        [lo, hi] => {
            let (f, l) = (lo.map_or(first, |e| e.point), hi.map_or(last, |e| e.point));
            let face: Vec<Vector2<f64>> = pts[f..=l].iter().map(|p| p.1).collect();
            (f, l, Line2::fit(&face).unwrap_or(line))
        }
    };
    let s = &Segment { first, last, line };
    // The sensor's dropout rate, measured on the face: the share of its columns without a point.
    // Beyond 30 % the face falls apart into pieces that cannot be told from pieces of the table:
    // no chord rather than a wrong one.
    let span = pts[last].0 - pts[first].0 + 1;
    let dropout = (span - (last - first + 1)) as f64 / span as f64;
    if dropout > 0.3 {
        return Err(FeatureError::NoChord {
            reason: "over 30 % of the columns across the chord have no point: too few to place \
                     its ends"
                .into(),
        });
    }
    let end = |idx: usize, forward: bool| {
        if sensor.points_only {
            // Nothing measured beyond the face: it may run on out of what the profiler saw.
            let outer = if forward {
                idx + 1
            } else {
                idx.wrapping_sub(1)
            };
            if outer >= pts.len() {
                return Err(FeatureError::ChordTruncated { column: pts[idx].0 });
            }
            let inner = if forward { idx - 1 } else { idx + 1 };
            let (a, b, point) = end_without_rays(&s.line, &pts[idx].1, &pts[inner].1, 0.5);
            // Continued one step, the face would leave the range the points show.
            let depth = sensor.dir_z * (b.y - sensor.apex_z);
            if depth < sensor.depth_near || depth > sensor.depth_far {
                return Err(FeatureError::ChordTruncated { column: pts[idx].0 });
            }
            return Ok((point, (a, b)));
        }
        let k = pts[idx].0;
        let k2 = if forward { k + 1 } else { k.wrapping_sub(1) };
        if k2 >= sensor.columns {
            return Err(FeatureError::ChordTruncated { column: k });
        }
        // Where the next column finds nothing, the chord may run on out of the measurement range.
        if profile.points[k2].is_none()
            && let Some(p) = s.line.intersect(&column_line(sensor, k2 as f64))
        {
            let depth = sensor.dir_z * (p.y - sensor.apex_z);
            if depth < sensor.depth_near || depth > sensor.depth_far {
                return Err(FeatureError::ChordTruncated { column: k });
            }
        }
        // Beyond a missing neighbour the face may go on under dropped points: given that the
        // neighbour is missing, the face's last column lies j columns farther with probability
        // proportional to p^j, so the end moves out by p / (1 - p) columns on average (none
        // without dropout: then a missing neighbour is the rim's shadow).
        let extra = if profile.points[k2].is_none() && dropout > 0.0 {
            dropout / (1.0 - dropout).max(0.5)
        } else {
            0.0
        };
        let truncated = FeatureError::ChordTruncated { column: k };
        let rim = interval_end(&pts, rim_ends[usize::from(forward)], idx, forward, sensor);
        let beyond = if forward {
            pts.get(rim + 1)
        } else {
            rim.checked_sub(1).and_then(|i| pts.get(i))
        }
        .map_or(pts[rim].0 as isize + if forward { 1 } else { -1 }, |p| {
            p.0 as isize
        });
        let on = |u: isize| s.line.intersect(&column_line(sensor, u as f64));
        let interval = on(pts[rim].0 as isize)
            .zip(on(beyond))
            .ok_or(truncated.clone())?;
        let point = end_beyond(sensor, &s.line, k, k2, extra).ok_or(truncated)?;
        Ok((point, interval))
    };
    let (low, high) = (end(first, false)?, end(last, true)?);
    let before: Vec<Vector2<f64>> = pts[..first]
        .iter()
        .rev()
        .take(BEYOND)
        .map(|p| p.1)
        .collect();
    let after: Vec<Vector2<f64>> = pts[last + 1..].iter().take(BEYOND).map(|p| p.1).collect();
    let beyond = if sensor.x_reversed {
        [after, before]
    } else {
        [before, after]
    };
    Ok(DiskProfile {
        chord: Chord::by_x(low.0, high.0, sensor),
        face: pts[first..=last].iter().map(|p| p.1).collect(),
        rim: [low.1, high.1],
        beyond,
    })
}

/// Chord of a white disk on black paper: the longest run of bright points (intensity above the
/// midpoint of the profile's range), ends placed between the last bright and first dark column.
pub fn disk_chord_intensity(
    profile: &Profile,
    sensor: &SensorModel,
    min_points: usize,
) -> Result<Chord, FeatureError> {
    let valid: Vec<(usize, f64)> = profile
        .points
        .iter()
        .enumerate()
        .filter_map(|(k, p)| p.map(|p| (k, p.intensity)))
        .collect();
    if valid.len() < min_points {
        return Err(FeatureError::TooFewPoints {
            found: valid.len(),
            need: min_points,
        });
    }
    let (lo, hi) = valid
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &(_, i)| {
            (l.min(i), h.max(i))
        });
    if hi <= 2.0 * lo {
        return Err(FeatureError::NoChord {
            reason: format!("no contrast: intensities span {lo:.3}..{hi:.3}"),
        });
    }
    let thr = 0.5 * (lo + hi);
    let bright = |k: usize| profile.points[k].is_some_and(|p| p.intensity >= thr);
    let mut best: Option<(usize, usize)> = None;
    let mut k = 0;
    while k < profile.points.len() {
        if bright(k) {
            let start = k;
            while k + 1 < profile.points.len() && bright(k + 1) {
                k += 1;
            }
            if best.is_none_or(|(a, b)| k - start > b - a) {
                best = Some((start, k));
            }
        }
        k += 1;
    }
    let (first, last) = best.ok_or_else(|| FeatureError::NoChord {
        reason: "no bright run".into(),
    })?;
    if last + 1 - first < min_points {
        return Err(FeatureError::NoChord {
            reason: format!("the bright run has {} points", last + 1 - first),
        });
    }
    if first == 0 || last + 1 >= sensor.columns {
        return Err(FeatureError::ChordTruncated {
            column: if first == 0 { 0 } else { last },
        });
    }
    let pts: Vec<Vector2<f64>> = (first..=last)
        .filter_map(|k| profile.points[k].map(|p| Vector2::new(p.x, p.z)))
        .collect();
    let line = Line2::fit(&pts).ok_or_else(|| FeatureError::NoChord {
        reason: "degenerate run".into(),
    })?;
    let a = end_between(sensor, &line, first, first - 1)
        .ok_or(FeatureError::ChordTruncated { column: first })?;
    let b = end_between(sensor, &line, last, last + 1)
        .ok_or(FeatureError::ChordTruncated { column: last })?;
    Ok(Chord::by_x(a, b, sensor))
}

/// The ball's arc: among runs of neighbouring points, the one best fitted by a circle no larger than
/// the ball; outliers beyond 4 RMS are dropped and the circle refitted.
pub fn ball_arc(
    profile: &Profile,
    ball_radius: f64,
    cfg: &SplitMerge,
) -> Result<Circle, FeatureError> {
    let pts = valid_points(profile);
    if pts.len() < 5 {
        return Err(FeatureError::TooFewPoints {
            found: pts.len(),
            need: 5,
        });
    }
    let mut best: Option<(Circle, usize)> = None;
    // Bridge up to 12 dropped columns, as the faces do: at 3, dropout 0.2 cut the arcs into pieces
    // and the longest piece alone gave 2.7x the translation error of the whole arc.
    for (a, b) in lines::runs(&pts, cfg.jump * 3.0, 12) {
        if b + 1 - a < 5 {
            continue;
        }
        let v: Vec<Vector2<f64>> = pts[a..=b].iter().map(|p| p.1).collect();
        let Some(c) = fit_circle(&v) else { continue };
        if c.radius > ball_radius * 1.05 + 1e-3 || c.radius < 0.05 * ball_radius {
            continue;
        }
        let c = trim_and_refit(&v, c);
        if best.as_ref().is_none_or(|(_, n)| v.len() > *n) {
            best = Some((c, v.len()));
        }
    }
    best.map(|b| b.0).ok_or_else(|| FeatureError::NoArc {
        reason: format!(
            "no run of points fits a circle of radius at most {:.2} mm",
            ball_radius * 1.05e3
        ),
    })
}

/// Which way a sensor looks along its z axis, read from ball arcs: it sees the ball's near side, so
/// each arc's circle centre lies beyond its points. +1 when the centres lie at larger z than their
/// arcs (z grows away from the sensor), -1 the other way; None without at least three arcs, nine
/// in ten of them agreeing.
pub fn view_direction_from_arcs(profiles: &[Profile], ball_radius: f64) -> Option<f64> {
    let cfg = SplitMerge::default();
    let votes: Vec<f64> = profiles
        .iter()
        .filter_map(|p| {
            let c = ball_arc(p, ball_radius, &cfg).ok()?;
            let arc = arc_points(p, &c);
            let mean_z = arc.iter().map(|q| q.y).sum::<f64>() / arc.len().max(1) as f64;
            let d = c.centre.y - mean_z;
            (d.abs() > 0.05 * c.radius).then_some(d.signum())
        })
        .collect();
    let away = votes.iter().filter(|v| **v > 0.0).count();
    let n = votes.len();
    if n < 3 {
        return None;
    }
    if away * 10 >= n * 9 {
        Some(1.0)
    } else if (n - away) * 10 >= n * 9 {
        Some(-1.0)
    } else {
        None
    }
}

fn trim_and_refit(v: &[Vector2<f64>], mut c: Circle) -> Circle {
    for _ in 0..3 {
        let cut = 4.0 * c.rms.max(1e-9);
        let kept: Vec<Vector2<f64>> = v
            .iter()
            .copied()
            .filter(|p| ((p - c.centre).norm() - c.radius).abs() <= cut)
            .collect();
        if kept.len() == v.len() || kept.len() < 5 {
            break;
        }
        match fit_circle(&kept) {
            Some(n) => c = n,
            None => break,
        }
    }
    c
}

/// Which way the profile crosses the edge: `Rising` when the specimen lies at higher x than the
/// edge, `Falling` when the profile runs over the specimen and drops off toward higher x.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EdgeSense {
    Falling,
    Rising,
}

/// The straight-edge point: from the specimen's top face (the largest segment not lying clearly below the others) walk toward
/// the edge over shallow bevels; the edge is the corner with a steep side wall, or the end of the
/// last face halfway to the next column where the profile jumps or ends. Faces are refitted with
/// their ends tightened, as for chords.
pub fn edge_point(
    profile: &Profile,
    sensor: &SensorModel,
    sense: EdgeSense,
    cfg: &SplitMerge,
) -> Result<Vector2<f64>, FeatureError> {
    edge_point_and_face(profile, sensor, sense, cfg).map(|e| e.end.point)
}

/// `edge_point` with the points of the top face it walked from (what `edge-full` fits too).
pub fn edge_point_and_face(
    profile: &Profile,
    sensor: &SensorModel,
    sense: EdgeSense,
    cfg: &SplitMerge,
) -> Result<EdgeProfile, FeatureError> {
    let (pts, segs) = segments(profile, cfg)?;
    let mut first_err = None;
    for i in top_face_candidates(&pts, &segs, sensor, cfg) {
        match walk_to_edge(&pts, &segs, i, sensor, sense, cfg) {
            Ok((e, next)) => {
                let (first0, last0, _) = tighten(&pts, &segs[i], cfg.split_tol, sensor);
                let (mut first, mut last) = (first0, last0);
                // Points beyond index `next` of the walk toward `sense`, nearest first.
                let beyond = |next: usize, sense: EdgeSense| -> Vec<Vector2<f64>> {
                    let forward = (sense == EdgeSense::Falling) != sensor.x_reversed;
                    if next >= pts.len() {
                        Vec::new()
                    } else if forward {
                        pts[next..].iter().take(BEYOND).map(|p| p.1).collect()
                    } else {
                        pts[..=next]
                            .iter()
                            .rev()
                            .take(BEYOND)
                            .map(|p| p.1)
                            .collect()
                    }
                };
                let back = match sense {
                    EdgeSense::Falling => EdgeSense::Rising,
                    EdgeSense::Rising => EdgeSense::Falling,
                };
                let other = walk_to_edge(&pts, &segs, i, sensor, back, cfg).ok();
                // The face stops where each walk ended it: wall points the walk told from the
                // face are not the face's (an end past `last` was walked over a bevel).
                for (sense, next) in [(sense, next)]
                    .into_iter()
                    .chain(other.map(|o| (back, o.1)))
                {
                    if (sense == EdgeSense::Falling) != sensor.x_reversed {
                        last = last.min(next.wrapping_sub(1));
                    } else {
                        first = first.max(next.wrapping_add(1));
                    }
                }
                if first >= last {
                    (first, last) = (first0, last0);
                }
                let other = other.map(|(o, next)| (o, beyond(next, back)));
                return Ok(EdgeProfile {
                    end: e,
                    face: pts[first..=last].iter().map(|p| p.1).collect(),
                    beyond: beyond(next, sense),
                    other,
                });
            }
            Err(e) => {
                first_err.get_or_insert(e);
            }
        }
    }
    Err(first_err.unwrap_or_else(|| FeatureError::NoEdge {
        reason: format!("no face of {} points", cfg.min_points),
    }))
}

/// A profile's valid points and their straight segments (of two points or more).
type Segmented = (Vec<(usize, Vector2<f64>)>, Vec<Segment>);

fn segments(profile: &Profile, cfg: &SplitMerge) -> Result<Segmented, FeatureError> {
    let pts = valid_points(profile);
    if pts.len() < cfg.min_points {
        return Err(FeatureError::TooFewPoints {
            found: pts.len(),
            need: cfg.min_points,
        });
    }
    let segs = split_and_merge(
        &pts,
        &SplitMerge {
            min_points: 2,
            ..*cfg
        },
    );
    Ok((pts, segs))
}

/// The top face's candidates, best first: among the substantial segments (a tenth of the largest
/// one's points or more), leave out those lying wholly below the nearest one (a table under the
/// specimen), then order by points (not by nearness: under a tilt a side wall is as near as the
/// face). A face whose walk finds no edge is not the top face: the caller tries the next.
fn top_face_candidates(
    pts: &[(usize, Vector2<f64>)],
    segs: &[Segment],
    sensor: &SensorModel,
    cfg: &SplitMerge,
) -> Vec<usize> {
    let largest = segs.iter().map(|s| s.last + 1 - s.first).max().unwrap_or(0);
    let min_pts = cfg.min_points.max(largest / 10);
    let depth = |s: &Segment| {
        let mid = (pts[s.first].1 + pts[s.last].1) / 2.0;
        sensor.dir_z * (mid.y - sensor.apex_z)
    };
    let mut cands: Vec<usize> = (0..segs.len())
        .filter(|&j| segs[j].last + 1 - segs[j].first >= min_pts)
        .collect();
    let ends = |s: &Segment| {
        let (a, b) = (pts[s.first].1, pts[s.last].1);
        let (da, db) = (
            sensor.dir_z * (a.y - sensor.apex_z),
            sensor.dir_z * (b.y - sensor.apex_z),
        );
        (da.min(db), da.max(db))
    };
    if let Some(&nearest) = cands
        .iter()
        .min_by(|&&a, &&b| depth(&segs[a]).total_cmp(&depth(&segs[b])))
    {
        let floor = ends(&segs[nearest]).1 + 2.0e-3;
        cands.retain(|&j| ends(&segs[j]).0 <= floor);
    }
    // A face with a parallel face above it (along its normal, toward the sensor) is not the top
    // face: a step's lower face, a table beside a bar, which a tilt brings as near as the top.
    let line = |s: &Segment| {
        let (a, b) = (pts[s.first].1, pts[s.last].1);
        let d = (b - a).try_normalize(1e-12)?;
        let mid = (a + b) / 2.0;
        let n = Vector2::new(-d.y, d.x);
        let toward = Vector2::new(0.0, sensor.apex_z) - mid;
        Some((mid, d, if n.dot(&toward) < 0.0 { -n } else { n }))
    };
    let lines: Vec<_> = cands.iter().map(|&j| line(&segs[j])).collect();
    let covered: Vec<bool> = lines
        .iter()
        .map(|lj| {
            let Some((mj, dj, nj)) = lj else { return false };
            lines
                .iter()
                .flatten()
                .any(|(mk, dk, _)| dj.dot(dk).abs() > PARALLEL_COS && (mk - mj).dot(nj) > STEP_MIN)
        })
        .collect();
    let top: Vec<usize> = cands
        .iter()
        .zip(&covered)
        .filter(|(_, c)| !**c)
        .map(|(&j, _)| j)
        .collect();
    if !top.is_empty() {
        cands = top;
    }
    cands.sort_by_key(|&j| std::cmp::Reverse(segs[j].last - segs[j].first));
    cands
}

/// Faces within 5 deg of each other count as parallel when choosing the top face.
const PARALLEL_COS: f64 = 0.996_194_698;
/// A parallel face this far above another (m) makes that one a lower face.
const STEP_MIN: f64 = 2.0e-3;

/// One end of a face that is an edge: its point, and where the edge can lie: at the corner
/// (`from == to`, where a wall was seen) or between the face's last column and the next.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeEnd {
    pub point: Vector2<f64>,
    pub from: Vector2<f64>,
    pub to: Vector2<f64>,
}

/// The edge of one profile (its point, and the interval between columns it lies in where the face
/// just stops), the top face's points it was walked from, and the valid points beyond the face's
/// end at the edge, nearest first, at most `BEYOND` (the wall, where it shows).
#[derive(Debug, Clone, PartialEq)]
pub struct EdgeProfile {
    pub end: EdgeEnd,
    pub face: Vec<Vector2<f64>>,
    pub beyond: Vec<Vector2<f64>>,
    /// The face's other end, walked to the other way, where it is an edge too (a bar seen across
    /// its width), with the points beyond it.
    pub other: Option<(EdgeEnd, Vec<Vector2<f64>>)>,
}

/// Two faces meeting at a corner (a ridge, a V groove, a step's face and wall): each face's points
/// in profile order, the face at lower x first, and the corner where their lines meet.
#[derive(Debug, Clone, PartialEq)]
pub struct TwoFaces {
    pub faces: [Vec<Vector2<f64>>; 2],
    pub corner: Vector2<f64>,
    /// The angle between the faces' lines in the profile (rad, 0 to 90 deg).
    pub angle: f64,
}

/// The two faces of a ridge (`outside`: the corner nearer the sensor than both faces, a roof or a
/// knife's edge) or of a groove (the corner farther, a V groove or a fillet's sides): the best of
/// `two_faces_candidates`, or the best whose faces meet at `angle` (rad, the lines' angle in the
/// profile) within 25 deg, when given (the angle a profile shows changes with how the laser
/// crosses the line).
pub fn two_faces(
    profile: &Profile,
    sensor: &SensorModel,
    outside: bool,
    angle: Option<f64>,
    cfg: &SplitMerge,
) -> Result<TwoFaces, FeatureError> {
    let near = |t: &TwoFaces| angle.is_none_or(|a| (t.angle - a).abs() <= 25f64.to_radians());
    let all = two_faces_candidates(profile, sensor, outside, cfg)?;
    let n = all.len();
    all.into_iter()
        .find(near)
        .ok_or_else(|| FeatureError::NoEdge {
            reason: format!(
                "none of {n} pairs of faces meets at the angle the other profiles show ({:.0} deg)",
                angle.unwrap_or(0.0).to_degrees()
            ),
        })
}

/// Every pair of segments of the profile that can be the target's two faces, the pair whose smaller
/// face has the most points first:
/// segments of `min_points` + 2 points or more meeting at 10 deg or more, at an outside (or
/// inside) corner, their facing ends within a jump or a quarter of the shorter one (a rounded
/// or chipped tip between them) and the corner at that tip. The two points on either side of
/// the corner are left to neither face (a blend); the corner is where the faces' lines meet. A
/// profile may also cross another corner (the plate a ridge stands on, a chamfer): which pair is
/// the target's, the caller tells from the angle most profiles agree on.
pub fn two_faces_candidates(
    profile: &Profile,
    sensor: &SensorModel,
    outside: bool,
    cfg: &SplitMerge,
) -> Result<Vec<TwoFaces>, FeatureError> {
    let (pts, segs) = segments(profile, cfg)?;
    let size = |s: &Segment| s.last + 1 - s.first;
    let need = cfg.min_points.max(4) + 2;
    let mut found: Vec<(usize, TwoFaces)> = Vec::new();
    let pairs = (0..segs.len()).flat_map(|i| (i + 1..segs.len().min(i + 4)).map(move |j| (i, j)));
    for (i, j) in pairs {
        let (a, b) = (&segs[i], &segs[j]);
        if size(a) < need || size(b) < need {
            continue;
        }
        let length = |s: &Segment| (pts[s.last].1 - pts[s.first].1).norm();
        let tip = (pts[b.first].1 - pts[a.last].1).norm();
        if tip > cfg.jump.max(0.25 * length(a).min(length(b))) {
            continue;
        }
        // (`angle_to` is the lines' angle, 0 to 90 deg.)
        let angle = a.line.angle_to(&b.line);
        if angle < 10f64.to_radians() {
            continue;
        }
        // Each face without the two points next to the corner, and without the points at its far
        // end that lie off its line (where it meets a table or a wall, split-and-merge's coarse
        // tolerance lets a neighbour's point join it).
        let face = |from: usize, to: usize, corner_first: bool| {
            let v: Vec<Vector2<f64>> = pts[from..=to].iter().map(|p| p.1).collect();
            let inner = &v[2.min(v.len())..v.len().saturating_sub(2).max(2.min(v.len()))];
            let line = Line2::fit(inner)?;
            let rms = (inner.iter().map(|p| line.distance(p).powi(2)).sum::<f64>()
                / inner.len() as f64)
                .sqrt();
            let thr = (4.0 * rms).clamp(1e-9, cfg.split_tol);
            // From the far end inward, the points off the line (at most a tenth of the face).
            let mut kept = v.clone();
            if !corner_first {
                kept.reverse();
            }
            let most = kept.len() / 10;
            for _ in 0..most {
                match kept.last() {
                    Some(p) if line.distance(p).abs() > thr => {
                        kept.pop();
                    }
                    _ => break,
                }
            }
            if !corner_first {
                kept.reverse();
            }
            let line = Line2::fit(&kept)?;
            Some((kept, line))
        };
        let (Some((fa, la)), Some((fb, lb))) = (
            face(a.first, a.last - 2, false),
            face(b.first + 2, b.last, true),
        ) else {
            continue;
        };
        if fa.len() < need - 2 || fb.len() < need - 2 {
            continue;
        }
        let Some(corner) = la.intersect(&lb) else {
            continue;
        };
        // The corner lies at the tip, not past a face that lies between.
        let reach = 2.0 * tip + cfg.jump;
        if (corner - pts[a.last].1).norm() > reach || (corner - pts[b.first].1).norm() > reach {
            continue;
        }
        // Outside: the corner is nearer the sensor than the faces' far ends' chord.
        let depth = |q: &Vector2<f64>| sensor.dir_z * (q.y - sensor.apex_z);
        let (far_a, far_b) = (fa[0], fb[fb.len() - 1]);
        let t = (corner.x - far_a.x) / (far_b.x - far_a.x);
        let on_chord = far_a + (far_b - far_a) * t;
        if !t.is_finite() || (depth(&corner) < depth(&on_chord)) != outside {
            continue;
        }
        // Ranked by the smaller face: a table meeting a wall or a face has many points on one
        // side only.
        let n = fa.len().min(fb.len());
        let faces = if sensor.x_reversed {
            [fb, fa]
        } else {
            [fa, fb]
        };
        found.push((
            n,
            TwoFaces {
                faces,
                corner,
                angle: la.angle_to(&lb),
            },
        ));
    }
    if found.is_empty() {
        return Err(FeatureError::NoEdge {
            reason: format!(
                "no two faces of {need} points or more meet at {} corner",
                if outside { "an outside" } else { "an inside" }
            ),
        });
    }
    found.sort_by(|a, b| b.0.cmp(&a.0));
    Ok(found.into_iter().map(|f| f.1).collect())
}

/// A bar (or plate) seen from any pose: its top face's points and every end of the face that is an
/// edge (one or both; which edge each is, the caller infers from where they lie).
#[derive(Debug, Clone, PartialEq)]
pub struct BarProfile {
    pub face: Vec<Vector2<f64>>,
    pub edges: Vec<EdgeEnd>,
}

/// The top face and its edges, walked in both senses. From any pose the face may be a small part
/// of the profile (a narrow bar on a table), a wall seen under a tilt can be as long as the face
/// and also ends at a convex corner, and the table under the bar can end at an edge too. So: of
/// the segments of 8 points or more with an edge, those parallel (within 15 deg) to the profile's
/// largest segment (the face or the table it lies on), the one nearest the sensor; failing that,
/// the one the laser meets most squarely (the poses look at the top face, its walls turned away).
pub fn bar_profile(
    profile: &Profile,
    sensor: &SensorModel,
    cfg: &SplitMerge,
) -> Result<BarProfile, FeatureError> {
    let (pts, segs) = segments(profile, cfg)?;
    let mut first_err = None;
    let mut found: Vec<(Line2, BarProfile)> = Vec::new();
    let size = |s: &Segment| s.last + 1 - s.first;
    for i in (0..segs.len()).filter(|&i| size(&segs[i]) >= cfg.min_points.max(8)) {
        let mut edges = Vec::new();
        for sense in [EdgeSense::Falling, EdgeSense::Rising] {
            match walk_to_edge(&pts, &segs, i, sensor, sense, cfg) {
                Ok((e, _)) => edges.push(e),
                Err(e) => {
                    first_err.get_or_insert(e);
                }
            }
        }
        if edges.is_empty() {
            continue;
        }
        let (first, last, line) = tighten(&pts, &segs[i], cfg.split_tol, sensor);
        let face: Vec<Vector2<f64>> = pts[first..=last].iter().map(|p| p.1).collect();
        found.push((line, BarProfile { face, edges }));
    }
    let apex = Vector2::new(0.0, sensor.apex_z);
    let square = |l: &Line2| {
        let ray = (l.point - apex).normalize();
        (l.dir.x * ray.y - l.dir.y * ray.x).abs() / l.dir.norm()
    };
    let largest = segs.iter().max_by_key(|s| size(s)).map(|s| s.line);
    let parallel =
        |f: &(Line2, BarProfile)| largest.is_some_and(|l| f.0.angle_to(&l) < 15f64.to_radians());
    let best = if found.iter().any(parallel) {
        found.into_iter().filter(parallel).min_by(|a, b| {
            a.0.distance(&apex)
                .abs()
                .total_cmp(&b.0.distance(&apex).abs())
        })
    } else {
        found
            .into_iter()
            .max_by(|a, b| square(&a.0).total_cmp(&square(&b.0)))
    };
    best.map(|b| b.1).ok_or_else(|| {
        first_err.unwrap_or_else(|| FeatureError::NoEdge {
            reason: format!("no face of {} points", cfg.min_points),
        })
    })
}

/// From face `i`, walk toward the edge in `sense` over shallow bevels to the corner with a steep
/// wall falling away from the sensor, or to the face's end halfway to the next column when what
/// lies beyond is farther from the sensor (or nothing). Anything else is not the specimen's edge.
/// With the edge, the index of the first point beyond the face's end (out of range if none).
fn walk_to_edge(
    pts: &[(usize, Vector2<f64>)],
    segs: &[Segment],
    mut i: usize,
    sensor: &SensorModel,
    sense: EdgeSense,
    cfg: &SplitMerge,
) -> Result<(EdgeEnd, usize), FeatureError> {
    // The sense is a direction in x; the walk goes by column, which runs the other way on a
    // sensor whose column 0 is at +x.
    let forward = (sense == EdgeSense::Falling) != sensor.x_reversed;
    let after = |idx: usize| {
        if forward {
            idx + 1
        } else {
            idx.wrapping_sub(1)
        }
    };
    loop {
        let (first, last, line) = tighten(pts, &segs[i], cfg.split_tol, sensor);
        let idx = if forward { last } else { first };
        let k = pts[idx].0;
        let next = after(idx);
        if let Some(&(kn, pn)) = pts.get(next)
            && kn.abs_diff(k) == 1
            && (pn - pts[idx].1).norm() <= cfg.jump
            && let Some(j) = segs.iter().position(|s| s.first <= next && next <= s.last)
            && j != i
        {
            let (f2, l2, line2) = tighten(pts, &segs[j], cfg.split_tol, sensor);
            let angle = line.angle_to(&line2);
            // A wall seen in a handful of noisy points gives a poor line: only trust the corner
            // when the wall is well sampled; otherwise fall through to the end of the face.
            if angle > std::f64::consts::FRAC_PI_4 && l2 + 1 - f2 >= 2 * cfg.min_points {
                let beyond = if forward { l2 } else { f2 };
                if nearer_than_line(sensor, &line, pts[beyond], cfg.split_tol) {
                    return Err(FeatureError::NoEdge {
                        reason: "the face meets a wall rising toward the sensor".into(),
                    });
                }
                let corner = line.intersect(&line2).ok_or_else(|| FeatureError::NoEdge {
                    reason: "parallel faces".into(),
                })?;
                let corner = if sensor.points_only {
                    corner
                } else {
                    split_corner(
                        &pts[first.min(f2)..=last.max(l2)],
                        corner,
                        sensor,
                        forward,
                        cfg,
                    )
                };
                return Ok((
                    EdgeEnd {
                        point: corner,
                        from: corner,
                        to: corner,
                    },
                    next,
                ));
            }
            if angle > 0.02 && angle <= std::f64::consts::FRAC_PI_4 {
                i = j;
                continue;
            }
        }
        // A wall too poorly sampled for a corner: tell the face's last points from the wall's
        // with the balanced threshold, as at a disk's rim. With `tighten`'s 4-RMS walk alone, the
        // wall's first points within the noise were taken for the face and the end lay 0.036 mm
        // (a third of a column) outward on average at z noise 0.12 mm where a wall 5-15 deg past
        // vertical showed: edge-refined's translation 1 sd off, the same on every placement.
        // The censored interval from its own last face point (`Balance`).
        let wall = end_before_wall(pts, first, last, &line, sensor, forward);
        let interval_idx = wall.map_or(idx, |e| e.interval);
        let (idx, line) = match wall {
            Some(end) if end.point != idx => {
                let (f, l) = if forward {
                    (first, end.point)
                } else {
                    (end.point, last)
                };
                let face: Vec<Vector2<f64>> = pts[f..=l].iter().map(|p| p.1).collect();
                (end.point, Line2::fit(&face).unwrap_or(line))
            }
            _ => (idx, line),
        };
        let next = after(idx);
        if sensor.points_only {
            return points_only_end(pts, idx, next, &line, sensor, forward, cfg)
                .map(|end| (end, next));
        }
        return ray_end(pts, idx, interval_idx, &line, sensor, forward, cfg).map(|end| (end, next));
    }
}

/// A face's end on a sensor with rays, where no corner was found: halfway between the face's last
/// column and the next, with the censored interval from `interval_idx`'s column to the next
/// (`end_before_wall`). Err where the face may go on unseen or meets something nearer.
fn ray_end(
    pts: &[(usize, Vector2<f64>)],
    idx: usize,
    interval_idx: usize,
    line: &Line2,
    sensor: &SensorModel,
    forward: bool,
    cfg: &SplitMerge,
) -> Result<EdgeEnd, FeatureError> {
    let (k, next) = (
        pts[idx].0,
        if forward {
            idx + 1
        } else {
            idx.wrapping_sub(1)
        },
    );
    let k2 = if forward { k + 1 } else { k.wrapping_sub(1) };
    if k2 >= sensor.columns {
        return Err(FeatureError::NoEdge {
            reason: "the face runs off the field of view".into(),
        });
    }
    if let Some(&p) = pts.get(next)
        && nearer_than_line(sensor, line, p, cfg.split_tol)
    {
        return Err(FeatureError::NoEdge {
            reason: "the profile rises toward the sensor beyond the face".into(),
        });
    }
    // Nothing measured at the next column, where the face continued would lie beyond the
    // measuring range: the face may go on unseen.
    let measured = pts.get(next).is_some_and(|p| p.0 == k2);
    if !measured && let Some(q) = line.intersect(&column_line(sensor, k2 as f64)) {
        let depth = sensor.dir_z * (q.y - sensor.apex_z);
        if !(sensor.depth_near..=sensor.depth_far).contains(&depth) {
            return Err(FeatureError::NoEdge {
                reason: "the face runs out of the measuring range".into(),
            });
        }
    }
    let parallel = || FeatureError::NoEdge {
        reason: "face parallel to the ray".into(),
    };
    let on = |u: f64| line.intersect(&column_line(sensor, u)).ok_or_else(parallel);
    let ki = pts[interval_end(pts, interval_idx, idx, forward, sensor)].0 as f64;
    Ok(EdgeEnd {
        point: end_between(sensor, line, k, k2).ok_or_else(parallel)?,
        from: on(ki)?,
        to: on(if forward { ki + 1.0 } else { ki - 1.0 })?,
    })
}

/// A corner between a face and a well-sampled wall, each line refitted from the points on its own
/// side of `corner` (by column), twice: near the corner the points lie near both lines, and each
/// walk takes some of the other's (at 0.25 mm of noise the wall's took the face's last points
/// and carried the corner a column out in a fifth of the views). `span` runs from the face's
/// first point to the wall's last.
fn split_corner(
    span: &[(usize, Vector2<f64>)],
    mut corner: Vector2<f64>,
    sensor: &SensorModel,
    forward: bool,
    cfg: &SplitMerge,
) -> Vector2<f64> {
    for _ in 0..2 {
        let Some(u) = sensor.column_of(corner.x, corner.y) else {
            break;
        };
        let face_side = |k: usize| ((k as f64) < u) == forward;
        let (mut fp, mut wp) = (Vec::new(), Vec::new());
        for &(k, p) in span {
            if face_side(k) { fp.push(p) } else { wp.push(p) }
        }
        if wp.len() < 2 * cfg.min_points {
            break;
        }
        let (Some(lf), Some(lw)) = (Line2::fit(&fp), Line2::fit(&wp)) else {
            break;
        };
        let Some(c) = lf.intersect(&lw) else { break };
        corner = c;
    }
    corner
}

/// A face's end on a sensor that gives points only (no rays to continue the face along): what
/// lies beyond, at `next`, must be no nearer the sensor than the face's end point `idx`, and the
/// end lies halfway to it along the face's `line`.
fn points_only_end(
    pts: &[(usize, Vector2<f64>)],
    idx: usize,
    next: usize,
    line: &Line2,
    sensor: &SensorModel,
    forward: bool,
    cfg: &SplitMerge,
) -> Result<EdgeEnd, FeatureError> {
    if next >= pts.len() {
        return Err(FeatureError::NoEdge {
            reason: "nothing measured beyond the face: it may run on unseen".into(),
        });
    }
    if sensor.dir_z * (pts[next].1.y - pts[idx].1.y) < -cfg.split_tol {
        return Err(FeatureError::NoEdge {
            reason: "the profile rises toward the sensor beyond the face".into(),
        });
    }
    let inner = if forward { idx - 1 } else { idx + 1 };
    let (from, to, point) = end_without_rays(line, &pts[idx].1, &pts[inner].1, 0.5);
    let depth = sensor.dir_z * (to.y - sensor.apex_z);
    if !(sensor.depth_near..=sensor.depth_far).contains(&depth) {
        return Err(FeatureError::NoEdge {
            reason: "the face runs out of the range the points show".into(),
        });
    }
    Ok(EdgeEnd { point, from, to })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::ProfilePoint;

    #[test]
    fn measured_noise_reads_the_profiles_own_noise() {
        // A tilted face and a step (whose triples must not count), unevenly sampled as a fan does,
        // with z noise 0.1 mm: read back within 10 %; exact data read as (nearly) none.
        let mut rng = crate::testkit::rng(5);
        let profile = |sigma: f64, rng: &mut crate::rng::Rng| Profile {
            points: (0..1000)
                .map(|k| {
                    let x = -0.05 + 0.1 * (k as f64 / 999.0).powf(1.2);
                    let step = if x > 0.01 { 0.02 } else { 0.0 };
                    (k % 37 != 0).then(|| ProfilePoint {
                        x,
                        z: 0.3 + 0.2 * x + step + sigma * crate::rng::gauss(rng),
                        intensity: 1.0,
                    })
                })
                .collect(),
        };
        let noisy: Vec<Profile> = (0..5).map(|_| profile(1e-4, &mut rng)).collect();
        let m = measured_noise(&noisy).unwrap();
        assert!((m / 1e-4 - 1.0).abs() < 0.1, "{m}");
        let exact = [profile(0.0, &mut rng)];
        assert!(measured_noise(&exact).unwrap() < 1e-12);
        assert_eq!(measured_noise(&[Profile { points: vec![] }]), None);
    }

    #[test]
    fn a_run_of_face_points_reads_its_own_noise() {
        let mut rng = crate::testkit::rng(6);
        for sigma in [2e-5, 1e-4, 2.5e-4] {
            let run: Vec<Vector2<f64>> = (0..500)
                .map(|k| {
                    let x = -0.04 + 0.08 * (k as f64 / 499.0).powf(1.1);
                    Vector2::new(x, 0.3 - 0.15 * x + sigma * crate::rng::gauss(&mut rng))
                })
                .collect();
            let m = run_noise(&run).unwrap();
            assert!((m / sigma - 1.0).abs() < 0.1, "{m} against {sigma}");
        }
        // 20 triples at least; exact points read as none.
        let exact: Vec<Vector2<f64>> = (0..22).map(|k| Vector2::new(k as f64, 0.5)).collect();
        assert_eq!(run_noise(&exact), Some(0.0));
        assert_eq!(run_noise(&exact[..21]), None);
    }

    /// The mean signed distance (columns) between a censored interval and the rim, and the mean
    /// end of a point placed half a column past the last face point, over `n` seeded face ends:
    /// face offsets N(0, sigma) up to column 0, the rim at phi (uniform) past it, the wall's
    /// points (j - phi) slope below the face's line at column j >= 1. The end as
    /// `end_before_wall` finds it: walked outward within 4 sigma, then inward past `t`.
    fn end_errors(slope: f64, sigma: f64, t: f64, n: usize, seed: u64) -> (f64, f64) {
        let mut rng = crate::testkit::rng(seed);
        let (mut interval, mut point) = (0.0, 0.0);
        for _ in 0..n {
            let phi: f64 = rand::RngExt::random(&mut rng);
            let off = |j: i32, rng: &mut crate::rng::Rng| {
                let wall = if j >= 1 {
                    (j as f64 - phi) * slope
                } else {
                    0.0
                };
                wall + sigma * crate::rng::gauss(rng)
            };
            let offs: Vec<f64> = (-10..=6).map(|j| off(j, &mut rng)).collect();
            let at = |j: i32| offs[(j + 10) as usize];
            let mut end = 0;
            while end < 6 && at(end + 1).abs() <= 4.0 * sigma {
                end += 1;
            }
            while end > -10 && at(end) > t {
                end -= 1;
            }
            // The interval [end, end + 1] against the rim at phi: out > 0, in < 0.
            let e = end as f64;
            interval += if e > phi {
                e - phi
            } else if e + 1.0 < phi {
                e + 1.0 - phi
            } else {
                0.0
            };
            point += e + 0.5 - phi;
        }
        (interval / n as f64, point / n as f64)
    }

    #[test]
    fn each_threshold_balances_what_its_end_is_used_for() {
        // A point half a column past the end is unbiased with the rates balanced, and a censored
        // interval with the distances balanced; the rates' threshold leaves the interval inward
        // (what biased disk-any-pose).
        let sigma = 1.0;
        for (i, slope) in [10.0, 3.0, 1.5].into_iter().enumerate() {
            let rates = balanced_threshold(slope, sigma, Balance::Rates);
            let violations = balanced_threshold(slope, sigma, Balance::Violations);
            assert!(violations > rates, "{slope}: {violations} <= {rates}");
            let (in_r, pt_r) = end_errors(slope, sigma, rates, 40_000, 90 + i as u64);
            let (in_v, _) = end_errors(slope, sigma, violations, 40_000, 90 + i as u64);
            assert!(pt_r.abs() < 0.03, "slope {slope}: point {pt_r:+.4} columns");
            assert!(
                in_v.abs() < 0.01,
                "slope {slope}: interval {in_v:+.4} columns"
            );
            assert!(
                in_r < -0.015,
                "slope {slope}: interval {in_r:+.4} columns with the rates"
            );
        }
    }
}
