//! Scanning on the move (beyond both papers): the profiles' clock offset estimated with the
//! transform. A profile time-stamped on the profiler's clock is placed on the controller's pose log
//! at its stamp plus the stated offset; an error d in that offset puts it where the flange was d
//! later. `Timed` wraps any model with d as one more specimen parameter: every evaluation places
//! the profiles on the log at their times plus d (the same interpolation as the capture file's,
//! so noise-free data fit exactly), and d's Jacobian column is the flange's velocity there.
//!
//! The column needs no model's help: a residual depends on the flange pose F and the transform X
//! only through F X, and F(t + d) = F(t) exp(d xi) with xi the flange's body twist (angular w,
//! linear v), so moving d is moving X to exp(d xi) X: rotation increment R^T w and translation
//! w x t + v, whose columns every model already has.

use super::{Model, Transform, slant::SlantNoise};
use crate::math::{pose_at, velocity_at};
use nalgebra::{DMatrix, DVector, Isometry3, Point3, Vector3};
use rustc_hash::FxHashMap;
use std::sync::{Arc, Mutex};

/// The controller's pose log and the time on it (stated offset applied) of every flange pose the
/// profiles were placed at.
#[derive(Debug)]
pub struct Timeline {
    stream: Vec<(f64, Isometry3<f64>)>,
    times: FxHashMap<PoseKey, f64>,
    /// Whether the profiler's clock may also run at another rate (a drift, s per s, about
    /// `t_ref`, the placed profiles' mean time): one more parameter.
    drift: bool,
    t_ref: f64,
}

type PoseKey = [u64; 7];

fn key(f: &Isometry3<f64>) -> PoseKey {
    let (t, q) = (f.translation.vector, f.rotation.coords);
    [t.x, t.y, t.z, q.x, q.y, q.z, q.w].map(f64::to_bits)
}

impl Timeline {
    /// From the log and each placed profile's (flange pose, time on the log). Profiles at one
    /// pose share its first time: two at one pose at different times are an arm standing still,
    /// whose velocity there is zero either way.
    pub fn new(
        stream: Vec<(f64, Isometry3<f64>)>,
        placed: impl IntoIterator<Item = (Isometry3<f64>, f64)>,
        drift: bool,
    ) -> Timeline {
        let mut times = FxHashMap::default();
        let (mut sum, mut n) = (0.0, 0usize);
        for (f, t) in placed {
            times.entry(key(&f)).or_insert(t);
            sum += t;
            n += 1;
        }
        Timeline {
            stream,
            times,
            drift,
            t_ref: sum / n.max(1) as f64,
        }
    }

    /// The time a profile placed at `t` is at under `clock` (shift s, drift s per s).
    fn shifted(&self, t: f64, clock: &[f64; 2]) -> f64 {
        t + clock[0] + clock[1] * (t - self.t_ref)
    }

    /// The clock's parameters: the shift, and the drift where it is estimated.
    fn n_params(&self) -> usize {
        1 + self.drift as usize
    }

    /// The log's pose at `t`, held at its first or last sample outside it.
    fn pose(&self, t: f64) -> Isometry3<f64> {
        let (first, last) = (self.stream[0], self.stream[self.stream.len() - 1]);
        pose_at(&self.stream, t.clamp(first.0, last.0)).unwrap_or(first.1)
    }

    /// Whether every placed profile stays within the log under `clock` (shift s, drift s per
    /// s): beyond it a profile is held at the log's first or last pose, not placed.
    pub fn covers(&self, clock: &[f64; 2]) -> bool {
        let (first, last) = (self.stream[0].0, self.stream[self.stream.len() - 1].0);
        self.times
            .values()
            .all(|t| (first..=last).contains(&self.shifted(*t, clock)))
    }
}

/// A pose `Timed` does not place (not on the log): it stays where it was recorded.
const NOT_PLACED: u32 = u32::MAX;

/// A model whose profiles' clock shift d (s) is its last specimen parameter.
#[derive(Debug)]
pub struct Timed<M: Model> {
    base: M,
    line: Arc<Timeline>,
    /// Distinct flange poses of `base` and their times at the stated offset (None: not placed
    /// by time; it stays where it is).
    slots: Vec<(Isometry3<f64>, Option<f64>)>,
    slot_of: FxHashMap<PoseKey, u32>,
    /// Each residual's slot.
    residual_slot: Vec<u32>,
    /// The slot of each pose in the order `Model::map_poses` visits them (`NOT_PLACED`: none),
    /// learnt at the first placement.
    visits: std::sync::OnceLock<Vec<u32>>,
    /// The base model placed for the last clock evaluated: Levenberg-Marquardt evaluates the
    /// Jacobian where it just evaluated an accepted step, and placing moves every point's pose.
    last: Mutex<Option<([u64; 2], Arc<M>)>>,
}

impl<M: Model> Clone for Timed<M> {
    fn clone(&self) -> Timed<M> {
        Timed {
            base: self.base.clone(),
            line: self.line.clone(),
            slots: self.slots.clone(),
            slot_of: self.slot_of.clone(),
            residual_slot: self.residual_slot.clone(),
            visits: self.visits.clone(),
            last: Mutex::new(None),
        }
    }
}

impl<M: Model> Timed<M> {
    /// The Jacobian `j` of the base model placed at the clock (`base_rows` writes its columns)
    /// with the clock's columns after them.
    fn with_clock_columns(
        &self,
        x: &Transform,
        s: &(M::Specimen, [f64; 2]),
        j: &mut DMatrix<f64>,
        base_rows: impl FnOnce(&M, &mut DMatrix<f64>),
    ) {
        let model = self.placed_model(&s.1);
        // The base model's columns into the first columns of j's storage (column-major: they
        // are its first n p entries), then the clock's after them.
        let extra = self.line.n_params();
        let (n, p) = (j.nrows(), j.ncols() - extra);
        let mut data: Vec<f64> = std::mem::replace(j, DMatrix::zeros(0, 0)).data.into();
        data.truncate(n * p);
        let mut inner = DMatrix::from_vec(n, p, data);
        base_rows(model.as_ref(), &mut inner);
        let twists: Vec<(Vector3<f64>, Vector3<f64>)> = self
            .slots
            .iter()
            .map(|(_, t)| {
                let (w, v) = t.map_or((Vector3::zeros(), Vector3::zeros()), |t| {
                    velocity_at(&self.line.stream, self.line.shifted(t, &s.1))
                });
                (x.rot.inverse() * w, w.cross(&x.t) + v)
            })
            .collect();
        let mut data: Vec<f64> = inner.data.into();
        // Written after the base columns in the same storage (its capacity is already there).
        for k in 0..n {
            let (a, b) = twists[self.residual_slot[k] as usize];
            let v = (0..3)
                .map(|c| data[c * n + k] * a[c] + data[(3 + c) * n + k] * b[c])
                .sum::<f64>();
            data.push(v);
        }
        // The drift's column: the shift's times the time from the reference.
        if self.line.drift {
            for k in 0..n {
                let slot = self.residual_slot[k] as usize;
                let c = data[p * n + k];
                data.push(
                    self.slots[slot]
                        .1
                        .map_or(0.0, |t| c * (t - self.line.t_ref)),
                );
            }
        }
        *j = DMatrix::from_vec(n, p + extra, data);
    }

    /// None when a flange pose of `base` is not on `line` (not placed by time), or the model
    /// does not say which pose each residual is from.
    pub fn new(base: M, line: Arc<Timeline>) -> Option<Timed<M>> {
        let t = Timed::build(base, line);
        let placed = t.slots.iter().all(|(_, time)| time.is_some());
        (placed && t.residual_slot.len() == t.base.n_residuals()).then_some(t)
    }

    fn build(base: M, line: Arc<Timeline>) -> Timed<M> {
        let (mut slots, mut slot_of) = (Vec::new(), FxHashMap::default());
        let mut residual_slot = Vec::with_capacity(base.n_residuals());
        for f in base.residual_flanges() {
            let k = key(f);
            let slot = *slot_of.entry(k).or_insert_with(|| {
                slots.push((*f, line.times.get(&k).copied()));
                (slots.len() - 1) as u32
            });
            residual_slot.push(slot);
        }
        Timed {
            base,
            line,
            slots,
            slot_of,
            residual_slot,
            visits: std::sync::OnceLock::new(),
            last: Mutex::new(None),
        }
    }

    /// `placed`'s model, kept for the next call with the same clock; placed again in place
    /// when no evaluation holds it (`Model::map_poses_into`).
    fn placed_model(&self, clock: &[f64; 2]) -> Arc<M> {
        let bits = clock.map(f64::to_bits);
        let mut last = self.last.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((b, m)) = last.as_mut() {
            if *b == bits {
                return m.clone();
            }
            if let Some(inner) = Arc::get_mut(m) {
                let poses = self.slot_poses(clock);
                self.base.map_poses_into(&mut self.mapper(&poses), inner);
                *b = bits;
                return m.clone();
            }
        }
        let m = Arc::new(self.placed(clock).0);
        *last = Some((bits, m.clone()));
        m
    }

    /// Each slot's pose at the times `clock` gives.
    fn slot_poses(&self, clock: &[f64; 2]) -> Vec<Isometry3<f64>> {
        self.slots
            .iter()
            .map(|(f, t)| t.map_or(*f, |t| self.line.pose(self.line.shifted(t, clock))))
            .collect()
    }

    /// A recorded pose's slot: read off `visits` in the order the base model visits its poses
    /// once they are known, else looked up (runs of points share a pose: the last one is
    /// remembered).
    fn slotter(&self) -> impl FnMut(&Isometry3<f64>) -> u32 + '_ {
        let known = self.visits.get();
        let (mut k, mut last) = (0, None::<(Isometry3<f64>, u32)>);
        move |f| {
            let slot = match known.and_then(|v| v.get(k)) {
                Some(&s) => s,
                None => match last {
                    Some((from, s)) if from == *f => s,
                    _ => self.slot_of.get(&key(f)).copied().unwrap_or(NOT_PLACED),
                },
            };
            (k, last) = (k + 1, Some((*f, slot)));
            slot
        }
    }

    /// A recorded pose to its slot's pose in `poses`.
    fn mapper<'a>(
        &'a self,
        poses: &'a [Isometry3<f64>],
    ) -> impl FnMut(&Isometry3<f64>) -> Isometry3<f64> + 'a {
        let mut slot = self.slotter();
        move |f| poses.get(slot(f) as usize).copied().unwrap_or(*f)
    }

    /// The base model with its poses placed at the times `clock` gives, and each slot's pose;
    /// the first placement learns the order the model visits its poses in (`visits`).
    fn placed(&self, clock: &[f64; 2]) -> (M, Vec<Isometry3<f64>>) {
        let poses = self.slot_poses(clock);
        let learn = self.visits.get().is_none();
        let (mut slot, mut visits) = (self.slotter(), Vec::new());
        let model = self.base.map_poses(&mut |f| {
            let s = slot(f);
            if learn {
                visits.push(s);
            }
            poses.get(s as usize).copied().unwrap_or(*f)
        });
        if learn {
            let _ = self.visits.set(visits);
        }
        (model, poses)
    }
}

impl<M: Model + 'static> Model for Timed<M> {
    /// The base model's specimen and the clock: its shift (s) and drift (s per s; 0 unless
    /// estimated).
    type Specimen = (M::Specimen, [f64; 2]);

    fn name(&self) -> &'static str {
        self.base.name()
    }
    fn n_specimen_params(&self) -> usize {
        self.base.n_specimen_params() + self.line.n_params()
    }
    fn n_features(&self) -> usize {
        self.base.n_features()
    }
    fn residuals_per_feature(&self) -> usize {
        self.base.residuals_per_feature()
    }
    fn n_residuals(&self) -> usize {
        self.base.n_residuals()
    }
    fn scale_runs(&self) -> Vec<usize> {
        self.base.scale_runs()
    }
    fn labels(&self, x: &Transform, s: &Self::Specimen) -> Vec<f64> {
        self.base.labels(x, &s.0)
    }

    fn eval(
        &self,
        x: &Transform,
        s: &Self::Specimen,
        labels: &[f64],
        r: &mut DVector<f64>,
        j: Option<&mut DMatrix<f64>>,
    ) {
        let Some(j) = j else {
            self.placed_model(&s.1).eval(x, &s.0, labels, r, None);
            return;
        };
        self.with_clock_columns(x, s, j, |m, inner| m.eval(x, &s.0, labels, r, Some(inner)));
    }

    fn has_covariance_rows(&self) -> bool {
        self.base.has_covariance_rows()
    }

    fn covariance_rows(
        &self,
        x: &Transform,
        s: &Self::Specimen,
        labels: &[f64],
        r: &mut DVector<f64>,
        j: &mut DMatrix<f64>,
    ) {
        self.with_clock_columns(x, s, j, |m, inner| {
            m.covariance_rows(x, &s.0, labels, r, inner)
        });
    }

    fn step(&self, s: &Self::Specimen, dx: &[f64]) -> Self::Specimen {
        let k = self.base.n_specimen_params();
        let drift = if self.line.drift { dx[k + 1] } else { 0.0 };
        (
            self.base.step(&s.0, &dx[..k]),
            [s.1[0] + dx[k], s.1[1] + drift],
        )
    }

    fn centre(&self, s: &Self::Specimen) -> Option<Point3<f64>> {
        self.base.centre(&s.0)
    }

    /// The weights from the residuals where the profiles are now placed; the model keeps the
    /// poses as recorded.
    fn reweighted(&self, x: &Transform, s: &Self::Specimen) -> Option<(Self, SlantNoise)> {
        let (placed, poses) = self.placed(&s.1);
        let (weighted, noise) = placed.reweighted(x, &s.0)?;
        let back: FxHashMap<PoseKey, Isometry3<f64>> = poses
            .iter()
            .zip(&self.slots)
            .map(|(to, (from, _))| (key(to), *from))
            .collect();
        let base = weighted.map_poses(&mut |f| back.get(&key(f)).copied().unwrap_or(*f));
        Some((Timed::build(base, self.line.clone()), noise))
    }

    fn residual_flanges(&self) -> Vec<&Isometry3<f64>> {
        self.base.residual_flanges()
    }
    fn clusters(&self) -> Vec<u32> {
        self.base.clusters()
    }
    fn orientation_groups(&self) -> Vec<u32> {
        self.base.orientation_groups()
    }

    fn without_poses(&self, drop: &dyn Fn(&Isometry3<f64>) -> bool) -> Self {
        Timed::build(self.base.without_poses(drop), self.line.clone())
    }

    fn radius(&self) -> Option<f64> {
        self.base.radius()
    }

    fn with_radius(&self, radius: f64) -> Option<Self> {
        Some(Timed::build(
            self.base.with_radius(radius)?,
            self.line.clone(),
        ))
    }

    fn map_poses(&self, to: &mut dyn FnMut(&Isometry3<f64>) -> Isometry3<f64>) -> Self {
        // The mapped poses keep their times.
        let placed = self
            .slots
            .iter()
            .filter_map(|(f, t)| t.map(|t| (to(f), t)))
            .collect::<Vec<_>>();
        let line = Timeline::new(self.line.stream.clone(), placed, self.line.drift);
        Timed::build(self.base.map_poses(to), Arc::new(line))
    }

    fn clock_shift(&self, s: &Self::Specimen) -> Option<(f64, Option<f64>)> {
        Some((s.1[0], self.line.drift.then_some(s.1[1])))
    }

    fn timed_problem(
        &self,
        _s: &Self::Specimen,
        _line: Arc<Timeline>,
    ) -> Option<Arc<dyn super::Refinable>> {
        None
    }
}

/// The clock shift a fit estimated, with its uncertainty.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClockFit {
    /// The profiles' clock shift from the stated offset (s): their true times are the stamps plus
    /// the stated offset plus this.
    pub shift_s: f64,
    /// Its standard deviation (s): the larger of the residual-level and the flange-pose-clustered
    /// sandwich (a robot's pose error moves a pose's points together).
    pub sd_s: f64,
    /// The share of the shift's effect on the residuals that no other parameter can take (0-1:
    /// the sine of the angle between its Jacobian column and the others' span). Near 0 the motion
    /// cannot tell a clock shift from a moved specimen or mounting.
    pub separation: f64,
    /// How fast (m/s) the points move with the shift in what no other parameter takes, on the
    /// translation's scale: next to the flange's speed, near 0 where the motion moves the points
    /// along the specimen only (a plane scanned along itself).
    pub visible_speed: f64,
    /// The profiler's clock's drift against the controller's (s per s, and its sd) about the
    /// profiles' mean time, where it was estimated: the shift holds at that time.
    pub drift: Option<(f64, f64)>,
    /// Where the shift was not estimated (held as stated, or undetermined): how far the fit's
    /// transform moves per second of shift its data hold (rotation rad, translation m): the
    /// bias an offset error leaves, which no bound includes.
    pub bias_per_s: Option<[f64; 6]>,
    /// Where the offset was held because its estimate (this shift, s) would place a profile
    /// beyond the pose log's span, with no logged pose to put it at.
    pub off_log: Option<f64>,
    /// Where the features were found again at the poses an estimated shift gives (this shift,
    /// s): the problem's poses are then the log's at each stamp plus the stated offset plus it.
    pub replaced_at: Option<f64>,
}

/// How the least-squares transform moves per second of clock shift the data hold while the fit
/// holds it at none: the transform part of A_oo^-1 A_od (A = J^T J of the timed `problem` at
/// `x`, o its other parameters, d the shift, its last). None where A_oo is singular.
pub fn bias_per_second(problem: &dyn super::Refinable, x: &Isometry3<f64>) -> Option<[f64; 6]> {
    let a = problem.sums(x).ata;
    let k = a.nrows().checked_sub(1)?;
    let others: Vec<usize> = (0..k).filter(|&c| c < 6 || a[(c, c)] != 0.0).collect();
    let aoo = a.select_rows(&others).select_columns(&others);
    let aod = DVector::from_fn(others.len(), |i, _| a[(others[i], k)]);
    let s = aoo.cholesky()?.solve(&aod);
    s.iter()
        .all(|v| v.is_finite())
        .then(|| std::array::from_fn(|i| s[i]))
}

/// The figures of a fit of `n_params` parameters whose last are the clock's (the shift, then
/// the drift when estimated), from its sums and normal matrix.
pub(super) fn clock_fit(
    (shift_s, drift): (f64, Option<f64>),
    n_params: usize,
    sums: &super::Sums,
    normal: &super::Normal,
) -> ClockFit {
    let index = n_params - 1 - drift.is_some() as usize;
    let (sd_s, separation, visible_speed) = parameter_figures(index, sums, normal);
    ClockFit {
        shift_s,
        sd_s,
        separation,
        visible_speed,
        drift: drift.map(|d| (d, parameter_figures(index + 1, sums, normal).0)),
        bias_per_s: None,
        off_log: None,
        replaced_at: None,
    }
}

/// Parameter `index`'s sd (the larger of the residual-level and the pose-clustered sandwich),
/// the share of its column no other takes, and that share's size on the translation's scale
/// (infinite sd and zeros where the fit does not use it).
fn parameter_figures(index: usize, sums: &super::Sums, normal: &super::Normal) -> (f64, f64, f64) {
    let unknown = (f64::INFINITY, 0.0, 0.0);
    let (used, n) = (&normal.used, sums.n);
    let (Some(k), Some(inv)) = (used.iter().position(|&c| c == index), normal.inverse()) else {
        return unknown;
    };
    let p = used.len();
    if n <= p {
        return unknown;
    }
    let row = inv.row(k);
    let quad = |m: &DMatrix<f64>| (&row * m * row.transpose())[(0, 0)];
    let meat = sums.meat.select_rows(used).select_columns(used);
    let residual = quad(&meat) * n as f64 / (n - p) as f64;
    let g = sums.scores.nrows();
    let clustered = if g >= 2 {
        let scores = sums.scores.select_columns(used);
        quad(&(scores.transpose() * &scores))
            * (g as f64 / (g - 1) as f64)
            * ((n - 1) as f64 / (n - p) as f64)
    } else {
        0.0
    };
    let translation = (3..6).map(|c| sums.ata[(c, c)]).sum::<f64>() / 3.0;
    (
        residual.max(clustered).max(0.0).sqrt(),
        (1.0 / (inv[(k, k)] * sums.ata[(index, index)]))
            .clamp(0.0, 1.0)
            .sqrt(),
        (1.0 / (inv[(k, k)] * translation)).max(0.0).sqrt(),
    )
}
