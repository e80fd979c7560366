//! How well each flange pose's points are predicted from the other poses: the specimen fitted to
//! every other pose's points with the transform held, then this pose's residuals against it. A
//! truth-free figure in the units of the data, by which any two transforms (lasercal's, a
//! vendor's, a colleague's) can be compared on the same recording: a transform that is off
//! predicts the left-out poses worse, while its own in-sample residual can hide it.

use super::honest::pose_key;
use super::{Model, Transform, eval};
use nalgebra::{DMatrix, Isometry3};

/// At most this many poses are left out in turn (each is one specimen fit over the rest).
pub const MAX_POSES: usize = 100;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// RMS over every pose's residuals, each from the specimen fitted without that pose (m).
    pub rms: f64,
    /// The worst-predicted pose's RMS (m) and its index (poses numbered in the order they first
    /// appear in the problem).
    pub worst: f64,
    pub worst_pose: usize,
    pub poses: usize,
}

/// The prediction of `model`'s poses at transform `x`, the specimen fitted from `start`. None with
/// fewer than 3 or more than `MAX_POSES` poses, or when a fit fails (a pose the others cannot do
/// without).
pub fn of<M: Model>(model: &M, start: &M::Specimen, x: &Isometry3<f64>) -> Option<Prediction> {
    let flanges: Vec<Isometry3<f64>> = model.residual_flanges().into_iter().copied().collect();
    if flanges.len() != model.n_residuals() {
        return None;
    }
    let mut poses: Vec<[u64; 7]> = Vec::new();
    for f in &flanges {
        let k = pose_key(f);
        if poses.last() != Some(&k) && !poses.contains(&k) {
            poses.push(k);
        }
        if poses.len() > MAX_POSES {
            return None;
        }
    }
    if poses.len() < 3 {
        return None;
    }
    let xt = Transform::from_isometry(x);
    let all = fit_specimen(model, &xt, start)?;
    let (mut sq, mut n) = (0.0, 0usize);
    let (mut worst, mut worst_pose) = (0.0f64, 0);
    for (i, key) in poses.iter().enumerate() {
        let others = model.without_poses(&|f| pose_key(f) == *key);
        let s = fit_specimen(&others, &xt, &all)?;
        let this = model.without_poses(&|f| pose_key(f) != *key);
        let labels = this.labels(&xt, &s);
        let r = eval(&this, &xt, &s, &labels, false).0;
        let ss = r.norm_squared();
        let rms = (ss / r.len().max(1) as f64).sqrt();
        if rms > worst {
            (worst, worst_pose) = (rms, i);
        }
        sq += ss;
        n += r.len();
    }
    Some(Prediction {
        rms: (sq / n.max(1) as f64).sqrt(),
        worst,
        worst_pose,
        poses: poses.len(),
    })
}

/// The specimen's parameters fitted with the transform held at `x` (Levenberg-Marquardt over the
/// specimen's columns alone). None when its normal matrix is singular throughout.
pub fn fit_specimen<M: Model>(
    model: &M,
    x: &Transform,
    start: &M::Specimen,
) -> Option<M::Specimen> {
    let p = model.n_specimen_params();
    let cost = |s: &M::Specimen| {
        let labels = model.labels(x, s);
        eval(model, x, s, &labels, false).0.norm_squared()
    };
    let mut s = *start;
    let mut c = cost(&s);
    let mut lambda = 1e-4;
    for _ in 0..100 {
        let labels = model.labels(x, &s);
        let (r, j) = eval(model, x, &s, &labels, true);
        let js: DMatrix<f64> = j.columns(6, p).into_owned();
        let a = js.tr_mul(&js);
        let g = js.tr_mul(&r);
        let mut moved = false;
        while lambda < 1e12 {
            let mut damped = a.clone();
            for i in 0..p {
                damped[(i, i)] += lambda * a[(i, i)].max(1e-30);
            }
            let Some(step) = damped.cholesky().map(|ch| ch.solve(&(-&g))) else {
                lambda *= 10.0;
                continue;
            };
            let next = model.step(&s, step.as_slice());
            let cn = cost(&next);
            if cn < c {
                let done = c - cn <= 1e-14 * c.max(1e-300);
                (s, c, moved) = (next, cn, true);
                lambda = (lambda / 10.0).max(1e-12);
                if done {
                    return Some(s);
                }
                break;
            }
            lambda *= 10.0;
        }
        if !moved {
            return Some(s);
        }
    }
    Some(s)
}
