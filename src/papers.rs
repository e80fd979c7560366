//! Published numbers of the two papers, for reproduction tests and scenarios (mm, radians).

/// Chen et al. 2018 (the disk paper).
/// Xu et al. (RCIM 2022), the straight-edge method.
pub mod xu2021 {
    /// Table 1: mean edge-direction deviation (deg) per number of rotations, for the parallel
    /// bar, the straight scale and the knife blade (the bar's 20 and 25 are printed negative).
    pub const TABLE1_MEAN_DEG: [(usize, [f64; 3]); 4] = [
        (10, [2.19, 3.10, 1.85]),
        (15, [1.16, 0.74, 0.81]),
        (20, [-1.03, 0.86, 0.84]),
        (25, [-1.12, 0.73, 0.94]),
    ];
    /// The specimens of Table 1's columns, as scenario specimen kinds.
    pub const TABLE1_SPECIMENS: [&str; 3] = ["parallel-bar", "scale", "knife-blade"];
}

pub mod chen2018 {
    /// Table I: T_tcp,i (mm).
    pub const TABLE1_T_TCP: [[f64; 3]; 4] = [
        [-222.966, -295.994, 360.786],
        [-232.113, -298.165, 344.196],
        [-374.932, -347.138, 338.836],
        [-377.572, -373.611, 352.241],
    ];
    /// Table I: R_tcp,i as (rx, ry, rz) radians, R = Rz Ry Rx.
    pub const TABLE1_R_TCP: [[f64; 3]; 4] = [
        [3.057, -0.103, -2.008],
        [3.115, -0.2, -2.269],
        [-2.981, 0.256, -2.491],
        [3.092, 0.208, 3.11],
    ];
    /// Table I: q^i (mm).
    pub const TABLE1_Q: [[f64; 3]; 4] = [
        [5.947, 0.0, 5.97],
        [-12.315, 0.0, 24.716],
        [9.328, 0.0, 34.277],
        [9.675, 0.0, 15.973],
    ];
    /// Table I: D_i^i, normalised.
    pub const TABLE1_D_SENSOR: [[f64; 3]; 4] = [
        [0.042, 0.336, -0.941],
        [-0.146, 0.424, -0.894],
        [0.222, 0.589, -0.777],
        [-0.024, 0.674, -0.738],
    ];
    /// Table I: D_i^b, normalised.
    pub const TABLE1_D_BASE: [[f64; 3]; 4] = [
        [0.181, -0.246, -0.952],
        [0.287, -0.294, -0.912],
        [0.391, -0.593, -0.704],
        [0.164, -0.631, -0.758],
    ];
    /// Eq. 49: Lambda, the disk calibration (rotation rows, translation mm in the last column).
    pub const EQ49: [[f64; 4]; 3] = [
        [0.99996, -0.00547, -0.00716, 6.0252],
        [-0.00544, -0.99998, 0.00288, 54.18211],
        [-0.00718, -0.00284, -0.99997, 364.25534],
    ];
    /// Eq. 50: the disk centre in the base frame (mm).
    pub const EQ50_DISK_CENTRE: [f64; 3] = [-319.622, -304.086, 11.48];
    /// Eq. 51: the calibration accuracy (mm).
    pub const EQ51_ACCURACY_MM: f64 = 0.212;
    /// Disk radius r_c (mm).
    pub const DISK_RADIUS_MM: f64 = 50.0;
    /// Table III: T_tcp,i (mm), R_tcp,i (rx, ry, rz), q^i (mm); 1-4 share an orientation (R_sensor),
    /// 5-8 give T_sensor.
    pub const TABLE3: [([f64; 3], [f64; 3], [f64; 3]); 8] = [
        (
            [-215.407, -287.69, 559.998],
            [3.08, -0.25, -2.611],
            [-16.168, 43.629, -58.079],
        ),
        (
            [-179.4, -289.3, 550.402],
            [3.08, -0.25, -2.611],
            [15.42, 23.498, -57.636],
        ),
        (
            [-187.799, -283.8, 502.902],
            [3.08, -0.25, -2.611],
            [23.695, 30.256, -10.06],
        ),
        (
            [-133.8, -268.0, 564.099],
            [3.08, -0.25, -2.611],
            [60.036, 19.653, -84.071],
        ),
        (
            [-317.98, -296.293, 567.379],
            [-3.074, -0.051, -2.689],
            [-26.706, 34.022, -52.304],
        ),
        (
            [-290.941, -319.017, 496.149],
            [3.116, -0.013, -3.027],
            [12.521, 45.942, 16.945],
        ),
        (
            [-275.77, -326.73, 480.747],
            [3.09, -0.136, 3.037],
            [-8.488, 54.055, 29.974],
        ),
        (
            [-217.283, -327.968, 569.943],
            [2.994, -0.249, -2.467],
            [-50.322, 37.241, -64.803],
        ),
    ];
    /// Eq. 53: Upsilon, the ball calibration.
    pub const EQ53: [[f64; 4]; 3] = [
        [0.99983, -0.0115, -0.01411, 6.30066],
        [-0.01129, -0.99983, 0.01485, 54.38647],
        [-0.01428, -0.01468, -0.99979, 364.14357],
    ];
    /// Eq. 56: ball-centre spread (mm).
    pub const EQ56_SPREAD_MM: f64 = 0.208;
    /// Ball radius (mm), Fig. 14b.
    pub const BALL_RADIUS_MM: f64 = 69.5;
    /// Fig. 15 points quoted in the text: (sigma mm, m, e mm).
    pub const FIG15_POINTS: [(f64, usize, f64); 4] = [
        (0.1, 100, 0.052),
        (0.9, 100, 0.449),
        (0.4, 10, 0.591),
        (0.4, 200, 0.135),
    ];

    use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};

    /// A published 3x4 matrix (mm) as a pose in metres, its rotation made orthonormal.
    pub fn pose_from_rows_mm(m: &[[f64; 4]; 3]) -> Isometry3<f64> {
        let r = Matrix3::from_fn(|i, j| m[i][j]);
        let rot = crate::math::nearest_rotation(&r);
        Isometry3::from_parts(
            Translation3::from(Vector3::new(m[0][3], m[1][3], m[2][3]) * 1e-3),
            UnitQuaternion::from_rotation_matrix(&rot),
        )
    }

    /// Eq. 49 as a pose (the disk paper's true flange_to_sensor for its simulation).
    pub fn eq49() -> Isometry3<f64> {
        pose_from_rows_mm(&EQ49)
    }

    /// Eq. 53 as a pose.
    pub fn eq53() -> Isometry3<f64> {
        pose_from_rows_mm(&EQ53)
    }
}
