//! A profile's fan of rays cast against the scene in one go. What every ray of the fan shares is
//! formed once per profile: each part's rotation from the fan's frame, the fan's origin and the
//! camera in the part's frame, the table's height along the fan. A ray then works in the part's
//! own frame with a few products, where `Scene::cast_ray` rotates it by quaternions between the
//! base, the fan and the part (four rotations a column, most of a profile's cost).
//!
//! The hits are `Scene::cast_ray`'s to rounding (the same tests in another frame); the tests below
//! hold them to 1e-15 m along the surface's normal on random scenes of every specimen kind, with
//! and without form error, seen or hidden alike.

use super::Scene;
use nalgebra::{Isometry3, Matrix3, Point3, Vector3};
use parry3d_f64::query::{Ray, RayCast};

/// One placed part as the fan's rays see it.
#[derive(Debug, Clone)]
struct FanPart {
    /// Rotation from the fan's frame into the part's.
    fan_to_part: Matrix3<f64>,
    /// The fan's origin and the camera in the part's frame.
    origin: Point3<f64>,
    camera: Point3<f64>,
    /// The part's bounding centre from the fan's origin, in the fan's frame, and its squared
    /// length (the cull).
    centre: Vector3<f64>,
    centre2: f64,
    /// Rotation from the part's frame into the base, and the part's origin in the base.
    part_to_base: Matrix3<f64>,
    part_origin: Vector3<f64>,
    /// The slopes x / w (w the depth along the rays' way) between which a ray in the fan's plane
    /// can meet the part (`ray_slopes`), and a point in it can be hidden by the part from the
    /// camera (`shadow_slopes`); None: any may.
    slopes: Option<(f64, f64)>,
    shadow: Option<(f64, f64)>,
}

/// A fan of rays from one origin, with the camera that must see what they light
/// (`Scene::fan`).
#[derive(Debug, Clone)]
pub struct Fan<'a> {
    scene: &'a Scene,
    parts: Vec<FanPart>,
    /// Rotation from the fan's frame into the base.
    fan_to_base: Matrix3<f64>,
    origin_in_base: Point3<f64>,
    camera_in_base: Point3<f64>,
    max_toi: f64,
    /// The way the rays travel along the fan's z (+1 or -1).
    forward: f64,
}

/// Where a ray of the fan meets the scene first: on a part (its index and the point and normal in
/// its frame) or on the table (in the base frame).
#[derive(Debug, Clone, Copy)]
pub struct FanHit {
    /// Distance along the (unit) ray, metres.
    pub toi: f64,
    /// The cosine between the ray and the surface's normal (the ray arriving from outside: > 0).
    pub cos_incidence: f64,
    pub reflectance: f64,
    pub specular: bool,
    part: Option<usize>,
    /// The nominal surface point (before a form error moves it) and the outward normal, in the
    /// part's frame (the base for the table, whose point `seen` forms: a part met later along
    /// the ray would waste it).
    nominal: Point3<f64>,
    normal: Vector3<f64>,
    /// The point the ray meets (the form error's surface).
    point: Point3<f64>,
    /// The ray's direction, fan frame.
    dir: Vector3<f64>,
}

impl Scene {
    /// The fan of rays leaving `origin_in_fan` (fan frame, placed at `base_to_fan`) toward
    /// `forward` along the fan's z (+1 or -1), each at most `max_toi` long, whose lit points
    /// `camera_in_fan` must see. Rays in the fan's x-z plane are culled per part by the slopes
    /// the part spans in that plane; any other direction casts too, culled by bounding spheres.
    pub fn fan(
        &self,
        base_to_fan: &Isometry3<f64>,
        origin_in_fan: &Point3<f64>,
        camera_in_fan: &Point3<f64>,
        forward: f64,
        max_toi: f64,
    ) -> Fan<'_> {
        let origin_in_base = base_to_fan * origin_in_fan;
        let camera_in_base = base_to_fan * camera_in_fan;
        let fan_to_base = base_to_fan.rotation.to_rotation_matrix().into_inner();
        let parts = (self.placed.iter())
            .map(|pl| {
                let part_to_base = pl.base_to_part.rotation.to_rotation_matrix().into_inner();
                let centre = fan_to_base.transpose() * (pl.bound_centre - origin_in_base);
                let fan_to_part = part_to_base.transpose() * fan_to_base;
                let origin = pl.base_to_part.inverse_transform_point(&origin_in_base);
                let v = pl.bounds.map(|b| corners(b, &fan_to_part, &origin));
                let camera = camera_in_fan - origin_in_fan;
                FanPart {
                    slopes: v.as_ref().and_then(|v| ray_slopes(v, forward)),
                    shadow: v.as_ref().and_then(|v| shadow_slopes(v, &camera, forward)),
                    fan_to_part,
                    origin,
                    camera: pl.base_to_part.inverse_transform_point(&camera_in_base),
                    centre2: centre.norm_squared(),
                    centre,
                    part_to_base,
                    part_origin: pl.base_to_part.translation.vector,
                }
            })
            .collect();
        Fan {
            scene: self,
            parts,
            fan_to_base,
            origin_in_base,
            camera_in_base,
            max_toi,
            forward,
        }
    }
}

/// The box `bounds` (part frame) as the fan sees it: its corners from the fan's origin, in the
/// fan's frame.
fn corners(
    (lo, hi): (Point3<f64>, Point3<f64>),
    fan_to_part: &Matrix3<f64>,
    origin: &Point3<f64>,
) -> [Vector3<f64>; 8] {
    std::array::from_fn(|i| {
        let pick = |bit: usize, a: f64, b: f64| if i & bit == 0 { a } else { b };
        let c = Point3::new(
            pick(1, lo.x, hi.x),
            pick(2, lo.y, hi.y),
            pick(4, lo.z, hi.z),
        );
        fan_to_part.tr_mul(&(c - origin))
    })
}

/// Where the fan's x-z plane cuts the edges of a box (`corners`): the corners of the convex
/// polygon the plane cuts from it.
fn cut(v: &[Vector3<f64>; 8]) -> Vec<Vector3<f64>> {
    let mut out = Vec::with_capacity(12);
    for i in 0..8 {
        for bit in [1, 2, 4] {
            let j = i | bit;
            let (a, b) = (v[i], v[j]);
            if j == i || (a.y > 0.0 && b.y > 0.0) || (a.y < 0.0 && b.y < 0.0) {
                continue;
            }
            if a.y == b.y {
                out.extend([a, b]);
            } else {
                out.push(a + (b - a) * (a.y / (a.y - b.y)));
            }
        }
    }
    out
}

/// The least and greatest slope x / w of points in the fan's plane (w the depth along
/// `forward`), widened by `margin` (relative) so that rounding never culls a ray that meets
/// the part: a ray meets a convex polygon only between its corners' slopes. None when a point
/// lies level with the origin or behind it (no cull); an empty range for no points.
fn slope_range(points: &[Vector3<f64>], forward: f64, margin: f64) -> Option<(f64, f64)> {
    let (mut least, mut most) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in points {
        let w = forward * p.z;
        if !(w > 0.0) {
            return None;
        }
        least = least.min(p.x / w);
        most = most.max(p.x / w);
    }
    let m = margin * (1.0 + least.abs().max(most.abs()));
    Some(if least <= most {
        (least - m, most + m)
    } else {
        (f64::INFINITY, f64::NEG_INFINITY)
    })
}

/// The slopes of the fan's in-plane rays that can meet a part in the box `v` (`corners`).
fn ray_slopes(v: &[Vector3<f64>; 8], forward: f64) -> Option<(f64, f64)> {
    slope_range(&cut(v), forward, 1e-9)
}

/// The slopes of the points of the fan's plane whose path to the camera `camera` (from the
/// fan's origin, fan frame) can pass through a part in the box `v`: the part's shadow cast from
/// the camera onto the plane. Only what lies between the camera and the plane casts one: the
/// plane's cut through the box, and the corners on the camera's side projected from it. The
/// margin covers a lit point's start a nanometre off the plane. None (no cull) when the camera
/// is in the plane or a corner no nearer the plane than it.
fn shadow_slopes(v: &[Vector3<f64>; 8], camera: &Vector3<f64>, forward: f64) -> Option<(f64, f64)> {
    if camera.y == 0.0 {
        return None;
    }
    let mut points = cut(v);
    for c in v {
        if c.y * camera.y > 0.0 {
            if c.y.abs() >= camera.y.abs() {
                return None;
            }
            points.push(camera + (c - camera) * (camera.y / (camera.y - c.y)));
        }
    }
    slope_range(&points, forward, 1e-6)
}

impl Fan<'_> {
    /// The first hit of the ray along the unit direction `dir_in_fan` (fan frame).
    #[inline]
    pub fn cast(&self, dir_in_fan: &Vector3<f64>) -> Option<FanHit> {
        let scene = self.scene;
        let mut best: Option<FanHit> = None;
        let mut limit = self.max_toi;
        if let Some(t) = scene.table {
            let dz = self.fan_to_base.row(2).transpose().dot(dir_in_fan);
            if dz != 0.0 {
                let toi = (t.height_m - self.origin_in_base.z) / dz;
                if (0.0..=limit).contains(&toi) {
                    limit = toi;
                    best = Some(FanHit {
                        toi,
                        cos_incidence: dz.abs(),
                        reflectance: t.reflectance,
                        specular: false,
                        part: None,
                        nominal: Point3::origin(),
                        normal: Vector3::new(0.0, 0.0, -dz.signum()),
                        point: Point3::origin(),
                        dir: *dir_in_fan,
                    });
                }
            }
        }
        for (index, (fp, pl)) in self.parts.iter().zip(&scene.placed).enumerate() {
            // Cull: a ray in the fan's plane outside the part's slopes...
            if let Some((least, most)) = fp.slopes
                && dir_in_fan.y == 0.0
            {
                let w = self.forward * dir_in_fan.z;
                if w > 0.0 && (dir_in_fan.x < least * w || dir_in_fan.x > most * w) {
                    continue;
                }
            }
            // ...or the distance from the bounding centre to the ray, and whether it lies ahead.
            let along = fp.centre.dot(dir_in_fan);
            let r = pl.part.bound_radius;
            if along < -r || along - r > limit || fp.centre2 - along * along > r * r {
                continue;
            }
            let dir = fp.fan_to_part * dir_in_fan;
            let Some(hit) = (pl.part.shape).cast_local_ray_and_get_normal(
                &Ray::new(fp.origin, dir),
                limit,
                true,
            ) else {
                continue;
            };
            let mut toi = hit.time_of_impact;
            let nominal = fp.origin + dir * toi;
            let cos = -dir.dot(&hit.normal);
            let form = &scene.forms[pl.specimen];
            if form.applies_to_part(pl.part_index) && cos > 0.05 {
                // The surface moved by the displacement's normal component: the ray meets it
                // that far earlier (or later), divided by the incidence cosine.
                let to_specimen = &pl.part.specimen_to_part;
                let d = form.displacement(&(to_specimen * nominal));
                toi -= to_specimen.inverse_transform_vector(&d).dot(&hit.normal) / cos;
            }
            let point = fp.origin + dir * toi;
            let (reflectance, specular) = pl.part.surface.at(&point);
            limit = limit.min(toi.max(0.0));
            best = Some(FanHit {
                toi,
                cos_incidence: cos,
                reflectance,
                specular,
                part: Some(index),
                nominal,
                normal: hit.normal,
                point,
                dir: *dir_in_fan,
            });
        }
        best
    }

    /// Whether the camera sees the lit point `hit`: the surface faces it and nothing lies between.
    /// The path starts on the nominal surface, a nanometre out along the normal. Every part is
    /// convex (a cylinder, a ball, a convex polyhedron, a flat sheet), so a path leaving a part on
    /// the side its normal faces never meets that part again: only the other parts and the table
    /// are tested.
    #[inline]
    pub fn seen(&self, hit: &FanHit) -> bool {
        let (start, skip) = match hit.part {
            Some(i) => {
                let fp = &self.parts[i];
                if hit.normal.dot(&(fp.camera - hit.point)) <= 0.0 {
                    return false;
                }
                let start = hit.nominal + hit.normal * 1e-9;
                // A form error's displaced point can face the camera where the nominal start
                // does not: then the path is tested against its own part too.
                let skip = hit.normal.dot(&(fp.camera - start)) > 0.0;
                (
                    Point3::from(fp.part_to_base * start.coords + fp.part_origin),
                    skip.then_some(i),
                )
            }
            None => {
                let p = self.origin_in_base + self.fan_to_base * hit.dir * hit.toi;
                if hit.normal.dot(&(self.camera_in_base - p)) <= 0.0 {
                    return false;
                }
                (p + hit.normal * 1e-9, None)
            }
        };
        !self.blocked(&start, skip, &hit.dir)
    }

    /// Whether the segment from `start` (base frame, lit by the ray along `dir`) to the camera
    /// meets the table or a part other than `skip`. The segment's parameter runs over [0, 1]: no
    /// square root or division to make its direction a unit vector.
    fn blocked(&self, start: &Point3<f64>, skip: Option<usize>, dir: &Vector3<f64>) -> bool {
        let scene = self.scene;
        let d = self.camera_in_base - start;
        // The table's plane between the two ends (a zero end on it).
        if let Some(t) = scene.table
            && d.z != 0.0
            && (start.z - t.height_m) * (self.camera_in_base.z - t.height_m) <= 0.0
        {
            return true;
        }
        let dd = d.norm_squared();
        let in_plane = dir.y == 0.0 && self.forward * dir.z > 0.0;
        for (index, (fp, pl)) in self.parts.iter().zip(&scene.placed).enumerate() {
            if skip == Some(index) {
                continue;
            }
            // Cull: a ray's point outside the part's shadow...
            if let Some((least, most)) = fp.shadow
                && in_plane
            {
                let w = self.forward * dir.z;
                if dir.x < least * w || dir.x > most * w {
                    continue;
                }
            }
            // ...or the segment's nearest point to the bounding centre beyond its radius:
            // |oc - d s|^2 at s = clamp(oc.d / dd), multiplied by dd where s is inside.
            let oc = pl.bound_centre - start;
            let (u, r2) = (oc.dot(&d), pl.part.bound_radius.powi(2));
            let far = if u <= 0.0 {
                oc.norm_squared() > r2
            } else if u >= dd {
                (oc - d).norm_squared() > r2
            } else {
                oc.norm_squared() * dd - u * u > r2 * dd
            };
            if far {
                continue;
            }
            let origin = Point3::from(fp.part_to_base.tr_mul(&(start.coords - fp.part_origin)));
            let ray = Ray::new(origin, fp.camera - origin);
            if (pl.part.shape)
                .cast_local_ray_and_get_normal(&ray, 1.0, true)
                .is_some()
            {
                return true;
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::super::{FormError, FormTolerance, Specimen, SpecimenKind, Table};
    use super::*;
    use crate::rng::{Rng, gauss};
    use nalgebra::{Translation3, UnitQuaternion};
    use rand::{RngExt, SeedableRng};

    fn kinds() -> Vec<SpecimenKind> {
        vec![
            SpecimenKind::DiskOnCylinder {
                radius: 0.05,
                height: 0.02,
            },
            SpecimenKind::DiskOnPaper {
                radius: 0.05,
                paper_half: 0.15,
            },
            SpecimenKind::BallOnPost {
                radius: 0.0695,
                post_radius: 0.01,
                post_height: 0.08,
            },
            SpecimenKind::ParallelBar {
                length: 0.15,
                width: 0.025,
                height: 0.012,
            },
            SpecimenKind::Scale {
                length: 0.15,
                width: 0.03,
                thickness: 0.001,
            },
            SpecimenKind::KnifeBlade {
                length: 0.06,
                width: 0.018,
                thickness: 0.0006,
                bevel: 0.001,
            },
            SpecimenKind::Ridge {
                length: 0.1,
                width: 0.04,
                height: 0.015,
            },
            SpecimenKind::VGroove {
                length: 0.1,
                width: 0.03,
                height: 0.012,
            },
            SpecimenKind::Step {
                length: 0.1,
                width: 0.03,
                height: 0.01,
            },
            SpecimenKind::Fillet {
                length: 0.1,
                width: 0.04,
            },
        ]
    }

    fn small_rotation(rng: &mut Rng, sd: f64) -> UnitQuaternion<f64> {
        UnitQuaternion::from_scaled_axis(Vector3::new(gauss(rng), gauss(rng), gauss(rng)) * sd)
    }

    /// `Scene::cast_ray`'s hit and the camera's view of it by a plain cast toward the camera
    /// (every part and the table, the direction made a unit vector): the reference the fan is
    /// held to.
    fn reference(
        scene: &Scene,
        origin: &Point3<f64>,
        dir: &Vector3<f64>,
        max_toi: f64,
        camera: &Point3<f64>,
    ) -> Option<(f64, f64, f64, bool)> {
        let hit = scene.cast_ray(origin, dir, max_toi)?;
        let n = hit.normal_in_base;
        let seen = n.dot(&(camera - hit.p_in_base)) > 0.0 && {
            let start = hit.nominal_in_base + n * 1e-9;
            let d = camera - start;
            scene.cast_ray(&start, &(d / d.norm()), d.norm()).is_none()
        };
        Some((hit.toi, -n.dot(dir), hit.reflectance, seen))
    }

    #[test]
    fn a_fan_meets_what_single_rays_meet() {
        let mut rng = Rng::seed_from_u64(31);
        let (mut rays, mut hits, mut seen, mut hidden) = (0, 0, 0, 0);
        let mut worst = 0f64;
        let (mut culled, mut shadowed) = (0, 0);
        let tol = FormTolerance {
            flatness: 20e-6,
            sphericity: 20e-6,
            straightness: 20e-6,
        };
        for trial in 0..60 {
            for kind in kinds() {
                let specimen = Specimen::new(kind.clone());
                let mut scene = Scene::new((trial % 3 != 0).then_some(Table {
                    height_m: -0.1 - 0.05 * rng.random::<f64>(),
                    reflectance: 0.3,
                }));
                let base_to_specimen = Isometry3::from_parts(
                    Translation3::new(0.0, 0.0, -0.02),
                    small_rotation(&mut rng, 0.4),
                );
                scene.add(&specimen, base_to_specimen);
                if trial % 2 == 1 {
                    scene.set_form(0, FormError::draw(&specimen, &tol, &mut rng));
                }
                // The fan from above, tilted and shifted at random; its apex 0.3-0.5 m away.
                let base_to_fan = Isometry3::from_parts(
                    Translation3::new(
                        0.03 * gauss(&mut rng),
                        0.03 * gauss(&mut rng),
                        0.05 * gauss(&mut rng),
                    ),
                    small_rotation(&mut rng, 0.35),
                );
                let origin_in_fan = Point3::new(0.0, 0.0, 0.3 + 0.2 * rng.random::<f64>());
                let camera_in_fan = Point3::new(0.0, 0.12, origin_in_fan.z);
                let max_toi = 0.8;
                let fan = scene.fan(&base_to_fan, &origin_in_fan, &camera_in_fan, -1.0, max_toi);
                let origin = base_to_fan * origin_in_fan;
                let camera = base_to_fan * camera_in_fan;
                culled += (fan.parts.iter())
                    .filter(|p| p.slopes.is_some_and(|s| s.0.is_finite()))
                    .count();
                shadowed += (fan.parts.iter())
                    .filter(|p| p.shadow.is_some_and(|s| s.0.is_finite()))
                    .count();
                for k in 0..400 {
                    let t = -0.45 + 0.9 * k as f64 / 399.0;
                    let dir_in_fan = Vector3::new(t, 0.0, -1.0).normalize();
                    let dir = base_to_fan.rotation * dir_in_fan;
                    let want = reference(&scene, &origin, &dir, max_toi, &camera);
                    let got = fan
                        .cast(&dir_in_fan)
                        .map(|h| (h.toi, h.cos_incidence, h.reflectance, fan.seen(&h)));
                    rays += 1;
                    match (want, got) {
                        (None, None) => {}
                        (Some(w), Some(g)) => {
                            hits += 1;
                            // The same surface to 1e-15 m: along a grazing ray the point
                            // itself moves by that over the cosine (the hit's own conditioning).
                            let dt = (w.0 - g.0).abs();
                            worst = worst.max(dt);
                            assert!(
                                dt * w.1.abs().max(1e-3) <= 1e-15,
                                "{kind:?} trial {trial} ray {k}: toi {} vs {} at cosine {}",
                                w.0,
                                g.0,
                                w.1
                            );
                            assert!((w.1 - g.1).abs() <= 1e-12, "{kind:?}: cosine");
                            assert_eq!(w.2, g.2, "{kind:?}: reflectance");
                            assert_eq!(w.3, g.3, "{kind:?} trial {trial} ray {k}: seen");
                            if g.3 { seen += 1 } else { hidden += 1 }
                        }
                        _ => panic!("{kind:?} trial {trial} ray {k}: {want:?} vs {got:?}"),
                    }
                }
            }
        }
        eprintln!(
            "{hits} hits of {rays} rays, {hidden} hidden; toi differs by at most {worst:e} m"
        );
        // The comparison is not vacuous: most rays hit, and some hits are hidden.
        // ...and the parts' slope culls were in play (60 trials of 10 specimens).
        assert!(hits > rays / 2 && hidden > rays / 50 && seen > rays / 3);
        assert!(culled > 400 && shadowed > 400, "{culled} {shadowed}");
    }

    #[test]
    fn a_convex_solid_is_bounded_by_its_vertices() {
        let h = Vector3::new(0.075, 0.0125, 0.006);
        let (lo, hi) = crate::scene::ConvexPlanes::cuboid(h).bounds().unwrap();
        assert!((hi.coords - h).norm() < 1e-15 && (lo.coords + h).norm() < 1e-15);
        // A knife blade's bevel: the box is the blade's own, tight on every side.
        let blade = Specimen::new(SpecimenKind::KnifeBlade {
            length: 0.06,
            width: 0.018,
            thickness: 0.0006,
            bevel: 0.001,
        });
        for part in blade.parts() {
            let (lo, hi) = part.shape.local_bounds().unwrap();
            let extent = hi - lo;
            assert!((extent.x - 0.06).abs() < 1e-12, "{extent:?}");
            assert!(extent.y > 0.0 && extent.y <= 0.018 + 1e-12, "{extent:?}");
            assert!(extent.z > 0.0 && extent.z <= 0.0006 + 1e-12, "{extent:?}");
        }
        // Planes bounding nothing finite (a half-space) have no box.
        let half = crate::scene::ConvexPlanes {
            planes: vec![(Vector3::z(), 0.0)],
        };
        assert!(half.bounds().is_none());
    }
}
