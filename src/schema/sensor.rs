//! A profiler given by its geometry instead of a preset: `[sensor.geometry]` in a scenario, and the
//! `sensor` object of a capture file (docs/sensors.md). Lengths in mm, angles in degrees, in the
//! sensor's own frame.

use crate::sensor::{RaySpacing, Resample, SensorGeometry};
use nalgebra::Point3;
use serde::{Deserialize, Serialize};

/// Which way the sensor frame's z axis points.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ZAxis {
    /// z grows away from the sensor (the laser travels toward +z), e.g. the VLM350.
    Away,
    /// z grows toward the sensor (the laser travels toward -z), e.g. the Gocator's frame.
    Toward,
}

/// A sensor's geometry as written by a user.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GeometrySection {
    /// The sensor's name in reports.
    #[serde(default = "d_name")]
    pub name: String,
    /// Points per profile (rays).
    pub columns: usize,
    /// How the rays are spaced: "equal-tan" (evenly in x at any one depth) or "equal-angle".
    #[serde(default = "d_spacing")]
    pub spacing: RaySpacing,
    /// Which way the sensor's z axis points: away (from the sensor into the scene) or toward.
    pub z_axis: ZAxis,
    /// The fan: its apex on the sensor's z axis and its half angle...
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub apex_z_mm: Option<f64>,
    /// The fan's half angle, deg (with apex_z_mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_angle_deg: Option<f64>,
    /// ...or the width of the line at two z values, [[z_mm, width_mm], [z_mm, width_mm]].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x_range_mm: Option<[[f64; 2]; 2]>,
    /// Measurement range: the z values (sensor frame) of its two ends.
    pub range_z_mm: [f64; 2],
    /// Column 0 at +x instead of -x.
    #[serde(default)]
    pub x_reversed: bool,
    /// z quantisation of the reported points (0: continuous).
    #[serde(default)]
    pub z_quantum_mm: f64,
    /// The camera's centre in the sensor frame (points it cannot see are missing from profiles).
    pub camera_mm: [f64; 3],
    /// Resampled output: one point per x step of this pitch (x = x_offset_mm + m x_pitch_mm)
    /// instead of one per ray; absent: one point per ray.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x_pitch_mm: Option<f64>,
    /// Resampled output: x of the first slot, mm.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub x_offset_mm: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

fn d_name() -> String {
    "custom".into()
}
fn d_spacing() -> RaySpacing {
    RaySpacing::EqualTan
}

impl GeometrySection {
    /// The record in SI units; `Err((field, value, reason))` names what is wrong.
    pub fn to_geometry(&self) -> Result<SensorGeometry, (&'static str, String, &'static str)> {
        let dir_z = match self.z_axis {
            ZAxis::Away => 1.0,
            ZAxis::Toward => -1.0,
        };
        if !(2..=crate::sensor::MAX_COLUMNS).contains(&self.columns) {
            return Err((
                "columns",
                self.columns.to_string(),
                "give 2 to 65536 columns (points per profile)",
            ));
        }
        let (apex_z, tan_half) = match (self.apex_z_mm, self.half_angle_deg, self.x_range_mm) {
            (Some(a), Some(h), None) => {
                if !(h > 0.0 && h < 80.0 && a.is_finite()) {
                    return Err((
                        "half_angle_deg",
                        h.to_string(),
                        "the fan's half angle must be in (0, 80) deg (and apex_z_mm finite)",
                    ));
                }
                (a * 1e-3, h.to_radians().tan())
            }
            (None, None, Some([[z1, w1], [z2, w2]])) => {
                // w = 2 t depth and z = apex + dir depth at both ends.
                let t = dir_z * (w2 - w1) / (2.0 * (z2 - z1));
                if !(t > 0.0 && t.is_finite() && w1 > 0.0 && w2 > 0.0) {
                    return Err((
                        "x_range_mm",
                        format!("{:?}", [[z1, w1], [z2, w2]]),
                        "the line must widen away from the sensor: give two z values with positive widths, the wider farther along z_axis",
                    ));
                }
                ((z1 - dir_z * w1 / (2.0 * t)) * 1e-3, t)
            }
            _ => {
                return Err((
                    "apex_z_mm",
                    "..".into(),
                    "give the fan as apex_z_mm and half_angle_deg, or as x_range_mm, not both",
                ));
            }
        };
        let depth = |z_mm: f64| dir_z * (z_mm * 1e-3 - apex_z);
        let (d0, d1) = (depth(self.range_z_mm[0]), depth(self.range_z_mm[1]));
        if !(d0 > 0.0 && d1 > 0.0 && d0 != d1 && d0.is_finite() && d1.is_finite()) {
            return Err((
                "range_z_mm",
                format!("{:?}", self.range_z_mm),
                "the measurement range must lie in front of the fan's apex along z_axis, with two different ends",
            ));
        }
        if self.z_quantum_mm < 0.0 || !self.z_quantum_mm.is_finite() {
            return Err((
                "z_quantum_mm",
                self.z_quantum_mm.to_string(),
                "must be a finite number >= 0",
            ));
        }
        if self.camera_mm.iter().any(|c| !c.is_finite()) {
            return Err((
                "camera_mm",
                format!("{:?}", self.camera_mm),
                "must be finite",
            ));
        }
        if let Some(p) = self.x_pitch_mm
            && !(p > 0.0 && p.is_finite())
        {
            return Err((
                "x_pitch_mm",
                p.to_string(),
                "a resampling pitch must be a finite number > 0 (leave it out for one point per ray)",
            ));
        }
        if !self.x_offset_mm.is_finite() {
            return Err((
                "x_offset_mm",
                self.x_offset_mm.to_string(),
                "must be finite",
            ));
        }
        Ok(SensorGeometry {
            name: self.name.clone(),
            frame: format!(
                "declared: fan apex at z = {:.1} mm, z {} the sensor",
                apex_z * 1e3,
                if dir_z > 0.0 { "away from" } else { "toward" }
            ),
            apex_z,
            dir_z,
            depth_near: d0.min(d1),
            depth_far: d0.max(d1),
            tan_half_fov: tan_half,
            columns: self.columns,
            spacing: self.spacing,
            x_reversed: self.x_reversed,
            z_quantum: (self.z_quantum_mm > 0.0).then_some(self.z_quantum_mm * 1e-3),
            camera: Point3::from(nalgebra::Vector3::from(self.camera_mm) * 1e-3),
            resample: self.x_pitch_mm.map(|p| Resample {
                pitch: p * 1e-3,
                offset: self.x_offset_mm * 1e-3,
            }),
        })
    }

    /// A record as written (apex and half angle).
    pub fn from_geometry(g: &SensorGeometry) -> GeometrySection {
        let z = |depth: f64| (g.apex_z + g.dir_z * depth) * 1e3;
        GeometrySection {
            name: g.name.clone(),
            columns: g.columns,
            spacing: g.spacing,
            z_axis: if g.dir_z > 0.0 {
                ZAxis::Away
            } else {
                ZAxis::Toward
            },
            apex_z_mm: Some(g.apex_z * 1e3),
            half_angle_deg: Some(g.tan_half_fov.atan().to_degrees()),
            x_range_mm: None,
            range_z_mm: [z(g.depth_near), z(g.depth_far)],
            x_reversed: g.x_reversed,
            z_quantum_mm: g.z_quantum.unwrap_or(0.0) * 1e3,
            camera_mm: [g.camera.x * 1e3, g.camera.y * 1e3, g.camera.z * 1e3],
            x_pitch_mm: g.resample.map(|r| r.pitch * 1e3),
            x_offset_mm: g.resample.map_or(0.0, |r| r.offset * 1e3),
        }
    }
}
