//! lasercal: a test bench for hand-eye calibration of 2D laser profile scanners on industrial robots.
//!
//! Internal units are metres and radians everywhere; frames are named `a_to_b` (the pose of frame b
//! expressed in frame a, so `p_in_a = a_to_b * p_in_b`). See `docs/conventions.md`.

pub mod calib;
pub mod captures;
pub mod error;
pub mod features;
pub mod id;
pub mod io;
pub mod math;
pub mod method;
pub mod metrics;
pub mod papers;
pub mod rng;
pub mod robot;
pub mod scenario;
pub mod scene;
pub mod schema;
pub mod sensor;
pub mod sim;
pub mod sweep;
pub mod testkit;
pub mod trial;
