//! The virtual line-laser profiler: fan geometry, range and field of view, camera occlusion,
//! z quantisation and seeded noise. Presets for the papers' two sensors.

mod noise;
mod points;
pub use noise::NoiseModel;
pub use points::{slots, uniform_grid};

use crate::scene::Scene;
use nalgebra::{Isometry3, Point3, Vector3};
use thiserror::Error;

#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum SensorError {
    #[error(
        "unknown sensor preset '{name}': use gocator-2340, gocator-2320, gocator-2330, \
         gocator-2350, gocator-2370, gocator-2380 or vlm350, or describe the sensor by its geometry"
    )]
    UnknownPreset { name: String },
    #[error("sensor '{name}': {field} = {value}: {reason}")]
    BadGeometry {
        name: String,
        field: &'static str,
        value: f64,
        reason: &'static str,
    },
}

/// LMI Gocator 23x0 from the maker's clearance, range and field of view near and far. Frame: origin
/// at the centre of the measurement range and of the field of view, z toward the sensor, x along
/// the laser line (the maker's unaligned sensor frame). The fan's virtual apex is where the field of
/// view's trapezoid sides meet. Unconfirmed: 1280 points per profile; z quantum 0.013 mm (the 2340's
/// finest z resolution). Assumed (not published): the camera sits 120 mm from the laser along +y,
/// level with the apex.
fn gocator_geometry(
    model: &str,
    clearance: f64,
    range: f64,
    near_w: f64,
    far_w: f64,
) -> SensorGeometry {
    let slope = (far_w - near_w) / range; // width growth per metre of depth
    let apex_to_near = near_w / slope;
    let apex_z = range / 2.0 + apex_to_near;
    let _ = clearance; // the emitter window sits `clearance` above the near end; the apex is virtual
    SensorGeometry {
        name: format!("gocator-{model}"),
        frame: "origin at the centre of the measurement range, z toward the sensor".into(),
        apex_z,
        dir_z: -1.0,
        depth_near: apex_to_near,
        depth_far: apex_to_near + range,
        tan_half_fov: far_w / 2.0 / (apex_to_near + range),
        columns: 1280,
        spacing: RaySpacing::EqualTan,
        x_reversed: false,
        z_quantum: Some(0.013e-3),
        camera: Point3::new(0.0, 0.120, apex_z),
        resample: None,
    }
}

/// Pepperl+Fuchs VLM350-F280-R4-1101. Frame: origin at the sensor, z the depth away from it, x along
/// the laser line (the edge paper's p_s = [x_s, 0, z_s]). From the edge paper: X range 40-160 mm,
/// Z range 60-350 mm, at most 980 points, quantised to 0.1 mm. Assumed (not published): camera 60 mm
/// from the laser along +y at the apex depth.
fn vlm350_geometry() -> SensorGeometry {
    let (near_w, far_w, z_near, z_far) = (0.040, 0.160, 0.060, 0.350);
    let slope = (far_w - near_w) / (z_far - z_near);
    let apex_to_near = near_w / slope;
    let apex_z = z_near - apex_to_near;
    SensorGeometry {
        name: "vlm350".into(),
        frame: "origin at the sensor, z the depth away from it".into(),
        apex_z,
        dir_z: 1.0,
        depth_near: apex_to_near,
        depth_far: apex_to_near + (z_far - z_near),
        tan_half_fov: far_w / 2.0 / (apex_to_near + z_far - z_near),
        columns: 980,
        spacing: RaySpacing::EqualTan,
        x_reversed: false,
        z_quantum: Some(0.1e-3),
        camera: Point3::new(0.0, 0.060, apex_z),
        resample: None,
    }
}

/// One measured point of a profile, in the sensor frame (metres; y = 0 by construction).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProfilePoint {
    pub x: f64,
    pub z: f64,
    /// Received signal, 0..1 (surface reflectance times the cosine of incidence).
    pub intensity: f64,
}

/// A profile: one entry per sensor column, `None` where the sensor reports no point.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Profile {
    pub points: Vec<Option<ProfilePoint>>,
}

impl Profile {
    /// Number of valid points.
    pub fn valid(&self) -> usize {
        self.points.iter().filter(|p| p.is_some()).count()
    }
}

/// How a profiler's columns (rays) are spaced across its fan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RaySpacing {
    /// Evenly in x / depth (the camera's pixel columns see the laser plane this way; equally, evenly
    /// in x at any one reference depth).
    EqualTan,
    /// Evenly in angle about the apex.
    EqualAngle,
}

/// A profiler's geometry, in SI units, from which its model is built: the record a scenario or a
/// capture file can give instead of a preset (docs/sensors.md).
#[derive(Debug, Clone, PartialEq)]
pub struct SensorGeometry {
    pub name: String,
    /// Where the frame's origin is and which way z points, in words.
    pub frame: String,
    /// The fan's (virtual) apex on the z axis, and the direction the laser travels along z (+1 or
    /// -1).
    pub apex_z: f64,
    pub dir_z: f64,
    /// Measurement range as depths from the apex along the fan axis.
    pub depth_near: f64,
    pub depth_far: f64,
    /// Half the fan's extent as a slope x / depth (the tangent of its half angle).
    pub tan_half_fov: f64,
    pub columns: usize,
    pub spacing: RaySpacing,
    /// Column 0 at +x instead of -x.
    pub x_reversed: bool,
    pub z_quantum: Option<f64>,
    /// Camera centre in the sensor frame (points it cannot see are dropped).
    pub camera: Point3<f64>,
    /// Resampled output: one point per x slot of a uniform grid instead of one per ray.
    pub resample: Option<Resample>,
}

/// A profiler's resampled output (e.g. the Gocator's "uniform spacing"): z is reported at the x
/// values `offset + m pitch` (integer m) across the far field of view, each interpolated between
/// the two neighbouring rays that both found the surface. A slot's column is its index from the
/// grid's low-x end (high-x with `x_reversed`); a slot's "ray" is the line x = its value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resample {
    pub pitch: f64,
    pub offset: f64,
}

/// Sizes a sensor record may have (columns) before it is refused: larger would be a typo, and the
/// profile buffers are allocated from it.
pub const MAX_COLUMNS: usize = 65_536;

/// A line-laser profiler. The laser fan lies in the sensor x-z plane and leaves a (virtual) apex on
/// the z axis at `apex_z`, travelling toward `dir_z` (+1 or -1). Ray k has slope `x / depth` by the
/// spacing law of its geometry; a profile has one column per ray, or per slot of its resampling
/// grid (`column_line` is where a column measures); depth is measured from the apex
/// along the fan axis.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorModel {
    pub name: String,
    /// What the frame is, in words (origin and z direction).
    pub frame: String,
    pub apex_z: f64,
    pub dir_z: f64,
    pub depth_near: f64,
    pub depth_far: f64,
    pub tan_half_fov: f64,
    pub columns: usize,
    pub spacing: RaySpacing,
    pub x_reversed: bool,
    /// z quantisation step of the reported points (None: continuous).
    pub z_quantum: Option<f64>,
    /// Camera centre in the sensor frame (points it cannot see are dropped).
    pub camera: Point3<f64>,
    pub noise: NoiseModel,
    /// Slope x/depth of each ray.
    tans: Vec<f64>,
    /// Each ray's unit direction (`column_dir`) formed once, with the `dir_z` it was formed for
    /// (a model whose `dir_z` was changed since forms them again).
    dirs: (f64, Vec<Vector3<f64>>),
    /// Resampled output: the grid and its lowest slot's m (`columns` slots from there).
    resample: Option<(Resample, i64)>,
    /// Known only by its points (`SensorModel::points_only`): its slots are the points' x grid,
    /// it has no rays to ray-cast, and its noise is the profiles' own.
    pub points_only: bool,
    /// A points-only sensor's step between neighbouring points (metres).
    point_step: f64,
}

impl SensorModel {
    /// A preset by name: `gocator-2340`, `vlm350`, or another Gocator 2300-series head
    /// (`gocator-2320`, `-2330`, `-2350`, `-2370`, `-2380`).
    pub fn preset(name: &str) -> Result<SensorModel, SensorError> {
        Self::preset_geometry(name).and_then(SensorModel::from_geometry)
    }

    /// The record of a preset.
    pub fn preset_geometry(name: &str) -> Result<SensorGeometry, SensorError> {
        let gocator = |model: &str, clearance: f64, range: f64, near_w: f64, far_w: f64| {
            gocator_geometry(
                model,
                clearance * 1e-3,
                range * 1e-3,
                near_w * 1e-3,
                far_w * 1e-3,
            )
        };
        match name {
            "gocator-2340" | "gocator2340" => Ok(gocator("2340", 190.0, 210.0, 96.0, 194.0)),
            // The other 2300-series heads (clearance / range / FOV near-far from the maker's
            // overview, docs/sensors.md); the same assumed 1280 columns and camera baseline.
            "gocator-2320" => Ok(gocator("2320", 40.0, 25.0, 18.0, 26.0)),
            "gocator-2330" => Ok(gocator("2330", 90.0, 80.0, 47.0, 85.0)),
            "gocator-2350" => Ok(gocator("2350", 300.0, 400.0, 158.0, 365.0)),
            "gocator-2370" => Ok(gocator("2370", 400.0, 500.0, 308.0, 687.0)),
            "gocator-2380" => Ok(gocator("2380", 350.0, 800.0, 390.0, 1260.0)),
            "vlm350" => Ok(vlm350_geometry()),
            _ => Err(SensorError::UnknownPreset {
                name: name.to_string(),
            }),
        }
    }

    /// The model of a sensor record, its values checked.
    pub fn from_geometry(g: SensorGeometry) -> Result<SensorModel, SensorError> {
        let bad =
            |field: &'static str, value: f64, reason: &'static str| SensorError::BadGeometry {
                name: g.name.clone(),
                field,
                value,
                reason,
            };
        if !(g.columns >= 2 && g.columns <= MAX_COLUMNS) {
            return Err(bad("columns", g.columns as f64, "give 2 to 65536 columns"));
        }
        if !(g.tan_half_fov > 0.0 && g.tan_half_fov < 80f64.to_radians().tan()) {
            return Err(bad(
                "half_angle",
                g.tan_half_fov.atan().to_degrees(),
                "the fan's half angle must be in (0, 80) deg",
            ));
        }
        if !(g.depth_near > 0.0 && g.depth_far > g.depth_near && g.depth_far.is_finite()) {
            return Err(bad(
                "depth_far",
                g.depth_far,
                "the measurement range must lie in front of the apex: 0 < near < far",
            ));
        }
        if !(g.dir_z == 1.0 || g.dir_z == -1.0) || !g.apex_z.is_finite() {
            return Err(bad(
                "dir_z",
                g.dir_z,
                "z must point away (+1) or toward (-1)",
            ));
        }
        if let Some(q) = g.z_quantum
            && !(q > 0.0 && q.is_finite())
        {
            return Err(bad("z_quantum", q, "a z quantum must be > 0"));
        }
        if let Some(r) = g.resample {
            if !(r.pitch > 0.0 && r.pitch.is_finite()) {
                return Err(bad("x_pitch", r.pitch, "a resampling pitch must be > 0"));
            }
            if !r.offset.is_finite() {
                return Err(bad("x_offset", r.offset, "must be finite"));
            }
            let slots = 2.0 * g.tan_half_fov * g.depth_far / r.pitch;
            if !(slots >= 1.0 && slots < MAX_COLUMNS as f64) {
                return Err(bad(
                    "x_pitch",
                    r.pitch,
                    "the pitch must give 2 to 65536 points across the far field of view",
                ));
            }
        }
        Ok(Self::build(g))
    }

    /// The model of a record known to be valid (the presets').
    fn build(g: SensorGeometry) -> SensorModel {
        let t = g.tan_half_fov;
        let half_angle = t.atan();
        let n = (g.columns - 1).max(1) as f64;
        let resample = g.resample.map(|r| {
            let w = g.tan_half_fov * g.depth_far;
            let lo = ((-w - r.offset) / r.pitch).ceil() as i64;
            let hi = ((w - r.offset) / r.pitch).floor() as i64;
            (r, lo, (hi - lo + 1).max(1) as usize)
        });
        let tans = (0..g.columns)
            .map(|k| {
                let kk = if g.x_reversed { g.columns - 1 - k } else { k };
                match g.spacing {
                    RaySpacing::EqualTan => -t + 2.0 * t * kk as f64 / n,
                    RaySpacing::EqualAngle => {
                        (-half_angle + 2.0 * half_angle * kk as f64 / n).tan()
                    }
                }
            })
            .collect::<Vec<f64>>();
        let dirs = (tans.iter())
            .map(|t| Vector3::new(*t, 0.0, g.dir_z).normalize())
            .collect();
        SensorModel {
            dirs: (g.dir_z, dirs),
            name: g.name,
            frame: g.frame,
            apex_z: g.apex_z,
            dir_z: g.dir_z,
            depth_near: g.depth_near,
            depth_far: g.depth_far,
            tan_half_fov: t,
            columns: resample.map_or(g.columns, |r| r.2),
            spacing: g.spacing,
            x_reversed: g.x_reversed,
            z_quantum: g.z_quantum,
            camera: g.camera,
            noise: NoiseModel::default(),
            tans,
            resample: resample.map(|r| (r.0, r.1)),
            points_only: false,
            point_step: 0.0,
        }
    }

    /// The record this model was built from.
    pub fn geometry(&self) -> SensorGeometry {
        SensorGeometry {
            name: self.name.clone(),
            frame: self.frame.clone(),
            apex_z: self.apex_z,
            dir_z: self.dir_z,
            depth_near: self.depth_near,
            depth_far: self.depth_far,
            tan_half_fov: self.tan_half_fov,
            columns: self.tans.len(),
            spacing: self.spacing,
            x_reversed: self.x_reversed,
            z_quantum: self.z_quantum,
            camera: self.camera,
            resample: self.resample.map(|r| r.0),
        }
    }

    /// Whether this is the named preset's geometry (noise aside).
    pub fn is_preset(&self) -> bool {
        SensorModel::preset(&self.name).is_ok_and(|p| {
            SensorModel {
                noise: self.noise,
                ..p
            } == *self
        })
    }

    /// LMI Gocator 2340 (see `gocator_geometry`).
    pub fn gocator_2340() -> SensorModel {
        Self::build(gocator_geometry("2340", 0.190, 0.210, 0.096, 0.194))
    }

    /// Pepperl+Fuchs VLM350 (see `vlm350_geometry`).
    pub fn vlm350() -> SensorModel {
        Self::build(vlm350_geometry())
    }

    /// The same sensor with no quantisation and no noise: exact geometry.
    pub fn ideal(mut self) -> SensorModel {
        self.z_quantum = None;
        self.noise = NoiseModel::default();
        self
    }

    /// Fan apex in the sensor frame.
    pub fn apex(&self) -> Point3<f64> {
        Point3::new(0.0, 0.0, self.apex_z)
    }

    /// The resampling grid, when the output is resampled.
    pub fn resampling(&self) -> Option<Resample> {
        self.resample.map(|r| r.0)
    }

    /// Slope x/depth of ray k (column k, unless the output is resampled).
    pub fn column_tan(&self, k: usize) -> f64 {
        self.tans[k]
    }

    /// The x of output slot `u` (fractional) of a resampled profile.
    fn slot_x(&self, r: &(Resample, i64), u: f64) -> f64 {
        let u = if self.x_reversed {
            (self.columns - 1) as f64 - u
        } else {
            u
        };
        r.0.offset + (r.1 as f64 + u) * r.0.pitch
    }

    /// The line along which output column `u` (fractional: between two columns, interpolated in
    /// the spacing of the two nearest; beyond the ends, extrapolated) measures, in the profile
    /// plane: a point on it and its unit direction (x, z), pointing away from the sensor. A ray of
    /// the fan, or the line x = slot for a resampled profile.
    pub fn column_line(&self, u: f64) -> ([f64; 2], [f64; 2]) {
        if let Some(r) = &self.resample {
            return ([self.slot_x(r, u), self.apex_z], [0.0, self.dir_z]);
        }
        let n = self.tans.len();
        let k = (u.floor().max(0.0) as usize).min(n - 2);
        let (t0, t1) = (self.column_tan(k), self.column_tan(k + 1));
        let t = t0 + (u - k as f64) * (t1 - t0);
        let norm = (t * t + 1.0).sqrt();
        ([0.0, self.apex_z], [t / norm, self.dir_z / norm])
    }

    /// The (fractional) output column that measures a profile point (x, z): the inverse of the
    /// spacing law (or of the resampling grid). None behind the apex.
    pub fn column_of(&self, x: f64, z: f64) -> Option<f64> {
        if let Some((r, lo)) = &self.resample {
            let u = (x - r.offset) / r.pitch - *lo as f64;
            return Some(if self.x_reversed {
                (self.columns - 1) as f64 - u
            } else {
                u
            });
        }
        let depth = self.dir_z * (z - self.apex_z);
        if !(depth > 0.0) {
            return None;
        }
        let t = x / depth;
        let n = (self.tans.len() - 1) as f64;
        let u = match self.spacing {
            RaySpacing::EqualTan => (t + self.tan_half_fov) / (2.0 * self.tan_half_fov),
            RaySpacing::EqualAngle => {
                let a = self.tan_half_fov.atan();
                (t.atan() + a) / (2.0 * a)
            }
        };
        let k = u * n;
        Some(if self.x_reversed { n - k } else { k })
    }

    /// Unit direction of ray k in the sensor frame.
    pub fn column_dir(&self, k: usize) -> Vector3<f64> {
        match self.dirs.1.get(k) {
            Some(d) if self.dirs.0 == self.dir_z => *d,
            _ => Vector3::new(self.column_tan(k), 0.0, self.dir_z).normalize(),
        }
    }

    /// Depth of a sensor-frame point along the fan axis, from the apex.
    pub fn depth(&self, p: &Point3<f64>) -> f64 {
        self.dir_z * (p.z - self.apex_z)
    }

    /// Whether a profile point (x, z) lies where the sensor measures: within its depth range and
    /// its fan.
    pub fn sees(&self, x: f64, z: f64) -> bool {
        let depth = self.dir_z * (z - self.apex_z);
        depth >= self.depth_near
            && depth <= self.depth_far
            && (x / depth).abs() <= self.tan_half_fov
    }

    /// Slope x/depth of the ray through a profile point (x, z).
    pub fn tan_of(&self, x: f64, z: f64) -> f64 {
        x / (self.dir_z * (z - self.apex_z))
    }

    /// z limits of the measurement range in the sensor frame (low, high).
    pub fn z_range(&self) -> (f64, f64) {
        let a = self.apex_z + self.dir_z * self.depth_near;
        let b = self.apex_z + self.dir_z * self.depth_far;
        (a.min(b), a.max(b))
    }

    /// Centre of the measurement range in the sensor frame.
    pub fn range_centre(&self) -> Point3<f64> {
        Point3::new(
            0.0,
            0.0,
            self.apex_z + self.dir_z * 0.5 * (self.depth_near + self.depth_far),
        )
    }

    /// How far beyond its last column a surface's end lies on average, in columns, at a depth: the
    /// end is somewhere up to the next ray, so half a ray spacing; on a resampled profile the last
    /// slot on the surface lies up to a pitch before the last ray on it (slots beyond are
    /// interpolated across the end, or empty), so half a pitch plus half a ray spacing.
    pub fn end_offset_columns(&self, depth: f64) -> f64 {
        if self.points_only {
            // No rays behind the points: the end lies anywhere up to the next slot.
            return 0.5;
        }
        match &self.resample {
            Some((r, _)) => {
                let ray_step = 2.0 * self.tan_half_fov * depth / (self.tans.len() - 1) as f64;
                0.5 + 0.5 * ray_step.abs() / r.pitch
            }
            None => 0.5,
        }
    }

    /// Spacing of the x samples at a depth (metres).
    pub fn x_step_at_depth(&self, depth: f64) -> f64 {
        if self.points_only {
            return self.point_step;
        }
        match &self.resample {
            Some((r, _)) => r.pitch,
            None => 2.0 * self.tan_half_fov * depth / (self.tans.len() - 1).max(1) as f64,
        }
    }

    /// Ray-cast one profile with the sensor at `base_to_sensor`. Geometry only (no noise) when `rng`
    /// is None; otherwise the noise model draws from `rng`.
    pub fn profile(
        &self,
        scene: &Scene,
        base_to_sensor: &Isometry3<f64>,
        mut rng: Option<&mut crate::rng::Rng>,
    ) -> Profile {
        let max_toi = self.depth_far / self.dir_z.abs()
            * (1.0 + self.tan_half_fov * self.tan_half_fov).sqrt()
            + 1e-9;
        let fan = scene.fan(
            base_to_sensor,
            &self.apex(),
            &self.camera,
            self.dir_z,
            max_toi,
        );
        let mut points = Vec::with_capacity(self.tans.len());
        for k in 0..self.tans.len() {
            let dir = self.column_dir(k);
            let p = fan.cast(&dir).and_then(|hit| {
                let p_in_sensor = self.apex() + dir * hit.toi;
                let depth = self.depth(&p_in_sensor);
                if depth < self.depth_near || depth > self.depth_far {
                    return None;
                }
                // The camera must see the lit point: facing it and with nothing in between.
                if !fan.seen(&hit) {
                    return None;
                }
                let intensity = hit.reflectance * hit.cos_incidence.max(0.0);
                Some((p_in_sensor, intensity, hit.specular))
            });
            let point = match (p, rng.as_deref_mut()) {
                (None, _) => None,
                (Some((p, intensity, _)), None) => Some(ProfilePoint {
                    x: p.x,
                    z: p.z,
                    intensity,
                }),
                (Some((p, intensity, specular)), Some(r)) => {
                    self.noise.apply(self, p, intensity, specular, r)
                }
            };
            points.push(point);
        }
        if let Some(r) = &self.resample {
            points = self.resampled(r, &points);
        }
        if let Some(step) = self.z_quantum {
            for q in points.iter_mut().flatten() {
                q.z = (q.z / step).round() * step;
            }
        }
        Profile { points }
    }

    /// The rays' points resampled onto the uniform x grid: each slot interpolated linearly between
    /// the two neighbouring rays that both have a point and bracket it (nothing where either is
    /// missing), as a resampling profiler does; a slot between the two sides of a step gets a point
    /// on the line joining them.
    fn resampled(
        &self,
        r: &(Resample, i64),
        rays: &[Option<ProfilePoint>],
    ) -> Vec<Option<ProfilePoint>> {
        let mut out = vec![None; self.columns];
        for pair in rays.windows(2) {
            let (Some(a), Some(b)) = (pair[0], pair[1]) else {
                continue;
            };
            let (lo, hi) = if a.x <= b.x { (a, b) } else { (b, a) };
            let Some(u0) = self.column_of(lo.x, lo.z) else {
                continue;
            };
            let Some(u1) = self.column_of(hi.x, hi.z) else {
                continue;
            };
            let (ua, ub) = (u0.min(u1), u0.max(u1));
            let first = ua.ceil().max(0.0) as usize;
            let last = (ub.floor() as i64).min(self.columns as i64 - 1);
            for k in first as i64..=last {
                let k = k as usize;
                let x = self.slot_x(r, k as f64);
                let f = if hi.x > lo.x {
                    (x - lo.x) / (hi.x - lo.x)
                } else {
                    0.0
                };
                out[k] = Some(ProfilePoint {
                    x,
                    z: lo.z + f * (hi.z - lo.z),
                    intensity: lo.intensity + f * (hi.intensity - lo.intensity),
                });
            }
        }
        out
    }
}
