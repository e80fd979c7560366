//! Specimen form error: how a real part departs from its nominal shape, as a small displacement
//! field in the specimen frame. The tolerances are peak-to-valley (as a form tolerance is
//! specified and measured); the shape of the error is fixed, its orientation drawn per trial.
//!
//! - disk flatness: the face is warped into a saddle (the commonest warp of a machined plate),
//!   w = a ((x^2 - y^2) cos 2phi + 2xy sin 2phi) / R^2 along the normal, peak-to-valley on the rim;
//!   a plate's (a scale's or parallel bar's) flatness: the same saddle about its top face's
//!   centre, peak-to-valley on the circle through its corners;
//! - ball sphericity: a radial deviation pv ((u . a)^2 - 1/2) about a random axis a (an ellipsoid);
//! - edge straightness: the edge bowed by pv (1/2 - 4 x^2 / L^2) toward a random direction across
//!   it.
//!
//! Edge rounding is a change of shape, not a small displacement: see `Specimen::edge_radius`.

use super::{Specimen, SpecimenKind};
use crate::rng::gauss;
use nalgebra::{Point3, Vector3};
use rand::RngExt;

/// Form tolerances, peak-to-valley, metres. Zero: a perfect part.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FormTolerance {
    pub flatness: f64,
    pub sphericity: f64,
    pub straightness: f64,
}

/// One part's form error (specimen frame, metres).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum FormError {
    #[default]
    None,
    /// A face: a saddle of peak-to-valley `pv` on the circle of radius `radius` about `centre`
    /// (x, y; the disk's centre, a plate's face's middle), axes at `phi`.
    Saddle {
        pv: f64,
        radius: f64,
        centre: [f64; 2],
        phi: f64,
    },
    /// Ball: radial deviation `pv ((u . axis)^2 - 1/2)`.
    Ellipsoid { pv: f64, axis: Vector3<f64> },
    /// Edge: bowed by `pv (1/2 - 4 x^2 / length^2)` along `toward` (a unit vector across the edge).
    Bow {
        pv: f64,
        length: f64,
        toward: Vector3<f64>,
    },
}

impl FormError {
    /// The form error of `specimen` for the tolerances (orientation from `rng`; a perfect part
    /// draws nothing, so switching the tolerances off changes no other number).
    pub fn draw(specimen: &Specimen, tol: &FormTolerance, rng: &mut crate::rng::Rng) -> FormError {
        match specimen.kind {
            SpecimenKind::DiskOnCylinder { radius, .. }
            | SpecimenKind::DiskOnPaper { radius, .. }
                if tol.flatness > 0.0 =>
            {
                FormError::Saddle {
                    pv: tol.flatness,
                    radius,
                    centre: [0.0, 0.0],
                    phi: rng.random_range(0.0..std::f64::consts::PI),
                }
            }
            SpecimenKind::BallOnPost { .. } if tol.sphericity > 0.0 => {
                let a = Vector3::new(gauss(rng), gauss(rng), gauss(rng));
                FormError::Ellipsoid {
                    pv: tol.sphericity,
                    axis: a.try_normalize(1e-12).unwrap_or_else(Vector3::z),
                }
            }
            _ if specimen.is_edge() && tol.straightness > 0.0 => {
                let psi = rng.random_range(0.0..std::f64::consts::TAU);
                FormError::Bow {
                    pv: tol.straightness,
                    length: specimen.edge_length().unwrap_or(1.0),
                    toward: Vector3::new(0.0, psi.cos(), psi.sin()),
                }
            }
            SpecimenKind::ParallelBar { length, width, .. }
            | SpecimenKind::Scale { length, width, .. }
                if tol.flatness > 0.0 =>
            {
                // The body lies at y < 0 from the edge: the face's middle is at y = -width / 2.
                FormError::Saddle {
                    pv: tol.flatness,
                    radius: 0.5 * length.hypot(width),
                    centre: [0.0, -0.5 * width],
                    phi: rng.random_range(0.0..std::f64::consts::PI),
                }
            }
            _ => FormError::None,
        }
    }

    pub fn is_none(&self) -> bool {
        matches!(self, FormError::None)
    }

    /// Whether the error deforms part `i` of the specimen (a ball's post stays as it is).
    pub fn applies_to_part(&self, i: usize) -> bool {
        match self {
            FormError::None => false,
            FormError::Ellipsoid { .. } => i == 0,
            _ => true,
        }
    }

    /// Displacement of the nominal surface point `p` (specimen frame) on the real part.
    pub fn displacement(&self, p: &Point3<f64>) -> Vector3<f64> {
        match *self {
            FormError::None => Vector3::zeros(),
            FormError::Saddle {
                pv,
                radius,
                centre,
                phi,
            } => {
                let (c, s) = ((2.0 * phi).cos(), (2.0 * phi).sin());
                let (x, y) = (p.x - centre[0], p.y - centre[1]);
                let w = 0.5 * pv * ((x * x - y * y) * c + 2.0 * x * y * s) / (radius * radius);
                Vector3::new(0.0, 0.0, w)
            }
            FormError::Ellipsoid { pv, axis } => match p.coords.try_normalize(1e-12) {
                Some(u) => u * pv * (u.dot(&axis).powi(2) - 0.5),
                None => Vector3::zeros(),
            },
            FormError::Bow { pv, length, toward } => {
                toward * pv * (0.5 - 4.0 * p.x * p.x / (length * length))
            }
        }
    }
}
