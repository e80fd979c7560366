//! Rerun recordings (feature `rerun`): the only module that knows Rerun types.
//!
//! Entity paths (documented in the README):
//! - `world/table`, `world/specimen/<i>/part_<k>`: static geometry;
//! - `world/arm/<link>` (transform per capture) with `world/arm/<link>/visual_<k>` (static shapes);
//! - `world/sensor/true` (the true sensor pose per capture) with `fan` (static) and `profile`
//!   (the profile in the sensor frame); `world/sensor/estimated` (the recovered sensor pose);
//! - `world/profile_in_base`, `world/features`: the profile and its feature in the base frame;
//! - `sweep/<series>/<column>`: a sweep's curves as scalar series on the timeline `x`.
//! Timelines: `capture` (profile index) for runs, `x` for sweeps.

use super::FormatError;
use crate::captures::{Captures, ProfileData};
use crate::robot::{Geometry, Robot};
use crate::scenario::Setup;
use crate::scene::{PartShape, Scene, Specimen};
use crate::sensor::SensorModel;
use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};

type Res = Result<(), FormatError>;

fn f3(v: &Vector3<f64>) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

fn quat(q: &UnitQuaternion<f64>) -> rerun::Quaternion {
    let c = q.coords;
    rerun::Quaternion::from_xyzw([c[0] as f32, c[1] as f32, c[2] as f32, c[3] as f32])
}

fn transform(p: &Isometry3<f64>) -> rerun::Transform3D {
    rerun::Transform3D::from_translation_rotation(f3(&p.translation.vector), quat(&p.rotation))
}

pub struct Recorder {
    rec: rerun::RecordingStream,
    /// URDF mesh visuals that could not be shown (file names), for the caller's warning.
    skipped_meshes: std::cell::RefCell<Vec<String>>,
}

fn e(x: impl std::fmt::Display) -> FormatError {
    FormatError::Render {
        what: "rerun".into(),
        message: x.to_string(),
    }
}

impl Recorder {
    /// The URDF mesh visuals the recording could not show (boxes, cylinders and spheres are).
    pub fn skipped_meshes(&self) -> Vec<String> {
        self.skipped_meshes.borrow().clone()
    }

    /// Record into an .rrd file.
    pub fn save(path: &std::path::Path) -> Result<Recorder, FormatError> {
        let rec = rerun::RecordingStreamBuilder::new("lasercal")
            .save(path)
            .map_err(|x| FormatError::Render {
                what: path.display().to_string(),
                message: x.to_string(),
            })?;
        Ok(Recorder {
            rec,
            skipped_meshes: Default::default(),
        })
    }

    /// Record into a newly spawned viewer (needs the `rerun` viewer on PATH).
    pub fn spawn() -> Result<Recorder, FormatError> {
        let rec = rerun::RecordingStreamBuilder::new("lasercal")
            .spawn()
            .map_err(|x| FormatError::Render {
                what: "rerun".into(),
                message: format!(
                    "cannot spawn the Rerun viewer ({x}); install it with `pip install rerun-sdk==0.36.3`"
                ),
            })?;
        Ok(Recorder {
            rec,
            skipped_meshes: Default::default(),
        })
    }

    fn shape(
        &self,
        path: &str,
        shape: &PartShape,
        pose: &Isometry3<f64>,
        color: [u8; 4],
        is_static: bool,
    ) -> Res {
        let q = [quat(&pose.rotation)];
        let c = [f3(&pose.translation.vector)];
        let log = |a: &dyn rerun::AsComponents| {
            if is_static {
                self.rec.log_static(path, a)
            } else {
                self.rec.log(path, a)
            }
        };
        match shape {
            PartShape::Cylinder(cy) => {
                // Lasercal's cylinder spans z in [z_min, z_max] of its frame; Rerun's is centred.
                let mid = pose * Point3::new(0.0, 0.0, 0.5 * (cy.z_min + cy.z_max));
                log(&rerun::Cylinders3D::from_lengths_and_radii(
                    [(cy.z_max - cy.z_min) as f32],
                    [cy.radius as f32],
                )
                .with_centers([f3(&mid.coords)])
                .with_quaternions(q)
                .with_colors([rerun::Color::from_unmultiplied_rgba(
                    color[0], color[1], color[2], color[3],
                )]))
            }
            PartShape::Ball(b) => log(&rerun::Ellipsoids3D::from_centers_and_radii(
                c,
                [b.radius as f32],
            )
            .with_colors([rerun::Color::from_unmultiplied_rgba(
                color[0], color[1], color[2], color[3],
            )])
            .with_fill_mode(rerun::FillMode::Solid)),
            PartShape::Planes(p) => {
                // Draw the bounding box of the planes' vertices along the frame axes.
                let h: Vec<f32> = (0..3)
                    .map(|k| {
                        p.planes
                            .iter()
                            .filter(|(n, _)| n[k].abs() > 0.999)
                            .map(|(_, off)| *off as f32)
                            .fold(0.0f32, f32::max)
                    })
                    .collect();
                log(&rerun::Boxes3D::from_half_sizes([[h[0], h[1], h[2]]])
                    .with_centers(c)
                    .with_quaternions(q)
                    .with_colors([rerun::Color::from_unmultiplied_rgba(
                        color[0], color[1], color[2], color[3],
                    )])
                    .with_fill_mode(rerun::FillMode::Solid))
            }
            PartShape::Sheet(s) => {
                log(
                    &rerun::Boxes3D::from_half_sizes([[s.half as f32, s.half as f32, 0.0005]])
                        .with_centers(c)
                        .with_quaternions(q)
                        .with_colors([rerun::Color::from_unmultiplied_rgba(20, 20, 20, 255)])
                        .with_fill_mode(rerun::FillMode::Solid),
                )
            }
        }
        .map_err(e)
    }

    fn scene(&self, scene: &Scene) -> Res {
        if let Some(t) = scene.table {
            self.rec
                .log_static(
                    "world/table",
                    &rerun::Boxes3D::from_half_sizes([[0.6f32, 0.6, 0.001]])
                        .with_centers([[0.0f32, 0.0, t.height_m as f32 - 0.001]])
                        .with_colors([rerun::Color::from_rgb(90, 90, 90)]),
                )
                .map_err(e)?;
        }
        for (i, (spec, pose)) in scene.specimens.iter().enumerate() {
            self.specimen(i, spec, pose)?;
        }
        Ok(())
    }

    fn specimen(&self, i: usize, spec: &Specimen, pose: &Isometry3<f64>) -> Res {
        for (k, part) in spec.parts().iter().enumerate() {
            self.shape(
                &format!("world/specimen/{i}/part_{k}"),
                &part.shape,
                &(pose * part.specimen_to_part),
                [200, 200, 210, 255],
                true,
            )?;
        }
        Ok(())
    }

    fn arm_geometry(&self, robot: &Robot) -> Res {
        for l in &robot.links {
            for (k, v) in l.visuals.iter().enumerate() {
                let path = format!("world/arm/{}/visual_{k}", l.name);
                let color = v
                    .rgba
                    .map(|c| {
                        [
                            (c[0] * 255.0) as u8,
                            (c[1] * 255.0) as u8,
                            (c[2] * 255.0) as u8,
                            255,
                        ]
                    })
                    .unwrap_or([230, 150, 30, 255]);
                let shape = match &v.geometry {
                    Geometry::Box { size } => {
                        PartShape::Planes(crate::scene::ConvexPlanes::cuboid(
                            Vector3::new(size[0], size[1], size[2]) / 2.0,
                        ))
                    }
                    Geometry::Cylinder { radius, length } => {
                        PartShape::Cylinder(crate::scene::CylinderZ {
                            radius: *radius,
                            z_min: -length / 2.0,
                            z_max: length / 2.0,
                        })
                    }
                    Geometry::Sphere { radius } => {
                        PartShape::Ball(parry3d_f64::shape::Ball::new(*radius))
                    }
                    // Mesh files are not loaded: said to the user (`skipped_meshes`).
                    Geometry::Mesh { filename } => {
                        let mut m = self.skipped_meshes.borrow_mut();
                        if !m.contains(filename) {
                            m.push(filename.clone());
                        }
                        continue;
                    }
                };
                self.shape(&path, &shape, &v.link_to_geometry, color, true)?;
            }
        }
        Ok(())
    }

    fn fan(&self, sensor: &SensorModel) -> Res {
        let apex = sensor.apex();
        let at = |t: f64, d: f64| Point3::new(t * d, 0.0, sensor.apex_z + sensor.dir_z * d);
        let (n, f, t) = (sensor.depth_near, sensor.depth_far, sensor.tan_half_fov);
        let strips: Vec<Vec<[f32; 3]>> = vec![
            vec![f3(&apex.coords), f3(&at(-t, f).coords)],
            vec![f3(&apex.coords), f3(&at(t, f).coords)],
            vec![
                f3(&at(-t, n).coords),
                f3(&at(t, n).coords),
                f3(&at(t, f).coords),
                f3(&at(-t, f).coords),
                f3(&at(-t, n).coords),
            ],
        ];
        self.rec
            .log_static(
                "world/sensor/true/fan",
                &rerun::LineStrips3D::new(strips)
                    .with_colors([rerun::Color::from_rgb(255, 40, 40)]),
            )
            .map_err(e)
    }

    fn axes(&self, path: &str, len: f32) -> Res {
        self.rec
            .log_static(
                path,
                &rerun::Arrows3D::from_vectors([[len, 0.0, 0.0], [0.0, len, 0.0], [0.0, 0.0, len]])
                    .with_colors([
                        rerun::Color::from_rgb(255, 0, 0),
                        rerun::Color::from_rgb(0, 255, 0),
                        rerun::Color::from_rgb(0, 0, 255),
                    ]),
            )
            .map_err(e)
    }

    /// A run: the arm, specimen, fan, every profile (sensor and base frame) with its feature, the
    /// true and the recovered sensor poses, on the timeline `capture`.
    pub fn log_run(&self, setup: &Setup, caps: &Captures, estimate: &Isometry3<f64>) -> Res {
        let rig = &setup.rig;
        let scene = setup
            .plan(caps.method)
            .map(|p| p.scene())
            .unwrap_or(&setup.scene);
        self.scene(scene)?;
        self.arm_geometry(&rig.robot)?;
        self.fan(&rig.sensor)?;
        self.axes("world/sensor/true/axes", 0.05)?;
        self.axes("world/sensor/estimated/axes", 0.04)?;
        let mut q_prev = [0.0; 6];
        for (i, p) in caps.profiles.iter().enumerate() {
            self.rec.set_time_sequence("capture", i as i64);
            if let Ok(q) = rig.robot.ik_nearest(&p.base_to_flange, &q_prev) {
                q_prev = q;
                for (l, pose) in rig.robot.links.iter().zip(rig.robot.link_poses(&q)) {
                    self.rec
                        .log(format!("world/arm/{}", l.name), &transform(&pose))
                        .map_err(e)?;
                }
            }
            let base_to_sensor = p.base_to_flange * rig.flange_to_sensor;
            self.rec
                .log("world/sensor/true", &transform(&base_to_sensor))
                .map_err(e)?;
            self.rec
                .log(
                    "world/sensor/estimated",
                    &transform(&(p.base_to_flange * estimate)),
                )
                .map_err(e)?;
            let (pts, feats): (Vec<Point3<f64>>, Vec<Point3<f64>>) = match &p.data {
                ProfileData::Raw(prof) => (
                    prof.points
                        .iter()
                        .flatten()
                        .map(|q| Point3::new(q.x, 0.0, q.z))
                        .collect(),
                    vec![],
                ),
                ProfileData::Chord { a, b } => (
                    vec![],
                    vec![Point3::new(a.x, 0.0, a.y), Point3::new(b.x, 0.0, b.y)],
                ),
                ProfileData::Circle(c) => (vec![], vec![Point3::new(c.centre.x, 0.0, c.centre.y)]),
                ProfileData::EdgePoint(q) => (vec![], vec![Point3::new(q.x, 0.0, q.y)]),
                ProfileData::Arc(a) => (
                    vec![],
                    a.iter().map(|q| Point3::new(q.x, 0.0, q.y)).collect(),
                ),
            };
            let in_sensor: Vec<[f32; 3]> = pts.iter().map(|q| f3(&q.coords)).collect();
            let in_base: Vec<[f32; 3]> = pts
                .iter()
                .map(|q| f3(&(base_to_sensor * q).coords))
                .collect();
            self.rec
                .log(
                    "world/sensor/true/profile",
                    &rerun::Points3D::new(in_sensor).with_radii([0.0004f32]),
                )
                .map_err(e)?;
            self.rec
                .log(
                    "world/profile_in_base",
                    &rerun::Points3D::new(in_base)
                        .with_radii([0.0004f32])
                        .with_colors([rerun::Color::from_rgb(60, 200, 255)]),
                )
                .map_err(e)?;
            let fb: Vec<[f32; 3]> = feats
                .iter()
                .map(|q| f3(&(base_to_sensor * q).coords))
                .collect();
            self.rec
                .log(
                    "world/features",
                    &rerun::Points3D::new(fb)
                        .with_radii([0.0015f32])
                        .with_colors([rerun::Color::from_rgb(255, 220, 0)]),
                )
                .map_err(e)?;
        }
        self.rec.flush_blocking().map_err(e)?;
        Ok(())
    }

    /// A sweep's curves as scalar series: `sweep/<series>/<column>` over the timeline `x` (the
    /// grid index of the x value).
    pub fn log_curves(&self, fig: &crate::io::plot::Figure) -> Res {
        // One view per metric: every series under `sweep/<summary column>/<k>`, named by its
        // value in the legend; the timeline is the grid key, at the grid values (a sequence for
        // whole numbers such as chord counts, else a duration whose seconds are the values).
        let clean = |k: &str| -> String {
            k.chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || c == '_' {
                        c
                    } else {
                        '_'
                    }
                })
                .collect()
        };
        let metric = clean(&fig.y_key);
        let timeline = rerun::TimelineName::try_new(&fig.x_key).map_err(|err| {
            crate::error::FormatError::Render {
                what: "sweep recording".into(),
                message: format!("timeline {:?}: {err}", fig.x_key),
            }
        })?;
        let whole = fig
            .series
            .iter()
            .flat_map(|s| s.points.iter())
            .all(|(x, _)| x.fract() == 0.0 && x.abs() < 1e15);
        for (k, s) in fig.series.iter().enumerate() {
            let path = format!("sweep/{metric}/{k}");
            self.rec
                .log_static(
                    path.as_str(),
                    &rerun::SeriesLines::new().with_names([s.label.as_str()]),
                )
                .map_err(e)?;
            for (x, y) in &s.points {
                if whole {
                    self.rec.set_time_sequence(timeline, *x as i64);
                } else {
                    self.rec.set_duration_secs(timeline, *x);
                }
                self.rec
                    .log(path.as_str(), &rerun::Scalars::new([*y]))
                    .map_err(e)?;
            }
        }
        self.rec.flush_blocking().map_err(e)?;
        Ok(())
    }
}
