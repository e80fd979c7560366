//! Analytic shapes implementing parry's `RayCast`, computed in the shape's local frame.
//!
//! parry casts rays against its `Cylinder` through the generic support-map (GJK) path, about 40x
//! too slow for a profiler with a thousand columns; these closed-form tests are exact and fast.

use nalgebra::{Point3, Vector3};
use parry3d_f64::query::{Ray, RayCast, RayIntersection};
use parry3d_f64::shape::FeatureId;

/// A ray against a solid ball of `radius` about the local origin, as parry's `Ball` but
/// without its cancellation near the limb: parry forms the discriminant as b^2 - a c, two
/// numbers near |o|^2 whose difference is small on a grazing ray, and loses a few digits of the
/// hit there (2e-15 m at a 0.4 m range). Here it is a r^2 - |o x d|^2 (Lagrange's identity),
/// the cross product formed directly, and the near root is c / q.
pub fn cast_ball(radius: f64, ray: &Ray, max_toi: f64, solid: bool) -> Option<RayIntersection> {
    let (o, d) = (ray.origin.coords, ray.dir);
    let a = d.norm_squared();
    let b = o.dot(&d);
    let c = o.norm_squared() - radius * radius;
    if a == 0.0 {
        return (c <= 0.0 && solid)
            .then(|| RayIntersection::new(0.0, Vector3::zeros(), FeatureId::Face(0)));
    }
    if c > 0.0 && b > 0.0 {
        return None;
    }
    let delta = a * radius * radius - o.cross(&d).norm_squared();
    if delta < 0.0 {
        return None;
    }
    let q = -(b + b.signum() * delta.sqrt());
    let (near, far) = if q != 0.0 {
        let (t0, t1) = (q / a, c / q);
        (t0.min(t1), t0.max(t1))
    } else {
        (0.0, 0.0)
    };
    let normal = |t: f64| (o + d * t).normalize();
    if near > 0.0 {
        (near <= max_toi).then(|| RayIntersection::new(near, normal(near), FeatureId::Face(0)))
    } else if solid {
        Some(RayIntersection::new(0.0, -normal(0.0), FeatureId::Face(0)))
    } else {
        (far <= max_toi).then(|| RayIntersection::new(far, -normal(far), FeatureId::Face(0)))
    }
}

/// A solid upright cylinder: x^2 + y^2 <= r^2, z in [z_min, z_max] (local frame).
/// The disk of the disk-on-cylinder specimen is its top face.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CylinderZ {
    pub radius: f64,
    pub z_min: f64,
    pub z_max: f64,
}

impl RayCast for CylinderZ {
    fn cast_local_ray_and_get_normal(
        &self,
        ray: &Ray,
        max_toi: f64,
        solid: bool,
    ) -> Option<RayIntersection> {
        let (o, d) = (ray.origin, ray.dir);
        let r2 = self.radius * self.radius;
        let inside = o.x * o.x + o.y * o.y <= r2 && o.z >= self.z_min && o.z <= self.z_max;
        if inside && solid {
            return Some(RayIntersection::new(
                0.0,
                Vector3::zeros(),
                FeatureId::Unknown,
            ));
        }
        // Entry/exit parameters of the slab z in [z_min, z_max] and of the infinite cylinder.
        let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
        let (mut n0, mut n1) = (Vector3::zeros(), Vector3::zeros());
        if d.z.abs() > 0.0 {
            let ta = (self.z_min - o.z) / d.z;
            let tb = (self.z_max - o.z) / d.z;
            let (ta, na, tb, nb) = if ta < tb {
                (ta, -Vector3::z(), tb, Vector3::z())
            } else {
                (tb, Vector3::z(), ta, -Vector3::z())
            };
            t0 = ta;
            n0 = na;
            t1 = tb;
            n1 = nb;
        } else if o.z < self.z_min || o.z > self.z_max {
            return None;
        }
        let a = d.x * d.x + d.y * d.y;
        if a > 0.0 {
            let b = o.x * d.x + o.y * d.y;
            let c = o.x * o.x + o.y * o.y - r2;
            // b^2 - a c loses digits as (|o| / r)^2 from a ray's origin far off the axis; by
            // Lagrange's identity it equals a r^2 - (o x d)^2, whose cross product is formed
            // from the two small components directly.
            let cross = o.x * d.y - o.y * d.x;
            let disc = a * r2 - cross * cross;
            if disc < 0.0 {
                return None;
            }
            let sq = disc.sqrt();
            // Numerically stable roots.
            let q = -(b + b.signum() * sq);
            let (mut ca, mut cb) = if q != 0.0 { (q / a, c / q) } else { (0.0, 0.0) };
            if ca > cb {
                std::mem::swap(&mut ca, &mut cb);
            }
            // The wall's normal is formed below, only for the end returned (its divisions
            // are a good part of a ray's cost).
            if ca > t0 {
                t0 = ca;
                n0 = WALL;
            }
            if cb < t1 {
                t1 = cb;
                n1 = WALL;
            }
        } else if o.x * o.x + o.y * o.y > r2 {
            return None;
        }
        if t0 > t1 {
            return None;
        }
        let normal = |t: f64, n: Vector3<f64>| {
            if n == WALL {
                let p = o + d * t;
                Vector3::new(p.x, p.y, 0.0) / self.radius
            } else {
                n
            }
        };
        if t0 >= 0.0 {
            (t0 <= max_toi).then(|| RayIntersection::new(t0, normal(t0, n0), FeatureId::Unknown))
        } else if t1 >= 0.0 && !solid {
            (t1 <= max_toi).then(|| RayIntersection::new(t1, -normal(t1, n1), FeatureId::Unknown))
        } else {
            None
        }
    }
}

/// `CylinderZ`'s mark for an end on its wall, whose normal is formed when returned (a face's
/// normal is never this: it is a unit z).
const WALL: Vector3<f64> = Vector3::new(f64::INFINITY, 0.0, 0.0);

/// A convex solid bounded by planes `n . p <= offset` (unit outward normals), e.g. a cuboid bar,
/// a thin scale, or a knife blade with a bevelled edge. Ray test by slab clipping (Cyrus-Beck).
#[derive(Debug, Clone, PartialEq)]
pub struct ConvexPlanes {
    pub planes: Vec<(Vector3<f64>, f64)>,
}

impl ConvexPlanes {
    /// Axis-aligned box centred on the origin with half-extents `h`.
    pub fn cuboid(h: Vector3<f64>) -> Self {
        let mut planes = Vec::with_capacity(6);
        for k in 0..3 {
            let mut n = Vector3::zeros();
            n[k] = 1.0;
            planes.push((n, h[k]));
            planes.push((-n, h[k]));
        }
        ConvexPlanes { planes }
    }

    /// The solid's bounding box in its frame (low and high corners), from its vertices: the
    /// points where three planes meet inside the rest. None when the planes bound no solid of
    /// finite size.
    pub fn bounds(&self) -> Option<(Point3<f64>, Point3<f64>)> {
        let n = self.planes.len();
        let scale = (self.planes.iter()).fold(0f64, |m, (_, off)| m.max(off.abs()));
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for i in 0..n {
            for j in i + 1..n {
                for k in j + 1..n {
                    let (a, b, c) = (&self.planes[i], &self.planes[j], &self.planes[k]);
                    let m = nalgebra::Matrix3::from_rows(&[
                        a.0.transpose(),
                        b.0.transpose(),
                        c.0.transpose(),
                    ]);
                    // Three planes nearly sharing a line meet nowhere useful (relative test).
                    if m.determinant().abs() < 1e-9 {
                        continue;
                    }
                    let Some(p) = m.lu().solve(&Vector3::new(a.1, b.1, c.1)) else {
                        continue;
                    };
                    if self.contains(&Point3::from(p), 1e-9 * scale.max(1e-3)) {
                        lo = lo.inf(&p);
                        hi = hi.sup(&p);
                    }
                }
            }
        }
        (lo.iter().chain(hi.iter()).all(|v| v.is_finite()))
            .then(|| (Point3::from(lo), Point3::from(hi)))
    }

    /// True when `p` is inside or on the boundary (within `tol`).
    pub fn contains(&self, p: &Point3<f64>, tol: f64) -> bool {
        self.planes
            .iter()
            .all(|(n, off)| n.dot(&p.coords) <= off + tol)
    }
}

impl RayCast for ConvexPlanes {
    fn cast_local_ray_and_get_normal(
        &self,
        ray: &Ray,
        max_toi: f64,
        solid: bool,
    ) -> Option<RayIntersection> {
        let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
        let (mut n0, mut n1) = (Vector3::zeros(), Vector3::zeros());
        for (n, off) in &self.planes {
            let denom = n.dot(&ray.dir);
            let dist = off - n.dot(&ray.origin.coords);
            if denom == 0.0 {
                if dist < 0.0 {
                    return None;
                }
                continue;
            }
            let t = dist / denom;
            if denom < 0.0 {
                if t > t0 {
                    t0 = t;
                    n0 = *n;
                }
            } else if t < t1 {
                t1 = t;
                n1 = *n;
            }
            if t0 > t1 {
                return None;
            }
        }
        if t0 >= 0.0 {
            (t0 <= max_toi).then(|| RayIntersection::new(t0, n0, FeatureId::Unknown))
        } else if t1 >= 0.0 {
            if solid {
                Some(RayIntersection::new(
                    0.0,
                    Vector3::zeros(),
                    FeatureId::Unknown,
                ))
            } else {
                (t1 <= max_toi).then(|| RayIntersection::new(t1, -n1, FeatureId::Unknown))
            }
        } else {
            None
        }
    }
}

/// A zero-thickness square sheet in the local plane z = 0 (|x|, |y| <= half): the black paper under
/// the white disk of the disk-on-paper specimen. Hit from either side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sheet {
    pub half: f64,
}

impl RayCast for Sheet {
    fn cast_local_ray_and_get_normal(
        &self,
        ray: &Ray,
        max_toi: f64,
        _solid: bool,
    ) -> Option<RayIntersection> {
        if ray.dir.z == 0.0 {
            return None;
        }
        let t = -ray.origin.z / ray.dir.z;
        if !(0.0..=max_toi).contains(&t) {
            return None;
        }
        let p = ray.point_at(t);
        if p.x.abs() > self.half || p.y.abs() > self.half {
            return None;
        }
        let n = if ray.dir.z < 0.0 {
            Vector3::z()
        } else {
            -Vector3::z()
        };
        Some(RayIntersection::new(t, n, FeatureId::Unknown))
    }
}
