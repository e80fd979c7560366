//! Rerun recordings (feature `rerun`): the only module that knows Rerun types.
//!
//! Entity paths (documented in the README):
//! - `world/table`, `world/specimen/<i>/part_<k>`: static geometry;
//! - `world/arm/<link>` (transform per capture) with `world/arm/<link>/visual_<k>` (static shapes);
//! - `world/sensor/true` (the true sensor pose per capture) with `fan` (static) and `profile`
//!   (the profile in the sensor frame); `world/sensor/estimated` (the recovered sensor pose);
//! - `world/profile_in_base`, `world/features`: the profile and its feature in the base frame;
//! - `sweep/<series>/<column>`: a sweep's curves as scalar series on the timeline `x`.
//! Timelines: `capture` (profile index) for runs, `x` for sweeps, and `profile_time` (seconds on
//! the profiler's clock) for profiles placed by their time stamps.

use super::FormatError;
use crate::captures::Captures;
use crate::method::view::{Fitted, View};
use crate::robot::{Geometry, Robot};
use crate::scenario::Setup;
use crate::scene::{PartShape, Scene, Specimen};
use crate::sensor::SensorModel;
use nalgebra::Vector2;
use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};

/// The timeline of profiles placed by their time stamps: seconds on the profiler's clock.
const PROFILE_TIME: &str = "profile_time";

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

/// What a recording knows besides the captures: the arm and scene where simulated, the sensor,
/// the true transform where known, and a summary text (the result and its verdict).
pub struct Recorded<'a> {
    pub robot: Option<&'a Robot>,
    pub scene: Option<&'a Scene>,
    pub sensor: &'a SensorModel,
    pub truth: Option<Isometry3<f64>>,
    pub summary: &'a str,
}

/// The power of ten that makes an error of `size` (m, or rad x 5 cm) about 5 cm long in view.
fn magnification(size: f64) -> f64 {
    if !(size > 0.0) {
        return 1.0;
    }
    10f64.powf((0.05 / size).log10().floor()).max(1.0)
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
                "world/sensor/fan",
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

    /// The sensor's housing: a box behind the laser's apex, seen from the flange.
    fn sensor_body(&self, sensor: &SensorModel) -> Res {
        let depth = 0.09;
        let centre = sensor.apex() - Vector3::z() * (sensor.dir_z * depth / 2.0);
        self.rec
            .log_static(
                "world/sensor/body",
                &rerun::Boxes3D::from_half_sizes([[0.03f32, 0.02, (depth / 2.0) as f32]])
                    .with_centers([f3(&centre.coords)])
                    .with_colors([rerun::Color::from_unmultiplied_rgba(40, 40, 48, 200)])
                    .with_fill_mode(rerun::FillMode::Solid),
            )
            .map_err(e)
    }

    /// The layout a recording opens with: the scene and the mapped profiles in the base frame;
    /// the current profile in the laser plane (sensor x right, z down, mm), the residual (and,
    /// where the truth is known, the error) over the captures, and the summary text.
    fn run_blueprint(&self, truth: bool) -> Res {
        use rerun::blueprint::components::PanelState;
        use rerun::blueprint::{
            Blueprint, BlueprintActivation, BlueprintPanel, ContainerLike, Horizontal,
            SelectionPanel, Spatial2DView, Spatial3DView, TextDocumentView, TimePanel,
            TimeSeriesView, Vertical,
        };
        let mut side: Vec<ContainerLike> = vec![
            Spatial2DView::new("laser plane (sensor x, z in mm)")
                .with_origin("/laser_plane")
                .into(),
            TimeSeriesView::new("residual RMS per profile (mm)")
                .with_origin("/residual")
                .into(),
        ];
        if truth {
            // Degrees and millimetres on axes of their own: on one axis the smaller looks flat.
            side.push(
                TimeSeriesView::new("rotation error against the truth (deg)")
                    .with_origin("/error/rotation_deg")
                    .into(),
            );
            side.push(
                TimeSeriesView::new("translation and sensor-origin error against the truth (mm)")
                    .with_origin("/error")
                    .with_contents(["$origin/translation_mm", "$origin/sensor_origin_mm"])
                    .into(),
            );
        }
        side.push(
            TextDocumentView::new("summary")
                .with_origin("/summary")
                .into(),
        );
        Blueprint::new(Horizontal::new([
            Vertical::new([
                // The 3D views are in metres (Rerun's unit); the laser plane and every scalar in mm.
                Spatial3DView::new("scene (base frame, metres)")
                    .with_origin("/world")
                    .into(),
                Spatial3DView::new("every profile mapped with the recovered transform (metres)")
                    .with_origin("/world/mapped")
                    .with_contents(["$origin/**"])
                    .into(),
            ])
            .into(),
            Vertical::new(side).into(),
        ]))
        .with_blueprint_panel(BlueprintPanel::from_state(PanelState::Collapsed))
        .with_selection_panel(SelectionPanel::from_state(PanelState::Collapsed))
        .with_time_panel(TimePanel::new().with_timeline("capture"))
        .send(
            &self.rec,
            BlueprintActivation {
                make_active: true,
                make_default: true,
            },
        )
        .map_err(e)
    }

    /// A run from a scenario: the scenario's arm, scene and true transform, then `log_captures`.
    pub fn log_run(
        &self,
        setup: &Setup,
        caps: &Captures,
        estimate: &Isometry3<f64>,
        summary: &str,
    ) -> Res {
        let rig = &setup.rig;
        let scene = setup
            .plan(caps.method)
            .map(|p| p.scene())
            .unwrap_or(&setup.scene);
        let what = Recorded {
            robot: Some(&rig.robot),
            scene: Some(scene),
            sensor: &rig.sensor,
            truth: Some(rig.flange_to_sensor),
            summary,
        };
        self.log_captures(&what, caps, estimate)
    }

    /// Captures calibrated as `estimate`, on the timeline `capture`: the arm (when known), the
    /// sensor's body, fan, profile and feature in its frame, every profile and feature mapped into
    /// the base frame with `estimate` and coloured by its distance from the specimen fitted there
    /// (truth-free), the fitted specimen; where the truth is known, the true sensor frame, the
    /// error magnified into view and its scalars.
    pub fn log_captures(&self, what: &Recorded, caps: &Captures, estimate: &Isometry3<f64>) -> Res {
        let view = crate::method::view::view(caps, what.sensor, estimate);
        self.run_blueprint(what.truth.is_some())?;
        self.rec
            .log_static("world", &rerun::ViewCoordinates::RIGHT_HAND_Z_UP())
            .map_err(e)?;
        self.rec
            .log_static("summary", &rerun::TextDocument::new(what.summary))
            .map_err(e)?;
        if let Some(scene) = what.scene {
            self.scene(scene)?;
        }
        if let Some(robot) = what.robot {
            self.arm_geometry(robot)?;
        }
        self.fan(what.sensor)?;
        self.sensor_body(what.sensor)?;
        self.axes("world/sensor/axes", 0.04)?;
        self.axes("world/flange/axes", 0.03)?;
        // The colour scale of the residuals: 3 x their overall RMS (at least 10 um).
        let all: Vec<f64> = view
            .profiles
            .iter()
            .flat_map(|p| p.feature_residuals.iter().chain(&p.surface_residuals))
            .copied()
            .collect();
        let rms = (all.iter().map(|x| x * x).sum::<f64>() / all.len().max(1) as f64).sqrt();
        let scale = (3.0 * rms).max(1e-5);
        if let Some(f) = &view.fitted {
            self.fitted(f)?;
        }
        if what.truth.is_some() {
            self.axes("world/truth/sensor/axes", 0.05)?;
        }
        let mut q_prev = [0.0; 6];
        // Profiles placed by their time stamps (scanning on the move) are on their own clock too.
        let stamps = caps.timing.as_ref().map(|t| &t.stamps);
        for (i, p) in view.profiles.iter().enumerate() {
            self.rec.set_time_sequence("capture", i as i64);
            if let Some(s) = stamps.and_then(|s| s.get(i)) {
                self.rec.set_duration_secs(PROFILE_TIME, *s);
            }
            if let Some(robot) = what.robot
                && let Ok(q) = robot.ik_nearest(&p.base_to_flange, &q_prev)
            {
                q_prev = q;
                for (l, pose) in robot.links.iter().zip(robot.link_poses(&q)) {
                    self.rec
                        .log(format!("world/arm/{}", l.name), &transform(&pose))
                        .map_err(e)?;
                }
            }
            self.rec
                .log("world/flange", &transform(&p.base_to_flange))
                .map_err(e)?;
            self.rec
                .log("world/sensor", &transform(&(p.base_to_flange * estimate)))
                .map_err(e)?;
            if let Some(truth) = what.truth {
                self.rec
                    .log(
                        "world/truth/sensor",
                        &transform(&(p.base_to_flange * truth)),
                    )
                    .map_err(e)?;
                self.error_at(p, &truth, estimate)?;
            }
            let plane = |q: &Vector2<f64>| [q.x as f32, 0.0, q.y as f32];
            self.rec
                .log(
                    "world/sensor/profile",
                    &rerun::Points3D::new(p.points.iter().map(plane))
                        .with_radii([rerun::Radius::new_ui_points(1.5)])
                        .with_colors([rerun::Color::from_rgb(60, 200, 255)]),
                )
                .map_err(e)?;
            let feats: Vec<[f32; 3]> = p
                .feature
                .iter()
                .flat_map(|f| f.features.iter().map(plane))
                .collect();
            // The same in the laser plane's own 2D view (mm; z grows downwards, away from the
            // sensor, as the image axes do).
            let mm = |q: &Vector2<f64>| [(q.x * 1e3) as f32, (q.y * 1e3) as f32];
            self.rec
                .log(
                    "laser_plane/profile",
                    &rerun::Points2D::new(p.points.iter().map(mm))
                        .with_radii([rerun::Radius::new_ui_points(1.5)])
                        .with_colors([rerun::Color::from_rgb(60, 200, 255)]),
                )
                .map_err(e)?;
            self.rec
                .log(
                    "laser_plane/features",
                    &rerun::Points2D::new(p.feature.iter().flat_map(|f| f.features.iter().map(mm)))
                        .with_radii([rerun::Radius::new_ui_points(5.0)])
                        .with_colors([rerun::Color::from_rgb(255, 220, 0)]),
                )
                .map_err(e)?;
            self.rec
                .log(
                    "world/sensor/features",
                    &rerun::Points3D::new(feats)
                        .with_radii([rerun::Radius::new_ui_points(5.0)])
                        .with_colors([rerun::Color::from_rgb(255, 220, 0)]),
                )
                .map_err(e)?;
            if let Some(r) = p.rms() {
                self.rec
                    .log("residual/rms_mm", &rerun::Scalars::new([r * 1e3]))
                    .map_err(e)?;
            }
        }
        self.rec.disable_timeline("capture");
        if stamps.is_some() {
            self.rec.disable_timeline(PROFILE_TIME);
        }
        self.mapped(&view, estimate, scale)?;
        self.rec.flush_blocking().map_err(e)?;
        Ok(())
    }

    /// Every profile's points and features mapped into the base frame with `estimate`, static,
    /// coloured by their distance from the fitted specimen (blue 0 to red at `scale` and beyond;
    /// grey: not on the fitted surface).
    fn mapped(&self, view: &View, estimate: &Isometry3<f64>, scale: f64) -> Res {
        // At most about 300,000 points, so a large run stays quick to open.
        let total: usize = view.profiles.iter().map(|p| p.points.len()).sum();
        let stride = total.div_ceil(300_000).max(1);
        let colour = |r: Option<f64>| match r {
            None => rerun::Color::from_rgb(150, 150, 150),
            Some(r) => {
                let t = (r.abs() / scale).min(1.0);
                rerun::Color::from_rgb(
                    (255.0 * t) as u8,
                    (120.0 * (1.0 - t)) as u8,
                    (255.0 * (1.0 - t)) as u8,
                )
            }
        };
        let (mut pts, mut cols) = (Vec::new(), Vec::new());
        let (mut feats, mut feat_cols) = (Vec::new(), Vec::new());
        for p in &view.profiles {
            let to_base = p.base_to_flange * estimate;
            let at = |q: &Vector2<f64>| f3(&(to_base * Point3::new(q.x, 0.0, q.y)).coords);
            match &p.feature {
                // The surface points carry residuals; the rest of the profile is grey.
                Some(f)
                    if f.surface.len() == p.surface_residuals.len() && !f.surface.is_empty() =>
                {
                    for (q, r) in f.surface.iter().zip(&p.surface_residuals).step_by(stride) {
                        pts.push(at(q));
                        cols.push(colour(Some(*r)));
                    }
                }
                _ => {
                    for q in p.points.iter().step_by(stride) {
                        pts.push(at(q));
                        cols.push(colour(None));
                    }
                }
            }
            if let Some(f) = &p.feature {
                for (k, q) in f.features.iter().enumerate() {
                    feats.push(at(q));
                    feat_cols.push(colour(p.feature_residuals.get(k).copied()));
                }
            }
        }
        self.rec
            .log_static(
                "world/mapped/profiles",
                &rerun::Points3D::new(pts)
                    .with_radii([rerun::Radius::new_ui_points(1.0)])
                    .with_colors(cols),
            )
            .map_err(e)?;
        self.rec
            .log_static(
                "world/mapped/features",
                &rerun::Points3D::new(feats)
                    .with_radii([rerun::Radius::new_ui_points(3.0)])
                    .with_colors(feat_cols),
            )
            .map_err(e)
    }

    /// The specimen fitted to the mapped profiles, drawn as a wireframe.
    fn fitted(&self, f: &Fitted) -> Res {
        let colour = [rerun::Color::from_unmultiplied_rgba(80, 255, 120, 160)];
        let path = "world/mapped/fitted_specimen";
        let plane_box = |point: &Point3<f64>, normal: &Vector3<f64>, half: f32| {
            let q = UnitQuaternion::rotation_between(&Vector3::z(), normal).unwrap_or_else(|| {
                UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
            });
            rerun::Boxes3D::from_half_sizes([[half, half, 0.0]])
                .with_centers([f3(&point.coords)])
                .with_quaternions([quat(&q)])
                .with_colors(colour)
        };
        match f {
            Fitted::Sphere { centre, radius } => self.rec.log_static(
                path,
                &rerun::Ellipsoids3D::from_centers_and_radii(
                    [f3(&centre.coords)],
                    [*radius as f32],
                )
                .with_colors(colour)
                .with_fill_mode(rerun::FillMode::MajorWireframe),
            ),
            Fitted::Disk {
                centre,
                normal,
                radius,
            } => {
                let u = normal
                    .cross(&Vector3::x())
                    .try_normalize(1e-6)
                    .unwrap_or_else(|| normal.cross(&Vector3::y()).normalize());
                let v = normal.cross(&u);
                let rim: Vec<[f32; 3]> = (0..=96)
                    .map(|k| {
                        let t = k as f64 * std::f64::consts::TAU / 96.0;
                        f3(&(centre + *radius * (u * t.cos() + v * t.sin())).coords)
                    })
                    .collect();
                self.rec
                    .log_static(path, &rerun::LineStrips3D::new([rim]).with_colors(colour))
            }
            Fitted::Edge {
                points,
                direction,
                face,
            } => {
                let lines: Vec<[[f32; 3]; 2]> = points
                    .iter()
                    .map(|p| {
                        [
                            f3(&(p - direction * 0.1).coords),
                            f3(&(p + direction * 0.1).coords),
                        ]
                    })
                    .collect();
                self.rec
                    .log_static(
                        path,
                        &rerun::LineStrips3D::new(lines)
                            .with_colors(colour)
                            .with_radii([rerun::Radius::new_ui_points(2.0)]),
                    )
                    .map_err(e)?;
                match face {
                    Some((q, n)) => self
                        .rec
                        .log_static("world/mapped/fitted_face", &plane_box(q, n, 0.05)),
                    None => Ok(()),
                }
            }
            Fitted::Plane { point, normal } => {
                self.rec.log_static(path, &plane_box(point, normal, 0.1))
            }
        }
        .map_err(e)
    }

    /// At one capture, the error against the truth: its scalars (`error/...`; the sensor
    /// origin's error moves with the pose through the rotation error) and what makes it visible
    /// under `world/truth/sensor`: an arrow to the recovered origin and a frame turned by the
    /// rotation error, both magnified by a power of ten to a few centimetres (in their labels).
    fn error_at(
        &self,
        p: &crate::method::view::ProfileView,
        truth: &Isometry3<f64>,
        estimate: &Isometry3<f64>,
    ) -> Res {
        // Both in the true sensor frame: the recovered origin, and the rotation between them.
        let err = truth.inverse() * estimate;
        let shift = err.translation.vector;
        let rot = err.rotation.scaled_axis();
        let size = shift.norm().max(rot.norm() * 0.05);
        let k = magnification(size);
        self.rec
            .log(
                "error/rotation_deg",
                &rerun::Scalars::new([rot.norm().to_degrees()]),
            )
            .map_err(e)?;
        self.rec
            .log(
                "error/translation_mm",
                &rerun::Scalars::new([(estimate.translation.vector - truth.translation.vector)
                    .norm()
                    * 1e3]),
            )
            .map_err(e)?;
        let origin_error_mm = ((p.base_to_flange * estimate).translation.vector
            - (p.base_to_flange * truth).translation.vector)
            .norm()
            * 1e3;
        self.rec
            .log(
                "error/sensor_origin_mm",
                &rerun::Scalars::new([origin_error_mm]),
            )
            .map_err(e)?;
        self.rec
            .log(
                "world/truth/sensor/error_arrow",
                &rerun::Arrows3D::from_vectors([f3(&(shift * k))])
                    .with_colors([rerun::Color::from_rgb(255, 0, 255)])
                    .with_radii([rerun::Radius::new_ui_points(2.0)])
                    .with_labels([format!("translation error x{k}")]),
            )
            .map_err(e)?;
        let magnified = UnitQuaternion::from_scaled_axis(rot * k);
        self.rec
            .log(
                "world/truth/sensor/rotation_error",
                &rerun::Transform3D::from_rotation(quat(&magnified)),
            )
            .map_err(e)?;
        self.rec
            .log(
                "world/truth/sensor/rotation_error/axes",
                &rerun::Arrows3D::from_vectors([
                    [0.05f32, 0.0, 0.0],
                    [0.0, 0.05, 0.0],
                    [0.0, 0.0, 0.05],
                ])
                .with_colors([rerun::Color::from_rgb(255, 0, 255)])
                .with_labels([
                    format!("rotation error x{k}"),
                    String::new(),
                    String::new(),
                ]),
            )
            .map_err(e)
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
        // Its own layout (the viewer keeps the last one per application otherwise): the curves in
        // one view, titled as the plot is, with the time panel on the grid key.
        {
            use rerun::blueprint::components::PanelState;
            use rerun::blueprint::{
                Blueprint, BlueprintActivation, BlueprintPanel, SelectionPanel, TimePanel,
                TimeSeriesView, Vertical,
            };
            Blueprint::new(Vertical::new([TimeSeriesView::new(fig.title.as_str())
                .with_origin(format!("/sweep/{metric}"))
                .into()]))
            .with_blueprint_panel(BlueprintPanel::from_state(PanelState::Collapsed))
            .with_selection_panel(SelectionPanel::from_state(PanelState::Collapsed))
            .with_time_panel(TimePanel::new().with_timeline(fig.x_key.as_str()))
            .send(
                &self.rec,
                BlueprintActivation {
                    make_active: true,
                    make_default: true,
                },
            )
            .map_err(e)?;
        }
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
