//! What a recording shows of a calibration, computed without the truth: every profile's points and
//! feature mapped into the base frame with the recovered transform, the specimen fitted to them
//! there, and each point's distance from it. A good calibration puts every profile on one sphere,
//! disk, line or plane; a wrong one smears them, whatever the data's source.

use super::ProfileFeature;
use crate::captures::{Captures, ProfileData};
use crate::sensor::SensorModel;
use nalgebra::{Isometry3, Matrix3, Point3, SymmetricEigen, Vector2, Vector3};

/// The specimen fitted, in the base frame, to the profiles mapped with the recovered transform.
#[derive(Debug, Clone, PartialEq)]
pub enum Fitted {
    Sphere {
        centre: Point3<f64>,
        radius: f64,
    },
    /// The rim circle in the face's plane.
    Disk {
        centre: Point3<f64>,
        normal: Vector3<f64>,
        radius: f64,
    },
    /// The edge lines seen (one, or the bar's two: a point on each and their common direction)
    /// and, where the profiles saw it, the top face's plane (a point and normal).
    Edge {
        points: Vec<Point3<f64>>,
        direction: Vector3<f64>,
        face: Option<(Point3<f64>, Vector3<f64>)>,
    },
    Plane {
        point: Point3<f64>,
        normal: Vector3<f64>,
    },
}

/// One profile as a view shows it.
#[derive(Debug, Clone, PartialEq)]
pub struct ProfileView {
    pub base_to_flange: Isometry3<f64>,
    /// Its points in the laser plane (sensor x, z; m): every valid raw point; for features given
    /// as such, the feature's own geometry (the chord, the arc, the edge point).
    pub points: Vec<Vector2<f64>>,
    pub feature: Option<ProfileFeature>,
    /// Distance (m) of each feature point and each surface point from the fitted specimen.
    pub feature_residuals: Vec<f64>,
    pub surface_residuals: Vec<f64>,
}

impl ProfileView {
    /// RMS (m) of the profile's residuals, None without any.
    pub fn rms(&self) -> Option<f64> {
        let r: Vec<f64> = self
            .feature_residuals
            .iter()
            .chain(&self.surface_residuals)
            .copied()
            .collect();
        (!r.is_empty()).then(|| (r.iter().map(|x| x * x).sum::<f64>() / r.len() as f64).sqrt())
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct View {
    pub profiles: Vec<ProfileView>,
    /// None when the mapped points do not determine the shape (too few, or degenerate).
    pub fitted: Option<Fitted>,
}

impl View {
    /// The median over the profiles of their residual RMS (m): how well a typical profile lands
    /// on the fitted specimen, whatever a few stray ones do. None without residuals.
    pub fn median_profile_rms(&self) -> Option<f64> {
        let mut r: Vec<f64> = self.profiles.iter().filter_map(ProfileView::rms).collect();
        r.sort_by(f64::total_cmp);
        r.get(r.len() / 2).copied()
    }
}

/// The view of `caps` calibrated as `flange_to_sensor`.
pub fn view(caps: &Captures, sensor: &SensorModel, flange_to_sensor: &Isometry3<f64>) -> View {
    let features =
        super::method(caps.method).profile_features(caps, &super::extraction_sensor(caps, sensor));
    let mut profiles: Vec<ProfileView> = caps
        .profiles
        .iter()
        .zip(features)
        .map(|(p, feature)| ProfileView {
            base_to_flange: p.base_to_flange,
            points: laser_plane_points(&p.data),
            feature,
            feature_residuals: Vec::new(),
            surface_residuals: Vec::new(),
        })
        .collect();
    let to_base = |p: &ProfileView, q: &Vector2<f64>| {
        p.base_to_flange * flange_to_sensor * Point3::new(q.x, 0.0, q.y)
    };
    // Per profile, its mapped feature points and surface points.
    let mapped = |surface: bool| -> Vec<Vec<Point3<f64>>> {
        profiles
            .iter()
            .filter_map(|p| p.feature.as_ref().map(|f| (p, f)))
            .map(|(p, f)| {
                let pts = if surface { &f.surface } else { &f.features };
                pts.iter().map(|q| to_base(p, q)).collect()
            })
            .collect()
    };
    let (feat_groups, surface_groups) = (mapped(false), mapped(true));
    let fitted = super::method(caps.method).fit_mapped(&feat_groups, &surface_groups);
    if let Some(shape) = &fitted {
        for p in &mut profiles {
            let Some(f) = &p.feature else { continue };
            let laser_normal = (p.base_to_flange * flange_to_sensor) * Vector3::y();
            let map =
                |q: &Vector2<f64>| p.base_to_flange * flange_to_sensor * Point3::new(q.x, 0.0, q.y);
            p.feature_residuals = f
                .features
                .iter()
                .map(|q| shape.feature_residual(&map(q), &laser_normal))
                .collect();
            p.surface_residuals = f
                .surface
                .iter()
                .filter_map(|q| shape.surface_residual(&map(q)))
                .collect();
        }
    }
    View { profiles, fitted }
}

fn plane_distance(f: &(Point3<f64>, Vector3<f64>), p: &Point3<f64>) -> f64 {
    (p - f.0).dot(&f.1)
}

/// The ball: the sphere through the arcs' points (`Method::fit_mapped`).
pub(crate) fn fit_ball(
    _features: &[Vec<Point3<f64>>],
    surface: &[Vec<Point3<f64>>],
) -> Option<Fitted> {
    trimmed(&surface.concat(), fit_sphere, |f, p| {
        f.surface_residual(p).unwrap_or(0.0)
    })
}

/// The disk: the face's plane, then the rim circle in it through the chord ends.
pub(crate) fn fit_disk_face(
    features: &[Vec<Point3<f64>>],
    surface: &[Vec<Point3<f64>>],
) -> Option<Fitted> {
    let feats = features.concat();
    let all: Vec<Point3<f64>> = feats
        .iter()
        .chain(surface.concat().iter())
        .copied()
        .collect();
    let plane = consensus_plane(surface).or_else(|| trimmed(&all, fit_plane, plane_distance))?;
    trimmed(
        &feats,
        |e| fit_disk(e, &plane),
        |f, p| f.feature_residual(p, &Vector3::zeros()),
    )
}

/// The bar: its top face's plane and its edge lines in it.
pub(crate) fn fit_bar(
    features: &[Vec<Point3<f64>>],
    surface: &[Vec<Point3<f64>>],
) -> Option<Fitted> {
    let face = consensus_plane(surface);
    trimmed(
        &features.concat(),
        |e| fit_edges(e, face.as_ref().map(|f| &f.1)),
        |f, p| {
            f.0.iter()
                .map(|q| {
                    let d = p - q;
                    (d - f.1 * d.dot(&f.1)).norm()
                })
                .fold(f64::INFINITY, f64::min)
        },
    )
    .map(|(points, direction)| Fitted::Edge {
        points,
        direction,
        face,
    })
}

/// The plane most profiles lie on.
pub(crate) fn fit_flat(
    _features: &[Vec<Point3<f64>>],
    surface: &[Vec<Point3<f64>>],
) -> Option<Fitted> {
    consensus_plane(surface).map(|(point, normal)| Fitted::Plane { point, normal })
}

impl Fitted {
    /// A feature point's distance from where the shape puts it: the ball arc's centre from the
    /// sphere centre's projection on the laser plane, a chord end from the rim circle, an edge
    /// point from the line, a line end from the plane.
    fn feature_residual(&self, p: &Point3<f64>, laser_normal: &Vector3<f64>) -> f64 {
        match self {
            Fitted::Sphere { centre, .. } => {
                let d = p - centre;
                (d - laser_normal * d.dot(laser_normal)).norm()
            }
            Fitted::Disk {
                centre,
                normal,
                radius,
            } => {
                let d = p - centre;
                let out = d.dot(normal);
                let radial = (d - normal * out).norm() - radius;
                out.hypot(radial)
            }
            Fitted::Edge {
                points, direction, ..
            } => points
                .iter()
                .map(|q| {
                    let d = p - q;
                    (d - direction * d.dot(direction)).norm()
                })
                .fold(f64::INFINITY, f64::min),
            Fitted::Plane { point, normal } => (p - point).dot(normal),
        }
    }

    /// A surface point's distance from the shape's surface (signed where it has a side).
    fn surface_residual(&self, p: &Point3<f64>) -> Option<f64> {
        match self {
            Fitted::Sphere { centre, radius } => Some((p - centre).norm() - radius),
            Fitted::Disk { centre, normal, .. } => Some((p - centre).dot(normal)),
            Fitted::Edge { face, .. } => face.map(|(q, n)| (p - q).dot(&n)),
            Fitted::Plane { point, normal } => Some((p - point).dot(normal)),
        }
    }
}

/// The profile's points in the laser plane: raw points as measured; a feature given as such as
/// its geometry (a chord sampled along its length, an arc's points, a circle's section).
fn laser_plane_points(data: &ProfileData) -> Vec<Vector2<f64>> {
    match data {
        ProfileData::Raw(prof) => crate::features::valid_points(prof)
            .into_iter()
            .map(|(_, q)| q)
            .collect(),
        ProfileData::Chord { a, b } => (0..=32).map(|k| a + (b - a) * (k as f64 / 32.0)).collect(),
        ProfileData::Circle(c) => (0..72)
            .map(|k| {
                let t = k as f64 * std::f64::consts::TAU / 72.0;
                c.centre + c.radius * Vector2::new(t.cos(), t.sin())
            })
            .collect(),
        ProfileData::Arc(a) => a.to_vec(),
        ProfileData::EdgePoint(q) => vec![*q],
    }
}

/// The fit refitted to the points within 4 x the median residual of the previous fit until the
/// kept points stay the same (at most 10 times): a profile that took the table for the specimen's face, or a false edge, must not
/// pull the fit (those points keep their large residuals, so the view shows them).
fn trimmed<T>(
    pts: &[Point3<f64>],
    fit: impl Fn(&[Point3<f64>]) -> Option<T>,
    residual: impl Fn(&T, &Point3<f64>) -> f64,
) -> Option<T> {
    let mut model = fit(pts)?;
    // A floor relative to the points' extent, so exact data keeps every point.
    let extent = pts.iter().map(|p| (p - pts[0]).norm()).fold(0.0, f64::max);
    let mut kept = pts.len();
    for _ in 0..10 {
        let r: Vec<f64> = pts.iter().map(|p| residual(&model, p).abs()).collect();
        let mut sorted = r.clone();
        sorted.sort_by(f64::total_cmp);
        let cut = (4.0 * sorted[sorted.len() / 2]).max(1e-9 * extent);
        let keep: Vec<Point3<f64>> = pts
            .iter()
            .zip(&r)
            .filter(|(_, r)| **r <= cut)
            .map(|(p, _)| *p)
            .collect();
        if keep.len() == kept {
            break;
        }
        kept = keep.len();
        match fit(&keep) {
            Some(m) => model = m,
            None => break,
        }
    }
    Some(model)
}

/// The plane most profiles' surface points lie on: planes through the points of pairs of
/// profiles, each scored by the profiles whose median distance from it is within 5 x the
/// profiles' own noise (their scatter about their own lines), the best refitted to the profiles
/// it holds. A profile that took the table or a wall for the face, however many points it has,
/// cannot tilt a narrow face's plane; a least-squares fit, even trimmed, can.
fn consensus_plane(groups: &[Vec<Point3<f64>>]) -> Option<(Point3<f64>, Vector3<f64>)> {
    let groups: Vec<&Vec<Point3<f64>>> = groups.iter().filter(|g| g.len() >= 3).collect();
    let all: Vec<Point3<f64>> = groups.iter().flat_map(|g| g.iter().copied()).collect();
    let n = groups.len();
    if n < 2 {
        return fit_plane(&all);
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    // Each profile's scatter about its own line.
    let noise = median(
        groups
            .iter()
            .map(|g| {
                let (_, e) = centroid_and_scatter(g);
                let mut ev: Vec<f64> = e.eigenvalues.iter().copied().collect();
                ev.sort_by(f64::total_cmp);
                ((ev[0] + ev[1]).max(0.0) / g.len() as f64).sqrt()
            })
            .collect(),
    );
    let extent = all.iter().map(|p| (p - all[0]).norm()).fold(0.0, f64::max);
    let tol = (5.0 * noise).max(1e-9 * extent);
    // Up to 16 points of each profile score a candidate.
    let samples: Vec<Vec<Point3<f64>>> = groups
        .iter()
        .map(|g| g.iter().step_by(g.len().div_ceil(16)).copied().collect())
        .collect();
    let holds = |plane: &(Point3<f64>, Vector3<f64>)| -> Vec<bool> {
        samples
            .iter()
            .map(|g| {
                median(
                    g.iter()
                        .map(|p| (p - plane.0).dot(&plane.1).abs())
                        .collect(),
                ) <= tol
            })
            .collect()
    };
    // Every pair for a few profiles; for many, each profile with a few partners across the set.
    let pairs: Vec<(usize, usize)> = if n <= 30 {
        (0..n)
            .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
            .collect()
    } else {
        (0..n)
            .flat_map(|i| [1, n / 7, n / 3, n / 2].map(|d| (i, (i + d.max(1)) % n)))
            .collect()
    };
    let best = pairs
        .iter()
        .filter_map(|&(i, j)| {
            let both: Vec<Point3<f64>> =
                groups[i].iter().chain(groups[j].iter()).copied().collect();
            let plane = fit_plane(&both)?;
            let count = holds(&plane).iter().filter(|h| **h).count();
            Some((count, plane))
        })
        .max_by_key(|(count, _)| *count)?;
    let held: Vec<Point3<f64>> = groups
        .iter()
        .zip(holds(&best.1))
        .filter(|(_, h)| *h)
        .flat_map(|(g, _)| g.iter().copied())
        .collect();
    fit_plane(&held).or(Some(best.1))
}

/// Below this ratio of the spread's smallest to largest principal value a fit is refused: the
/// points do not span what the shape needs (relative, so any unit or scale).
const MIN_SPREAD: f64 = 1e-10;

fn centroid_and_scatter(pts: &[Point3<f64>]) -> (Point3<f64>, SymmetricEigen<f64, nalgebra::U3>) {
    let mean = pts.iter().map(|p| p.coords).sum::<Vector3<f64>>() / pts.len() as f64;
    let cov = pts
        .iter()
        .map(|p| (p.coords - mean) * (p.coords - mean).transpose())
        .sum::<Matrix3<f64>>();
    (Point3::from(mean), SymmetricEigen::new(cov))
}

/// Total-least-squares plane: the centroid and the direction of least spread; None when the
/// points are (nearly) collinear.
fn fit_plane(pts: &[Point3<f64>]) -> Option<(Point3<f64>, Vector3<f64>)> {
    if pts.len() < 3 {
        return None;
    }
    let (mean, eig) = centroid_and_scatter(pts);
    let mut order = [0, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let (min, mid, max) = (
        eig.eigenvalues[order[0]],
        eig.eigenvalues[order[1]],
        eig.eigenvalues[order[2]],
    );
    if !(max > 0.0) || mid < MIN_SPREAD * max || !min.is_finite() {
        return None;
    }
    Some((mean, eig.eigenvectors.column(order[0]).into_owned()))
}

/// Total-least-squares line: the centroid and the direction of most spread.
fn fit_line(pts: &[Point3<f64>]) -> Option<(Point3<f64>, Vector3<f64>)> {
    if pts.len() < 2 {
        return None;
    }
    let (mean, eig) = centroid_and_scatter(pts);
    let k = eig.eigenvalues.imax();
    (eig.eigenvalues[k] > 0.0).then(|| (mean, eig.eigenvectors.column(k).into_owned()))
}

/// The split of sorted values in two (the first `k`, the rest) with the least sum of squares
/// within the sides: (that sum, k).
fn best_split(sorted: &[f64]) -> (f64, usize) {
    let n = sorted.len();
    let (mut s1, mut s2) = (vec![0.0; n + 1], vec![0.0; n + 1]);
    for (i, x) in sorted.iter().enumerate() {
        s1[i + 1] = s1[i] + x;
        s2[i + 1] = s2[i] + x * x;
    }
    let ss = |a: usize, b: usize| {
        let m = (b - a) as f64;
        if m == 0.0 {
            0.0
        } else {
            (s2[b] - s2[a]) - (s1[b] - s1[a]).powi(2) / m
        }
    };
    (1..n)
        .map(|k| (ss(0, k) + ss(k, n), k))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .unwrap_or((ss(0, n), n))
}

/// The bar's edge lines from edge points of either edge. The direction: in the face's plane
/// when it is known, the one across which the points split into two sides with the least
/// spread (every half degree, then refined from the scatter within the sides); else the points'
/// main axis. Two lines (through the mean of each side's points near its median) when the sides' medians lie far apart
/// against the spread within them, else one.
fn fit_edges(
    pts: &[Point3<f64>],
    face_normal: Option<&Vector3<f64>>,
) -> Option<(Vec<Point3<f64>>, Vector3<f64>)> {
    let (mean, main) = fit_line(pts)?;
    let normal = match face_normal {
        Some(n) => *n,
        None => {
            let (_, eig) = centroid_and_scatter(pts);
            let mut order = [0, 1, 2];
            order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
            eig.eigenvectors.column(order[2]).into_owned()
        }
    };
    let offsets = |dir: &Vector3<f64>| -> Vec<(f64, usize)> {
        let across = normal.cross(dir);
        let mut off: Vec<(f64, usize)> = pts
            .iter()
            .enumerate()
            .map(|(i, p)| ((p - mean).dot(&across), i))
            .collect();
        off.sort_by(|a, b| a.0.total_cmp(&b.0));
        off
    };
    // A direction's split across it, and its cost: the squared distances from each side's
    // median, each at most (2 % of the offsets' range)^2 so that a stray point (a false edge,
    // the table's edge) cannot choose the direction.
    let split_of = |dir: &Vector3<f64>| {
        let off = offsets(dir);
        let values: Vec<f64> = off.iter().map(|x| x.0).collect();
        let (_, k) = best_split(&values);
        let cap = (0.02 * (values[values.len() - 1] - values[0])).powi(2);
        let median = |v: &[f64]| if v.is_empty() { 0.0 } else { v[v.len() / 2] };
        let (a, b) = values.split_at(k);
        let (ma, mb) = (median(a), median(b));
        let cost = a.iter().map(|x| (x - ma).powi(2).min(cap)).sum::<f64>()
            + b.iter().map(|x| (x - mb).powi(2).min(cap)).sum::<f64>();
        (cost, off, k)
    };
    let direction = match face_normal {
        None => main,
        Some(n) => {
            let u = n
                .cross(&Vector3::x())
                .try_normalize(1e-6)
                .unwrap_or_else(|| n.cross(&Vector3::y()).normalize());
            let v = n.cross(&u);
            (0..360)
                .map(|k| {
                    let t = k as f64 * std::f64::consts::PI / 360.0;
                    u * t.cos() + v * t.sin()
                })
                .min_by(|a, b| split_of(a).0.total_cmp(&split_of(b).0))?
        }
    };
    let side_mean = |s: &[(f64, usize)]| {
        Point3::from(s.iter().map(|(_, i)| pts[*i].coords).sum::<Vector3<f64>>() / s.len() as f64)
    };
    // Refined from the scatter within the two sides, kept in the face's plane; stray points
    // (beyond 2 % of the offsets' range from their side's median) left out.
    let (_, off, k) = split_of(&direction);
    let near = 0.02 * (off[off.len() - 1].0 - off[0].0);
    let inliers = |s: &[(f64, usize)]| -> Vec<(f64, usize)> {
        let m = s.get(s.len() / 2).map_or(0.0, |x| x.0);
        s.iter()
            .filter(|x| (x.0 - m).abs() <= near)
            .copied()
            .collect()
    };
    let (a, b) = off.split_at(k);
    let within = [inliers(a), inliers(b)]
        .into_iter()
        .filter(|s| !s.is_empty())
        .flat_map(|s| {
            let c = side_mean(&s);
            s.into_iter()
                .map(move |(_, i)| (pts[i] - c) * (pts[i] - c).transpose())
        })
        .sum::<Matrix3<f64>>();
    let e = SymmetricEigen::new(within);
    let refined: Vector3<f64> = e.eigenvectors.column(e.eigenvalues.imax()).into_owned();
    let direction = (refined - normal * refined.dot(&normal))
        .try_normalize(1e-12)
        .unwrap_or(direction);
    let (_, off, k) = split_of(&direction);
    let (a, b) = off.split_at(k);
    // The spread within a side, robustly (1.4826 x the median absolute deviation): a stray
    // point must not merge the two edges.
    let spread = |s: &[(f64, usize)]| {
        let median = |mut v: Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let m = median(s.iter().map(|x| x.0).collect());
        1.4826 * median(s.iter().map(|x| (x.0 - m).abs()).collect())
    };
    if a.len() >= 2
        && b.len() >= 2
        && b[b.len() / 2].0 - a[a.len() / 2].0 > 10.0 * spread(a).max(spread(b))
    {
        return Some((
            vec![side_mean(&inliers(a)), side_mean(&inliers(b))],
            direction,
        ));
    }
    Some((vec![mean], direction))
}

/// The sphere through the points (`features::fit_sphere`: algebraic, then geometric).
fn fit_sphere(pts: &[Point3<f64>]) -> Option<Fitted> {
    let v: Vec<Vector3<f64>> = pts.iter().map(|p| p.coords).collect();
    crate::features::fit_sphere(&v).map(|s| Fitted::Sphere {
        centre: Point3::from(s.centre),
        radius: s.radius,
    })
}

/// The disk's rim circle, in the face's plane (`plane`), from the chord ends.
fn fit_disk(ends: &[Point3<f64>], plane: &(Point3<f64>, Vector3<f64>)) -> Option<Fitted> {
    let (point, normal) = *plane;
    let u = normal
        .cross(&Vector3::x())
        .try_normalize(1e-6)
        .unwrap_or_else(|| normal.cross(&Vector3::y()).normalize());
    let v = normal.cross(&u);
    let in_plane: Vec<Vector2<f64>> = ends
        .iter()
        .map(|p| Vector2::new((p - point).dot(&u), (p - point).dot(&v)))
        .collect();
    let c = crate::features::fit_circle(&in_plane)?;
    Some(Fitted::Disk {
        centre: point + u * c.centre.x + v * c.centre.y,
        normal,
        radius: c.radius,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_recover_exact_shapes() {
        let centre = Point3::new(0.4, -0.1, 0.3);
        let sphere: Vec<Point3<f64>> = (0..40)
            .map(|k| {
                let (t, f) = (k as f64 * 0.7, k as f64 * 0.31);
                centre + 0.025 * Vector3::new(t.cos() * f.sin(), t.sin() * f.sin(), f.cos())
            })
            .collect();
        let Some(Fitted::Sphere { centre: c, radius }) = fit_sphere(&sphere) else {
            panic!("no sphere")
        };
        assert!((c - centre).norm() < 1e-12 && (radius - 0.025).abs() < 1e-12);
        // Coplanar points cannot fix a sphere.
        let flat: Vec<Point3<f64>> = sphere.iter().map(|p| Point3::new(p.x, p.y, 0.3)).collect();
        assert!(fit_sphere(&flat).is_none());
        let line: Vec<Point3<f64>> = (0..5).map(|k| Point3::new(k as f64, 0.0, 0.0)).collect();
        assert!(fit_plane(&line).is_none());
        let (p, d) = fit_line(&line).unwrap();
        assert!(p.y.abs() < 1e-15 && (d.x.abs() - 1.0).abs() < 1e-12);
        // Two parallel edges 30 mm apart are two lines; one edge is one.
        let two: Vec<Point3<f64>> = (0..10)
            .map(|k| Point3::new(0.01 * k as f64, 0.03 * (k % 2) as f64, 0.0))
            .collect();
        let (lines, d) = fit_edges(&two, Some(&Vector3::z())).unwrap();
        assert_eq!(lines.len(), 2);
        assert!((d.x.abs() - 1.0).abs() < 1e-12);
        assert_eq!(fit_edges(&two[..1], None).map(|x| x.0.len()), None);
        assert_eq!(fit_edges(&two, None).unwrap().0.len(), 2);
        // Seen from free poses: 6 points on one edge, 16 on the other, one false edge between.
        let seen = [
            (-0.0849, -0.0255),
            (-0.0842, -0.0247),
            (0.0962, -0.0251),
            (0.0128, -0.0254),
            (-0.0590, -0.0253),
            (-0.0764, -0.0253),
            (0.0221, -0.0001),
            (-0.0682, -0.0005),
            (-0.0716, -0.0254),
            (0.0257, -0.0254),
            (-0.0033, 0.0000),
            (0.0317, -0.0000),
            (0.0374, -0.0254),
            (0.0422, -0.0254),
            (0.0531, -0.0249),
            (-0.0193, -0.0254),
            (0.0050, -0.0000),
            (-0.0251, -0.0000),
            (-0.0153, -0.0254),
            (-0.0130, -0.0082),
            (0.0221, 0.0000),
            (-0.0512, -0.0254),
        ];
        let seen: Vec<Point3<f64>> = seen.iter().map(|(x, y)| Point3::new(*x, *y, 0.0)).collect();
        let (lines, d) = fit_edges(&seen, Some(&Vector3::z())).unwrap();
        assert_eq!(lines.len(), 2, "{lines:?} {d}");
        let one: Vec<Point3<f64>> = two.iter().filter(|p| p.y == 0.0).copied().collect();
        assert_eq!(fit_edges(&one, None).unwrap().0.len(), 1);
    }
}
