//! The figures a trial reports, as a type: trials.csv's columns, summary.csv's statistics, the
//! report's table and the plot keys all come from `Metric`, so a new figure is one variant here.

/// One reported figure; its name carries its unit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Metric {
    /// Angle of R_est^T R_true.
    RotationError,
    /// |t_est - t_true|.
    TranslationError,
    /// |R_est - R_true|_F.
    FrobeniusRotation,
    /// Distance of the reconstructed specimen centre from the true one (disk, ball).
    CentreError,
    /// The method's own accuracy figure: the spread of the specimen centres (disk paper Sec.
    /// III-D, Eq. 56); truth-free.
    Accuracy,
    /// Edge method: mean angle of the group edge directions from the global one (Xu Table 1).
    EdgeAngleDev,
    /// Edge method: mean distance of the points from the fitted edge (Xu Table 2).
    EdgeDistance,
    /// Edge method: radius of the precision ball reconstructed with the estimate (Xu Table 3).
    SphereRadius,
    /// The verdict's residual test: residual RMS over the stated noise; truth-free.
    NoiseRatio,
    /// The largest predicted standard deviation of the rotation and of the translation.
    PredictedSdRotation,
    PredictedSdTranslation,
    /// The verdict: 1 suspect, 0 otherwise (its mean over trials is the share called suspect).
    Suspect,
    /// The verdict's honest 95 % bound on the rotation and translation error; truth-free.
    BoundRotation,
    BoundTranslation,
    /// The verdict: 1 imprecise (bound beyond the tolerance), 0 otherwise.
    Imprecise,
    /// 1 when both errors against the truth lie within their 95 % bounds (the mean over trials
    /// is the bound's coverage; the truth is needed).
    Covered,
    /// The rotation and translation errors of the results judged ok only (absent otherwise):
    /// their statistics are what a user who trusts the verdict gets.
    RotationErrorOk,
    TranslationErrorOk,
}

impl Metric {
    /// Every metric, in the order of trials.csv's columns.
    pub const ALL: [Metric; 18] = [
        Metric::RotationError,
        Metric::TranslationError,
        Metric::FrobeniusRotation,
        Metric::CentreError,
        Metric::Accuracy,
        Metric::EdgeAngleDev,
        Metric::EdgeDistance,
        Metric::SphereRadius,
        Metric::NoiseRatio,
        Metric::PredictedSdRotation,
        Metric::PredictedSdTranslation,
        Metric::Suspect,
        Metric::BoundRotation,
        Metric::BoundTranslation,
        Metric::Imprecise,
        Metric::Covered,
        Metric::RotationErrorOk,
        Metric::TranslationErrorOk,
    ];

    /// The verdict's figures (and what follows from it), the last of `ALL`: `run` prints them
    /// with the verdict, not on the result's line.
    pub fn is_verdict(self) -> bool {
        self.index() >= Metric::NoiseRatio.index()
    }

    /// The metrics summarised per grid point and method, in summary.csv's order.
    pub const SUMMARISED: [Metric; 12] = [
        Metric::CentreError,
        Metric::RotationError,
        Metric::TranslationError,
        Metric::EdgeAngleDev,
        Metric::EdgeDistance,
        Metric::SphereRadius,
        Metric::NoiseRatio,
        Metric::Suspect,
        Metric::Imprecise,
        Metric::Covered,
        Metric::RotationErrorOk,
        Metric::TranslationErrorOk,
    ];

    /// Column name (with its unit).
    pub fn name(self) -> &'static str {
        match self {
            Metric::RotationError => "rotation_error_deg",
            Metric::TranslationError => "translation_error_mm",
            Metric::FrobeniusRotation => "frobenius_rotation",
            Metric::CentreError => "centre_error_mm",
            Metric::Accuracy => "accuracy_mm",
            Metric::EdgeAngleDev => "edge_angle_dev_deg",
            Metric::EdgeDistance => "edge_distance_mm",
            Metric::SphereRadius => "sphere_radius_mm",
            Metric::NoiseRatio => "noise_ratio",
            Metric::PredictedSdRotation => "predicted_sd_rotation_deg",
            Metric::PredictedSdTranslation => "predicted_sd_translation_mm",
            Metric::Suspect => "suspect",
            Metric::BoundRotation => "bound_rotation_deg",
            Metric::BoundTranslation => "bound_translation_mm",
            Metric::Imprecise => "imprecise",
            Metric::Covered => "covered",
            Metric::RotationErrorOk => "rotation_error_ok_deg",
            Metric::TranslationErrorOk => "translation_error_ok_mm",
        }
    }

    /// In words, for printed results.
    pub fn words(self) -> &'static str {
        match self {
            Metric::RotationError => "rotation error",
            Metric::TranslationError => "translation error",
            Metric::FrobeniusRotation => "|dR|_F",
            Metric::CentreError => "centre error",
            Metric::Accuracy => "centre spread (accuracy)",
            Metric::EdgeAngleDev => "mean edge-direction deviation",
            Metric::EdgeDistance => "mean point-to-edge distance",
            Metric::SphereRadius => "reconstructed ball radius",
            Metric::NoiseRatio => "residual RMS / stated noise",
            Metric::PredictedSdRotation => "predicted rotation sd (largest axis)",
            Metric::PredictedSdTranslation => "predicted translation sd (largest axis)",
            Metric::Suspect => "share judged suspect",
            Metric::BoundRotation => "95 % bound on the rotation error",
            Metric::BoundTranslation => "95 % bound on the translation error",
            Metric::Imprecise => "share judged imprecise",
            Metric::Covered => "share of errors within their 95 % bounds",
            Metric::RotationErrorOk => "rotation error of the results judged ok",
            Metric::TranslationErrorOk => "translation error of the results judged ok",
        }
    }

    /// Unit for printing ("" when dimensionless).
    pub fn unit(self) -> &'static str {
        match self {
            Metric::RotationError
            | Metric::EdgeAngleDev
            | Metric::PredictedSdRotation
            | Metric::BoundRotation
            | Metric::RotationErrorOk => "deg",
            Metric::FrobeniusRotation
            | Metric::NoiseRatio
            | Metric::Suspect
            | Metric::Imprecise
            | Metric::Covered => "",
            _ => "mm",
        }
    }

    fn index(self) -> usize {
        self as usize
    }

    /// The metric a column name names.
    pub fn from_name(name: &str) -> Option<Metric> {
        Metric::ALL.into_iter().find(|m| m.name() == name)
    }
}

/// A value per metric (absent where the method does not report it).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Metrics([Option<f64>; 18]);

impl Metrics {
    pub fn get(&self, m: Metric) -> Option<f64> {
        self.0[m.index()]
    }

    pub fn set(&mut self, m: Metric, v: Option<f64>) {
        self.0[m.index()] = v;
    }

    /// With `m` set to `v`.
    pub fn with(mut self, m: Metric, v: Option<f64>) -> Metrics {
        self.set(m, v);
        self
    }

    /// The present values, in `Metric::ALL` order.
    pub fn present(&self) -> impl Iterator<Item = (Metric, f64)> + '_ {
        Metric::ALL
            .into_iter()
            .filter_map(|m| self.get(m).map(|v| (m, v)))
    }
}

/// The statistics of a summarised metric.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stat {
    Mean,
    Rms,
    Std,
    Median,
    P95,
}

impl Stat {
    pub const ALL: [Stat; 5] = [Stat::Mean, Stat::Rms, Stat::Std, Stat::Median, Stat::P95];

    pub fn name(self) -> &'static str {
        match self {
            Stat::Mean => "mean",
            Stat::Rms => "rms",
            Stat::Std => "std",
            Stat::Median => "median",
            Stat::P95 => "p95",
        }
    }
}

/// A summary column, `<metric>_<stat>` (e.g. `centre_error_mm_std`).
pub fn parse_column(column: &str) -> Option<(Metric, Stat)> {
    Metric::SUMMARISED.into_iter().find_map(|m| {
        let stat = column.strip_prefix(m.name())?.strip_prefix('_')?;
        Stat::ALL
            .into_iter()
            .find(|s| s.name() == stat)
            .map(|s| (m, s))
    })
}

/// A summary column's name, `<metric>_<stat>`.
pub fn column(m: Metric, s: Stat) -> String {
    format!("{}_{}", m.name(), s.name())
}

/// Every summary column name, in summary.csv's order.
pub fn summary_columns() -> impl Iterator<Item = String> {
    Metric::SUMMARISED
        .into_iter()
        .flat_map(|m| Stat::ALL.map(move |s| column(m, s)))
}
