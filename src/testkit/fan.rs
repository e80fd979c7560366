//! A second profile generator for tests, written apart from `sensor/` and `scene/` and sharing no
//! code with them: a fan of rays from an apex, each intersected in closed form with the specimens'
//! faces (discs, cylinder walls, spheres, boxes, the table plane), a hit kept only when a camera
//! sees it, then Gaussian z noise and dropout. Profiles lasercal's ray caster did not make, to test
//! the feature extraction and the methods on.

use nalgebra::{Isometry3, Point3, Vector3};
use rand::RngExt;

/// The fan, in the sensor frame: apex at (0, 0, apex_z), rays toward `dir_z` along z, `columns`
/// rays over +-half_angle, evenly in angle or in tan, column 0 at -x (or +x when reversed). A hit
/// is reported when its z lies in `z_range`.
#[derive(Debug, Clone, PartialEq)]
pub struct Fan {
    pub apex_z: f64,
    pub dir_z: f64,
    pub half_angle: f64,
    pub columns: usize,
    pub equal_angle: bool,
    pub reversed: bool,
    pub z_range: (f64, f64),
    pub camera: Point3<f64>,
}

impl Fan {
    /// The direction of column k's ray in the sensor frame (unit).
    pub fn ray(&self, k: usize) -> Vector3<f64> {
        let u = if self.reversed {
            1.0 - k as f64 / (self.columns - 1) as f64
        } else {
            k as f64 / (self.columns - 1) as f64
        };
        let a = if self.equal_angle {
            -self.half_angle + 2.0 * self.half_angle * u
        } else {
            let t = self.half_angle.tan();
            (-t + 2.0 * t * u).atan()
        };
        Vector3::new(a.sin(), 0.0, self.dir_z * a.cos())
    }
}

/// A face-bounded solid in the base frame. `frame` maps the solid's own coordinates to the base.
#[derive(Debug, Clone, PartialEq)]
pub enum Solid {
    /// A disk of `radius` on a cylinder of the same radius: top face at local z = 0, wall down to
    /// z = -height.
    DiskOnCylinder {
        frame: Isometry3<f64>,
        radius: f64,
        height: f64,
    },
    Sphere {
        centre: Point3<f64>,
        radius: f64,
    },
    /// An axis-aligned box in its frame: x in [-lx/2, lx/2], y in [-ly, 0], z in [-lz, 0].
    Bar {
        frame: Isometry3<f64>,
        lx: f64,
        ly: f64,
        lz: f64,
    },
    /// The plane z = height (base frame), seen from above.
    Table {
        height: f64,
    },
    /// A plane through `point` with unit `normal` (a tilted table), seen from the normal's side.
    Plane {
        point: Point3<f64>,
        normal: Vector3<f64>,
    },
    /// Two faces meeting along the frame's x axis, seen from +z: z = -|y| tan(slope) (a ridge)
    /// or, `groove`, z = +|y| tan(slope) (a V groove); unbounded.
    Wedge {
        frame: Isometry3<f64>,
        slope: f64,
        groove: bool,
    },
}

/// The nearest hit of a ray (origin o, unit direction d, both in the base frame) beyond `t_min`:
/// distance and outward normal.
fn hit(s: &Solid, o: &Point3<f64>, d: &Vector3<f64>, t_min: f64) -> Option<(f64, Vector3<f64>)> {
    let mut best: Option<(f64, Vector3<f64>)> = None;
    let mut keep = |t: f64, n: Vector3<f64>| {
        if t > t_min && best.is_none_or(|b| t < b.0) {
            best = Some((t, n));
        }
    };
    match s {
        Solid::Table { height } => {
            if d.z.abs() > 1e-15 {
                keep((height - o.z) / d.z, Vector3::z());
            }
        }
        Solid::Plane { point, normal } => {
            let dn = normal.dot(d);
            if dn.abs() > 1e-15 {
                keep((point - o).dot(normal) / dn, *normal);
            }
        }
        Solid::Wedge {
            frame,
            slope,
            groove,
        } => {
            let (lo, ld) = (
                frame.inverse_transform_point(o),
                frame.inverse_transform_vector(d),
            );
            let s = if *groove { 1.0 } else { -1.0 } * slope.tan();
            // Face y >= 0: z = s y; face y <= 0: z = -s y. Outward normals toward +z.
            for side in [1.0, -1.0] {
                let n = Vector3::new(0.0, -s * side, 1.0).normalize();
                let dn = n.dot(&ld);
                if dn.abs() > 1e-15 {
                    let t = -n.dot(&lo.coords) / dn;
                    if (lo.y + ld.y * t) * side >= 0.0 {
                        keep(t, frame.rotation * n);
                    }
                }
            }
        }
        Solid::Sphere { centre, radius } => {
            let oc = o - centre;
            let b = oc.dot(d);
            let disc = b * b - (oc.norm_squared() - radius * radius);
            if disc >= 0.0 {
                for t in [-b - disc.sqrt(), -b + disc.sqrt()] {
                    keep(t, (o + d * t - centre) / *radius);
                }
            }
        }
        Solid::DiskOnCylinder {
            frame,
            radius,
            height,
        } => {
            let (lo, ld) = (
                frame.inverse_transform_point(o),
                frame.inverse_transform_vector(d),
            );
            let r2 = radius * radius;
            for (zf, n) in [(0.0, 1.0), (-height, -1.0)] {
                if ld.z.abs() > 1e-15 {
                    let t = (zf - lo.z) / ld.z;
                    let p = lo + ld * t;
                    if p.x * p.x + p.y * p.y <= r2 {
                        keep(t, frame.rotation * Vector3::new(0.0, 0.0, n));
                    }
                }
            }
            // The wall: x^2 + y^2 = r^2 for -height <= z <= 0.
            let a = ld.x * ld.x + ld.y * ld.y;
            if a > 1e-18 {
                let b = lo.x * ld.x + lo.y * ld.y;
                let disc = b * b - a * (lo.x * lo.x + lo.y * lo.y - r2);
                if disc >= 0.0 {
                    for t in [(-b - disc.sqrt()) / a, (-b + disc.sqrt()) / a] {
                        let p = lo + ld * t;
                        if p.z <= 0.0 && p.z >= -height {
                            keep(t, frame.rotation * Vector3::new(p.x, p.y, 0.0) / *radius);
                        }
                    }
                }
            }
        }
        Solid::Bar { frame, lx, ly, lz } => {
            let (lo, ld) = (
                frame.inverse_transform_point(o),
                frame.inverse_transform_vector(d),
            );
            let lims = [(-lx / 2.0, lx / 2.0), (-ly, 0.0), (-lz, 0.0)];
            for axis in 0..3 {
                if ld[axis].abs() < 1e-15 {
                    continue;
                }
                for (face, sign) in [(lims[axis].0, -1.0), (lims[axis].1, 1.0)] {
                    let t = (face - lo[axis]) / ld[axis];
                    let p = lo + ld * t;
                    let inside = (0..3)
                        .filter(|&j| j != axis)
                        .all(|j| p[j] >= lims[j].0 - 1e-12 && p[j] <= lims[j].1 + 1e-12);
                    if inside {
                        let mut n = Vector3::zeros();
                        n[axis] = sign;
                        keep(t, frame.rotation * n);
                    }
                }
            }
        }
    }
    best
}

fn nearest(solids: &[Solid], o: &Point3<f64>, d: &Vector3<f64>) -> Option<(f64, Vector3<f64>)> {
    solids
        .iter()
        .filter_map(|s| hit(s, o, d, 1e-12))
        .min_by(|a, b| a.0.total_cmp(&b.0))
}

/// Noise added to a generated profile.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Noise {
    /// Gaussian z noise (metres).
    pub sigma_z: f64,
    /// Probability that a point is missing.
    pub dropout: f64,
    /// Where above 0: the z noise at the far end of the fan's z range (metres), `sigma_z` being
    /// the near end's, linear in depth between them (a profiler's noise grows with depth).
    pub sigma_z_far: f64,
}

impl Noise {
    /// The z noise at a point of sensor z `z` (`sigma_z_far`).
    fn sigma_at(&self, fan: &Fan, z: f64) -> f64 {
        if !(self.sigma_z_far > 0.0) {
            return self.sigma_z;
        }
        let depth = |z: f64| (z - fan.apex_z) * fan.dir_z;
        let (a, b) = (depth(fan.z_range.0), depth(fan.z_range.1));
        let (near, far) = (a.min(b), a.max(b));
        let f = ((depth(z) - near) / (far - near)).clamp(0.0, 1.0);
        self.sigma_z + f * (self.sigma_z_far - self.sigma_z)
    }
}

/// One profile, in the sensor frame: (x, z) per column, None where nothing is seen.
pub fn profile(
    fan: &Fan,
    solids: &[Solid],
    base_to_sensor: &Isometry3<f64>,
    noise: Noise,
    rng: &mut crate::rng::Rng,
) -> Vec<Option<(f64, f64)>> {
    let apex = base_to_sensor * Point3::new(0.0, 0.0, fan.apex_z);
    let camera = base_to_sensor * fan.camera;
    (0..fan.columns)
        .map(|k| {
            let d = base_to_sensor.rotation * fan.ray(k);
            let (t, n) = nearest(solids, &apex, &d)?;
            let p = apex + d * t;
            // The camera must face the lit side and see the point unobstructed.
            let to_cam = camera - p;
            if n.dot(&to_cam) <= 0.0 || n.dot(&d) >= 0.0 {
                return None;
            }
            let dist = to_cam.norm();
            let start = p + n * 1e-9;
            if nearest(solids, &start, &(to_cam / dist)).is_some_and(|(tc, _)| tc < dist) {
                return None;
            }
            let q = base_to_sensor.inverse_transform_point(&p);
            if q.z < fan.z_range.0 || q.z > fan.z_range.1 {
                return None;
            }
            let (drop, dz): (f64, f64) = (rng.random(), rng.sample(rand_distr::StandardNormal));
            if drop < noise.dropout {
                return None;
            }
            Some((q.x, q.z + noise.sigma_at(fan, q.z) * dz))
        })
        .collect()
}
