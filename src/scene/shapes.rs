//! Analytic shapes implementing parry's `RayCast`, computed in the shape's local frame.
//!
//! parry casts rays against its `Cylinder` through the generic support-map (GJK) path, about 40x
//! too slow for a profiler with a thousand columns; these closed-form tests are exact and fast.

use nalgebra::{Point3, Vector3};
use parry3d_f64::query::{Ray, RayCast, RayIntersection};
use parry3d_f64::shape::FeatureId;

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
            let disc = b * b - a * c;
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
