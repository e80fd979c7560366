//! Specimens placed anywhere (`base_to_specimen`), a table plane, and ray casts through parry.

mod fan;
pub mod form;
pub mod shapes;
mod specimen;

pub use fan::{Fan, FanHit};
pub use form::{FormError, FormTolerance};
pub use shapes::{ConvexPlanes, CylinderZ, Sheet};
pub use specimen::{Specimen, SpecimenKind, SpecimenType, UnknownSpecimen};

use nalgebra::{Isometry3, Point3, Vector3};
use parry3d_f64::query::{Ray, RayCast, RayIntersection};
use parry3d_f64::shape::Ball;

/// One analytic shape of a specimen.
#[derive(Debug, Clone)]
pub enum PartShape {
    Cylinder(CylinderZ),
    Planes(ConvexPlanes),
    Ball(Ball),
    Sheet(Sheet),
}

impl RayCast for PartShape {
    fn cast_local_ray_and_get_normal(
        &self,
        ray: &Ray,
        max_toi: f64,
        solid: bool,
    ) -> Option<RayIntersection> {
        match self {
            PartShape::Cylinder(s) => s.cast_local_ray_and_get_normal(ray, max_toi, solid),
            PartShape::Planes(s) => s.cast_local_ray_and_get_normal(ray, max_toi, solid),
            PartShape::Ball(s) => shapes::cast_ball(s.radius, ray, max_toi, solid),
            PartShape::Sheet(s) => s.cast_local_ray_and_get_normal(ray, max_toi, solid),
        }
    }
}

impl PartShape {
    /// The shape's bounding box in its own frame (low and high corners): None when it has none.
    pub fn local_bounds(&self) -> Option<(Point3<f64>, Point3<f64>)> {
        match self {
            PartShape::Cylinder(c) => Some((
                Point3::new(-c.radius, -c.radius, c.z_min),
                Point3::new(c.radius, c.radius, c.z_max),
            )),
            PartShape::Planes(p) => p.bounds(),
            PartShape::Ball(b) => Some((
                Point3::from(Vector3::repeat(-b.radius)),
                Point3::from(Vector3::repeat(b.radius)),
            )),
            PartShape::Sheet(s) => Some((
                Point3::new(-s.half, -s.half, 0.0),
                Point3::new(s.half, s.half, 0.0),
            )),
        }
    }
}

/// How bright a surface looks to the sensor (0 black .. 1 white).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Surface {
    Uniform {
        reflectance: f64,
        specular: bool,
    },
    /// A white disk of `radius` printed on black paper (local z = 0 plane).
    DiskOnPaper {
        radius: f64,
        disk: f64,
        paper: f64,
    },
}

impl Surface {
    fn at(&self, p_in_part: &Point3<f64>) -> (f64, bool) {
        match *self {
            Surface::Uniform {
                reflectance,
                specular,
            } => (reflectance, specular),
            Surface::DiskOnPaper {
                radius,
                disk,
                paper,
            } => (
                // Squared, not `hypot`: libm's hypot was a fifth of a paper profile's cost.
                if p_in_part.x * p_in_part.x + p_in_part.y * p_in_part.y <= radius * radius {
                    disk
                } else {
                    paper
                },
                false,
            ),
        }
    }
}

/// A shape of a specimen, relative to the specimen frame.
#[derive(Debug, Clone)]
pub struct Part {
    pub specimen_to_part: Isometry3<f64>,
    pub shape: PartShape,
    pub surface: Surface,
    /// Radius of a sphere around the part's origin that contains it (for culling).
    pub bound_radius: f64,
}

#[derive(Debug, Clone)]
struct Placed {
    base_to_part: Isometry3<f64>,
    part: Part,
    bound_centre: Point3<f64>,
    /// The part's bounding box in its frame (`PartShape::local_bounds`).
    bounds: Option<(Point3<f64>, Point3<f64>)>,
    specimen: usize,
    /// Index of the part within its specimen, and the specimen's pose (for its form error).
    part_index: usize,
    base_to_specimen: Isometry3<f64>,
}

/// What a ray hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HitWhat {
    Specimen(usize),
    Table,
}

#[derive(Debug, Clone, Copy)]
pub struct Hit {
    /// Distance along the (unit) ray, metres.
    pub toi: f64,
    pub p_in_base: Point3<f64>,
    /// Where the nominal surface was hit (`p_in_base` before the specimen's form error moved it):
    /// a ray leaving the surface starts here, outside the nominal solid even where the form
    /// error sinks the real surface into it.
    pub nominal_in_base: Point3<f64>,
    /// Outward unit normal at the hit, base frame.
    pub normal_in_base: Vector3<f64>,
    pub reflectance: f64,
    pub specular: bool,
    pub what: HitWhat,
}

/// The table: the plane z = `height_m` in the base frame, seen from above.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Table {
    pub height_m: f64,
    pub reflectance: f64,
}

/// Specimens and table. Placing computes every part's pose and bounding sphere once; each ray is
/// then culled against the bounding spheres and transformed into a part's local frame only when it
/// can hit it.
#[derive(Debug, Clone, Default)]
pub struct Scene {
    placed: Vec<Placed>,
    pub table: Option<Table>,
    pub specimens: Vec<(Specimen, Isometry3<f64>)>,
    /// Each specimen's form error (none unless set).
    pub forms: Vec<FormError>,
}

impl Scene {
    pub fn new(table: Option<Table>) -> Scene {
        Scene {
            placed: Vec::new(),
            table,
            specimens: Vec::new(),
            forms: Vec::new(),
        }
    }

    /// Place a specimen; returns its index (reported in `HitWhat::Specimen`).
    pub fn add(&mut self, specimen: &Specimen, base_to_specimen: Isometry3<f64>) -> usize {
        let idx = self.specimens.len();
        for (part_index, part) in specimen.parts().into_iter().enumerate() {
            let base_to_part = base_to_specimen * part.specimen_to_part;
            self.placed.push(Placed {
                bound_centre: base_to_part * Point3::origin(),
                bounds: part.shape.local_bounds(),
                base_to_part,
                part,
                specimen: idx,
                part_index,
                base_to_specimen,
            });
        }
        self.specimens.push((specimen.clone(), base_to_specimen));
        self.forms.push(FormError::None);
        idx
    }

    /// Give specimen `idx` a form error: rays then see its real surface (to first order in the
    /// error, which is microns on a part of centimetres).
    pub fn set_form(&mut self, idx: usize, form: FormError) {
        if let Some(f) = self.forms.get_mut(idx) {
            *f = form;
        }
    }

    /// First hit of the ray `origin + t * dir` (`dir` a unit vector) with `t` in [0, max_toi].
    /// A profile's rays go through `Scene::fan` instead, which forms what they share once.
    pub fn cast_ray(&self, origin: &Point3<f64>, dir: &Vector3<f64>, max_toi: f64) -> Option<Hit> {
        self.cast(origin, dir, max_toi)
    }

    /// The first hit from `origin` along `dir`.
    fn cast(&self, origin: &Point3<f64>, dir: &Vector3<f64>, max_toi: f64) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut limit = max_toi;
        if let Some(t) = self.table
            && dir.z != 0.0
        {
            let toi = (t.height_m - origin.z) / dir.z;
            if (0.0..=limit).contains(&toi) {
                limit = toi;
                let n = if dir.z < 0.0 {
                    Vector3::z()
                } else {
                    -Vector3::z()
                };
                best = Some(Hit {
                    toi,
                    p_in_base: origin + dir * toi,
                    nominal_in_base: origin + dir * toi,
                    normal_in_base: n,
                    reflectance: t.reflectance,
                    specular: false,
                    what: HitWhat::Table,
                });
            }
        }
        for pl in &self.placed {
            // Cull: distance from the bounding centre to the ray, and whether it lies ahead.
            let oc = pl.bound_centre - origin;
            let oc2 = oc.norm_squared();
            let along = oc.dot(dir);
            let r = pl.part.bound_radius;
            if along < -r || along - r > limit || oc2 - along * along > r * r {
                continue;
            }
            if let Some(hit) = pl.part.shape.cast_ray_and_get_normal(
                &pl.base_to_part,
                &Ray::new(*origin, *dir),
                limit,
                true,
            ) {
                let mut toi = hit.time_of_impact;
                let nominal = origin + dir * toi;
                let form = &self.forms[pl.specimen];
                if form.applies_to_part(pl.part_index) {
                    // The surface moved by the displacement's normal component: the ray meets it
                    // that far earlier (or later), divided by the incidence cosine.
                    let p = origin + dir * toi;
                    let d = pl.base_to_specimen
                        * form.displacement(&pl.base_to_specimen.inverse_transform_point(&p));
                    let cos = -dir.dot(&hit.normal);
                    if cos > 0.05 {
                        toi -= d.dot(&hit.normal) / cos;
                    }
                }
                let p = origin + dir * toi;
                let (reflectance, specular) = pl
                    .part
                    .surface
                    .at(&pl.base_to_part.inverse_transform_point(&p));
                limit = limit.min(toi.max(0.0));
                best = Some(Hit {
                    toi,
                    p_in_base: p,
                    nominal_in_base: nominal,
                    normal_in_base: hit.normal,
                    reflectance,
                    specular,
                    what: HitWhat::Specimen(pl.specimen),
                });
            }
        }
        best
    }
}

/// The scene with its first specimen's form error (the scene itself for a perfect part).
pub fn with_form(
    scene: std::borrow::Cow<'_, Scene>,
    form: FormError,
) -> std::borrow::Cow<'_, Scene> {
    if form.is_none() {
        return scene;
    }
    let mut s = scene.into_owned();
    s.set_form(0, form);
    std::borrow::Cow::Owned(s)
}

/// The scene with its first specimen's disk or ball radius set to `radius` (when the tolerance is
/// non-zero; otherwise the scene itself).
pub fn with_radius(scene: &Scene, radius: f64, tolerance: f64) -> std::borrow::Cow<'_, Scene> {
    if tolerance == 0.0 {
        return std::borrow::Cow::Borrowed(scene);
    }
    let mut out = Scene::new(scene.table);
    for (i, (spec, pose)) in scene.specimens.iter().enumerate() {
        let mut s = spec.clone();
        if i == 0 {
            match &mut s.kind {
                SpecimenKind::DiskOnCylinder { radius: r, .. }
                | SpecimenKind::DiskOnPaper { radius: r, .. }
                | SpecimenKind::BallOnPost { radius: r, .. } => *r = radius,
                _ => {}
            }
        }
        out.add(&s, *pose);
    }
    std::borrow::Cow::Owned(out)
}
