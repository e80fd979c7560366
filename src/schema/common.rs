//! What every method's plan is built on: the rig (robot, sensor, true mounting) and the scenario's
//! specimen and table, in SI units.

use super::{Scenario, ScenarioError, SpecimenSection, Validator};
use crate::math::pose_from_xyz_rpy;
use crate::robot::Robot;
use crate::scene::{Scene, Specimen, SpecimenKind, Table};
use crate::sensor::{NoiseModel, SensorGeometry, SensorModel};
use crate::sim::Rig;
use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};

/// What every method's plan is built on: the rig and the scenario's own specimen and table.
#[derive(Debug, Clone)]
pub struct Common {
    pub rig: Rig,
    pub scene: Scene,
    pub specimen: Specimen,
    pub base_to_specimen: Isometry3<f64>,
    pub table: Option<Table>,
}

impl Common {
    /// A method's own specimen (its section at `key`) in a scene of its own with the same table,
    /// or the scenario's specimen and scene when the method has none.
    pub fn own(
        &self,
        section: Option<&SpecimenSection>,
        key: &str,
        v: &Validator,
    ) -> Result<(Specimen, Isometry3<f64>, Scene), ScenarioError> {
        match section {
            Some(sp) => {
                let (spec, pose) = place_specimen(sp, key, v)?;
                let mut scene = Scene::new(self.table);
                scene.add(&spec, pose);
                Ok((spec, pose, scene))
            }
            None => Ok((
                self.specimen.clone(),
                self.base_to_specimen,
                self.scene.clone(),
            )),
        }
    }
}

/// A specimen section's specimen and its pose.
pub fn place_specimen(
    s: &SpecimenSection,
    key: &str,
    v: &Validator,
) -> Result<(Specimen, Isometry3<f64>), ScenarioError> {
    let mut specimen = Specimen::new(s.kind_checked(key, v)?);
    if let Some(r) = s.reflectance {
        specimen.reflectance = r;
    }
    specimen.edge_radius = s.edge_radius_mm.unwrap_or(0.0) * 1e-3;
    let p = s.position_mm;
    let r = s.rpy_deg;
    let pose = pose_from_xyz_rpy(
        [p[0] * 1e-3, p[1] * 1e-3, p[2] * 1e-3],
        [r[0].to_radians(), r[1].to_radians(), r[2].to_radians()],
    );
    Ok((specimen, pose))
}

impl Scenario {
    /// The true flange_to_sensor.
    pub fn mount(&self) -> Isometry3<f64> {
        let t = Vector3::from(self.sensor.mount_position_mm) * 1e-3;
        let rot = match (&self.sensor.mount_rotation, &self.sensor.mount_rpy_deg) {
            (Some(m), _) => UnitQuaternion::from_rotation_matrix(&crate::math::nearest_rotation(
                &Matrix3::from_fn(|i, j| m[i][j]),
            )),
            (None, Some(r)) => UnitQuaternion::from_euler_angles(
                r[0].to_radians(),
                r[1].to_radians(),
                r[2].to_radians(),
            ),
            (None, None) => UnitQuaternion::identity(),
        };
        Isometry3::from_parts(Translation3::from(t), rot)
    }

    /// The sensor's record: the preset's, or the declared geometry, checked.
    pub fn sensor_geometry(&self, v: &Validator) -> Result<SensorGeometry, ScenarioError> {
        let s = &self.sensor;
        v.one_of(
            ("sensor.preset", s.preset.is_some()),
            ("sensor.geometry", s.geometry.is_some()),
            "the sensor",
        )?;
        let g = match (&s.preset, &s.geometry) {
            (Some(p), _) => SensorModel::preset_geometry(p)
                .map_err(|e| v.bad("sensor.preset", format!("\"{p}\""), e.to_string()))?,
            (None, Some(g)) => g.to_geometry().map_err(|(field, value, reason)| {
                v.bad(&format!("sensor.geometry.{field}"), value, reason)
            })?,
            (None, None) => return Err(v.bad("sensor.preset", "(missing)", "give a sensor")),
        };
        // The model's own checks (columns, fan angle, range) name the record's field.
        SensorModel::from_geometry(g.clone())
            .map_err(|e| v.bad("sensor.geometry", "..", e.to_string()))?;
        Ok(g)
    }

    /// The specimen this scenario describes.
    pub fn specimen_kind(&self, v: &Validator) -> Result<SpecimenKind, ScenarioError> {
        self.specimen.kind_checked("specimen", v)
    }

    fn sensor_model(&self, v: &Validator) -> Result<SensorModel, ScenarioError> {
        let mut sensor = SensorModel::from_geometry(self.sensor_geometry(v)?)
            .map_err(|e| v.bad("sensor.geometry", "..", e.to_string()))?;
        if !self.sensor.quantise {
            sensor.z_quantum = None;
        }
        let n = &self.sensor.noise;
        sensor.noise = NoiseModel {
            z_sigma_near: n.z_sigma_near_mm * 1e-3,
            z_sigma_far: n.z_sigma_far_mm * 1e-3,
            x_sigma: n.x_sigma_mm * 1e-3,
            dropout: n.dropout,
            outlier_rate: n.outlier_rate,
            outlier_amplitude: n.outlier_amplitude_mm * 1e-3,
            dark_threshold: n.dark_threshold,
            dark_noise_factor: n.dark_noise_factor,
            dark_dropout: n.dark_dropout,
        };
        Ok(sensor)
    }

    /// The rig, the scenario's specimen in its scene, and the table, without any method's plan:
    /// what `lasercal scan` needs.
    pub fn common(&self, file: &str) -> Result<Common, ScenarioError> {
        let v = Validator { file };
        let robot = Robot::resolve(&self.robot.name).map_err(|e| {
            v.bad(
                "robot.name",
                format!("\"{}\"", self.robot.name),
                e.to_string(),
            )
        })?;
        let sensor = self.sensor_model(&v)?;
        let (specimen, base_to_specimen) = place_specimen(&self.specimen, "specimen", &v)?;
        let table = self.table.as_ref().map(|t| Table {
            height_m: t.height_mm * 1e-3,
            reflectance: t.reflectance,
        });
        let mut scene = Scene::new(table);
        scene.add(&specimen, base_to_specimen);
        Ok(Common {
            rig: Rig {
                robot,
                sensor,
                flange_to_sensor: self.mount(),
            },
            scene,
            specimen,
            base_to_specimen,
            table,
        })
    }
}
