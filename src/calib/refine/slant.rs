//! How far to trust points on a surface the sensor sees at a slant (a specimen's side wall), read
//! from the fit's own residuals (beyond both papers).
//!
//! A profiler's noise moves a point mostly along its depth (sensor z). A point on a wall nearly
//! parallel to z then moves along the wall: its distance from the wall spreads by sigma |n . z|
//! only, and it locates the wall far better than a face point locates the face. How much better
//! depends on what else moves the point across the wall, which the declared z noise does not say:
//! jitter along x, noise following the camera's line of sight rather than z, the wall's own form
//! error. So each residual's spread is modelled as sigma sqrt(u + kappa^2), u = (n . z)^2, with one
//! kappa for every such point, estimated by maximum likelihood from the residuals of a first fit
//! (with a cautious kappa). The face points (u near 1, hundreds per profile) fix sigma; the wall
//! points fix kappa. A sensor whose noise is along z alone gets weights near 1 / |n . z|; one with
//! x noise or line-of-sight noise a larger kappa and weights no larger than its data support.

/// kappa before the residuals are read (`method::wall_points`), and its upper end: 0.3 held most
/// of the gain over no weighting and stays cautious under noise along the line of sight.
pub const KAPPA_START: f64 = 0.3;
/// kappa's lower end: weights at most 100 times a face point's, so that the sums of the normal
/// equations keep their precision and one point cannot pin a wall.
pub const KAPPA_MIN: f64 = 0.01;
/// Residuals beyond this many of their own modelled spreads are left out of the estimate (a face
/// point taken for a wall's, a speck): Gaussian noise puts 6e-5 of its points there.
const TRIM: f64 = 4.0;
/// Fewest wall residuals kappa is estimated from; with fewer it stays at `KAPPA_START`.
pub const MIN_WALL_POINTS: usize = 20;

/// A residual (m, unweighted: the point's distance from its surface) with u = (n . z)^2, n the
/// surface's normal and z the sensor's depth direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Slanted {
    pub residual: f64,
    pub u: f64,
}

/// What `estimate` found: kappa, the face's noise sigma (m) and how many residuals each came from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlantNoise {
    pub kappa: f64,
    pub sigma: f64,
    pub face_points: usize,
    pub wall_points: usize,
}

impl SlantNoise {
    /// The weight that scales a residual with this u to the face's noise (a face point's is
    /// about 1).
    pub fn weight(&self, u: f64) -> f64 {
        weight(u, self.kappa)
    }

    /// Whether a residual lies within `TRIM` of its modelled spread: a point beyond it is not
    /// the surface's (a face point taken for a wall's, a speck), and would pull with its full
    /// weight.
    pub fn fits(&self, s: &Slanted) -> bool {
        s.residual * s.residual
            <= TRIM * TRIM * self.sigma * self.sigma * (s.u + self.kappa * self.kappa)
    }
}

/// 1 / sqrt(u + kappa^2): a residual's spread in units of sigma, inverted.
pub fn weight(u: f64, kappa: f64) -> f64 {
    1.0 / (u + kappa * kappa).sqrt()
}

/// kappa and sigma from the residuals of a fit (`Slanted`), or None when there are too few wall
/// points (`MIN_WALL_POINTS`) or face points to say. sigma is the face points' root mean square
/// scaled by their u (trimmed at `TRIM` of a robust first spread); kappa maximises the wall points'
/// likelihood given sigma, trimmed likewise, within [`KAPPA_MIN`, `KAPPA_START`].
pub fn estimate(face: &[Slanted], walls: &[Slanted]) -> Option<SlantNoise> {
    if walls.len() < MIN_WALL_POINTS || face.len() < MIN_WALL_POINTS {
        return None;
    }
    let scaled = |s: &Slanted, kappa: f64| s.residual * s.residual / (s.u + kappa * kappa);
    // A robust first spread: the median of a chi-square with one degree of freedom is 0.4549.
    let mut z2: Vec<f64> = face.iter().map(|s| scaled(s, KAPPA_MIN)).collect();
    let mid = z2.len() / 2;
    let median = *z2.select_nth_unstable_by(mid, f64::total_cmp).1;
    let first = median / 0.4549;
    let (sum, kept) = face
        .iter()
        .map(|s| scaled(s, KAPPA_MIN))
        .filter(|v| *v <= TRIM * TRIM * first)
        .fold((0.0, 0usize), |(a, n), v| (a + v, n + 1));
    let sigma2 = sum / kept.max(1) as f64;
    if !(sigma2 > 0.0 && sigma2.is_finite()) {
        return None;
    }
    // The wall points' negative log likelihood in kappa (sigma fixed), over the points within
    // TRIM spreads at the cautious kappa: a point out of the model must not widen it.
    let inliers: Vec<Slanted> = walls
        .iter()
        .filter(|s| scaled(s, KAPPA_START) <= TRIM * TRIM * sigma2)
        .copied()
        .collect();
    if inliers.len() < MIN_WALL_POINTS {
        return None;
    }
    let nll = |log_kappa: f64| {
        let k2 = (2.0 * log_kappa).exp();
        inliers
            .iter()
            .map(|s| (s.u + k2).ln() + s.residual * s.residual / (sigma2 * (s.u + k2)))
            .sum::<f64>()
    };
    // A grid over log kappa, then golden-section search about its best point: the likelihood
    // may have more than one dip on a coarse grid, never within one grid step.
    let (lo, hi) = (KAPPA_MIN.ln(), KAPPA_START.ln());
    const STEPS: usize = 24;
    let at = |i: usize| lo + (hi - lo) * i as f64 / STEPS as f64;
    let best = (0..=STEPS)
        .map(|i| (i, nll(at(i))))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(0, |b| b.0);
    let (mut a, mut b) = (at(best.saturating_sub(1)), at((best + 1).min(STEPS)));
    let g = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..40 {
        let (c, d) = (b - g * (b - a), a + g * (b - a));
        if nll(c) < nll(d) {
            b = d;
        } else {
            a = c;
        }
    }
    Some(SlantNoise {
        kappa: ((a + b) / 2.0).exp().clamp(KAPPA_MIN, KAPPA_START),
        sigma: sigma2.sqrt(),
        face_points: kept,
        wall_points: inliers.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::gauss;
    use rand::RngExt;

    /// Residuals of a sensor whose wall points spread by sigma sqrt(u + kappa^2).
    fn draw(kappa: f64, seed: u64) -> (Vec<Slanted>, Vec<Slanted>) {
        let mut r = crate::rng::stream(seed, &[]);
        let sigma = 0.05e-3;
        let face = (0..5000)
            .map(|_| {
                let u: f64 = 0.8 + 0.2 * r.random::<f64>();
                Slanted {
                    residual: sigma * (u + kappa * kappa).sqrt() * gauss(&mut r),
                    u,
                }
            })
            .collect();
        let walls = (0..2000)
            .map(|_| {
                let u = (0.3 * r.random::<f64>()).powi(2);
                Slanted {
                    residual: sigma * (u + kappa * kappa).sqrt() * gauss(&mut r),
                    u,
                }
            })
            .collect();
        (face, walls)
    }

    #[test]
    fn kappa_is_recovered_from_residuals_it_shaped() {
        for (kappa, seed) in [(0.02, 1), (0.05, 2), (0.1, 3), (0.2, 4)] {
            let (face, walls) = draw(kappa, seed);
            let e = estimate(&face, &walls).unwrap();
            assert!(
                (e.kappa / kappa - 1.0).abs() < 0.15,
                "kappa {kappa}: estimated {}",
                e.kappa
            );
            assert!((e.sigma / 0.05e-3 - 1.0).abs() < 0.05, "sigma {}", e.sigma);
        }
    }

    #[test]
    fn kappa_stays_in_its_bounds_and_outliers_do_not_widen_it() {
        // Noise along z alone: the lower end.
        let (face, walls) = draw(0.0, 5);
        let at_end = |k: f64, end: f64| (k / end - 1.0).abs() < 1e-6;
        let k = estimate(&face, &walls).unwrap().kappa;
        assert!(at_end(k, KAPPA_MIN), "{k}");
        // Noise as large across the wall as along it: the cautious end.
        let (face, walls) = draw(1.0, 6);
        let k = estimate(&face, &walls).unwrap().kappa;
        assert!(at_end(k, KAPPA_START), "{k}");
        // One wall point in fifty a millimetre off.
        let (face, mut walls) = draw(0.05, 7);
        for w in walls.iter_mut().step_by(50) {
            w.residual = 1e-3;
        }
        let e = estimate(&face, &walls).unwrap();
        assert!((e.kappa / 0.05 - 1.0).abs() < 0.15, "{}", e.kappa);
    }

    #[test]
    fn too_few_wall_points_leave_kappa_unestimated() {
        let (face, walls) = draw(0.05, 8);
        assert!(estimate(&face, &walls[..MIN_WALL_POINTS - 1]).is_none());
        assert!(estimate(&face[..3], &walls).is_none());
    }
}
