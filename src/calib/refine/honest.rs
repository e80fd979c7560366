//! An honest covariance: one that holds the errors the sensor-noise model leaves out.
//!
//! The residual-level sandwich (`covariance_from`) treats every residual as independent. A robot's
//! pose error, a vibration or a specimen's form error moves all the points of one flange pose
//! together, so hundreds of points per pose do not average it away, and that covariance is too
//! small by about the square root of the points per pose. Clustering the sandwich's middle term by
//! flange pose (the infinitesimal jackknife over poses; geodesy's correlated-observation
//! adjustment) counts each pose's error once, whatever its cause, at the cost of one pass over J.
//! With few poses it is itself noisy, so the result is the larger of the two in every direction
//! (the clustered one's spread over directions first shrunk toward its mean, `shrunk_spread`),
//! and its quantiles use Student's t at the two estimates' effective degrees of freedom
//! (`effective_dof`).

use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Matrix6, SymmetricEigen};
use rustc_hash::FxHashMap;

/// The two-sided 95 % normal quantile.
const Z_975: f64 = 1.959_963_985;
/// The one-sided 95 % normal quantile (chi-square quantiles).
#[cfg(test)]
const Z_95: f64 = 1.644_853_627;
/// The normal quantile of sqrt(0.95) = 0.97468: each of the two norms' bounds at this level
/// holds both together in 95 % when the two errors are independent, and in at least 95 %
/// whatever their correlation (Royen's Gaussian correlation inequality); `joint_z` starts there.
const Z_JOINT: f64 = 1.954_508_327;

/// The honest covariance of the six transform parameters (rotation rad in the sensor frame,
/// translation m in the flange frame) and what its quantiles need.
#[derive(Debug, Clone, PartialEq)]
pub struct Honest {
    pub covariance: Matrix6<f64>,
    /// Distinct flange poses the residuals came from (0: not known, every residual alone).
    pub clusters: usize,
    /// Degrees of freedom of the quantiles: when clustered, the Satterthwaite combination of
    /// poses - 1 (pooled over the directions the shrinkage pools, with every direction
    /// measured) and residuals - parameters (`effective_dof`); else residuals - parameters.
    pub dof: usize,
    /// The transform's directions the scatter between poses was measured in (at most 6; 0:
    /// not clustered, or too few poses for the parameters); the rest take their mean widening.
    pub pose_directions: usize,
    /// How much the pose clustering widens the residual-level covariance in its most widened
    /// direction, as a factor on the standard deviation (1: the sensor noise explains the
    /// scatter between poses).
    pub inflation: f64,
    /// Orientation groups among the poses (`orientation_groups`; 0: none shared) and the
    /// factor on the sd their design effect widened the covariance by (1: not widened).
    pub orientation_groups: usize,
    pub group_widening: f64,
    /// Where the groups widened each direction by its own factor (all six seen): the map W
    /// with W C W^T the widened covariance for C the one they widened, so that another
    /// covariance of the same errors is widened alike (`unexplained`). None: every direction
    /// by `group_widening`.
    pub group_map: Option<Matrix6<f64>>,
    /// The residual-level covariance (`covariance` holds it and the clustered one).
    pub residual: Matrix6<f64>,
    /// The covariance a shift of each flange pose's points by its own independent error of unit
    /// standard deviation per axis (m) would give the transform: what a robot's stated accuracy
    /// predicts from the pose set's design, where too few poses cannot measure it.
    pub per_pose_shift: Matrix6<f64>,
    /// What `shift_scatter` needs where the leverage-corrected steps were taken (None: they
    /// were not), kept so that only a result weighed against a stated error pays for it.
    pub leverage: Option<std::sync::Arc<Leverage>>,
    /// The poses' leverage-corrected steps the clustered covariance came from (empty: it took
    /// none, `clustered`), kept to be weighed again against a stated error model.
    pub steps: Vec<nalgebra::Vector6<f64>>,
    /// The residual-level covariance's degrees of freedom (residuals - parameters).
    pub residual_dof: usize,
    /// How many poses carry the bound's leading directions (`carried_by`; the poses where not
    /// counted): the scatter's degrees of freedom when weighed again (`unexplained`).
    pub carrying: f64,
    /// The variance per axis (m^2) of each pose's own shift the bound states
    /// (`with_systematic`'s per-pose error; 0: none stated): what a closed form's response to
    /// the same shifts is weighed with (`bounds_around_moved`).
    pub per_pose_variance: f64,
}

/// The chi-square distribution's 99 % quantile at 2 degrees of freedom (-2 ln 0.01).
const CHI2_2_99: f64 = 9.210_340_372;

/// J^T J `a` and its inverse `inv` over the columns a fit used, and each pose's J_c^T J_c over
/// them (`grams`): what `Honest::shift_scatter` computes from.
#[derive(Debug, Clone, PartialEq)]
pub struct Leverage {
    pub a: DMatrix<f64>,
    pub inv: DMatrix<f64>,
    pub grams: Vec<DMatrix<f64>>,
}

/// The covariance of biases that move the transform by `shift` per unit of independent errors
/// of standard deviation `sd` each.
pub fn shifts_covariance(shifts: &[(nalgebra::Vector6<f64>, f64)]) -> Matrix6<f64> {
    shifts
        .iter()
        .map(|(d, sd)| d * d.transpose() * (sd * sd))
        .sum()
}

/// `m` (symmetric) with its negative eigenvalues set to zero: a difference of covariances whose
/// remainder is rounding or sampling noise where it dips below zero.
pub fn psd(m: &Matrix6<f64>) -> Matrix6<f64> {
    let e = SymmetricEigen::new(*m);
    e.eigenvectors
        * Matrix6::from_diagonal(&e.eigenvalues.map(|l| l.max(0.0)))
        * e.eigenvectors.transpose()
}

/// 95 % bounds on the transform's error: per axis and on the whole rotation and translation.
/// The two whole bounds are one 95 % statement: the rotation and the translation error lie
/// within them together in at least 95 % of calibrations (`ok` needs both within the
/// tolerance). Each alone at 95 % held both only 87-91 % where the two errors are nearly
/// independent (the full-profile fits over placements). The two events are symmetric convex
/// sets of one Gaussian vector, so the probability of both is at least the product of each
/// (Royen's Gaussian correlation inequality, 2014): sqrt(0.95) each would do for any pair,
/// exactly for independent errors but up to 97.5 % together where they move as one. Each is
/// taken at the level the two lengths' correlation sets (`joint_z`): 95 % together either way.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    pub rotation_deg: [f64; 3],
    pub translation_mm: [f64; 3],
    pub rotation_norm_deg: f64,
    pub translation_norm_mm: f64,
}

/// How the fit and a closed form near it move per unit of one error they share, with that
/// error's variance (`Honest::bounds_around_moved`): rotation rad in the sensor frame,
/// translation m, as the covariance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Moved {
    pub fit: nalgebra::Vector6<f64>,
    pub closed: nalgebra::Vector6<f64>,
    pub variance: f64,
}

impl Honest {
    /// No information: infinite covariance.
    pub fn unknown() -> Honest {
        Honest {
            covariance: Matrix6::from_element(f64::INFINITY),
            clusters: 0,
            dof: 0,
            pose_directions: 0,
            inflation: f64::NAN,
            orientation_groups: 0,
            group_widening: 1.0,
            group_map: None,
            residual: Matrix6::from_element(f64::INFINITY),
            per_pose_shift: Matrix6::zeros(),
            leverage: None,
            steps: Vec::new(),
            residual_dof: 0,
            carrying: 0.0,
            per_pose_variance: 0.0,
        }
    }

    /// From the inverse of J^T J over the columns the fit uses (`inv`; None: singular), the
    /// fit's sums (`super::Sums`: each cluster's score among them), those columns and the
    /// residual-level covariance `cov` (6x6).
    pub fn of(
        inv: Option<&DMatrix<f64>>,
        sums: &super::Sums,
        groups: &[u32],
        used: &[usize],
        cov: &Matrix6<f64>,
    ) -> Honest {
        let (n, p, g) = (sums.n, used.len(), sums.scores.nrows());
        let pj = sums.ata.nrows();
        // Each cluster's J_c^T J_c over the columns used, when kept.
        let grams: Vec<DMatrix<f64>> = if g > 0 && sums.grams.ncols() == pj * g {
            (0..g)
                .map(|c| DMatrix::from_fn(p, p, |r, k| sums.grams[(used[r], pj * c + used[k])]))
                .collect()
        } else {
            Vec::new()
        };
        let per_pose_shift = match (inv, grams.is_empty()) {
            (Some(inv), false) => {
                // sum_c S_c S_c^T, S_c the cluster's J_c^T J_c over the translation columns: a
                // shift d_c of pose c's points moves its residuals by J_c,t R^T d_c, and R drops
                // out of an isotropic shift's covariance.
                // By hand: a general product per pose of these few columns cost more to set
                // up than to do.
                let mut m = DMatrix::zeros(p, p);
                for gc in &grams {
                    let s = gc.columns(3, 3);
                    for c in 0..p {
                        for r in c..p {
                            let v = s[(r, 0)] * s[(c, 0)]
                                + s[(r, 1)] * s[(c, 1)]
                                + s[(r, 2)] * s[(c, 2)];
                            m[(r, c)] += v;
                        }
                    }
                }
                m.fill_upper_triangle_with_lower_triangle();
                let inv6 = inv.rows(0, 6);
                let full = inv6 * m * inv6.transpose();
                Matrix6::from_fn(|r, c| full[(r, c)])
            }
            _ => Matrix6::zeros(),
        };
        let alone = Honest {
            covariance: *cov,
            clusters: 0,
            dof: n.saturating_sub(p).max(1),
            pose_directions: 0,
            inflation: 1.0,
            orientation_groups: 0,
            group_widening: 1.0,
            group_map: None,
            residual: *cov,
            per_pose_shift,
            leverage: None,
            steps: Vec::new(),
            residual_dof: n.saturating_sub(p).max(1),
            carrying: g as f64,
            per_pose_variance: 0.0,
        };
        if g < 2 || n <= p || !cov.iter().all(|v| v.is_finite()) {
            return alone;
        }
        let Some(inv) = inv else {
            return alone;
        };
        let informative = pose_directions(g, p);
        let (clustered, pooled, steps) = clustered(inv, sums, &grams, used, cov, informative);
        // The scores of g poses span at most g - 1 directions, and the specimen's parameters
        // take p - 6 of them: with few poses (8 ball or plane poses) the clustered covariance
        // says nothing in the transform's remaining directions. There the residual-level one is
        // raised by the mean widening of the directions it does see (pose error is no smaller
        // where it cannot be measured).
        let (covariance, inflation, share) = larger_of(cov, &clustered, informative);
        // Student's t at g - 1 degrees of freedom treats the whole covariance as measured by the
        // poses' scatter alone; where the residual-level one holds it in part (no robot error:
        // the two estimate the same), that over-covered the independent generator's random rigs
        // (97.9-99.1 %). The degrees of freedom are the two estimates' Satterthwaite
        // combination. With fewer directions measured than six (8 ball or plane poses), every
        // direction rests on the clustered estimate wherever the measured ones' mean widening
        // exceeds 1 (g - 1, as before); where it does not (the scatter no larger than the noise
        // explains), the residual-level covariance holds and the t factor at g - 1 had
        // over-covered: the ball paper's protocols from the independent kit 98.6 % -> 95.7 %
        // (1,000 placements), the plane at 7 / 8 poses 97.8 / 98.6 -> 94.0 / 96.4 % (500
        // trials; docs/verdict.md).
        let mut carrying = g as f64;
        let dof = if informative == 6 {
            // The shrunk part pools its directions' degrees of freedom (`shrunk_spread`), each
            // one fewer than the poses that carry the bound's leading directions (`carried_by`;
            // g where the poses' grams are not kept).
            let carried =
                carried_by(inv, &grams, used, &covariance, cov, &clustered).unwrap_or(g as f64);
            carrying = carried;
            let dof_clustered = ((carried - 1.0).max(1.0) * pooled) as usize;
            effective_dof(share, dof_clustered.max(1), n - p)
        } else if informative > 0 {
            effective_dof(share, g - 1, n - p)
        } else {
            // No direction measured: the scatter's size is not known at all.
            g - 1
        };
        // Poses seen with one orientation may share an error the pose clustering counts as
        // independent: widened by the groups' design effect where they measure it.
        let widened = group_widening(inv, &sums.scores, groups, used, n, &covariance);
        let dof = match widened.measured {
            // The groups' scatter sets that share of the bound: it takes their degrees of
            // freedom, as the poses' share takes theirs.
            Some((share, big_g)) => effective_dof(share, big_g - 1, dof).min(dof),
            None => dof,
        };
        Honest {
            covariance: widened.covariance,
            clusters: g,
            dof,
            pose_directions: informative,
            inflation: inflation * widened.factor,
            orientation_groups: groups.iter().map(|&c| c as usize + 1).max().unwrap_or(0),
            group_widening: widened.factor,
            group_map: widened.map,
            residual: *cov,
            per_pose_shift,
            leverage: (!steps.is_empty()).then(|| {
                std::sync::Arc::new(Leverage {
                    a: sums.ata.select_rows(used).select_columns(used),
                    inv: inv.clone(),
                    grams,
                })
            }),
            steps,
            residual_dof: n - p,
            carrying,
            per_pose_variance: 0.0,
        }
    }

    /// The same with an error added that no residual shows: one common to every pose (a
    /// robot's absolute error over the small region a pose set spans moves every pose alike, so
    /// the fit takes it into the transform), of standard deviation `rotation` (rad) and
    /// `translation` (m) per axis.
    ///
    /// Where too few poses measure the scatter between them in every direction
    /// (`pose_directions` < 6), the same accuracy, independent from pose to pose, is also a
    /// floor: what it predicts through the pose set's design (`per_pose_shift`) with the
    /// residual-level covariance. With poses enough the scatter is measured, and the
    /// accuracy's floor (which takes a robot's smooth, pose-to-pose correlated error for an
    /// independent one) would only widen the bound. `own` (m, per axis) is an error each pose
    /// has alone (a repeatability): it joins the floor, not the common term, and stays in it
    /// with every direction measured, where one pose or two carry a direction the scatter
    /// cannot show. There the floor is the stated model and the scatter counts only where it
    /// shows more (`unexplained`, as `with_kinematic` weighs it); `noise_share` is the share of
    /// the residuals' variance the sensor's stated noise makes (at most 1; 1 where none is
    /// stated), for the pose errors move the residuals too and the residual-level covariance
    /// would count them a second time.
    pub fn with_systematic(
        &self,
        rotation: f64,
        translation: f64,
        own: f64,
        noise_share: f64,
    ) -> Honest {
        let mut c = self.covariance;
        let mut dof = self.dof;
        // With every direction measured, the repeatability alone: a direction one pose or two
        // carry takes their own error whole, and no scatter between poses shows it (the
        // independent kit's 16 free plane poses with 0.1 mm a pose stated: one result 1.6 mm
        // off, judged ok under the scatter's 0.47 mm bound; with the floor, imprecise).
        let per_pose = if self.pose_directions < 6 {
            translation * translation + own * own
        } else {
            own * own
        };
        let floor = self.residual + self.per_pose_shift * per_pose;
        let finite = floor.iter().all(|v| v.is_finite());
        // The stated model: the sensor's noise as stated and each pose's own error (the
        // residuals carry the pose errors too; counted twice, the floor alone covered 97.3 %
        // in `a_stated_repeatability_is_the_model_the_scatter_adds_to`).
        let share = if noise_share.is_finite() {
            noise_share.clamp(0.0, 1.0)
        } else {
            1.0
        };
        let stated = self.residual * share + self.per_pose_shift * per_pose;
        // What the stated model makes the poses' steps show, which is what they are weighed
        // against (against `stated` itself, the plane's steps read its pose errors as an excess
        // in every direction: 99.0 % covered where the model alone held 95.5 %).
        let weighed = (per_pose > 0.0 && finite && self.pose_directions == 6 && share > 0.0)
            .then(|| {
                let shown = self.residual * share + self.shift_scatter() * per_pose;
                self.unexplained(&self.steps, &[], &shown, self.carrying, None)
            })
            .flatten();
        if let Some(Unexplained {
            excess,
            dof: dof_excess,
            share: measured,
            ..
        }) = weighed
        {
            // The scatter shrunk toward the floor's shape, not the residuals': the larger of
            // the scatter's noisy estimate and the floor had widened every direction (the kit's
            // random rigs with the repeatability stated: 96.6-99.0 % of every answer covered;
            // weighed so, 96.1-96.7 % but the plane's 99.0, docs/verdict.md). Where the scatter
            // is the larger, the bound is the scatter's whole, with its degrees of freedom (its
            // excess over the floor is as uncertain as it): a repeatability half the truth,
            // 91.4 % covered with the excess's share alone, 92.2 % so (92.6 stating nothing).
            c = stated + excess;
            dof = effective_dof(measured, dof_excess, self.residual_dof);
        } else if per_pose > 0.0 && finite {
            c = larger_of(&c, &floor, 6).0;
            // The floor is a stated model, known as the residuals' covariance is: only the
            // share the poses' scatter sets beyond it takes their few degrees of freedom (the
            // t factor at 7 for 8 ball poses, 1.21 on the sd, had held 98.9 % with the floor
            // setting the bound).
            dof = effective_dof(share_of(&c, &(c - floor)), self.dof, self.residual_dof);
        }
        for i in 0..3 {
            c[(i, i)] += rotation * rotation;
            c[(3 + i, 3 + i)] += translation * translation;
        }
        Honest {
            covariance: c,
            dof,
            per_pose_variance: if finite { per_pose } else { 0.0 },
            ..self.clone()
        }
    }

    /// How an assumed arm error of stated size splits between its two kinds of error, read from
    /// the poses' steps: the share `t` of the error's variance in one kind (joint origins),
    /// the rest in the other (zeros), where `pattern` (per error, each pose's step at one sd,
    /// as `with_kinematic`'s) was drawn at the share `assumed` and `second[e]` marks the errors
    /// of the other kind. The steps (this fit's, or `at_fit` where it kept none) are whitened
    /// by what the independent part makes each show (`shift_scatter` at `own`, spread evenly
    /// over the poses), their scale read again from what no pattern can make; their part the
    /// patterns span is then Gaussian with covariance B D B^T + s^2 I, D each error's variance
    /// relative to the assumed (a t / assumed, a (1 - t) / (1 - assumed), a the size's share
    /// of the stated, integrated out). The likelihood on a grid, a weak prior at the assumed
    /// share: the posterior mean and sd of t. Since the bias covariance
    /// is linear in t, the one at the mean is the posterior mean covariance. None where there
    /// are too few steps or the steps do not show the patterns (chi-square 99 % over none).
    pub fn error_split(
        &self,
        pattern: &[Vec<nalgebra::Vector6<f64>>],
        second: &[bool],
        assumed: f64,
        at_fit: Option<&[nalgebra::Vector6<f64>]>,
        own: f64,
    ) -> Option<(f64, f64)> {
        let steps = match at_fit {
            Some(s) if self.steps.is_empty() => s,
            _ => self.steps.as_slice(),
        };
        let g = steps.len();
        let e = pattern.len();
        if g < 2 || e == 0 || second.len() != e || pattern.iter().any(|p| p.len() != g) {
            return None;
        }
        if !(assumed > 0.0 && assumed < 1.0) {
            return None;
        }
        let shown = (self.residual + self.shift_scatter() * (own * own)) / g as f64;
        let l = shown.cholesky()?.l();
        let white = |d: &nalgebra::Vector6<f64>| l.solve_lower_triangular(d);
        let mut y = DVector::zeros(6 * g);
        for (p, d) in steps.iter().enumerate() {
            y.rows_mut(6 * p, 6).copy_from(&white(d)?);
        }
        let mut b = DMatrix::zeros(6 * g, e);
        for (k, col) in pattern.iter().enumerate() {
            for (p, d) in col.iter().enumerate() {
                b.view_mut((6 * p, k), (6, 1)).copy_from(&white(d)?);
            }
        }
        if !(y.iter().chain(b.iter()).all(|v| v.is_finite())) {
            return None;
        }
        let svd = b.svd(true, true);
        let (u, vt) = (svd.u?, svd.v_t?);
        let top = svd.singular_values.max();
        if !(top > 0.0) {
            return None;
        }
        // The patterns' span to a relative tolerance, as `unexplained` takes it.
        let keep: Vec<usize> = (0..svd.singular_values.len())
            .filter(|&i| svd.singular_values[i] > 1e-6 * top)
            .collect();
        let k = keep.len();
        // The rest's dimensions: the steps' sum is fixed (a fit's scores sum to zero), so six
        // fewer.
        let rest = (6 * g).saturating_sub(k + 6);
        if k == 0 || rest < 6 {
            return None;
        }
        let z = u.select_columns(&keep).tr_mul(&y);
        let s2 = ((y.norm_squared() - z.norm_squared()).max(0.0) / rest as f64).max(1e-6);
        // M = S V^T over the kept directions: z = M a + noise, a each error's amount in sds.
        let m = DMatrix::from_fn(k, e, |r, c| svd.singular_values[keep[r]] * vt[(keep[r], c)]);
        // The arm's error may be smaller than the accuracy stated (a bound): its size is a
        // second unknown, `scale` its variance over the stated one, integrated out (flat in its
        // log). With the size fixed, steps that show no pattern made the kind whose patterns
        // are the smaller in the steps the likely one (10 % in the origins on a disk's four
        // scans without arm error); with it free they leave the share at its prior.
        const GRID: usize = 40;
        const SCALES: usize = 16;
        let log_likelihood = |t: f64, scale: f64| -> Option<f64> {
            let w = DVector::from_fn(e, |c, _| {
                scale
                    * if second[c] {
                        (1.0 - t) / (1.0 - assumed)
                    } else {
                        t / assumed
                    }
            });
            let mut c = &m * DMatrix::from_diagonal(&w) * m.transpose();
            for i in 0..k {
                c[(i, i)] += s2;
            }
            let ch = c.cholesky()?;
            let log_det: f64 = ch.l().diagonal().iter().map(|v| 2.0 * v.ln()).sum();
            let q = z.dot(&ch.solve(&z));
            Some(-0.5 * (log_det + q))
        };
        // A weak prior at the assumed share (a Beta of total weight 2: flat at one half), on
        // the cells' midpoints; scales from 1e-3 to 4 times the stated variance.
        let (pa, pb) = (2.0 * assumed, 2.0 * (1.0 - assumed));
        let mut cells = Vec::with_capacity(GRID * SCALES);
        for i in 0..GRID {
            let t = (i as f64 + 0.5) / GRID as f64;
            let prior = (pa - 1.0) * t.ln() + (pb - 1.0) * (1.0 - t).ln();
            for j in 0..SCALES {
                let scale = 1e-3 * 4e3f64.powf(j as f64 / (SCALES - 1) as f64);
                cells.push((t, prior + log_likelihood(t, scale)?));
            }
        }
        let best = cells.iter().map(|g| g.1).fold(f64::NEG_INFINITY, f64::max);
        // Only where the steps show the patterns: against none at all, the best cell must gain
        // the chi-square's 99 % at its two parameters (else both kinds are equally unseen, and
        // the kind of fewer errors merely costs the least to leave unseen).
        let none = log_likelihood(0.5, 0.0)?;
        if !(best - none > 0.5 * CHI2_2_99) {
            return None;
        }
        let weights: Vec<(f64, f64)> = cells.iter().map(|&(t, v)| (t, (v - best).exp())).collect();
        let total: f64 = weights.iter().map(|w| w.1).sum();
        let mean = weights.iter().map(|(t, w)| t * w).sum::<f64>() / total;
        let var = weights
            .iter()
            .map(|(t, w)| (t - mean).powi(2) * w)
            .sum::<f64>()
            / total;
        (mean.is_finite() && var.is_finite()).then(|| (mean, var.sqrt()))
    }

    /// `with_systematic` where the arm's kinematic error is stated: `shifts` holds each error's
    /// bias on the fit per unit and its standard deviation (`Refinable::pose_shift`),
    /// `pattern` the poses' steps each error makes at one sd (as `steps`; None: not known),
    /// `at_fit` the fit's own steps and each pose's orientation group where `of` kept no
    /// steps (beyond `MAX_JACKKNIFE` poses: `Clustering`'s CR1 steps, `PoseShift::steps_at_fit`),
    /// `rotation`, `translation` the accuracy beyond them and `own` each pose's own error
    /// (as `with_systematic`'s).
    ///
    /// `residual`: the residual-level covariance less the errors' misfit in the residuals
    /// (`Refinable::pose_shift`'s `residual_without`; None: the fit's own). The model's own
    /// covariance (that residual-level one, the kinematic biases, the rest of
    /// the accuracy independent from pose to pose) holds what it states. The scatter between
    /// poses counts only where it shows more than that: a kinematic error moves the poses in
    /// a smooth pattern, which the clustering reads as independent per-pose errors (a 48-pose
    /// plane's rotation bound 3.6 times its errors' RMS). So the poses' steps are first rid of
    /// every pattern the stated errors can make (`unexplained`), and what is left is weighed
    /// against the independent part. Where `pattern` is not known, the model's or the measured
    /// covariance, whichever is larger in each direction (adding the biases to the measured
    /// one counted the varying part twice), its quantile at the degrees of freedom of the share
    /// the measured one sets (the model is stated, as `with_systematic`'s floor).
    pub fn with_kinematic(
        &self,
        shifts: &[(nalgebra::Vector6<f64>, f64)],
        pattern: Option<&[Vec<nalgebra::Vector6<f64>>]>,
        at_fit: Option<(&[nalgebra::Vector6<f64>], &[u32])>,
        residual: Option<&Matrix6<f64>>,
        rotation: f64,
        translation: f64,
        own: f64,
    ) -> Honest {
        let kinematic = shifts_covariance(shifts);
        let per_pose = translation * translation + own * own;
        let finite = |m: &Matrix6<f64>| m.iter().all(|v| v.is_finite());
        // The residuals' level less the arm's misfit in them, which the biases carry whole.
        let residual = residual
            .filter(|m| finite(m))
            .copied()
            .unwrap_or(self.residual);
        let independent = residual + self.per_pose_shift * per_pose;
        let model = independent + kinematic;
        let (steps, groups) = match at_fit {
            Some((s, g)) if self.steps.is_empty() => (s, Some(g).filter(|g| !g.is_empty())),
            _ => (self.steps.as_slice(), None),
        };
        let weighed = pattern.filter(|_| finite(&model)).and_then(|p| {
            // The steps are weighed against what the independent part makes them show, as in
            // `with_systematic`.
            let shown = residual + self.shift_scatter() * per_pose;
            self.unexplained(steps, p, &shown, steps.len() as f64, groups)
        });
        // What the scatter widened: beyond the model where it is weighed against it (the arm's
        // patterns are the model's, not scatter), the fit's own figures otherwise.
        let mut widened = (self.inflation, self.group_widening);
        let (mut c, dof) = match weighed {
            Some(u) => {
                let c = model + u.excess;
                if let Some((_, e)) = whitened(&model, &c) {
                    widened = (e.eigenvalues.max().max(1.0).sqrt(), u.group_widening);
                }
                // The share of the bound the scatter sets (its degrees of freedom).
                (
                    c,
                    effective_dof(share_of(&c, &u.excess), u.dof, self.residual_dof),
                )
            }
            None if finite(&model) => {
                let c = larger_of(&self.covariance, &model, 6).0;
                (
                    c,
                    effective_dof(share_of(&c, &(c - model)), self.dof, self.residual_dof),
                )
            }
            None => (self.covariance + kinematic, self.dof),
        };
        for i in 0..3 {
            c[(i, i)] += rotation * rotation;
            c[(3 + i, 3 + i)] += translation * translation;
        }
        Honest {
            covariance: c,
            dof,
            inflation: widened.0,
            group_widening: widened.1,
            ..self.clone()
        }
    }

    /// What the poses' steps show beyond the stated errors: the steps less their least-squares
    /// fit by the errors' patterns (`pattern`: per error, each pose's step at one sd; the
    /// fitted amounts are whatever this arm's errors are, so no draw of them is mistaken for
    /// scatter), scaled for the dimensions the fit took, shrunk toward the `independent`
    /// covariance's shape (`shrunk_spread`), raised to at least it in every direction
    /// (`larger_of`), less it; widened by the orientation groups' design effect as `of`
    /// widens. With that estimate's degrees of freedom and the share of the raised covariance
    /// the scatter sets whole (`larger_of`'s: where it is the larger, the bound rests on it,
    /// not on its excess alone). No patterns: the steps as they are. None where the patterns
    /// do not match the steps (another clustering).
    fn unexplained(
        &self,
        steps: &[nalgebra::Vector6<f64>],
        pattern: &[Vec<nalgebra::Vector6<f64>>],
        independent: &Matrix6<f64>,
        poses: f64,
        groups: Option<&[u32]>,
    ) -> Option<Unexplained> {
        let g = steps.len();
        if g < 2 || pattern.iter().any(|p| p.len() != g) {
            return None;
        }
        // The fit in the steps whitened by the independent covariance: the steps mix radians
        // and metres, and a projection that is least squares in their raw numbers moves the
        // small ones by what it fits to the large ones (with the arm stated and none drawn, the
        // edge paper's 25 groups' scatter reached 1.3-3.6 times the independent covariance in
        // its largest direction after the raw fit, 1.2-1.8 before it, and the groups widened
        // the refined fit's bound 1.55 times: docs/verdict.md, "Fifty-fifth session").
        let l = independent.cholesky().map(|c| c.l());
        let whiten = |v: &nalgebra::Vector6<f64>| match &l {
            Some(l) => l.solve_lower_triangular(v).unwrap_or(*v),
            None => *v,
        };
        let white: Vec<nalgebra::Vector6<f64>> = steps.iter().map(whiten).collect();
        let y = DVector::from_fn(6 * g, |r, _| white[r / 6][r % 6]);
        let (left, k) = if pattern.is_empty() {
            (y, 0)
        } else {
            let white: Vec<Vec<nalgebra::Vector6<f64>>> = pattern
                .iter()
                .map(|p| p.iter().map(whiten).collect())
                .collect();
            let b = DMatrix::from_fn(6 * g, pattern.len(), |r, e| white[e][r / 6][r % 6]);
            // The patterns' span, to a relative tolerance: errors that move no pose's step
            // (taken whole into the transform) or move it as another does add no dimension.
            let svd = b.svd(true, false);
            let u = svd.u?;
            let top = svd.singular_values.max();
            let keep: Vec<usize> = (0..svd.singular_values.len())
                .filter(|&i| svd.singular_values[i] > 1e-9 * top)
                .collect();
            let basis = u.select_columns(&keep);
            (&y - &basis * (basis.tr_mul(&y)), keep.len())
        };
        if 6 * g <= k + 6 {
            return None;
        }
        // The fit took k of the 6g dimensions: the rest's sum of squares is short by that.
        let scale = ((6 * g) as f64 / (6 * g - k) as f64).sqrt();
        let steps: Vec<nalgebra::Vector6<f64>> = (0..g)
            .map(|c| {
                let w = nalgebra::Vector6::from_fn(|i, _| left[6 * c + i] * scale);
                l.as_ref().map_or(w, |l| l * w)
            })
            .collect();
        let (measured, pooled) = shrunk_spread(independent, &steps);
        let (raised, _, share) = larger_of(independent, &measured, 6);
        let dof =
            (((poses.min(g as f64) - 1.0).max(1.0) * pooled - k as f64 / 6.0) as usize).max(1);
        let by_groups = groups.filter(|l| l.len() == g).and_then(|labels| {
            // The groups' design effect from these steps, the patterns' share taken out: the
            // one `of` measured from the scores holds the patterns too, which are smooth in the
            // pose and so shared by a group's poses. Every pose's error, the stated part too,
            // is widened by it (a vibration shared by neighbouring poses: the edge protocol
            // with every cause stated covered 85 % with the pose-level excess alone widened).
            let big_g = labels.iter().map(|&c| c as usize + 1).max()?;
            let mut summed = vec![nalgebra::Vector6::zeros(); big_g];
            for (s, &c) in steps.iter().zip(labels) {
                summed[c as usize] += s;
            }
            let between: Matrix6<f64> = summed
                .iter()
                .map(|s| s * s.transpose())
                .sum::<Matrix6<f64>>()
                * (big_g as f64 / (big_g - 1) as f64);
            let (w, factor) = design_map(&raised, &between, big_g)?;
            let dof_g = (((big_g - 1) as f64 - k as f64 / 6.0) as usize).max(1);
            Some((
                w * raised * w.transpose() - independent,
                dof.min(dof_g),
                factor,
            ))
        });
        // Widened as the groups widened the pose-level covariance, direction by direction (not
        // every direction by the most widened one's factor).
        let (excess, dof, by) = match (by_groups, &self.group_map) {
            (Some(e), _) => e,
            (None, Some(w)) => (
                w * (raised - independent) * w.transpose(),
                dof,
                self.group_widening,
            ),
            (None, None) => (
                (raised - independent) * (self.group_widening * self.group_widening),
                dof,
                self.group_widening,
            ),
        };
        excess.iter().all(|v| v.is_finite()).then_some(Unexplained {
            excess,
            dof,
            share,
            group_widening: by,
        })
    }

    /// What each pose's points shifted by its own independent error of unit sd per axis make
    /// the poses' leverage-corrected steps show (their expected sum of squares, the free
    /// function `shift_scatter`; `per_pose_shift` where the steps are not taken). The steps read
    /// a pose error through each pose's leverage, not as the fit takes it: on the independent
    /// kit's 16 free plane poses they show it several times over in the directions one or two
    /// poses carry, so a stated error is weighed against this.
    pub fn shift_scatter(&self) -> Matrix6<f64> {
        self.leverage
            .as_ref()
            .and_then(|l| shift_scatter(&l.a, &l.inv, &l.grams))
            .unwrap_or(self.per_pose_shift)
    }

    /// The same with a bias added that moves the transform by `shift` per unit of an error of
    /// standard deviation `sd` (a specimen's radius against its stated one).
    pub fn with_shift(&self, shift: &nalgebra::Vector6<f64>, sd: f64) -> Honest {
        Honest {
            covariance: self.covariance + shift * shift.transpose() * (sd * sd),
            ..self.clone()
        }
    }

    /// The whole bounds (deg, mm; jointly 95 %, as `Bounds`' norms) on the error of a result
    /// `offset` (rad, m, as the covariance) from the fit this covariance is the fit's: a closed
    /// form one Gauss-Newton step from the least-squares fit of its own features. The fit is
    /// efficient under the model, so its error is uncorrelated with any consistent estimator's
    /// distance from it (Hausman 1978, lemma 2.1): the result's error is the fixed offset plus
    /// the fit's error, bounded by the quantile of that sum's length. Adding the offset's
    /// length to the fit's bound instead (the triangle inequality) held 97.7 % of the disk
    /// paper's Fig. 15 and 99.9 % of Fig. 17 results.
    pub fn bounds_around(&self, offset: &nalgebra::Vector6<f64>) -> (f64, f64) {
        self.bounds_of(&self.covariance, offset)
    }

    /// `bounds_around` for a closed form whose error shares errors with the fit's: each of
    /// `moves` is how the fit and the closed form move per unit of one error (a pose's own
    /// stated shift along one axis, `per_pose_variance`; an arm's kinematic error, through
    /// every pose) with that error's variance. Under such errors the fit is not efficient (it
    /// weighs a pose by its points, the error comes a pose or a pattern at a time), its error
    /// and its distance from the closed form correlate, and Hausman's lemma fails: on the
    /// independent kit's ball protocol with 0.3 mm a pose the closed form was as precise as the
    /// fit, its distance from it as large as the fit's error and correlated -0.5 with it, and
    /// `bounds_around` held 100 % (docs/verdict.md, "Forty-ninth session"). With the offset d
    /// (closed form less fit) known, the fit's error is Gaussian with mean K V^+ d and
    /// covariance C - K V^+ K^T, K = sum s^2 F (G - F)^T and V = sum s^2 (G - F)(G - F)^T the
    /// errors' parts of Cov(fit error, d) and Var(d), `noise` the sensor noise's part of Var(d)
    /// (Var(closed form) less Var(fit) under it); the result's error is d plus it.
    pub fn bounds_around_moved(
        &self,
        offset: &nalgebra::Vector6<f64>,
        moves: &[Moved],
        noise: &Matrix6<f64>,
    ) -> (f64, f64) {
        let (mut k, mut v) = (Matrix6::zeros(), Matrix6::zeros());
        for m in moves.iter().filter(|m| m.variance > 0.0) {
            let w = m.closed - m.fit;
            k += m.fit * w.transpose() * m.variance;
            v += w * w.transpose() * m.variance;
        }
        // The sensor noise moves the offset too, uncorrelated with the fit's error (the fit is
        // efficient under it: Hausman's lemma): in V, not in K. Left out, a direction the shifts
        // barely move read the noise as a shift (the kit's ball protocol 93.5 % covered,
        // docs/verdict.md).
        let v = v + noise;
        // V's pseudo-inverse: a direction where the closed form moves as the fit does (G = F)
        // carries no offset to read.
        let top = v.norm();
        if !(top > 0.0 && top.is_finite() && k.iter().all(|x| x.is_finite())) {
            return self.bounds_around(offset);
        }
        let Ok(v_plus) = v.pseudo_inverse(1e-9 * top) else {
            return self.bounds_around(offset);
        };
        let b = k * v_plus;
        let d = -offset;
        let mean = d + b * d;
        let read = b * k.transpose();
        let c = self.covariance - (read + read.transpose()) * 0.5;
        // What the offset explains is at most the errors' part of C (Cauchy-Schwarz), and C
        // holds it where they are stated: a negative remainder is rounding.
        self.bounds_of(&psd(&c), &mean)
    }

    /// The whole bounds (deg, mm) on an error of mean `mean` and covariance `cov` (the t factor
    /// at this bound's degrees of freedom on it).
    fn bounds_of(&self, cov: &Matrix6<f64>, mean: &nalgebra::Vector6<f64>) -> (f64, f64) {
        let t = student_t_975(self.dof) / Z_975;
        let c = cov * (t * t);
        let z = joint_z(&c, mean);
        let rot: Matrix3<f64> = c.fixed_view::<3, 3>(0, 0).into_owned();
        let tra: Matrix3<f64> = c.fixed_view::<3, 3>(3, 3).into_owned();
        (
            offset_norm_quantile(&rot, &mean.fixed_rows::<3>(0).into_owned(), z).to_degrees(),
            offset_norm_quantile(&tra, &mean.fixed_rows::<3>(3).into_owned(), z) * 1e3,
        )
    }

    /// 95 % bounds on the error (deg, mm).
    pub fn bounds(&self) -> Bounds {
        let t = student_t_975(self.dof) / Z_975;
        let sd = |i: usize| self.covariance[(i, i)].max(0.0).sqrt();
        let rot: Matrix3<f64> = self.covariance.fixed_view::<3, 3>(0, 0).into_owned();
        let tra: Matrix3<f64> = self.covariance.fixed_view::<3, 3>(3, 3).into_owned();
        let z = joint_z(&self.covariance, &nalgebra::Vector6::zeros());
        Bounds {
            rotation_deg: std::array::from_fn(|i| (Z_975 * t * sd(i)).to_degrees()),
            translation_mm: std::array::from_fn(|i| Z_975 * t * sd(3 + i) * 1e3),
            rotation_norm_deg: (t * norm_quantile(&rot, z)).to_degrees(),
            translation_norm_mm: t * norm_quantile(&tra, z) * 1e3,
        }
    }
}

/// The pose-clustered covariance of the transform (6 x 6) and the factor on its degrees of
/// freedom that pooling its directions toward their mean gives (`shrunk_spread`; 1 where not
/// shrunk). With every direction measured and each pose's gram kept, the poses'
/// leverage-corrected steps (CR2), shrunk; else the CR1 sandwich. With fewer poses than
/// directions to see, some direction rests on one pose (leverage near 1) and the correction
/// blows up: the few-pose widening in `larger_of` holds those sets.
fn clustered(
    inv: &DMatrix<f64>,
    sums: &super::Sums,
    grams: &[DMatrix<f64>],
    used: &[usize],
    cov: &Matrix6<f64>,
    informative: usize,
) -> (Matrix6<f64>, f64, Vec<nalgebra::Vector6<f64>>) {
    let (n, p, g) = (sums.n, used.len(), sums.scores.nrows());
    let adjusted = (informative == 6 && !grams.is_empty())
        .then(|| {
            leverage_adjusted(
                &sums.ata.select_rows(used).select_columns(used),
                inv,
                grams,
                &sums.scores.select_columns(used),
            )
        })
        .flatten();
    match adjusted {
        Some(steps) => {
            let (c, pooled) = shrunk_spread(cov, &steps);
            (c, pooled, steps)
        }
        None => {
            // The small-sample factor of the clustered sandwich (CR1).
            let factor = (g as f64 / (g - 1) as f64) * ((n - 1) as f64 / (n - p) as f64);
            (
                scores_spread(inv, &sums.scores, used) * factor,
                1.0,
                Vec::new(),
            )
        }
    }
}

/// Each cluster's score J_c^T r_c over every column of J, one row per cluster (`g` x p): summed
/// over runs of one cluster (a pose's residuals are consecutive as a rule), each run in row
/// order. No clusters (`clusters` not one per residual): 0 x p.
pub fn scores(r: &DVector<f64>, j: &DMatrix<f64>, clusters: &[u32], g: usize) -> DMatrix<f64> {
    let (n, p) = (r.len(), j.ncols());
    if clusters.len() != n || n == 0 {
        return DMatrix::zeros(0, p);
    }
    let runs = runs(clusters);
    let mut sums = vec![0.0; p * g];
    let rs = r.as_slice();
    for k in 0..p {
        let col = &j.as_slice()[k * n..(k + 1) * n];
        for &(a, b, cl) in &runs {
            // A short run (a chord end's rows) in row order, here rather than in a call per run
            // (the same bits as `dot`, which sums fewer than eight rows so); a long one (an
            // arc's points) with `dot`'s eight partial sums.
            let (x, y) = (&col[a..b], &rs[a..b]);
            sums[k * g + cl] += if x.len() < 8 {
                x.iter().zip(y).fold(0.0, |s, (x, y)| s + x * y)
            } else {
                super::dot(x, y)
            };
        }
    }
    DMatrix::from_vec(g, p, sums)
}

/// How many poses carry the leading direction l of the rotation's and of the translation's
/// block of `c` (the fewer of the two), as the scatter between poses measures it: Kish's
/// effective number (sum w)^2 / sum w^2 of the poses' step variances there. A pose's leverage
/// along l is h_c = l^T A^-1 A_c A^-1 l / l^T A^-1 l (summing to 1); the noise gives its step
/// a variance in proportion to h_c, a pose's own error (which enters the fit like a change of
/// the parameters that pose alone sees) one in proportion to h_c^2, so w_c = h_c + kappa h_c^2,
/// kappa from the `clustered` covariance's excess over the `residual` one along l. A direction
/// that a few poses carry is measured by about that many steps, not by every pose: on the
/// independent kit's random rigs (16 free poses, each turned by up to 0.017 deg; the leading
/// directions carried by 4 poses at the median, 2.4 at the tenth percentile) the bound at
/// g - 1 degrees of freedom times the pooling (about 50) held 83-91 % of the errors, and at
/// these 92-94 % (docs/verdict.md). None where the grams are not kept or the transform's
/// columns are not the first six used.
fn carried_by(
    inv: &DMatrix<f64>,
    grams: &[DMatrix<f64>],
    used: &[usize],
    c: &Matrix6<f64>,
    residual: &Matrix6<f64>,
    clustered: &Matrix6<f64>,
) -> Option<f64> {
    if grams.is_empty() || used.len() < 6 || used[..6] != [0, 1, 2, 3, 4, 5] {
        return None;
    }
    let p = inv.nrows();
    let mut fewest = f64::INFINITY;
    for block in [0, 3] {
        let e = SymmetricEigen::new(c.fixed_view::<3, 3>(block, block).into_owned());
        let k = e.eigenvalues.imax();
        let l = DVector::from_fn(p, |i, _| match i.checked_sub(block) {
            Some(a) if a < 3 => e.eigenvectors[(a, k)],
            _ => 0.0,
        });
        let al = inv * &l;
        let total = l.dot(&al);
        let h: Vec<f64> = grams
            .iter()
            .map(|a| (al.dot(&(a * &al)) / total).max(0.0))
            .collect();
        let l6 = l.fixed_rows::<6>(0).into_owned();
        let ratio = l6.dot(&(clustered * l6)) / l6.dot(&(residual * l6));
        let h2: f64 = h.iter().map(|x| x * x).sum();
        // A step's variance along l: the noise's h_c plus the pose error's kappa h_c^2, kappa
        // from how far the scatter exceeds the noise there (the scatter's variance is the
        // noise's times 1 + kappa sum h_c^2).
        let kappa = if ratio.is_finite() && h2 > 0.0 {
            (ratio - 1.0).max(0.0) / h2
        } else {
            0.0
        };
        let w: Vec<f64> = h.iter().map(|x| x + kappa * x * x).collect();
        let (s1, s2) = (w.iter().sum::<f64>(), w.iter().map(|x| x * x).sum::<f64>());
        if s2 > 0.0 && s1.is_finite() {
            fewest = fewest.min(s1 * s1 / s2);
        }
    }
    fewest.is_finite().then_some(fewest)
}

/// The transform's directions the scatter between `g` poses measures when the fit has `p`
/// parameters: their scores span g - 1 directions, the specimen's parameters take p - 6.
pub fn pose_directions(g: usize, p: usize) -> usize {
    g.saturating_sub(1)
        .saturating_sub(p.saturating_sub(6))
        .min(6)
}

/// Up to this many clusters, each one's J_c^T J_c is kept: the clustered covariance is then the
/// jackknife's (CR3), and few-pose sets get their design floor. Beyond, the CR1 small-sample
/// factor is enough (the two differ by about p / g) and a pose's gram per profile would cost
/// as much as the verdict.
pub const MAX_JACKKNIFE: usize = 64;

/// Each cluster's J_c^T J_c (p x p `g`, cluster c in columns pc..pc+p), by runs as `scores`.
/// No clusters, or more than `MAX_JACKKNIFE`: p x 0.
pub fn grams(j: &DMatrix<f64>, clusters: &[u32], g: usize) -> DMatrix<f64> {
    if g > MAX_JACKKNIFE {
        return DMatrix::zeros(j.ncols(), 0);
    }
    grams_of(j, clusters, g)
}

/// `grams` however many clusters.
pub(crate) fn grams_of(j: &DMatrix<f64>, clusters: &[u32], g: usize) -> DMatrix<f64> {
    let (n, p) = (j.nrows(), j.ncols());
    if clusters.len() != n || n == 0 {
        return DMatrix::zeros(p, 0);
    }
    let runs = runs(clusters);
    let mut sums = vec![0.0; p * p * g];
    let col = |k: usize| &j.as_slice()[k * n..(k + 1) * n];
    for k in 0..p {
        for l in k..p {
            let (a_col, b_col) = (col(k), col(l));
            for &(a, b, cl) in &runs {
                let v = super::dot(&a_col[a..b], &b_col[a..b]);
                sums[(p * cl + l) * p + k] += v;
                if l != k {
                    sums[(p * cl + k) * p + l] += v;
                }
            }
        }
    }
    DMatrix::from_vec(p, p * g, sums)
}

/// The clustered sandwich with each pose's score corrected for its leverage (CR2, Bell and
/// McCaffrey): a fit pulls towards each pose, so that pose's residuals understate its error by
/// (I - H_c) where H_c is its share of the fit. In the parameters' space, with
/// M_c = A^-1/2 A_c A^-1/2 (eigenvalues: the pose's leverage along each direction), the score
/// becomes A^1/2 (I - M_c)^-1/2 A^-1/2 s_c. Plain CR1 covered 91 % of the errors of the
/// independent generator's edge and disk from 16 poses (one pose often carries a direction);
/// the jackknife's (I - M_c)^-1 (CR3) over-covered (97-99 %). None without the clusters' grams,
/// or when one pose alone carries a direction (leverage 1).
///
/// A pose's gram A_c = F^T F has the rank of its rows (a chord's four), so with B = A^-1/2 F^T
/// the step A^-1/2 (I - B B^T)^-1/2 A^-1/2 s_c is A^-1 (s_c + F^T f(X) F A^-1 s_c), f(x) =
/// ((1 - x)^-1/2 - 1) / x of X = F A^-1 F^T (k x k, the same leverages): no p x p
/// decomposition per pose. F comes from `low_rank_factor`; A^-1 is the fit's (`inv`). Returns
/// the transform's 6 x 6 block, the only one the verdict reads.
fn leverage_adjusted(
    a: &DMatrix<f64>,
    inv: &DMatrix<f64>,
    grams: &[DMatrix<f64>],
    scores: &DMatrix<f64>,
) -> Option<Vec<nalgebra::Vector6<f64>>> {
    let g = grams.len();
    if g < 2 || scores.nrows() != g || a.clone().cholesky().is_none() {
        return None;
    }
    let p = a.nrows();
    let scale: Vec<f64> = (0..p).map(|i| a[(i, i)].sqrt()).collect();
    // Only the transform's block is wanted: each step through A^-1's first six rows.
    let inv6 = inv.rows(0, 6);
    let mut steps = Vec::with_capacity(g);
    for (c, gc) in grams.iter().enumerate() {
        let f = low_rank_factor(gc, &scale);
        let s: DVector<f64> = scores.row(c).transpose();
        // A pose whose rows say nothing has no leverage to correct for.
        let corrected = if f.nrows() == 0 {
            s
        } else {
            let fa = &f * inv;
            let fx = widened(&(&fa * f.transpose()))?;
            &s + f.transpose() * (fx * (&fa * &s))
        };
        let step: nalgebra::Vector6<f64> = (inv6 * corrected).fixed_rows::<6>(0).into_owned();
        if !step.iter().all(|x| x.is_finite()) {
            return None;
        }
        steps.push(step);
    }
    Some(steps)
}

/// Each pose's map from its score (over the columns used) to its leverage-corrected step
/// (`leverage_adjusted`), 6 x p: A^-1 (I + F^T f(X) F A^-1) over the transform's rows. The
/// correction is linear in the score, so one map serves every residual vector of the fit
/// (the arm's kinematic errors in `Clustering`). None as `leverage_adjusted`, which keeps its
/// own products: the map's grouping of them rounds the last bits otherwise, and a fit's
/// figures stay what they were.
pub fn leverage_maps(
    a: &DMatrix<f64>,
    inv: &DMatrix<f64>,
    grams: &[DMatrix<f64>],
) -> Option<Vec<DMatrix<f64>>> {
    let g = grams.len();
    if g < 2 || a.clone().cholesky().is_none() {
        return None;
    }
    let p = a.nrows();
    let scale: Vec<f64> = (0..p).map(|i| a[(i, i)].sqrt()).collect();
    // Only the transform's block is wanted: each step through A^-1's first six rows.
    let inv6 = inv.rows(0, 6).into_owned();
    grams
        .iter()
        .map(|gc| {
            let f = low_rank_factor(gc, &scale);
            // A pose whose rows say nothing has no leverage to correct for.
            if f.nrows() == 0 {
                return Some(inv6.clone());
            }
            let fa = &f * inv;
            let fx = widened(&(&fa * f.transpose()))?;
            Some(&inv6 + (&inv6 * f.transpose()) * (fx * fa))
        })
        .collect()
}

/// The expected sum over poses of d_c d_c^T, the leverage-corrected steps (`leverage_maps`)
/// that each pose's points shifted by its own independent error of unit sd per axis make,
/// refitted: the error's score u_c = S_c R_c^T e_c (S_c the pose's gram over the translation
/// columns; R drops out of an isotropic shift) has covariance V_c = S_c S_c^T, and at the fit
/// a pose's score is s_c = u_c - A_c A^-1 sum_d u_d, so
/// Cov(s_c) = (I - A_c A^-1) V_c (I - A_c A^-1)^T + A_c A^-1 (sum_{d != c} V_d) A^-1 A_c.
/// With many poses each of small leverage this is `per_pose_shift`'s A^-1 (sum V_c) A^-1;
/// where one pose or two carry a direction, CR2's correction (exact for noise independent
/// from row to row) reads the other poses' errors that leak into that pose's residuals
/// through its (1 - h)^-1. `a` is J^T J and `inv` its inverse over the columns used, `grams`
/// each pose's J_c^T J_c over them; the transform's columns first. None as `leverage_maps`.
fn shift_scatter(
    a: &DMatrix<f64>,
    inv: &DMatrix<f64>,
    grams: &[DMatrix<f64>],
) -> Option<Matrix6<f64>> {
    let p = a.nrows();
    if p < 6 {
        return None;
    }
    let maps = leverage_maps(a, inv, grams)?;
    let total: DMatrix<f64> = grams
        .iter()
        .map(|gc| {
            let s = gc.columns(3, 3);
            &s * s.transpose()
        })
        .fold(DMatrix::zeros(p, p), |t, v| t + v);
    let mut e = DMatrix::<f64>::zeros(6, 6);
    for (gc, m) in grams.iter().zip(&maps) {
        let s = gc.columns(3, 3);
        // M_c A_c A^-1 and M_c (I - A_c A^-1) S_c.
        let mp = m * (gc * inv);
        let q = m * s - &mp * s;
        let others = &total - &s * s.transpose();
        e += &q * q.transpose() + &mp * others * mp.transpose();
    }
    let e = Matrix6::from_fn(|r, c| 0.5 * (e[(r, c)] + e[(c, r)]));
    e.iter().all(|v| v.is_finite()).then_some(e)
}

/// The steps `maps` give the clusters' scores (`scores`: a row per cluster, over the columns
/// used); None where one is not finite.
fn steps_of(maps: &[DMatrix<f64>], scores: &DMatrix<f64>) -> Option<Vec<nalgebra::Vector6<f64>>> {
    maps.iter()
        .enumerate()
        .map(|(c, m)| {
            let step = m * scores.row(c).transpose();
            let step = nalgebra::Vector6::from_fn(|i, _| step[i]);
            step.iter().all(|x| x.is_finite()).then_some(step)
        })
        .collect()
}

/// What the pose clustering (`Honest::of`'s leverage-corrected steps, before their shrinkage)
/// would measure from a given change of the fit's residuals, refitted: for an error the
/// residuals do not model (an arm's kinematic error), the scatter between poses its pattern
/// makes, so that `Honest::with_kinematic` can tell it from scatter the stated errors do not
/// explain. Only where every direction is measured. Beyond `MAX_JACKKNIFE` poses, where
/// `Honest::of` takes the CR1 sandwich, the steps are its: A^-1 s_c times the square root of
/// its small-sample factor, whose squares sum to it (`corrected` false); `Honest::of` keeps
/// none of them there, so the fit's own are asked for too (`PoseShift::steps_at_fit`).
pub struct Clustering {
    clusters: Vec<u32>,
    /// Each cluster's gram over the used columns.
    grams: Vec<DMatrix<f64>>,
    maps: Vec<DMatrix<f64>>,
    used: Vec<usize>,
    /// The maps correct each pose's leverage (CR2; at most `MAX_JACKKNIFE` poses).
    pub corrected: bool,
}

impl Clustering {
    /// For the rows `j` (each in its cluster, `clusters`), their J^T J `a` over every column,
    /// its inverse `inv` over the columns `used`. None where the clustering takes no steps.
    pub fn of(
        j: &DMatrix<f64>,
        clusters: Vec<u32>,
        a: &DMatrix<f64>,
        inv: &DMatrix<f64>,
        used: &[usize],
    ) -> Option<Clustering> {
        let g = clusters.iter().map(|&c| c as usize + 1).max()?;
        let (n, p, pj) = (j.nrows(), used.len(), j.ncols());
        if p < 6 || pose_directions(g, p) < 6 || n <= p {
            return None;
        }
        let all = grams_of(j, &clusters, g);
        if all.ncols() != pj * g {
            return None;
        }
        let grams: Vec<DMatrix<f64>> = (0..g)
            .map(|c| DMatrix::from_fn(p, p, |r, k| all[(used[r], pj * c + used[k])]))
            .collect();
        let corrected = g <= MAX_JACKKNIFE;
        let maps = if corrected {
            leverage_maps(&a.select_rows(used).select_columns(used), inv, &grams)?
        } else {
            // `clustered`'s CR1 factor, on each step's square root.
            let factor = (g as f64 / (g - 1) as f64) * ((n - 1) as f64 / (n - p) as f64);
            vec![inv.rows(0, 6) * factor.sqrt(); g]
        };
        Some(Clustering {
            clusters,
            grams,
            maps,
            used: used.to_vec(),
            corrected,
        })
    }

    /// Each pose's step d_c that a residual change `dr` makes once the fit has taken its step
    /// `d` (over the used columns) for it: from each pose's score J_c^T dr_c + A_c d.
    pub fn steps(
        &self,
        j: &DMatrix<f64>,
        dr: &DVector<f64>,
        d: &DVector<f64>,
    ) -> Option<Vec<nalgebra::Vector6<f64>>> {
        let g = self.grams.len();
        let s = scores(dr, j, &self.clusters, g);
        if s.nrows() != g {
            return None;
        }
        self.steps_from(&s.select_columns(&self.used), d)
    }

    /// `steps` from each pose's score over the used columns (clusters x used), summed by the
    /// caller.
    pub fn steps_from(
        &self,
        scores: &DMatrix<f64>,
        d: &DVector<f64>,
    ) -> Option<Vec<nalgebra::Vector6<f64>>> {
        let (g, p) = (self.grams.len(), self.used.len());
        if scores.shape() != (g, p) {
            return None;
        }
        let moved = DMatrix::from_fn(g, p, |c, k| {
            scores[(c, k)] + self.grams[c].row(k).dot(&d.transpose())
        });
        steps_of(&self.maps, &moved)
    }

    /// The number of clusters.
    pub fn len(&self) -> usize {
        self.grams.len()
    }
}

/// The clustered covariance sum_c d_c d_c^T of the poses' leverage-corrected steps `steps`,
/// its spread about the residual-level covariance `cov` shrunk as Ledoit and Wolf (2004) shrink
/// a sample covariance: in `cov`'s whitened frame, toward its mean eigenvalue, by the share of
/// its dispersion the draws' own scatter explains. With g poses the eigenvalues of a 6 x 6
/// estimate spread by about (1 +- sqrt(6/g))^2 from noise alone, and `larger_of` raises every
/// direction to the larger: without robot error the bounds on the independent generator's
/// random rigs (16 poses) came out about 20 % wide (97.9-99.1 % covered; 94.6-96.5 % shrunk). A real pose error's direction
/// stands out of that scatter and keeps its share; one that spreads over every direction moves
/// the mean. Also returns the factor on the clustered estimate's degrees of freedom the
/// pooling gives (1 to 6: how many directions the mean holds, as far as it was shrunk toward).
/// Falls back to the plain sum (factor 1) where `cov` is singular.
fn shrunk_spread(cov: &Matrix6<f64>, steps: &[nalgebra::Vector6<f64>]) -> (Matrix6<f64>, f64) {
    let plain: Matrix6<f64> = steps.iter().map(|d| d * d.transpose()).sum();
    let g = steps.len();
    let Some(l) = cov.cholesky().map(|c| c.l()) else {
        return (plain, 1.0);
    };
    let Some(y) = steps
        .iter()
        .map(|d| l.solve_lower_triangular(d))
        .collect::<Option<Vec<_>>>()
    else {
        return (plain, 1.0);
    };
    if g < 2 {
        return (plain, 1.0);
    }
    let sample: Matrix6<f64> = y.iter().map(|v| v * v.transpose()).sum::<Matrix6<f64>>() / g as f64;
    let mu = sample.trace() / 6.0;
    let d2 = (sample - Matrix6::identity() * mu).norm_squared();
    let b2 = (y
        .iter()
        .map(|v| (v * v.transpose() - sample).norm_squared())
        .sum::<f64>()
        / (g * g) as f64)
        .min(d2);
    if !(d2 > 0.0) || !b2.is_finite() {
        return (plain, 1.0);
    }
    let w = b2 / d2;
    let shrunk = (Matrix6::identity() * (w * mu) + sample * (1.0 - w)) * g as f64;
    // How many directions the mean pools: the eigenvalues' participation ratio
    // (sum)^2 / sum of squares, 6 when they are alike, 1 when one direction holds it all (the
    // mean is then that direction's estimate again, with no more degrees of freedom).
    let directions = (sample.trace() * sample.trace() / sample.norm_squared()).clamp(1.0, 6.0);
    let pool = directions / (1.0 + (directions - 1.0) * (1.0 - w));
    (l * shrunk * l.transpose(), pool)
}

/// f(X) for X = F A^-1 F^T (k x k, symmetrised), f(h) = ((1 - h)^-1/2 - 1) / h on its
/// eigenvalues; None where one reaches 1 (a pose alone carries a direction). A chord's or a
/// few points' k <= 4 goes through a fixed-size decomposition (no allocation per pose), the
/// rest through a dynamic one.
fn widened(x: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let k = x.nrows();
    let widen = |h: f64| {
        let h = h.max(0.0);
        // Its limit 1/2 + 3h/8 where h is too small to divide by.
        if h < 1e-8 {
            0.5 + 0.375 * h
        } else {
            ((1.0 - h).powf(-0.5) - 1.0) / h
        }
    };
    let sym = |r: usize, c: usize| 0.5 * (x[(r, c)] + x[(c, r)]);
    if k <= 4 {
        // Padded with zeros: the pad is its own block, and F has no rows there.
        let m = nalgebra::Matrix4::from_fn(|r, c| if r < k && c < k { sym(r, c) } else { 0.0 });
        let e = SymmetricEigen::new(m);
        if !e.eigenvalues.iter().all(|&h| h < 1.0 - 1e-9) {
            return None;
        }
        let fx = e.eigenvectors
            * nalgebra::Matrix4::from_diagonal(&e.eigenvalues.map(widen))
            * e.eigenvectors.transpose();
        return Some(DMatrix::from_fn(k, k, |r, c| fx[(r, c)]));
    }
    let e = SymmetricEigen::new(DMatrix::from_fn(k, k, sym));
    if !e.eigenvalues.iter().all(|&h| h < 1.0 - 1e-9) {
        return None;
    }
    Some(
        &e.eigenvectors
            * DMatrix::from_diagonal(&e.eigenvalues.map(widen))
            * e.eigenvectors.transpose(),
    )
}

/// F (k x p) with F^T F = `gram` (symmetric, positive semi-definite), k its numerical rank: a
/// Cholesky factor with diagonal pivoting of the gram with each column divided by its `scale`
/// (the parameters' units differ by orders), stopping where what remains is below 1e-13 of the
/// largest diagonal (rounding in the sums of a pose's few rows), the columns scaled back.
fn low_rank_factor(gram: &DMatrix<f64>, scale: &[f64]) -> DMatrix<f64> {
    let p = gram.nrows();
    let unit = |i: usize, j: usize| gram[(i, j)] / (scale[i] * scale[j]);
    let mut d: Vec<f64> = (0..p).map(|i| unit(i, i)).collect();
    let floor = 1e-13 * d.iter().copied().fold(0.0, f64::max);
    let mut rows: Vec<Vec<f64>> = Vec::new();
    while rows.len() < p {
        let Some((j, &dj)) = d.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)) else {
            break;
        };
        if !(dj > floor) {
            break;
        }
        let root = dj.sqrt();
        let row: Vec<f64> = (0..p)
            .map(|i| {
                let done: f64 = rows.iter().map(|r| r[i] * r[j]).sum();
                (unit(i, j) - done) / root
            })
            .collect();
        for (di, ri) in d.iter_mut().zip(&row) {
            *di -= ri * ri;
        }
        d[j] = 0.0;
        rows.push(row);
    }
    DMatrix::from_fn(rows.len(), p, |r, c| rows[r][c] * scale[c])
}

/// sum_c (A^-1 s_c)(A^-1 s_c)^T over the transform's six rows (A^-1: `inv`, over the columns
/// `used`; s_c: row c of `scores`, over every column). By hand rather than as two matrix
/// products (their packing and the copy of the used columns cost more than the sums, with a
/// sweep's thousands of clusters per fit): eight clusters at a time, one lane each, share each
/// of A^-1's entries, which the scores' layout (a column per parameter) makes one load.
fn scores_spread(inv: &DMatrix<f64>, scores: &DMatrix<f64>, used: &[usize]) -> Matrix6<f64> {
    let g = scores.nrows();
    let inv6: Vec<[f64; 6]> = (0..used.len())
        .map(|k| std::array::from_fn(|r| inv[(r, k)]))
        .collect();
    let columns: Vec<&[f64]> = used
        .iter()
        .map(|&u| &scores.as_slice()[u * g..(u + 1) * g])
        .collect();
    let v = spread(&inv6, &columns);
    let mut out = Matrix6::zeros();
    // `spread`'s sums are the pairs i <= j row by row, as `pairs` lists them.
    for (e, (i, j)) in super::pairs(6).into_iter().enumerate() {
        let t: f64 = v[e].iter().sum();
        out[(i, j)] = t;
        out[(j, i)] = t;
    }
    out
}

/// `scores_spread`'s sums in lanes: t = A^-1 s for eight clusters at once (each used column
/// of the scores, cluster after cluster), then t_i t_j. The last chunk's spare lanes are zero
/// and add nothing.
#[multiversion::multiversion(targets("x86_64+avx512f", "x86_64+avx2"))]
fn spread(inv6: &[[f64; 6]], columns: &[&[f64]]) -> [[f64; 8]; 21] {
    let g = columns.first().map_or(0, |c| c.len());
    let mut v = [[0.0; 8]; 21];
    for c0 in (0..g).step_by(8) {
        let mut t = [[0.0; 8]; 6];
        for (a, col) in inv6.iter().zip(columns) {
            let s: [f64; 8] = match col.get(c0..c0 + 8).map(<[f64; 8]>::try_from) {
                Some(Ok(s)) => s,
                _ => std::array::from_fn(|l| col.get(c0 + l).copied().unwrap_or(0.0)),
            };
            for r in 0..6 {
                for l in 0..8 {
                    t[r][l] += a[r] * s[l];
                }
            }
        }
        let mut e = 0;
        for i in 0..6 {
            for j in i..6 {
                for l in 0..8 {
                    v[e][l] += t[i][l] * t[j][l];
                }
                e += 1;
            }
        }
    }
    v
}

/// The runs of one cluster: (first row, end, cluster).
fn runs(clusters: &[u32]) -> Vec<(usize, usize, usize)> {
    let n = clusters.len();
    let mut runs = Vec::new();
    let mut start = 0;
    for i in 1..=n {
        if i == n || clusters[i] != clusters[start] {
            runs.push((start, i, clusters[start] as usize));
            start = i;
        }
    }
    runs
}

/// What the poses' steps show beyond a stated model (`Honest::unexplained`): the excess
/// covariance, its degrees of freedom, the share of the raised covariance the scatter sets, and
/// the orientation groups' factor on the sd it was widened by (1: not widened).
struct Unexplained {
    excess: Matrix6<f64>,
    dof: usize,
    share: f64,
    group_widening: f64,
}

/// The covariance the orientation groups' scatter widens (`group_widening`).
struct GroupWidened {
    covariance: Matrix6<f64>,
    /// The factor on the sd in the most widened direction (1: not widened).
    factor: f64,
    /// Where directions are widened apart: W with W C W^T the widened covariance.
    map: Option<Matrix6<f64>>,
    /// Where the groups see every direction: the share of the whitened trace their scatter
    /// sets and the number of groups (for the degrees of freedom).
    measured: Option<(f64, usize)>,
}

/// How much the scatter between orientation groups exceeds what `covariance` allows: poses
/// seen with one orientation share the view, and with it whatever error the view determines
/// (where a face ends between columns, how much of a wall shows, the arm's vibration over one
/// scan), so a group's poses do not average it away as the clustering by pose assumes. The
/// groups' clustered covariance (CR1) whitened by `covariance`: the mean of its eigenvalues in
/// the directions the groups can measure (`pose_directions`), a design effect in the sense of
/// survey sampling, widens every direction (ten groups measure a direction's scatter too
/// roughly to widen it alone; clustering by group outright, its few directions widened as few
/// poses' are, over-covered: 98-99 %). Where the groups see all six directions, a direction
/// whose eigenvalue exceeds the largest that G groups' noise alone gives (the Marchenko-Pastur
/// edge (1 + sqrt(g))^2, g = 6 / (G - 1)) is widened by the error it implies: a spike l of the
/// true covariance shows as the sample eigenvalue v = l (1 + g / (l - 1)) (Baik, Ben Arous and
/// Peche 2005; the inverse is the spiked model's debiasing, Donoho, Gavish and Johnstone
/// 2018). An error that moves one direction more than the rest (the arm's vibration turning
/// the edge's rotation) is not averaged away with the others, and noise alone widens nothing
/// (the groups' eigenvalues taken as they are took the sensor-noise rows of `edge-causes` from
/// 96 to 98 %; their excess over the edge held 0.73 of a one-direction error's scatter, the
/// inverse 0.96).
fn group_widening(
    inv: &DMatrix<f64>,
    scores: &DMatrix<f64>,
    groups: &[u32],
    used: &[usize],
    n: usize,
    covariance: &Matrix6<f64>,
) -> GroupWidened {
    let unchanged = GroupWidened {
        covariance: *covariance,
        factor: 1.0,
        map: None,
        measured: None,
    };
    let (g, p) = (scores.nrows(), used.len());
    let big_g = groups.iter().map(|&c| c as usize + 1).max().unwrap_or(0);
    let k = pose_directions(big_g, p);
    if groups.len() != g || k == 0 || n <= p {
        return unchanged;
    }
    let mut summed = DMatrix::zeros(big_g, scores.ncols());
    for (c, &grp) in groups.iter().enumerate() {
        let mut row = summed.row_mut(grp as usize);
        row += scores.row(c);
    }
    let factor = (big_g as f64 / (big_g - 1) as f64) * ((n - 1) as f64 / (n - p) as f64);
    let between = scores_spread(inv, &summed, used) * factor;
    let Some((l, em)) = whitened(covariance, &between) else {
        return unchanged;
    };
    let mut e: Vec<f64> = em.eigenvalues.iter().copied().collect();
    e.sort_by(|x, y| y.total_cmp(x));
    let mean = e[..k].iter().sum::<f64>() / k as f64;
    if !mean.is_finite() || !e.iter().all(|v| v.is_finite()) {
        return unchanged;
    }
    let mean = mean.max(1.0);
    if k < 6 {
        return GroupWidened {
            covariance: covariance * mean,
            factor: mean.sqrt(),
            map: None,
            measured: None,
        };
    }
    let raised = groups_raised(&em, mean, big_g);
    let mid = em.eigenvectors * Matrix6::from_diagonal(&raised) * em.eigenvectors.transpose();
    let from_groups: f64 = raised.iter().filter(|&&v| v > 1.0).sum();
    let map = groups_map(&l, &em, &raised);
    GroupWidened {
        covariance: l * mid * l.transpose(),
        factor: raised.max().sqrt(),
        map,
        measured: Some((from_groups / raised.sum(), big_g)),
    }
}

/// The groups' whitened eigenvalues `em` (their scatter over the pose-level covariance) as the
/// error each implies beyond what `big_g` groups' noise gives (`spike`), at least `mean`.
fn groups_raised(
    em: &SymmetricEigen<f64, nalgebra::U6>,
    mean: f64,
    big_g: usize,
) -> nalgebra::Vector6<f64> {
    let gamma = 6.0 / (big_g - 1) as f64;
    em.eigenvalues.map(|v| spike(v, gamma).max(mean))
}

/// W = L V D^(1/2) V^T L^-1 for the pose-level covariance's factor L, the groups' whitened
/// eigenvectors V and `raised` D: W (L L^T) W^T = L V D V^T L^T.
fn groups_map(
    l: &Matrix6<f64>,
    em: &SymmetricEigen<f64, nalgebra::U6>,
    raised: &nalgebra::Vector6<f64>,
) -> Option<Matrix6<f64>> {
    let root = em.eigenvectors
        * Matrix6::from_diagonal(&raised.map(f64::sqrt))
        * em.eigenvectors.transpose();
    l.try_inverse().map(|li| l * root * li)
}

/// The groups' design-effect map (`groups_map`) of the `between` groups' scatter (6 x 6) over
/// the pose-level covariance `cov`, every direction measured by `big_g` groups, and its factor
/// on the sd in the most widened direction; None where `cov` has no factor or the groups are
/// too few.
fn design_map(
    cov: &Matrix6<f64>,
    between: &Matrix6<f64>,
    big_g: usize,
) -> Option<(Matrix6<f64>, f64)> {
    if big_g < 7 {
        return None;
    }
    let (l, em) = whitened(cov, between)?;
    let mean = (em.eigenvalues.sum() / 6.0).max(1.0);
    if !mean.is_finite() {
        return None;
    }
    let raised = groups_raised(&em, mean, big_g);
    Some((groups_map(&l, &em, &raised)?, raised.max().sqrt()))
}

/// Poses whose orientations agree to within this angle (rad) share a group
/// (`orientation_groups`): the tolerance the protocols' "one orientation" groups are read with
/// (`calib::ORIENTATION_TOLERANCE_DEG`, 0.1 deg). A robot's reported orientation over a pure
/// translation repeats to thousandths of a degree; the views the protocols vary differ by
/// degrees.
const SAME_ORIENTATION_RAD: f64 =
    crate::calib::ORIENTATION_TOLERANCE_DEG * std::f64::consts::PI / 180.0;

/// Most orientations `orientations` tells apart: beyond, each direction is seen by groups
/// enough, and the count bounds its comparisons.
const MAX_ORIENTATIONS: usize = 256;

/// How many orientations (within `SAME_ORIENTATION_RAD`) `flanges` show, up to
/// `MAX_ORIENTATIONS`: one comparison per run of one pose, no table.
pub fn orientations<'a>(flanges: impl IntoIterator<Item = &'a Isometry3<f64>>) -> usize {
    let near = (SAME_ORIENTATION_RAD / 2.0).cos();
    let mut reps: Vec<nalgebra::UnitQuaternion<f64>> = Vec::new();
    let mut last: Option<&Isometry3<f64>> = None;
    for f in flanges {
        if last.is_some_and(|l| std::ptr::eq(l, f) || l.rotation == f.rotation) {
            continue;
        }
        last = Some(f);
        let q = f.rotation;
        if !reps.iter().any(|r| r.coords.dot(&q.coords).abs() >= near) {
            reps.push(q);
            if reps.len() >= MAX_ORIENTATIONS {
                break;
            }
        }
    }
    reps.len()
}

/// Each of the `g` clusters' orientation group, numbered in order of first sight: clusters
/// (flange poses, `clusters`) whose first residuals' flange orientations agree within
/// `SAME_ORIENTATION_RAD`. Empty when the flanges are not one per residual, or when fewer than
/// two clusters share a group on average (then the groups say nothing the poses do not).
pub fn orientation_groups(flanges: &[&Isometry3<f64>], clusters: &[u32], g: usize) -> Vec<u32> {
    if flanges.len() != clusters.len() || g < 4 {
        return Vec::new();
    }
    let mut first: Vec<Option<&Isometry3<f64>>> = vec![None; g];
    for (&f, &c) in flanges.iter().zip(clusters) {
        first[c as usize].get_or_insert(f);
    }
    // |q1 . q2| = cos(angle / 2).
    let near = (SAME_ORIENTATION_RAD / 2.0).cos();
    let mut reps: Vec<nalgebra::UnitQuaternion<f64>> = Vec::new();
    let mut out = Vec::with_capacity(g);
    for f in first {
        let Some(f) = f else {
            return Vec::new();
        };
        let q = f.rotation;
        let id = match reps
            .iter()
            .position(|r| r.coords.dot(&q.coords).abs() >= near)
        {
            Some(i) => i,
            None => {
                reps.push(q);
                if 2 * reps.len() > g {
                    return Vec::new();
                }
                reps.len() - 1
            }
        };
        out.push(id as u32);
    }
    out
}

/// A flange pose bit for bit, as a hashable key (one pose, one cluster).
pub fn pose_key(f: &Isometry3<f64>) -> [u64; 7] {
    let (q, t) = (f.rotation.coords, f.translation.vector);
    [q.x, q.y, q.z, q.w, t.x, t.y, t.z].map(f64::to_bits)
}

/// Each residual's cluster: residuals seen from one flange pose (bit for bit) share a number.
/// Empty when the poses are not known or not one per residual.
pub fn clusters(flanges: &[&Isometry3<f64>], n_residuals: usize) -> Vec<u32> {
    if flanges.len() != n_residuals {
        return Vec::new();
    }
    // Each new run's pose by a 64-bit digest of its bits, checked against the cluster's first
    // pose: a table of small entries (the full keys' was the verdict's third cost on a chord per
    // pose). A digest shared by two poses (about 1e-16 for a thousand) falls back to full keys.
    // Room for a pose per two residuals (a disk chord's two ends, numbered per end) up to a
    // thousand poses; one grown on the way rehashes.
    let cap = (n_residuals / 2).min(1 << 10);
    let mut ids: FxHashMap<u64, u32> = FxHashMap::with_capacity_and_hasher(cap, Default::default());
    let mut firsts: Vec<&Isometry3<f64>> = Vec::with_capacity(cap);
    let mut out = Vec::with_capacity(n_residuals);
    let mut last: Option<(&Isometry3<f64>, u32)> = None;
    for &f in flanges {
        // Runs of one pose are the rule: compare with the previous before hashing.
        let id = match last {
            Some((g, id)) if std::ptr::eq(g, f) || g == f => id,
            _ => {
                let key = pose_key(f);
                let next = firsts.len() as u32;
                let id = *ids.entry(digest(&key)).or_insert(next);
                if id == next {
                    firsts.push(f);
                } else if pose_key(firsts[id as usize]) != key {
                    return clusters_by_key(flanges, n_residuals);
                }
                id
            }
        };
        last = Some((f, id));
        out.push(id);
    }
    out
}

/// A pose's bits mixed into 64 (FxHash's multiply-rotate, each word in turn).
fn digest(key: &[u64; 7]) -> u64 {
    key.iter().fold(0u64, |h, &w| {
        (h.rotate_left(5) ^ w).wrapping_mul(0xf135_7aea_2e62_a9c5)
    })
}

/// `clusters` by a table of full keys.
fn clusters_by_key(flanges: &[&Isometry3<f64>], n_residuals: usize) -> Vec<u32> {
    let mut ids: FxHashMap<[u64; 7], u32> =
        FxHashMap::with_capacity_and_hasher((n_residuals / 2).min(1 << 10), Default::default());
    flanges
        .iter()
        .map(|&f| {
            let next = ids.len() as u32;
            *ids.entry(pose_key(f)).or_insert(next)
        })
        .collect()
}

/// The smallest covariance that holds both `a` and `b` along `a`'s principal directions: with
/// a = S S, the eigenvalues of S^-1 b S^-1 are raised to at least 1. When `b` is estimated in
/// only `informative` (< 6) directions, every eigenvalue is raised to at least the mean of the
/// largest `informative` ones. Returns it, the square root of the largest raised eigenvalue
/// (at least 1) and the share of its whitened trace `b` sets: the raised directions, where it
/// is the larger or lifts the floor (for `effective_dof`; NaN in the fallback). Falls back to a + b where `a` is singular (a pivot of its Cholesky factor at
/// most 1e-24 of its largest diagonal entry).
///
/// Any factor a = L L^T gives the same matrix: L = S Q with Q orthogonal, so L^-1 b L^-T =
/// Q^T (S^-1 b S^-1) Q has the same eigenvalues, its eigenvectors turned by Q^T, and Q cancels
/// in L W D W^T L^T. The Cholesky factor costs less than S's eigen decomposition.
fn larger_of(a: &Matrix6<f64>, b: &Matrix6<f64>, informative: usize) -> (Matrix6<f64>, f64, f64) {
    let top = a.diagonal().max();
    let Some((l, em)) = whitened(a, b) else {
        return (a + b, f64::NAN, f64::NAN);
    };
    if !(top > 0.0) || l.diagonal().iter().any(|&d| !(d * d > 1e-24 * top)) {
        return (a + b, f64::NAN, f64::NAN);
    }
    let floor = if (1..6).contains(&informative) {
        let mut l: Vec<f64> = em.eigenvalues.iter().copied().collect();
        l.sort_by(|x, y| y.total_cmp(x));
        (l[..informative].iter().sum::<f64>() / informative as f64).max(1.0)
    } else {
        1.0
    };
    let raised = em.eigenvalues.map(|l| l.max(floor));
    let mid = em.eigenvectors * Matrix6::from_diagonal(&raised) * em.eigenvectors.transpose();
    // The share of the whitened trace `b` sets (the directions where it is the larger).
    let from_b: f64 = raised.iter().filter(|&&v| v > 1.0).sum();
    let share = from_b / raised.sum();
    (l * mid * l.transpose(), raised.max().sqrt(), share)
}

/// `b` whitened by `a`'s Cholesky factor L: L^-1 b L^-T by two triangular solves (b
/// symmetric), symmetrised, and its eigen decomposition, with L; None where `a` has no factor.
fn whitened(
    a: &Matrix6<f64>,
    b: &Matrix6<f64>,
) -> Option<(Matrix6<f64>, SymmetricEigen<f64, nalgebra::U6>)> {
    let l = a.cholesky()?.l();
    let lb = l.solve_lower_triangular(b)?;
    let m = l.solve_lower_triangular(&lb.transpose())?;
    Some((l, SymmetricEigen::new((m + m.transpose()) * 0.5)))
}

/// The spiked covariance model's inverse: the population eigenvalue l (in units of the noise)
/// whose sample eigenvalue is `v` at aspect ratio `gamma` (dimensions over degrees of freedom),
/// v = l (1 + gamma / (l - 1)) above the Marchenko-Pastur edge (1 + sqrt(gamma))^2; 1 at or
/// below it, where noise alone gives such eigenvalues (Baik, Ben Arous and Peche 2005; Donoho,
/// Gavish and Johnstone 2018).
fn spike(v: f64, gamma: f64) -> f64 {
    let edge = (1.0 + gamma.sqrt()).powi(2);
    if v <= edge {
        return 1.0;
    }
    let b = v + 1.0 - gamma;
    0.5 * (b + (b * b - 4.0 * v).max(0.0).sqrt())
}

/// The share of covariance `c` that its part `part` makes, for `effective_dof`: the whitened
/// trace tr(c^-1 part) / 6, in [0, 1] (1 where `c` is not positive definite).
fn share_of(c: &Matrix6<f64>, part: &Matrix6<f64>) -> f64 {
    c.cholesky()
        .map(|l| l.solve(part).trace() / 6.0)
        .unwrap_or(1.0)
        .clamp(0.0, 1.0)
}

/// Satterthwaite's effective degrees of freedom of a covariance whose share `f` of its trace
/// comes from an estimate with `dof_b` degrees of freedom and the rest from one with `dof_a`:
/// 1/nu = f^2/dof_b + (1 - f)^2/dof_a, the pose-clustered part taken as one piece (its
/// directions share the same scores, so counting them apart would overstate nu).
fn effective_dof(f: f64, dof_b: usize, dof_a: usize) -> usize {
    if !f.is_finite() || dof_b == 0 || dof_a == 0 {
        return dof_b;
    }
    let inv = f * f / dof_b as f64 + (1.0 - f) * (1.0 - f) / dof_a as f64;
    if !(inv > 0.0) {
        return dof_a;
    }
    // The epsilon: 1 / (1 / k) rounds below k.
    ((1.0 / inv + 1e-6).floor() as usize).clamp(dof_b, dof_a.max(dof_b))
}

/// The normal quantile z at which the rotation's and the translation's length bounds (each at
/// Phi(z), `offset_norm_quantile`) hold both errors together in 95 %, for e ~ N(0, c) around
/// the fixed `offset` d (rad, m, as c). Each length's square, taken to its Wilson-Hilferty
/// normal score, is close to normal, and the two scores are taken as jointly normal with the
/// squares' correlation: Cov(|a|^2, |b|^2) = 2 |C_ab|_F^2 + 4 d_a^T C_ab d_b, the variances
/// as in `offset_norm_quantile`. Independent errors need sqrt(0.95) each (z = 1.9545), errors
/// that move as one 95 % each (1.6449); a constant between the two either over-covered the
/// pair (96.6 % for rotation and translation correlated 0.95 an axis) or, at 95 % each, fell
/// to 90 % on independent ones.
fn joint_z(c: &Matrix6<f64>, offset: &nalgebra::Vector6<f64>) -> f64 {
    let (ca, cb) = (c.fixed_view::<3, 3>(0, 0), c.fixed_view::<3, 3>(3, 3));
    let cab = c.fixed_view::<3, 3>(0, 3);
    let (da, db) = (offset.fixed_rows::<3>(0), offset.fixed_rows::<3>(3));
    let var_a = 2.0 * ca.norm_squared() + 4.0 * (da.transpose() * ca * da)[(0, 0)].max(0.0);
    let var_b = 2.0 * cb.norm_squared() + 4.0 * (db.transpose() * cb * db)[(0, 0)].max(0.0);
    let cov = 2.0 * cab.norm_squared() + 4.0 * (da.transpose() * cab * db)[(0, 0)];
    let rho = cov / (var_a * var_b).sqrt();
    if !rho.is_finite() {
        return Z_JOINT;
    }
    joint_z_at(rho.clamp(-1.0, 1.0))
}

/// `joint_z` at correlation `rho`, from a table over asin(rho) (257 entries, built once, read by
/// linear interpolation: within 1e-4 of `solve_joint_z`): the verdict asks for it several times
/// a result, and solving afresh took 1.7 us a call, more than the rest of the bound.
fn joint_z_at(rho: f64) -> f64 {
    const N: usize = 257;
    static TABLE: std::sync::OnceLock<[f64; N]> = std::sync::OnceLock::new();
    let half_pi = std::f64::consts::FRAC_PI_2;
    let table = TABLE.get_or_init(|| {
        std::array::from_fn(|k| {
            let u = -half_pi + std::f64::consts::PI * k as f64 / (N - 1) as f64;
            solve_joint_z(u.sin().clamp(-0.999_999, 0.999_999))
        })
    });
    let x = (rho.asin() + half_pi) / std::f64::consts::PI * (N - 1) as f64;
    let k = (x.floor() as usize).min(N - 2);
    let w = x - k as f64;
    table[k] * (1.0 - w) + table[k + 1] * w
}

/// Newton on P(X <= z, Y <= z) = 0.95 from the independent case's root; the pair's distribution
/// function rises in z with derivative 2 phi(z) Phi(z sqrt((1-rho)/(1+rho))).
fn solve_joint_z(rho: f64) -> f64 {
    let mut z = Z_JOINT;
    for _ in 0..8 {
        let f = both_below(z, rho) - 0.95;
        let density = (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt();
        let slope = 2.0 * density * crate::math::normal_cdf(z * ((1.0 - rho) / (1.0 + rho)).sqrt());
        let step = f / slope;
        z = (z - step).clamp(1.0, 3.0);
        if step.abs() < 1e-9 {
            break;
        }
    }
    z
}

/// P(X <= z, Y <= z) for X, Y standard normal with correlation rho: Phi(z)^2 plus the integral
/// of the pair's density at (z, z) over the correlation from 0 to rho, which with rho = sin(u)
/// is exp(-z^2 / (1 + sin u)) / (2 pi) du, smooth on the whole range (Gauss-Legendre, 16 nodes).
fn both_below(z: f64, rho: f64) -> f64 {
    const NODES: [(f64, f64); 8] = [
        (0.095_012_509_837_637_44, 0.189_450_610_455_068_5),
        (0.281_603_550_779_258_9, 0.182_603_415_044_923_6),
        (0.458_016_777_657_227_4, 0.169_156_519_395_002_5),
        (0.617_876_244_402_643_8, 0.149_595_988_816_576_7),
        (0.755_404_408_355_003, 0.124_628_971_255_533_9),
        (0.865_631_202_387_831_7, 0.095_158_511_682_492_8),
        (0.944_575_023_073_232_6, 0.062_253_523_938_647_9),
        (0.989_400_934_991_649_9, 0.027_152_459_411_754_1),
    ];
    let p = crate::math::normal_cdf(z);
    let end = rho.asin();
    let g = |u: f64| (-z * z / (1.0 + u.sin())).exp();
    let half = 0.5 * end;
    let integral: f64 = NODES
        .iter()
        .map(|&(x, w)| w * (g(half * (1.0 + x)) + g(half * (1.0 - x))))
        .sum::<f64>()
        * half;
    p * p + integral / (2.0 * std::f64::consts::PI)
}

/// The quantile of |d + e| for e ~ N(0, c), c 3x3, a fixed offset d, at the level whose normal
/// quantile is `z`: |d + e|^2 taken as a scaled chi-square with its mean |d|^2 + tr c and
/// variance 2 tr c^2 + 4 d^T c d (Patnaik's approximation of the non-central chi-square;
/// Satterthwaite's of a weighted sum of chi-square(1) variables where d = 0).
fn offset_norm_quantile(c: &Matrix3<f64>, d: &nalgebra::Vector3<f64>, z: f64) -> f64 {
    // Only the eigenvalues' sum and sum of squares are wanted: for a covariance (symmetric,
    // positive semi-definite) c's trace and squared Frobenius norm, with no decomposition. A
    // negative variance is no covariance: its eigenvalues, clamped at zero.
    let (s1, s2) = if c.diagonal().iter().all(|&v| v >= 0.0) {
        (c.trace(), c.norm_squared())
    } else {
        let l = SymmetricEigen::new(*c).eigenvalues.map(|v| v.max(0.0));
        (l.sum(), l.norm_squared())
    };
    let mean = d.norm_squared() + s1;
    let var = 2.0 * s2 + 4.0 * (d.transpose() * c * d)[(0, 0)].max(0.0);
    if !mean.is_finite() {
        return f64::INFINITY;
    }
    if !(var > 0.0) {
        return mean.max(0.0).sqrt();
    }
    let (scale, dof) = (var / (2.0 * mean), 2.0 * mean * mean / var);
    (scale * chi_square_quantile(dof, z)).sqrt()
}

/// The 95 % quantile of |e| for e ~ N(0, c), c 3x3 (`norm_quantile`).
#[cfg(test)]
fn norm_quantile_95(c: &Matrix3<f64>) -> f64 {
    norm_quantile(c, Z_95)
}

/// The quantile of |e| for e ~ N(0, c), c 3x3, at the level whose normal quantile is `z`
/// (`offset_norm_quantile` without an offset).
fn norm_quantile(c: &Matrix3<f64>, z: f64) -> f64 {
    offset_norm_quantile(c, &nalgebra::Vector3::zeros(), z)
}

/// The chi-square distribution's 95 % quantile (`chi_square_quantile`).
#[cfg(test)]
fn chi_square_95(dof: f64) -> f64 {
    chi_square_quantile(dof, Z_95)
}

/// The chi-square distribution's quantile at the level whose normal quantile is `z`
/// (Wilson-Hilferty; within 3 % at 1 degree of freedom at 95 %, closer beyond).
fn chi_square_quantile(dof: f64, z: f64) -> f64 {
    let h = 2.0 / (9.0 * dof);
    dof * (1.0 - h + z * h.sqrt()).powi(3)
}

/// Student's t distribution's 97.5 % quantile (two-sided 95 %): exact (tabulated) up to 4 degrees
/// of freedom, a Cornish-Fisher expansion beyond (within 0.5 % from 5 on).
pub fn student_t_975(dof: usize) -> f64 {
    match dof {
        0 => f64::INFINITY,
        1 => 12.706_204_736,
        2 => 4.302_652_730,
        3 => 3.182_446_305,
        4 => 2.776_445_105,
        _ => {
            let (z, v) = (Z_975, dof as f64);
            let (z3, z5, z7) = (z.powi(3), z.powi(5), z.powi(7));
            z + (z3 + z) / (4.0 * v)
                + (5.0 * z5 + 16.0 * z3 + 3.0 * z) / (96.0 * v * v)
                + (3.0 * z7 + 19.0 * z5 + 17.0 * z3 - 15.0 * z) / (384.0 * v * v * v)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn quantiles_match_tables() {
        // Tables: t(0.975; 3, 5, 10, 30) and chi-square(0.95; 1, 3, 10).
        for (v, t) in [(3, 3.182), (5, 2.571), (10, 2.228), (30, 2.042)] {
            assert!(
                (student_t_975(v) - t).abs() < 0.005 * t,
                "{v}: {}",
                student_t_975(v)
            );
        }
        for (v, c) in [(1.0, 3.841), (3.0, 7.815), (10.0, 18.307)] {
            assert!(
                (chi_square_95(v) - c).abs() < 0.03 * c,
                "{v}: {}",
                chi_square_95(v)
            );
        }
    }

    #[test]
    fn the_norm_quantile_of_an_isotropic_gaussian_is_the_chi_square_one() {
        let q = norm_quantile_95(&(Matrix3::identity() * 4.0));
        assert!((q - 2.0 * chi_square_95(3.0).sqrt()).abs() < 1e-12);
        // One axis only: the two-sided normal quantile.
        let q1 = norm_quantile_95(&Matrix3::from_diagonal(&Vector3::new(1.0, 0.0, 0.0)));
        assert!((q1 - Z_975).abs() < 0.03, "{q1}");
    }

    /// The leverage correction through each pose's low-rank factor against the same through
    /// A^-1/2 and a p x p eigen-decomposition per pose (its first form), on poses of two to
    /// eight rows, one of them rank-deficient, in columns of very different units.
    #[test]
    fn the_low_rank_leverage_correction_is_the_eigen_one() {
        let p = 11;
        // Rows of scattered values (a sine's fractional digits), full rank together, the
        // columns in units six orders apart (radians and metres of a transform, a clock).
        let value = |i: usize, c: usize| {
            let v = ((i * p + c) as f64 * 12.9898).sin() * 43758.5453;
            (v - v.floor() - 0.5) * [1e-3, 1.0, 1e3][c % 3]
        };
        let (mut grams, mut scores) = (Vec::new(), Vec::new());
        let mut a = DMatrix::zeros(p, p);
        let mut i = 0;
        for k in [2, 4, 4, 3, 8, 4, 2, 4, 5, 4, 4, 4, 4, 6, 4, 4] {
            let j = DMatrix::from_fn(k, p, |r, c| value(i + r, c));
            // A pose seen twice alike: rank below its rows.
            let j = if k == 6 {
                DMatrix::from_fn(k, p, |r, c| j[(r % 3, c)])
            } else {
                j
            };
            i += k;
            let r = DVector::from_fn(k, |r, _| ((i + r) as f64 * 1.3).cos() * 1e-3);
            let gc = j.transpose() * &j;
            a += &gc;
            scores.push(j.transpose() * r);
            grams.push(gc);
        }
        // A pose's score per row.
        let scores = DMatrix::from_columns(&scores).transpose();
        // The reference in the unit-diagonal scale (A = D S D, S = C C^T), where nothing is
        // ill-conditioned: A's square root L = D C, M_c = L^-1 A_c L^-T, the step
        // L^-T (I - M_c)^-1/2 L^-1 s_c (any square root gives the same).
        let d = DVector::from_fn(p, |i, _| a[(i, i)].sqrt());
        let unit = DMatrix::from_fn(p, p, |r, c| a[(r, c)] / (d[r] * d[c]));
        let inv = unit.clone().cholesky().expect("full rank").inverse();
        let inv = DMatrix::from_fn(p, p, |r, c| inv[(r, c)] / (d[r] * d[c]));
        let fast: Matrix6<f64> = leverage_adjusted(&a, &inv, &grams, &scores)
            .expect("no pose alone")
            .iter()
            .map(|d| d * d.transpose())
            .sum();
        let ci = unit
            .cholesky()
            .expect("full rank")
            .l()
            .try_inverse()
            .expect("triangular");
        let li = &ci * DMatrix::from_diagonal(&d.map(|v| 1.0 / v));
        let mut v = DMatrix::zeros(p, p);
        for (c, gc) in grams.iter().enumerate() {
            let m = &li * gc * li.transpose();
            let em = SymmetricEigen::new((&m + m.transpose()) * 0.5);
            let w = &em.eigenvectors
                * DMatrix::from_diagonal(&em.eigenvalues.map(|h| 1.0 / (1.0 - h.max(0.0)).sqrt()))
                * em.eigenvectors.transpose();
            let step = li.transpose() * (w * (&li * scores.row(c).transpose()));
            v += &step * step.transpose();
        }
        let v = Matrix6::from_fn(|r, c| v[(r, c)]);
        assert!((fast - v).amax() <= 1e-10 * v.amax(), "{fast} vs {v}");
    }

    /// The spread of the scores by hand is the two products it replaces, over the used
    /// parameters only (one of the scores' columns left out, as a fit's fixed parameter is).
    #[test]
    fn the_scores_spread_is_the_products_one() {
        let (pj, g) = (9, 70);
        let value = |i: usize| {
            let v = (i as f64 * 12.9898).sin() * 43758.5453;
            v - v.floor() - 0.5
        };
        let scores = DMatrix::from_fn(pj, g, |r, c| value(r * g + c) * [1e-3, 1.0][r % 2]);
        let used = [0, 1, 2, 3, 4, 5, 6, 8];
        let inv = DMatrix::from_fn(8, 8, |r, c| value(1000 + r.min(c) * 8 + r.max(c)));
        let t = inv.rows(0, 6) * scores.select_rows(&used);
        let full = &t * t.transpose();
        let want = Matrix6::from_fn(|r, c| full[(r, c)]);
        // A pose's score per row; 70 poses leave a part chunk of lanes.
        let by_pose = scores.transpose();
        let got = scores_spread(&inv, &by_pose, &used);
        assert!(
            (got - want).amax() <= 1e-13 * want.amax(),
            "{got} vs {want}"
        );
        // The left-out column counts for nothing.
        let mut other = by_pose.clone();
        other.column_mut(7).fill(1e6);
        assert_eq!(scores_spread(&inv, &other, &used), got);
    }

    #[test]
    fn the_larger_of_two_covariances_holds_both() {
        let a = Matrix6::from_diagonal(&nalgebra::Vector6::new(1.0, 2.0, 3.0, 4.0, 5.0, 6.0));
        let mut b = Matrix6::identity() * 0.5;
        b[(0, 0)] = 9.0;
        b[(0, 1)] = 0.3;
        b[(1, 0)] = 0.3;
        let (c, f, share) = larger_of(&a, &b, 6);
        for m in [a, b] {
            let d = SymmetricEigen::new(c - m).eigenvalues.min();
            assert!(d > -1e-9, "{d}");
        }
        assert!((f - 3.0).abs() < 0.01, "{f}");
        // b sets one direction (about 9 in a's units) of a whitened trace of about 9 + 5.
        assert!((share - 9.0 / 14.0).abs() < 0.01, "{share}");
        // Where b is within a, a itself.
        let (c, f, share) = larger_of(&a, &(a * 0.5), 6);
        assert!((c - a).norm() < 1e-12 && f == 1.0 && share == 0.0);
    }

    #[test]
    fn the_larger_of_is_the_symmetric_square_roots_one() {
        // Any factor of a gives the matrix a's symmetric square root gives.
        let f = Matrix6::from_fn(|r, c| {
            ((r * 7 + c * 3) as f64).sin() + if r == c { 3.0 } else { 0.0 }
        });
        let g = Matrix6::from_fn(|r, c| ((r * 5 + c * 11) as f64).cos());
        let (a, b) = (f * f.transpose() * 1e-6, g * g.transpose() * 2e-6);
        for informative in [6, 3] {
            let e = SymmetricEigen::new(a);
            let u = e.eigenvectors;
            let half = u * Matrix6::from_diagonal(&e.eigenvalues.map(f64::sqrt)) * u.transpose();
            let inv_half = half.try_inverse().unwrap();
            let m = inv_half * b * inv_half;
            let em = SymmetricEigen::new((m + m.transpose()) * 0.5);
            let mut l: Vec<f64> = em.eigenvalues.iter().copied().collect();
            l.sort_by(|x, y| y.total_cmp(x));
            let floor = if informative < 6 {
                (l[..informative].iter().sum::<f64>() / informative as f64).max(1.0)
            } else {
                1.0
            };
            let raised = em.eigenvalues.map(|l| l.max(floor));
            let want = half
                * (em.eigenvectors * Matrix6::from_diagonal(&raised) * em.eigenvectors.transpose())
                * half;
            let (got, top, _) = larger_of(&a, &b, informative);
            assert!(
                (got - want).amax() <= 1e-10 * want.amax(),
                "{got} vs {want}"
            );
            assert!((top - raised.max().sqrt()).abs() < 1e-10 * top);
            assert!(top > 1.0);
        }
        // A singular a: the sum.
        let mut s = a;
        s.row_mut(2).fill(0.0);
        s.column_mut(2).fill(0.0);
        let (c, top, _) = larger_of(&s, &b, 6);
        assert!(top.is_nan() && c == s + b);
    }

    #[test]
    fn the_two_whole_bounds_hold_both_errors_together_in_95_percent() {
        // 200,000 draws of the six errors from three covariances: rotation and translation
        // independent, moving nearly as one (each axis's pair correlated 0.95), and a random
        // one. Both within their bounds together in 94.6 / 95.2 / 94.6 % (each at 95 %, about
        // 90 % for independent ones; each at sqrt(0.95) whatever the correlation, 94.6 / 96.6 /
        // 94.8 %); the norm quantile's scaled chi-square (Satterthwaite) costs up to half a
        // point on an uneven covariance.
        let mut g = crate::testkit::rng(3);
        let f = Matrix6::from_fn(|_, _| crate::rng::gauss(&mut g));
        let one = Matrix6::from_fn(|r, k| {
            let (a, b) = (1.0 + (r % 3) as f64, 1.0 + (k % 3) as f64);
            a * b
                * match (r == k, r % 3 == k % 3) {
                    (true, _) => 1.0,
                    (false, true) => 0.95,
                    _ => 0.3,
                }
        });
        let independent =
            Matrix6::from_diagonal(&nalgebra::Vector6::new(4.0, 1.0, 0.25, 9.0, 1.0, 1.0));
        for (what, c, lo, hi) in [
            ("independent", independent, 0.94, 0.955),
            ("as one", one, 0.94, 0.96),
            ("random", f * f.transpose(), 0.94, 0.96),
        ] {
            let h = Honest {
                covariance: c,
                dof: 1_000_000,
                ..Honest::unknown()
            };
            let b = h.bounds();
            let l = c.cholesky().expect("positive definite").l();
            let n = 200_000;
            let both = (0..n)
                .filter(|_| {
                    let e = l * nalgebra::Vector6::from_fn(|_, _| crate::rng::gauss(&mut g));
                    e.fixed_rows::<3>(0).norm().to_degrees() <= b.rotation_norm_deg
                        && e.fixed_rows::<3>(3).norm() * 1e3 <= b.translation_norm_mm
                })
                .count() as f64
                / n as f64;
            assert!(lo <= both && both <= hi, "{what}: both within {both}");
        }
    }

    #[test]
    fn both_below_is_the_bivariate_normal_distribution_function() {
        // The ends and the middle in closed form: independent Phi(z)^2, as one Phi(z), opposed
        // 2 Phi(z) - 1; at rho = 0.5, Phi2(0, 0) = 1/4 + asin(0.5) / (2 pi) = 1/3.
        for z in [1.6, 1.8, 2.0] {
            let p = crate::math::normal_cdf(z);
            assert!((both_below(z, 0.0) - p * p).abs() < 1e-9);
            assert!((both_below(z, 0.999_999) - p).abs() < 1e-4);
            assert!((both_below(z, -0.999_999) - (2.0 * p - 1.0)).abs() < 1e-4);
        }
        assert!((both_below(0.0, 0.5) - 1.0 / 3.0).abs() < 1e-7);
        let i = Matrix6::identity();
        // (the normal distribution function here is good to 1.5e-7: z to a few 1e-6)
        assert!((joint_z(&i, &nalgebra::Vector6::zeros()) - Z_JOINT).abs() < 1e-5);
        let mut one = Matrix6::identity();
        for k in 0..3 {
            (one[(k, k + 3)], one[(k + 3, k)]) = (1.0, 1.0);
        }
        assert!((joint_z(&one, &nalgebra::Vector6::zeros()) - Z_95).abs() < 1e-3);
    }

    #[test]
    fn the_joint_level_table_is_the_solved_one() {
        for k in 0..=400 {
            let rho = -0.9999 + 1.9998 * k as f64 / 400.0;
            let (a, b) = (joint_z_at(rho), solve_joint_z(rho));
            assert!((a - b).abs() < 1e-4, "rho {rho}: table {a}, solved {b}");
            let p = both_below(b, rho);
            assert!((p - 0.95).abs() < 1e-6, "rho {rho}: {p}");
        }
    }

    #[test]
    fn the_bounds_around_an_offset_hold_both_errors_together_in_95_percent() {
        // A closed form's two errors, a fixed offset from the fit plus the fit's error, whose
        // rotation and translation parts are correlated: along the offset both lengths move
        // with one component of the error. 200,000 draws, offsets from none to four spreads.
        let mut g = crate::testkit::rng(12);
        let f = Matrix6::from_fn(|_, _| crate::rng::gauss(&mut g));
        let mix = Matrix6::from_fn(|r, k| if r % 3 == k % 3 { 0.8 } else { 0.1 });
        for (what, c) in [
            ("random", f * f.transpose()),
            ("coupled", mix + Matrix6::identity() * 0.2),
        ] {
            let l = c.cholesky().expect("positive definite").l();
            let h = Honest {
                covariance: c,
                dof: 1_000_000,
                ..Honest::unknown()
            };
            for scale in [0.0, 1.0, 4.0] {
                let d = nalgebra::Vector6::new(1.0, -0.5, 0.3, 0.2, 0.9, -0.4).normalize()
                    * scale
                    * c.trace().sqrt();
                let (br, bt) = h.bounds_around(&d);
                let n = 200_000;
                let both = (0..n)
                    .filter(|_| {
                        let e =
                            d + l * nalgebra::Vector6::from_fn(|_, _| crate::rng::gauss(&mut g));
                        e.fixed_rows::<3>(0).norm().to_degrees() <= br
                            && e.fixed_rows::<3>(3).norm() * 1e3 <= bt
                    })
                    .count() as f64
                    / n as f64;
                assert!(
                    (0.94..=0.96).contains(&both),
                    "{what}, offset {scale}: {both}"
                );
            }
        }
    }

    /// Where each pose's own shift moves the fit and the closed form both (the ball protocol
    /// with a per-pose error, docs/verdict.md "Forty-ninth session"), the bound around the
    /// offset, read through how each moves, holds its 95 % (4,000 draws); the bound that takes
    /// the fit's error as independent of the offset over-covers. 8 poses, the closed form
    /// moving half as the fit does plus its own response.
    #[test]
    fn the_bounds_around_a_moved_offset_hold_95_percent_where_pose_shifts_move_both() {
        let mut g = crate::testkit::rng(49);
        let errors = 24;
        let fit: Vec<nalgebra::Vector6<f64>> = (0..errors)
            .map(|_| nalgebra::Vector6::from_fn(|_, _| crate::rng::gauss(&mut g)))
            .collect();
        let closed: Vec<nalgebra::Vector6<f64>> = fit
            .iter()
            .map(|f| f * 0.5 + nalgebra::Vector6::from_fn(|_, _| crate::rng::gauss(&mut g)))
            .collect();
        let s2 = 0.3f64.powi(2);
        let c: Matrix6<f64> = fit.iter().map(|f| f * f.transpose() * s2).sum();
        let h = Honest {
            covariance: c,
            dof: 1_000_000,
            per_pose_variance: s2,
            ..Honest::unknown()
        };
        let moves: Vec<Moved> = (fit.iter().zip(&closed))
            .map(|(f, g)| Moved {
                fit: *f,
                closed: *g,
                variance: s2,
            })
            .collect();
        let n = 4000;
        let (mut moved, mut alone) = (0, 0);
        for _ in 0..n {
            let e: Vec<f64> = (0..errors)
                .map(|_| s2.sqrt() * crate::rng::gauss(&mut g))
                .collect();
            let e_fit: nalgebra::Vector6<f64> = fit.iter().zip(&e).map(|(f, x)| f * *x).sum();
            let e_closed: nalgebra::Vector6<f64> = closed.iter().zip(&e).map(|(f, x)| f * *x).sum();
            // The fit's step from the closed form, as `assess` gives it.
            let offset = e_fit - e_closed;
            let within = |(br, bt): (f64, f64)| {
                e_closed.fixed_rows::<3>(0).norm().to_degrees() <= br
                    && e_closed.fixed_rows::<3>(3).norm() * 1e3 <= bt
            };
            moved += within(h.bounds_around_moved(&offset, &moves, &Matrix6::zeros())) as usize;
            alone += within(h.bounds_around(&offset)) as usize;
        }
        let (moved, alone) = (moved as f64 / n as f64, alone as f64 / n as f64);
        assert!((0.935..=0.965).contains(&moved), "moved {moved}");
        assert!(alone > 0.98, "independent {alone}");
        // No error stated: the plain bound.
        let unstated: Vec<Moved> = (moves.iter())
            .map(|m| Moved {
                variance: 0.0,
                ..*m
            })
            .collect();
        let d = nalgebra::Vector6::from_fn(|i, _| i as f64 * 0.1);
        assert_eq!(
            h.bounds_around_moved(&d, &unstated, &Matrix6::zeros()),
            h.bounds_around(&d)
        );
    }

    #[test]
    fn the_offset_norm_quantile_holds_its_level() {
        // |d + e| for e ~ N(0, c) and a fixed d from none to four times the spread: 100,000
        // draws within the 95 % quantile 94-96 % of the time (Patnaik's approximation).
        let mut g = crate::testkit::rng(8);
        let f = Matrix3::from_fn(|_, _| crate::rng::gauss(&mut g));
        let c = f * f.transpose();
        let l = c.cholesky().expect("positive definite").l();
        for scale in [0.0, 0.5, 1.0, 2.0, 4.0] {
            let d = nalgebra::Vector3::new(1.0, -0.5, 0.3).normalize() * scale * c.trace().sqrt();
            let q = offset_norm_quantile(&c, &d, Z_95);
            let n = 100_000;
            let within = (0..n)
                .filter(|_| {
                    let e = l * nalgebra::Vector3::from_fn(|_, _| crate::rng::gauss(&mut g));
                    (d + e).norm() <= q
                })
                .count() as f64
                / n as f64;
            assert!(
                (0.94..=0.96).contains(&within),
                "offset {scale} spreads: {within} within"
            );
        }
    }

    #[test]
    fn the_norm_quantile_needs_no_decomposition() {
        // A covariance's trace and Frobenius norm are its eigenvalues' sum and root sum of squares.
        let f = Matrix3::new(0.3, -0.1, 0.05, 0.2, 0.4, -0.3, 0.0, 0.1, 0.2);
        let c = f * f.transpose();
        let l = SymmetricEigen::new(c).eigenvalues;
        let (s1, s2): (f64, f64) = (l.sum(), l.norm_squared());
        let want = (s2 / s1 * chi_square_95(s1 * s1 / s2)).sqrt();
        assert!((norm_quantile_95(&c) - want).abs() < 1e-12 * want);
    }

    #[test]
    fn directions_few_poses_cannot_see_take_the_mean_widening() {
        let a = Matrix6::identity();
        let b = Matrix6::from_diagonal(&nalgebra::Vector6::new(9.0, 4.0, 0.0, 0.0, 0.0, 0.0));
        let (c, f, _) = larger_of(&a, &b, 2);
        let want = nalgebra::Vector6::new(9.0, 6.5, 6.5, 6.5, 6.5, 6.5);
        assert!((c - Matrix6::from_diagonal(&want)).norm() < 1e-9, "{c}");
        assert!((f - 3.0).abs() < 1e-9);
        // Every direction informative: only raised to 1.
        let (c, _, _) = larger_of(&a, &b, 6);
        let want = nalgebra::Vector6::new(9.0, 4.0, 1.0, 1.0, 1.0, 1.0);
        assert!((c - Matrix6::from_diagonal(&want)).norm() < 1e-9, "{c}");
    }

    #[test]
    fn clusters_number_the_poses_in_order_of_first_sight() {
        let p: Vec<Isometry3<f64>> = (0..3)
            .map(|i| Isometry3::translation(i as f64, 0.0, 0.0))
            .collect();
        let f = [&p[0], &p[0], &p[1], &p[2], &p[0]];
        assert_eq!(clusters(&f, 5), vec![0, 0, 1, 2, 0]);
        assert!(clusters(&f, 4).is_empty());
        // The full keys' fallback numbers alike, here and on 300 poses seen twice, apart.
        assert_eq!(clusters_by_key(&f, 5), clusters(&f, 5));
        let many: Vec<Isometry3<f64>> = (0..300)
            .map(|i| Isometry3::new(Vector3::new(0.1 * i as f64, 0.0, 0.0), Vector3::z() * 0.01))
            .collect();
        let f: Vec<&Isometry3<f64>> = many.iter().chain(many.iter().rev()).collect();
        let c = clusters(&f, 600);
        assert_eq!(c, clusters_by_key(&f, 600));
        assert_eq!((c[299], c[300], c[599]), (299, 299, 0));
    }

    /// The residual-level sandwich A^-1 (sum r_i^2 J_i^T J_i) A^-1 of six parameters, by rows.
    fn sandwich(inv: &DMatrix<f64>, j: &DMatrix<f64>, r: &DVector<f64>) -> Matrix6<f64> {
        let mut meat = DMatrix::zeros(6, 6);
        for i in 0..j.nrows() {
            let row = j.row(i).transpose() * r[i];
            meat += &row * row.transpose();
        }
        let full = inv * meat * inv;
        Matrix6::from_fn(|a, b| full[(a, b)])
    }

    /// A linear fit's design of `poses` x `per` rows of six uniform columns: the Jacobian, each
    /// row's pose and (J^T J)^-1.
    fn random_design(
        dr: &mut Draws,
        poses: usize,
        per: usize,
    ) -> (DMatrix<f64>, Vec<u32>, DMatrix<f64>) {
        let n = poses * per;
        let j = DMatrix::from_fn(n, 6, |_, _| dr.uniform() - 0.5);
        let cl = (0..n).map(|i| (i / per) as u32).collect();
        let inv = (j.transpose() * &j).try_inverse().unwrap();
        (j, cl, inv)
    }

    /// The figures of the fit to residuals `drawn` of design `j` (clusters `cl`, `poses` of
    /// them; residual-level covariance `cov`) and its poses' steps, as a fit's bound takes them.
    fn fit_and_steps(
        j: &DMatrix<f64>,
        cl: &[u32],
        inv: &DMatrix<f64>,
        clustering: &Clustering,
        drawn: &DVector<f64>,
        cov: &Matrix6<f64>,
        poses: usize,
    ) -> (Honest, Vec<nalgebra::Vector6<f64>>) {
        let used: Vec<usize> = (0..6).collect();
        let step = -inv * j.tr_mul(drawn);
        let sums = super::super::Sums::of(&(drawn + j * &step), j, cl, poses);
        (
            Honest::of(Some(inv), &sums, &[], &used, cov),
            clustering.steps(j, drawn, &step).unwrap(),
        )
    }

    /// `shift_scatter` is the poses' steps' expected sum of squares under independent per-pose
    /// shifts, by Monte Carlo on a design whose poses have three rows each, one of them
    /// weighing four times the others (it carries a direction nearly alone, as one of a
    /// plane's lines may), and differs there from `per_pose_shift`, the fit's
    /// own covariance under those shifts (the steps read the shifts through each pose's
    /// leverage: along the direction the heavy pose carries they show a third of it).
    #[test]
    fn the_shift_scatter_is_what_the_steps_show_under_pose_shifts() {
        let (poses, per, draws) = (10usize, 3usize, 20_000);
        let used: Vec<usize> = (0..6).collect();
        let mut dr = Draws(77);
        let (mut j, cl, _) = random_design(&mut dr, poses, per);
        // The first pose's rows weigh four times: it carries a direction nearly alone.
        j.rows_mut(0, per).scale_mut(4.0);
        let inv = (j.transpose() * &j).try_inverse().unwrap();
        let mut mean = Matrix6::zeros();
        let mut expected = None;
        for _ in 0..draws {
            let r = shifted_rows(&mut dr, &j, per);
            let res = &r - &j * (&inv * j.transpose() * &r);
            let sums = super::super::Sums::of(&res, &j, &cl, poses);
            let h = Honest::of(Some(&inv), &sums, &[], &used, &sandwich(&inv, &j, &res));
            assert_eq!(h.steps.len(), poses);
            mean += h
                .steps
                .iter()
                .map(|s| s * s.transpose())
                .sum::<Matrix6<f64>>()
                / draws as f64;
            expected = Some((h.shift_scatter(), h.per_pose_shift));
        }
        let (e, fit) = expected.unwrap();
        let off = (mean - e).norm() / e.norm();
        assert!(
            off < 0.03,
            "Monte Carlo {mean:.3e} against {e:.3e}: {off:.3} off"
        );
        let (_, w) = whitened(&fit, &e).unwrap();
        // Whitened by the fit's covariance, the scatter is 0.28-1.27 of it here.
        assert!(
            w.eigenvalues.min() < 0.5 && w.eigenvalues.max() > 1.1,
            "the steps read the shifts as the fit takes them: {:?}",
            w.eigenvalues
        );
    }

    /// The rows' change when each pose's points (`per` consecutive rows of `j` a pose) move by
    /// their own shift of unit sd per axis along the translation columns.
    fn shifted_rows(dr: &mut Draws, j: &DMatrix<f64>, per: usize) -> DVector<f64> {
        let d: Vec<Vector3<f64>> = (0..j.nrows() / per)
            .map(|_| Vector3::new(dr.gauss(), dr.gauss(), dr.gauss()))
            .collect();
        DVector::from_fn(j.nrows(), |i, _| {
            (0..3).map(|t| j[(i, 3 + t)] * d[i / per][t]).sum::<f64>()
        })
    }

    /// Seeded draws: uniform in (0, 1) and standard normal (Box-Muller), one sequence.
    struct Draws(u64);

    impl Draws {
        fn uniform(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        }
        fn gauss(&mut self) -> f64 {
            let (a, b) = (self.uniform(), self.uniform());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        }
    }

    #[test]
    fn orientation_groups_join_the_poses_of_one_orientation() {
        let turn = |a: f64| Vector3::new(0.3, -0.2, 0.9).normalize() * a;
        // Three orientations, four translations each; the third 1e-3 rad (0.057 deg) off the
        // first.
        let poses: Vec<Isometry3<f64>> = (0..12)
            .map(|i| {
                let a = [0.2, 0.6, 0.201][i / 4];
                Isometry3::new(Vector3::new(0.01 * (i % 4) as f64, 0.0, 0.5), turn(a))
            })
            .collect();
        let f: Vec<&Isometry3<f64>> = poses.iter().flat_map(|p| [p, p]).collect();
        let cl = clusters(&f, f.len());
        assert_eq!(
            orientation_groups(&f, &cl, 12),
            vec![0, 0, 0, 0, 1, 1, 1, 1, 0, 0, 0, 0]
        );
        assert_eq!(orientations(f.iter().copied()), 2);
        // Every pose its own orientation: no groups; nor without a flange per residual.
        let free: Vec<Isometry3<f64>> = (0..12)
            .map(|i| Isometry3::new(Vector3::zeros(), turn(0.01 * i as f64)))
            .collect();
        let f: Vec<&Isometry3<f64>> = free.iter().collect();
        assert!(orientation_groups(&f, &clusters(&f, 12), 12).is_empty());
        assert_eq!(orientations(f.iter().copied()), 12);
        assert!(orientation_groups(&f[..5], &clusters(&f, 12), 12).is_empty());
    }

    /// 120 poses of 5 rows each in 30 orientation groups of 4 (`GROUPED`): six random columns,
    /// each row's pose, each pose's group, the inverse of J^T J and the columns used.
    const GROUPED: (usize, usize, usize) = (120, 5, 4);

    #[allow(clippy::type_complexity)]
    fn grouped_design(
        d: &mut Draws,
    ) -> (DMatrix<f64>, Vec<u32>, Vec<u32>, DMatrix<f64>, Vec<usize>) {
        let (poses, per, size) = GROUPED;
        let n = poses * per;
        let j = DMatrix::from_fn(n, 6, |_, _| d.uniform() - 0.5);
        let cl: Vec<u32> = (0..n).map(|i| (i / per) as u32).collect();
        let groups: Vec<u32> = (0..poses).map(|c| (c / size) as u32).collect();
        let inv = (j.transpose() * &j).try_inverse().unwrap();
        (j, cl, groups, inv, (0..6).collect())
    }

    /// 120 poses in 30 orientation groups of 4, each group's rows moved by its own error in the
    /// parameters (a view's systematic error), 400 draws: the pose clustering alone sees about
    /// a quarter of the scatter; with the groups' widening the predicted variance is the seen
    /// one. (Ten such groups for six parameters: 0.76 of it, the fit taking part of each
    /// group's error; the ray-cast line targets' share is smaller, measured in docs/verdict.md.)
    #[test]
    fn errors_shared_by_an_orientation_group_widen_the_bound() {
        let (poses, per, size) = GROUPED;
        let n = poses * per;
        let mut d = Draws(2026);
        let (j, cl, groups, inv, used) = grouped_design(&mut d);
        let draws = 400;
        let (mut seen, mut alone, mut widened) = (0.0, 0.0, 0.0);
        for _ in 0..draws {
            let w: Vec<nalgebra::Vector6<f64>> = (0..poses / size)
                .map(|_| nalgebra::Vector6::from_fn(|_, _| d.gauss()))
                .collect();
            let r = DVector::from_fn(n, |i, _| {
                j.row(i).dot(&w[i / per / size].transpose()) + 0.01 * d.gauss()
            });
            let step = &inv * j.transpose() * &r;
            let res = &r - &j * &step;
            let cov = sandwich(&inv, &j, &res);
            let sums = super::super::Sums::of(&res, &j, &cl, poses);
            seen += step[0] * step[0] / draws as f64;
            alone +=
                Honest::of(Some(&inv), &sums, &[], &used, &cov).covariance[(0, 0)] / draws as f64;
            widened += Honest::of(Some(&inv), &sums, &groups, &used, &cov).covariance[(0, 0)]
                / draws as f64;
        }
        eprintln!(
            "pose clustering {}, with the groups {}",
            alone / seen,
            widened / seen
        );
        assert!(
            alone / seen < 0.5,
            "pose clustering: {} of the scatter",
            alone / seen
        );
        assert!(
            (widened / seen - 1.0).abs() < 0.3,
            "with the groups: {} of the scatter",
            widened / seen
        );
    }

    /// An error shared by the poses of one orientation group along one direction only: 30
    /// groups of 4 poses see all six directions, and the bound in that direction holds its
    /// scatter (the pose clustering alone about 0.3 of it); with no shared error the groups
    /// widen nothing beyond what their noise gives (400 draws each).
    #[test]
    fn an_error_the_groups_share_in_one_direction_widens_that_direction() {
        let (poses, per, size) = GROUPED;
        let n = poses * per;
        let mut d = Draws(2027);
        let (j, cl, groups, inv, used) = grouped_design(&mut d);
        let draws = 400;
        for shared in [1.0, 0.0] {
            let (mut seen, mut widened, mut alone, mut dof) = (0.0, 0.0, 0.0, 0.0);
            for _ in 0..draws {
                let w: Vec<f64> = (0..poses / size).map(|_| shared * d.gauss()).collect();
                let r =
                    DVector::from_fn(n, |i, _| j[(i, 0)] * w[i / per / size] + 0.01 * d.gauss());
                let step = &inv * j.transpose() * &r;
                let res = &r - &j * &step;
                let cov = sandwich(&inv, &j, &res);
                let sums = super::super::Sums::of(&res, &j, &cl, poses);
                let h = Honest::of(Some(&inv), &sums, &groups, &used, &cov);
                let a = Honest::of(Some(&inv), &sums, &[], &used, &cov);
                seen += step[0] * step[0] / draws as f64;
                widened += h.covariance[(0, 0)] / draws as f64;
                alone += a.covariance[(0, 0)] / draws as f64;
                dof += h.dof as f64 / draws as f64;
                // The map widens the covariance the groups widened into the widened one (a
                // stated error's excess is widened by it, `unexplained`).
                let w = h.group_map.expect("30 groups see every direction");
                let mapped = w * a.covariance * w.transpose();
                assert!((mapped - h.covariance).norm() < 1e-9 * h.covariance.norm());
            }
            eprintln!(
                "shared {shared}: widened {} alone {} of the scatter, dof {dof}",
                widened / seen,
                alone / seen
            );
            if shared > 0.0 {
                assert!(alone / seen < 0.5, "pose clustering: {}", alone / seen);
                assert!(
                    (widened / seen - 1.0).abs() < 0.25,
                    "with the groups: {} of the scatter",
                    widened / seen
                );
                // The groups' scatter sets the bound: their 29 degrees of freedom rule.
                assert!(dof < 40.0, "{dof}");
            } else {
                assert!(
                    widened / alone < 1.1,
                    "noise alone widened by {}",
                    widened / alone
                );
            }
        }
    }

    /// The covariance per-pose shifts predict (`per_pose_shift`) is the one their least-squares
    /// steps show: 5 poses of 40 rows each, every pose's rows moved by the translation columns
    /// times its own standard normal shift, 4,000 draws. Five poses see the scatter between
    /// them in 4 directions only, so a stated accuracy raises the bound to the prediction.
    #[test]
    fn per_pose_shifts_predict_the_scatter_they_cause() {
        let (poses, per) = (5usize, 40usize);
        let n = poses * per;
        let mut dr = Draws(12345);
        let (j, cl, inv) = random_design(&mut dr, poses, per);
        let sums = super::super::Sums::of(&DVector::zeros(n), &j, &cl, poses);
        let used: Vec<usize> = (0..6).collect();
        let h = Honest::of(Some(&inv), &sums, &[], &used, &Matrix6::identity());
        let draws = 4000;
        let mut mc = Matrix6::zeros();
        for _ in 0..draws {
            let r = shifted_rows(&mut dr, &j, per);
            let step = &inv * j.transpose() * r;
            mc += Matrix6::from_fn(|a, b| step[a] * step[b]) / draws as f64;
        }
        for i in 0..6 {
            let (want, got) = (h.per_pose_shift[(i, i)], mc[(i, i)]);
            assert!(
                (got / want - 1.0).abs() < 0.1,
                "{i}: predicted {want}, seen {got}"
            );
        }
        assert_eq!(h.pose_directions, 4);
        let with = h.with_systematic(0.0, 1.0, 0.0, 1.0);
        for i in 0..6 {
            assert!(with.covariance[(i, i)] >= h.per_pose_shift[(i, i)] * (1.0 - 1e-9));
        }
        assert_eq!(
            h.with_systematic(0.0, 0.0, 0.0, 1.0).covariance,
            h.covariance
        );
        // Each pose's own error (a repeatability) raises the same floor, and only the common
        // accuracy adds its whole variance on top.
        let own = h.with_systematic(0.0, 0.0, 1.0, 1.0);
        for i in 0..6 {
            assert!(own.covariance[(i, i)] >= h.per_pose_shift[(i, i)] * (1.0 - 1e-9));
            let added = with.covariance[(i, i)] - own.covariance[(i, i)];
            let want = if i < 3 { 0.0 } else { 1.0 };
            assert!((added - want).abs() < 1e-9, "{i}: {added}");
        }
    }

    /// `Clustering::steps` of a residual change and the fit's step for it are the pose
    /// clustering's own steps (`Honest::of`) of the refitted residuals.
    #[test]
    fn the_clusterings_steps_of_a_change_are_the_refitted_residuals_steps() {
        let (poses, per) = (12usize, 30usize);
        let mut dr = Draws(777);
        let (j, cl, inv) = random_design(&mut dr, poses, per);
        let change = DVector::from_fn(poses * per, |_, _| dr.gauss());
        let d = -&inv * j.tr_mul(&change);
        let refitted = &change + &j * &d;
        let sums = super::super::Sums::of(&refitted, &j, &cl, poses);
        let used: Vec<usize> = (0..6).collect();
        let h = Honest::of(
            Some(&inv),
            &sums,
            &[],
            &used,
            &(sandwich(&inv, &j, &refitted)),
        );
        assert_eq!(h.steps.len(), poses);
        let c = Clustering::of(&j, cl, &(j.transpose() * &j), &inv, &used).unwrap();
        let steps = c.steps(&j, &change, &d).unwrap();
        for (a, b) in steps.iter().zip(&h.steps) {
            assert!((a - b).norm() < 1e-9 * b.norm().max(1e-12), "{a} vs {b}");
        }
    }

    /// The split of an arm error between its two kinds is read back from steps drawn at a
    /// known split (patterns drawn at another): all in the first kind, all in the second, or
    /// the assumed one; and too few steps give none.
    #[test]
    fn an_arm_errors_split_is_read_from_the_poses_steps() {
        use nalgebra::Vector6;
        let (g, errors, assumed) = (40usize, 24usize, 0.4);
        let second: Vec<bool> = (0..errors).map(|e| e % 4 == 3).collect();
        let h = Honest {
            residual: Matrix6::identity() * (g as f64 * 1e-4),
            ..Honest::unknown()
        };
        let read_sized = |t: f64, size: f64, seed: u64| {
            let mut dr = Draws(seed);
            let pattern: Vec<Vec<Vector6<f64>>> = (0..errors)
                .map(|_| {
                    (0..g)
                        .map(|_| Vector6::from_fn(|_, _| 0.1 * dr.gauss()))
                        .collect()
                })
                .collect();
            let mut steps: Vec<Vector6<f64>> = (0..g)
                .map(|_| Vector6::from_fn(|_, _| 1e-2 * dr.gauss()))
                .collect();
            for (e, col) in pattern.iter().enumerate() {
                let w = if second[e] {
                    (1.0 - t) / (1.0 - assumed)
                } else {
                    t / assumed
                };
                let a = size * w.sqrt() * dr.gauss();
                for (s, d) in steps.iter_mut().zip(col) {
                    *s += d * a;
                }
            }
            let h = Honest { steps, ..h.clone() };
            h.error_split(&pattern, &second, assumed, None, 0.0)
        };
        let read = |t: f64, seed: u64| read_sized(t, 1.0, seed).unwrap();
        for seed in 0..5 {
            let (t, sd) = read(1.0, 11 + seed);
            assert!(t > 0.8 && sd < 0.2, "all in the first kind: {t} ± {sd}");
            let (t, sd) = read(0.0, 21 + seed);
            assert!(t < 0.2 && sd < 0.2, "all in the second kind: {t} ± {sd}");
        }
        let mean: f64 = (0..10).map(|seed| read(assumed, 31 + seed).0).sum::<f64>() / 10.0;
        assert!(
            (mean - assumed).abs() < 0.15,
            "at the assumed split: {mean}"
        );
        // No arm error in the steps (the stated accuracy a bound it is well inside): no share
        // is read (the kind of fewer errors, read regardless, came out at 1 %).
        for seed in 0..5 {
            assert_eq!(read_sized(1.0, 0.0, 41 + seed), None, "no arm error");
        }
        let few = Honest {
            steps: vec![Vector6::zeros(); 1],
            ..h.clone()
        };
        let one: Vec<Vec<Vector6<f64>>> = vec![vec![Vector6::zeros(); 1]; errors];
        assert!(few.error_split(&one, &second, assumed, None, 0.0).is_none());
    }

    /// A stated error's pattern over the poses, however large its draw, is not taken for
    /// scatter between poses (the bound is the model's), while an independent per-pose error
    /// the statement leaves out still widens it by about what it causes; without the pattern,
    /// the measured scatter of a large draw sets the bound.
    #[test]
    fn a_stated_kinematic_pattern_is_not_taken_for_scatter() {
        pattern_not_taken_for_scatter(40);
    }

    /// The same beyond `MAX_JACKKNIFE` poses, where `Honest::of` keeps no steps and the fit's
    /// own (CR1, `Clustering`) are passed in.
    #[test]
    fn beyond_the_jackknifes_poses_a_stated_pattern_is_not_taken_for_scatter_either() {
        pattern_not_taken_for_scatter(100);
    }

    /// Beyond `MAX_JACKKNIFE` poses with orientation groups: an error each group's poses share
    /// (a vibration neighbouring poses share) widens the bound by about what it causes once the
    /// fit's own steps are summed per group, the stated patterns taken out; read pose by pose
    /// it shows about a fifth of it (five poses a group).
    #[test]
    fn an_error_a_group_shares_widens_the_bound_beyond_the_patterns() {
        use nalgebra::Vector6;
        let (poses, per, size) = (100usize, 30usize, 5usize);
        let n = poses * per;
        let mut dr = Draws(5151);
        let (j, cl, inv) = random_design(&mut dr, poses, per);
        let used: Vec<usize> = (0..6).collect();
        let clustering =
            Clustering::of(&j, cl.clone(), &(j.transpose() * &j), &inv, &used).unwrap();
        let labels: Vec<u32> = (0..poses).map(|c| (c / size) as u32).collect();
        let change = DVector::from_fn(n, |i, _| (0.3 * (i / per) as f64).sin());
        let fit_step = |r: &DVector<f64>| -&inv * j.tr_mul(r);
        let shifts = vec![(
            Vector6::from_iterator(fit_step(&change).iter().copied()),
            1.0,
        )];
        let pattern = vec![clustering.steps(&j, &change, &fit_step(&change)).unwrap()];
        let (sigma, tau) = (1e-3, 1e-2);
        let shared: Vec<Vector6<f64>> = (0..poses / size)
            .map(|_| Vector6::from_fn(|_, _| tau * dr.gauss()))
            .collect();
        let drawn = DVector::from_fn(n, |i, _| {
            change[i] * 4.0 + sigma * dr.gauss() + (j.row(i) * shared[i / per / size])[0]
        });
        let cov = (&inv * sigma * sigma).fixed_view::<6, 6>(0, 0).into_owned();
        let (h, steps) = fit_and_steps(&j, &cl, &inv, &clustering, &drawn, &cov, poses);
        let model = h.residual + shifts_covariance(&shifts);
        let grouped = h.with_kinematic(
            &shifts,
            Some(&pattern),
            Some((&steps, &labels)),
            None,
            0.0,
            0.0,
            0.0,
        );
        let alone = h.with_kinematic(
            &shifts,
            Some(&pattern),
            Some((&steps, &[])),
            None,
            0.0,
            0.0,
            0.0,
        );
        // What the shared errors cause: sum_G A^-1 (sum_{c in G} A_c) tau^2 (...) A^-1.
        let caused: DMatrix<f64> = (0..poses / size)
            .map(|g| {
                let jg = j.rows(g * size * per, size * per);
                let ag = jg.transpose() * jg;
                &inv * &ag * &ag * &inv * (tau * tau)
            })
            .fold(DMatrix::zeros(6, 6), |s, m| s + m);
        let trace = |c: &Matrix6<f64>| (c - model).trace();
        let want = caused.trace();
        eprintln!(
            "excess over the model: summed per group {:.3}, pose by pose {:.3} of what the shared errors cause",
            trace(&grouped.covariance) / want,
            trace(&alone.covariance) / want
        );
        assert!(
            trace(&grouped.covariance) > 0.5 * want && trace(&grouped.covariance) < 2.0 * want,
            "summed per group: {} against {want}",
            trace(&grouped.covariance)
        );
        assert!(
            trace(&alone.covariance) < 0.5 * want,
            "pose by pose: {} against {want}",
            trace(&alone.covariance)
        );
    }

    /// With no error shared by a group, the patterns' fit leaves the groups' scatter at the
    /// noise's in every direction when the parameters' units differ by a thousand (radians and
    /// metres): fitted in the raw numbers, the fit follows the large numbers' noise and moves
    /// the small ones by the patterns' size there, and the groups widened the bound (here 1.96
    /// times on average; the edge paper's 25 groups: docs/verdict.md, "Fifty-fifth session").
    /// 50 draws of 100 poses in 20 groups.
    #[test]
    fn the_patterns_fit_in_mixed_units_widens_no_group() {
        use nalgebra::Vector6;
        let (poses, per, size) = (100usize, 30usize, 5usize);
        let n = poses * per;
        let mut dr = Draws(5353);
        let (mut j, cl, _) = random_design(&mut dr, poses, per);
        // The first three parameters a thousand times smaller than the rest, as radians are
        // against the metres a lever of 1 m turns them into.
        j.columns_mut(0, 3).scale_mut(1e3);
        let inv = (j.transpose() * &j).try_inverse().unwrap();
        let used: Vec<usize> = (0..6).collect();
        let clustering =
            Clustering::of(&j, cl.clone(), &(j.transpose() * &j), &inv, &used).unwrap();
        let labels: Vec<u32> = (0..poses).map(|c| (c / size) as u32).collect();
        let sigma = 1e-3;
        let cov = (&inv * sigma * sigma).fixed_view::<6, 6>(0, 0).into_owned();
        // Twelve patterns smooth in the pose, twenty times the noise's steps in the small
        // parameters and as large as them in the large ones (an arm's link errors against a
        // sensor's noise), with no bias of their own.
        let sd: Vec<f64> = (0..6)
            .map(|i| (cov[(i, i)] / poses as f64).sqrt())
            .collect();
        let pattern: Vec<Vec<Vector6<f64>>> = (0..12)
            .map(|e| {
                (0..poses)
                    .map(|c| {
                        Vector6::from_fn(|i, _| {
                            let size = if i < 3 { 20.0 } else { 1.0 };
                            size * sd[i] * (0.05 * (c * (e + 1)) as f64 + i as f64).sin()
                        })
                    })
                    .collect()
            })
            .collect();
        let shifts = vec![(Vector6::zeros(), 1.0); 12];
        let (draws, mut widest) = (50, 0.0f64);
        let mut mean = 0.0;
        for _ in 0..draws {
            let drawn = DVector::from_fn(n, |_, _| sigma * dr.gauss());
            let (h, steps) = fit_and_steps(&j, &cl, &inv, &clustering, &drawn, &cov, poses);
            let k = h.with_kinematic(
                &shifts,
                Some(&pattern),
                Some((&steps, &labels)),
                None,
                0.0,
                0.0,
                0.0,
            );
            widest = widest.max(k.group_widening);
            mean += k.group_widening / draws as f64;
        }
        eprintln!("groups' widening: mean {mean:.3}, widest {widest:.3}");
        assert!(mean < 1.15, "mean {mean}");
        assert!(widest < 1.6, "widest {widest}");
    }

    fn pattern_not_taken_for_scatter(poses: usize) {
        use nalgebra::Vector6;
        let per = 30usize;
        let n = poses * per;
        let mut dr = Draws(4242);
        let (j, cl, inv) = random_design(&mut dr, poses, per);
        let used: Vec<usize> = (0..6).collect();
        let a = j.transpose() * &j;
        let clustering = Clustering::of(&j, cl.clone(), &a, &inv, &used).unwrap();
        // Three smooth patterns over the poses (each row moved by a pose-dependent amount).
        let changes: Vec<DVector<f64>> = (0..3)
            .map(|e| {
                DVector::from_fn(n, |i, _| {
                    let (c, k) = ((i / per) as f64, (i % per) as f64);
                    (0.3 * c * (e + 1) as f64).sin() + 0.02 * k * (e as f64 - 1.0)
                })
            })
            .collect();
        let fit_step = |r: &DVector<f64>| -&inv * j.tr_mul(r);
        let shifts: Vec<(Vector6<f64>, f64)> = changes
            .iter()
            .map(|c| (Vector6::from_iterator(fit_step(c).iter().copied()), 1.0))
            .collect();
        let pattern: Vec<Vec<Vector6<f64>>> = changes
            .iter()
            .map(|c| clustering.steps(&j, c, &fit_step(c)).unwrap())
            .collect();
        let sigma = 1e-3;
        let honest_of = |r: &DVector<f64>| {
            let refitted = r + &j * fit_step(r);
            let sums = super::super::Sums::of(&refitted, &j, &cl, poses);
            Honest::of(
                Some(&inv),
                &sums,
                &[],
                &used,
                &(&inv * sigma * sigma).fixed_view::<6, 6>(0, 0).into_owned(),
            )
        };
        // A draw of 3, -2 and 5 sd, and the sensor's noise.
        let noise = DVector::from_fn(n, |_, _| sigma * dr.gauss());
        let drawn = &changes[0] * 3.0 - &changes[1] * 2.0 + &changes[2] * 5.0 + &noise;
        let h = honest_of(&drawn);
        assert_eq!(h.steps.is_empty(), poses > MAX_JACKKNIFE);
        assert_eq!(clustering.corrected, poses <= MAX_JACKKNIFE);
        // The fit's own steps, where `of` kept none.
        let at_fit = |r: &DVector<f64>| clustering.steps(&j, r, &fit_step(r)).unwrap();
        let own_steps = at_fit(&drawn);
        let fit = Some((own_steps.as_slice(), &[] as &[u32]));
        let model = h.residual + shifts_covariance(&shifts);
        let with = h.with_kinematic(&shifts, Some(&pattern), fit, None, 0.0, 0.0, 0.0);
        let without = h.with_kinematic(&shifts, None, fit, None, 0.0, 0.0, 0.0);
        for i in 0..6 {
            let (m, w) = (model[(i, i)], with.covariance[(i, i)]);
            assert!(
                w >= m * (1.0 - 1e-9) && w - m < 2.0 * h.residual[(i, i)],
                "{i}: {w} vs {m}"
            );
        }
        assert!((0..6).any(|i| without.covariance[(i, i)] > 4.0 * model[(i, i)]));
        // The widening reported is the scatter's beyond the model, not the patterns'.
        assert!(
            with.inflation < 1.5 && h.inflation > 2.0 * with.inflation,
            "{} against the fit's {}",
            with.inflation,
            h.inflation
        );
        // An error of its own at each pose, 10 times the noise over a pose's rows.
        let tau = 10.0 * sigma;
        let own: Vec<Vector6<f64>> = (0..poses)
            .map(|_| Vector6::from_fn(|_, _| tau * dr.gauss()))
            .collect();
        let moved = DVector::from_fn(n, |i, _| (j.row(i) * own[i / per])[0]);
        let h = honest_of(&(&drawn + &moved));
        let own_steps = at_fit(&(&drawn + &moved));
        let fit = Some((own_steps.as_slice(), &[] as &[u32]));
        let with = h.with_kinematic(&shifts, Some(&pattern), fit, None, 0.0, 0.0, 0.0);
        assert!(with.inflation > 1.5, "{}", with.inflation);
        // What independent per-pose shifts of tau through J cause: sum_c A^-1 A_c A_c A^-1.
        let caused: DMatrix<f64> = (0..poses)
            .map(|c| {
                let jc = j.rows(c * per, per);
                let ac = jc.transpose() * jc;
                &inv * &ac * &ac * &inv * (tau * tau)
            })
            .fold(DMatrix::zeros(6, 6), |s, m| s + m);
        for i in 0..6 {
            let excess = with.covariance[(i, i)] - model[(i, i)];
            let want = caused[(i, i)];
            assert!(
                excess > 0.4 * want && excess < 2.5 * want,
                "{i}: {excess} vs {want}"
            );
        }
    }

    /// Points of 20 poses, each pose shifted by its own error much larger than the noise: the
    /// clustered covariance sees the shifts, the residual-level one does not.
    #[test]
    fn pose_errors_widen_the_honest_covariance() {
        let (poses, per) = (20usize, 50usize);
        let n = poses * per;
        // A location model y = mu + e: one parameter, padded to six columns with tiny ones.
        let mut j = DMatrix::zeros(n, 6);
        let mut r = DVector::zeros(n);
        let mut cl = Vec::new();
        for i in 0..n {
            let pose = i / per;
            j[(i, 0)] = 1.0;
            for c in 1..6 {
                j[(i, c)] = (((i * 31 + c * 17) % 97) as f64 / 97.0 - 0.5) * 1e-3;
            }
            let shift = if pose % 2 == 0 { 1.0 } else { -1.0 };
            r[i] = shift + 0.01 * (((i * 7919) % 101) as f64 / 101.0 - 0.5);
            cl.push(pose as u32);
        }
        let a = j.transpose() * &j;
        let used: Vec<usize> = (0..6).collect();
        let inv = a.clone().try_inverse().unwrap();
        let cov = sandwich(&inv, &j, &r);
        let sums = super::super::Sums::of(&r, &j, &cl, 20);
        let h = Honest::of(Some(&inv), &sums, &[], &used, &cov);
        // The clustered covariance holds nearly all of it: its g - 1 degrees of freedom rule.
        assert_eq!(h.clusters, 20);
        assert!((19..=25).contains(&h.dof), "{}", h.dof);
        // sd of the mean of 20 pose shifts of +-1: about 1 / sqrt(20), against about
        // 1 / sqrt(1000) at the residual level.
        let sd = h.covariance[(0, 0)].sqrt();
        assert!(sd > 0.15 && sd < 0.4, "{sd}");
        assert!(h.inflation > 4.0, "{}", h.inflation);
    }

    /// Points of 20 poses with independent noise alone: the clustered and the residual-level
    /// covariances estimate the same, the larger of the two is mostly the residual-level one,
    /// and the quantiles' degrees of freedom are well above the poses' 19; half the trace from
    /// each gives about four times 19, none from the clustered one the residuals'.
    #[test]
    fn without_pose_errors_the_quantiles_take_more_degrees_of_freedom() {
        let (poses, per) = (20usize, 50usize);
        let n = poses * per;
        let mut dr = Draws(777);
        let (j, cl, inv) = random_design(&mut dr, poses, per);
        let r = DVector::from_fn(n, |_, _| dr.gauss() * 0.01);
        let cov = sandwich(&inv, &j, &r);
        let sums = super::super::Sums::of(&r, &j, &cl, poses);
        let used: Vec<usize> = (0..6).collect();
        let h = Honest::of(Some(&inv), &sums, &[], &used, &cov);
        assert_eq!(h.pose_directions, 6);
        assert!(h.dof > 40, "{}", h.dof);
        assert_eq!(effective_dof(0.5, 19, 994), 74);
        assert_eq!(effective_dof(0.0, 19, 994), 994);
        assert_eq!(effective_dof(1.0, 19, 994), 19);
        assert_eq!(effective_dof(f64::NAN, 19, 994), 19);
    }

    /// A stated repeatability with every direction measured (16 poses x 30 points, each pose's
    /// points moved by its own shift along the translation columns): the bound covers about
    /// 95 % where the statement is the truth (96.8 %; the larger of the scatter and a floor
    /// from the residuals, which carry the shifts too, had covered 98.7 %), and where the
    /// truth is twice it, the scatter shows the rest: as much as with nothing stated (92.2
    /// against 92.6 %; the scatter alone falls short on this design).
    #[test]
    fn a_stated_repeatability_is_the_model_the_scatter_adds_to() {
        let (poses, per, draws) = (16usize, 30usize, 1500);
        let n = poses * per;
        let used: Vec<usize> = (0..6).collect();
        let (noise, stated) = (0.01, 0.01);
        for truth in [stated, 2.0 * stated] {
            let mut dr = Draws(4242 + (truth * 1e4) as u64);
            let (mut covered, mut alone) = (0, 0);
            for _ in 0..draws {
                let (j, cl, inv) = random_design(&mut dr, poses, per);
                let d: Vec<Vector3<f64>> = (0..poses)
                    .map(|_| Vector3::new(dr.gauss(), dr.gauss(), dr.gauss()) * truth)
                    .collect();
                let r = DVector::from_fn(n, |i, _| {
                    dr.gauss() * noise + (0..3).map(|t| j[(i, 3 + t)] * d[i / per][t]).sum::<f64>()
                });
                let err = &inv * j.transpose() * &r;
                let res = &r - &j * &err;
                let cov = sandwich(&inv, &j, &res);
                let sums = super::super::Sums::of(&res, &j, &cl, poses);
                let h = Honest::of(Some(&inv), &sums, &[], &used, &cov);
                assert_eq!(h.pose_directions, 6);
                // The residuals' variance against the noise's (what `verdict` states).
                let var = res.norm_squared() / (n - 6) as f64;
                let b = h
                    .with_systematic(0.0, 0.0, stated, noise * noise / var)
                    .bounds();
                let rot = Vector3::new(err[0], err[1], err[2]).norm().to_degrees();
                let tra = Vector3::new(err[3], err[4], err[5]).norm() * 1e3;
                covered += usize::from(rot <= b.rotation_norm_deg && tra <= b.translation_norm_mm);
                let a = h.bounds();
                alone += usize::from(rot <= a.rotation_norm_deg && tra <= a.translation_norm_mm);
            }
            let share = covered as f64 / draws as f64;
            eprintln!(
                "repeatability {truth} against {stated} stated: {share} covered, {alone} of {draws} with nothing stated"
            );
            let want = if truth == stated {
                0.93..=0.97
            } else {
                (alone as f64 / draws as f64 - 0.01)..=0.97
            };
            assert!(
                want.contains(&share),
                "repeatability {truth} against {stated} stated: {share} covered, {alone} of \
                 {draws} with nothing stated"
            );
        }
    }

    /// Coverage of the joint bound over seeded draws of a linear fit of 16 poses x 30 points
    /// (each draw its own design): with noise alone, and with each pose's points moved by its
    /// own error along one parameter (a robot's error in one direction, 4 and 50 times the
    /// noise's effect on one pose: 94.7 and 94.4 % covered). The first covered 96.5 %, and
    /// 99.3 % with the clustered covariance's eigenvalues raised one by one, not shrunk
    /// (`shrunk_spread`), and Student's t at 15.
    #[test]
    fn the_bound_covers_95_percent_with_and_without_a_pose_error() {
        let (poses, per, draws) = (16usize, 30usize, 1500);
        let n = poses * per;
        let used: Vec<usize> = (0..6).collect();
        for pose_sd in [0.0, 4.0, 50.0] {
            let mut dr = Draws(2024 + pose_sd as u64);
            let mut covered = 0;
            for _ in 0..draws {
                let (j, cl, inv) = random_design(&mut dr, poses, per);
                // One pose's share of the noise on parameter 0 is about sd / sqrt(per / 12).
                let shift: Vec<f64> = (0..poses)
                    .map(|_| dr.gauss() * pose_sd * 0.01 / (per as f64 / 12.0).sqrt())
                    .collect();
                let r = DVector::from_fn(n, |i, _| dr.gauss() * 0.01 + j[(i, 0)] * shift[i / per]);
                let err = &inv * j.transpose() * &r;
                // The fit's residuals (what the estimator sees), not the draws.
                let res = &r - &j * &err;
                let cov = sandwich(&inv, &j, &res);
                let sums = super::super::Sums::of(&res, &j, &cl, poses);
                let b = Honest::of(Some(&inv), &sums, &[], &used, &cov).bounds();
                let rot = Vector3::new(err[0], err[1], err[2]).norm().to_degrees();
                let tra = Vector3::new(err[3], err[4], err[5]).norm() * 1e3;
                covered += usize::from(rot <= b.rotation_norm_deg && tra <= b.translation_norm_mm);
            }
            let share = covered as f64 / draws as f64;
            assert!(
                (0.93..=0.97).contains(&share),
                "pose error sd {pose_sd}: {share} covered"
            );
        }
    }
}
