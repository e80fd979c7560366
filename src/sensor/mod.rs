//! The virtual line-laser profiler: fan geometry, range and field of view, camera occlusion,
//! z quantisation and seeded noise. Presets for the papers' two sensors.

mod noise;
pub use noise::NoiseModel;

use crate::scene::Scene;
use nalgebra::{Isometry3, Point3, Vector3};
use thiserror::Error;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum SensorError {
    #[error("unknown sensor preset '{name}': use gocator-2340 or vlm350")]
    UnknownPreset { name: String },
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

/// A line-laser profiler. The laser fan lies in the sensor x-z plane and leaves a (virtual) apex on
/// the z axis at `apex_z`, travelling toward `dir_z` (+1 or -1). Column k's ray has slope
/// `x / depth = tan_k`, tan_k evenly spaced over the field of view, which is where a camera column
/// sees the laser plane; depth is measured from the apex along the fan axis.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorModel {
    pub name: String,
    /// What the frame is, in words (origin and z direction).
    pub frame: &'static str,
    pub apex_z: f64,
    pub dir_z: f64,
    pub depth_near: f64,
    pub depth_far: f64,
    pub tan_half_fov: f64,
    pub columns: usize,
    /// z quantisation step of the reported points (None: continuous).
    pub z_quantum: Option<f64>,
    /// Camera centre in the sensor frame (points it cannot see are dropped).
    pub camera: Point3<f64>,
    pub noise: NoiseModel,
}

impl SensorModel {
    /// A preset by name: `gocator-2340` or `vlm350`.
    pub fn preset(name: &str) -> Result<SensorModel, SensorError> {
        match name {
            "gocator-2340" | "gocator2340" => Ok(Self::gocator_2340()),
            "vlm350" => Ok(Self::vlm350()),
            _ => Err(SensorError::UnknownPreset {
                name: name.to_string(),
            }),
        }
    }

    /// LMI Gocator 2340. Frame: origin at the centre of the measurement range and of the field of
    /// view, z toward the sensor, x along the laser line (the maker's unaligned sensor frame).
    /// Confirmed (maker's datasheet): clearance 190 mm, range 210 mm, FOV 96 mm near / 194 mm far.
    /// Unconfirmed: 1280 points per profile; z resolution 0.013-0.037 mm (quantum 0.013 mm used).
    /// Assumed (not published): the camera sits 120 mm from the laser along +y, level with the
    /// laser's virtual apex.
    pub fn gocator_2340() -> SensorModel {
        let (near_w, far_w, range, clearance) = (0.096, 0.194, 0.210, 0.190);
        // The fan's virtual apex: where the trapezoid's sides meet.
        let slope = (far_w - near_w) / range; // width growth per metre of depth
        let apex_to_near = near_w / slope;
        let apex_z = range / 2.0 + apex_to_near;
        let _ = clearance; // the emitter window sits 190 mm above the near end; the apex is virtual
        SensorModel {
            name: "gocator-2340".into(),
            frame: "origin at the centre of the measurement range, z toward the sensor",
            apex_z,
            dir_z: -1.0,
            depth_near: apex_to_near,
            depth_far: apex_to_near + range,
            tan_half_fov: far_w / 2.0 / (apex_to_near + range),
            columns: 1280,
            z_quantum: Some(0.013e-3),
            camera: Point3::new(0.0, 0.120, apex_z),
            noise: NoiseModel::default(),
        }
    }

    /// Pepperl+Fuchs VLM350-F280-R4-1101. Frame: origin at the sensor, z the depth away from it,
    /// x along the laser line (the edge paper's p_s = [x_s, 0, z_s]).
    /// From the edge paper: X range 40-160 mm, Z range 60-350 mm, at most 980 points, quantised to
    /// 0.1 mm. Assumed (not published): camera 60 mm from the laser along +y at the apex depth.
    pub fn vlm350() -> SensorModel {
        let (near_w, far_w, z_near, z_far) = (0.040, 0.160, 0.060, 0.350);
        let slope = (far_w - near_w) / (z_far - z_near);
        let apex_to_near = near_w / slope;
        let apex_z = z_near - apex_to_near;
        SensorModel {
            name: "vlm350".into(),
            frame: "origin at the sensor, z the depth away from it",
            apex_z,
            dir_z: 1.0,
            depth_near: apex_to_near,
            depth_far: apex_to_near + (z_far - z_near),
            tan_half_fov: far_w / 2.0 / (apex_to_near + z_far - z_near),
            columns: 980,
            z_quantum: Some(0.1e-3),
            camera: Point3::new(0.0, 0.060, apex_z),
            noise: NoiseModel::default(),
        }
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

    /// Slope x/depth of column k.
    pub fn column_tan(&self, k: usize) -> f64 {
        let n = (self.columns - 1).max(1) as f64;
        -self.tan_half_fov + 2.0 * self.tan_half_fov * k as f64 / n
    }

    /// Unit direction of column k's ray in the sensor frame.
    pub fn column_dir(&self, k: usize) -> Vector3<f64> {
        Vector3::new(self.column_tan(k), 0.0, self.dir_z).normalize()
    }

    /// Depth of a sensor-frame point along the fan axis, from the apex.
    pub fn depth(&self, p: &Point3<f64>) -> f64 {
        self.dir_z * (p.z - self.apex_z)
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

    /// Spacing of the x samples at a depth (metres).
    pub fn x_step_at_depth(&self, depth: f64) -> f64 {
        2.0 * self.tan_half_fov * depth / (self.columns - 1).max(1) as f64
    }

    /// Ray-cast one profile with the sensor at `base_to_sensor`. Geometry only (no noise) when `rng`
    /// is None; otherwise the noise model draws from `rng`.
    pub fn profile(
        &self,
        scene: &Scene,
        base_to_sensor: &Isometry3<f64>,
        mut rng: Option<&mut crate::rng::Rng>,
    ) -> Profile {
        let apex = base_to_sensor * self.apex();
        let camera = base_to_sensor * self.camera;
        let max_toi = self.depth_far / self.dir_z.abs()
            * (1.0 + self.tan_half_fov * self.tan_half_fov).sqrt()
            + 1e-9;
        let mut points = Vec::with_capacity(self.columns);
        for k in 0..self.columns {
            let dir = base_to_sensor.rotation * self.column_dir(k);
            let p = scene.cast_ray(&apex, &dir, max_toi).and_then(|hit| {
                let p_in_sensor = base_to_sensor.inverse_transform_point(&hit.p_in_base);
                let depth = self.depth(&p_in_sensor);
                if depth < self.depth_near || depth > self.depth_far {
                    return None;
                }
                // The camera must see the lit point: facing it and with nothing in between.
                let to_cam = camera - hit.p_in_base;
                if hit.normal_in_base.dot(&to_cam) <= 0.0 {
                    return None;
                }
                let start = hit.p_in_base + hit.normal_in_base * 1e-9;
                if scene.blocked(&start, &camera) {
                    return None;
                }
                let intensity = hit.reflectance * (-hit.normal_in_base.dot(&dir)).max(0.0);
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
            points.push(point.map(|mut q| {
                if let Some(step) = self.z_quantum {
                    q.z = (q.z / step).round() * step;
                }
                q
            }));
        }
        Profile { points }
    }
}
