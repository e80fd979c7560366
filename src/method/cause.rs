//! The likely cause of a result judged suspect: the verdict says what the data show, not the
//! first check that tripped. Each gross mistake a capture file can hold (poses and profiles paired
//! one record apart, positions in metres, quaternions in x, y, z, w order, Euler angles in
//! radians or in another order, profiles mirrored in x, the other edge sense, a wrong specimen
//! size) is undone in turn and the kept variant re-run;
//! a correction that makes the model fit `CLEARLY_BETTER` times better and no longer suspect
//! names the cause. Refits cost one calibration each and run only for suspect results.

use super::verdict::{Assessed, CLEARLY_BETTER, Verdict, assess, assess_within, within_bounds};
use crate::captures::{CaptureProfile, Captures, ProfileData};
use crate::features::EdgeSense;
use crate::sensor::SensorModel;
use nalgebra::{Quaternion, UnitQuaternion, Vector2};

/// The mistakes that move poses against profiles or profiles themselves: each can stop a
/// variant running (a group no longer at one orientation, a scan of the wrong length).
const MOVES: [Mistake; 5] = [
    Mistake::Pairing(1),
    Mistake::Pairing(-1),
    Mistake::Metres,
    Mistake::QuaternionXyzw,
    Mistake::Mirrored,
];

/// The Euler mistakes: they turn every pose by a rule of its orientation alone, so poses that
/// shared an orientation still share one (no refused variant runs after undoing them).
const TURNS: [Mistake; 3] = [
    Mistake::RadiansAsDegrees,
    Mistake::EulerSwapped,
    Mistake::EulerProductOrder,
];

/// The iteration cap of a refit's censored features (a bar's edges, a disk's rim from any
/// poses), against `calib::refine::CENSORED_ITERATIONS` for a result: only the refit's residuals
/// are compared, and a correction that is not the cause can creep to the cap (the kit's
/// gross-mistake test 107.6 -> 96.0 s with this cap, its table unchanged; docs/verdict.md).
/// A capture whose disk scans are inferred (`disk::inferred_scans`) and a fit of the clock
/// offset keep the full cap.
const REFIT_ITERATIONS: usize = 100;

/// The farthest a flange can be from the robot's base (m): no serial arm reaches 10 m.
const MAX_REACH_M: f64 = 10.0;

/// A gross mistake in a capture file, named by what the file got wrong.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mistake {
    /// Each profile was given the pose of the record after it (+1) or before it (-1).
    Pairing(i8),
    /// Positions in metres where the file wants millimetres.
    Metres,
    /// Quaternions in x, y, z, w order where the file wants w, x, y, z.
    QuaternionXyzw,
    /// Orientation angles in radians where the list wants degrees.
    RadiansAsDegrees,
    /// Euler angles listed in the other order: KUKA's A, B, C (about z, y, x) read as FANUC's
    /// W, P, R (about x, y, z), or the other way round.
    EulerSwapped,
    /// Euler angles that compose the other way: R = Rx Ry Rz (moving axes) read as Rz Ry Rx.
    EulerProductOrder,
    /// Profiles mirrored in x (a sensor frame turned 180 deg about its z, or x read reversed).
    Mirrored,
    /// The other edge sense.
    EdgeSense,
    /// The specimen's radius is this factor of the file's.
    Radius(f64),
}

impl Mistake {
    /// What the data show and how to check it, with the improvement that shows it.
    fn explain(&self, caps: &Captures, method: super::MethodId, before: f64, after: f64) -> String {
        self.explain_with(
            caps,
            &format!(
                "with that undone {method} fits {:.0} times better (residual RMS {before:.4} -> \
                 {after:.4} mm)",
                before / after
            ),
        )
    }

    /// What the data show (`fit`: the evidence) and how to check it.
    fn explain_with(&self, caps: &Captures, fit: &str) -> String {
        match *self {
            Mistake::Pairing(k) => format!(
                "likely cause: poses and profiles are paired one record apart (each profile's pose \
                 is that of the record {}): {fit}; check how poses and profiles were matched \
                 (timestamps, a skipped or repeated record)",
                if k > 0 { "after it" } else { "before it" }
            ),
            Mistake::Metres => format!(
                "likely cause: the positions are in metres, not millimetres: {fit}; give \
                 tcp_position_mm in millimetres"
            ),
            Mistake::QuaternionXyzw => format!(
                "likely cause: the quaternions are in x, y, z, w order: {fit}; give \
                 tcp_quaternion_wxyz as w, x, y, z (ABB RAPID order; ROS and Eigen write x, y, z, w)"
            ),
            Mistake::RadiansAsDegrees => format!(
                "likely cause: the poses' orientation angles are in radians, not degrees: {fit}; \
                 give them in degrees (or a list whose convention says _rad)"
            ),
            Mistake::EulerSwapped => format!(
                "likely cause: the Euler angles are listed in the other order (KUKA's A, B, C, \
                 about z, y, x, read as W, P, R, about x, y, z, or the other way round): {fit}; \
                 check the pose list's convention (tcp_mm_abc_deg against tcp_mm_wpr_deg)"
            ),
            Mistake::EulerProductOrder => format!(
                "likely cause: the Euler angles compose the other way (R = Rx Ry Rz, about moving \
                 axes, read as R = Rz Ry Rx): {fit}; convert the poses to R = Rz(r) Ry(p) Rx(w) \
                 or give quaternions"
            ),
            Mistake::Mirrored => format!(
                "likely cause: the profiles are mirrored in x (the labels fit a sensor turned \
                 180 deg about its z): {fit}; check the sensor's x direction against its data \
                 sheet and the exporter's settings"
            ),
            Mistake::EdgeSense => format!(
                "likely cause: the edge sense is the other one ({}): {fit}; set edge_sense",
                match caps.edge_sense {
                    Some(EdgeSense::Falling) => "rising, not falling",
                    _ => "falling, not rising",
                }
            ),
            Mistake::Radius(f) => {
                let r = caps.specimen_radius.unwrap_or(f64::NAN) * 1e3;
                format!(
                    "likely cause: the specimen's size: the data fit a radius of {:.2} mm best, \
                     the file says {r:.2} mm: {fit}; measure the specimen and check its kind",
                    r * f
                )
            }
        }
    }

    /// The captures with this mistake undone; None where it cannot apply.
    pub fn undo(&self, caps: &Captures) -> Option<Captures> {
        let mut c = caps.clone();
        match *self {
            Mistake::Pairing(k) => {
                let n = c.profiles.len();
                if n < 3 {
                    return None;
                }
                // Profile i takes the pose recorded with profile i - k; the one left without a
                // pose is dropped.
                let poses: Vec<_> = caps.profiles.iter().map(|p| p.base_to_flange).collect();
                let profiles: Vec<CaptureProfile> = (0..n)
                    .filter_map(|i| {
                        let j = i as i64 - k as i64;
                        (0..n as i64).contains(&j).then(|| CaptureProfile {
                            base_to_flange: poses[j as usize],
                            ..caps.profiles[i].clone()
                        })
                    })
                    .collect();
                c.profiles = profiles;
            }
            Mistake::Metres => {
                // Read as metres, every position lies within 10 m of the base (no arm reaches
                // farther); a file with a flange farther out than 10 mm is in millimetres
                // already, and a refit 1,000 times out only costs time.
                let far = caps
                    .profiles
                    .iter()
                    .map(|p| p.base_to_flange.translation.vector.norm())
                    .fold(0.0, f64::max);
                if !(far * 1e3 <= MAX_REACH_M) {
                    return None;
                }
                for p in &mut c.profiles {
                    p.base_to_flange.translation.vector *= 1e3;
                }
            }
            Mistake::QuaternionXyzw => {
                for p in &mut c.profiles {
                    // The file's (x, y, z, w) was read as (w, x, y, z).
                    let q = p.base_to_flange.rotation.quaternion();
                    let read = [q.w, q.i, q.j, q.k];
                    p.base_to_flange.rotation = UnitQuaternion::from_quaternion(Quaternion::new(
                        read[3], read[0], read[1], read[2],
                    ));
                }
            }
            Mistake::RadiansAsDegrees => {
                // Read as degrees, angles given in radians are at most pi degrees each: a pose
                // turned farther cannot come from that mistake.
                let angles: Vec<(f64, f64, f64)> = caps
                    .profiles
                    .iter()
                    .map(|p| p.base_to_flange.rotation.euler_angles())
                    .collect();
                let most = std::f64::consts::PI.to_radians() * (1.0 + 1e-9);
                if !angles
                    .iter()
                    .all(|&(w, p, r)| w.abs().max(p.abs()).max(r.abs()) <= most)
                {
                    return None;
                }
                let k = 180.0 / std::f64::consts::PI;
                for (p, (w, pp, r)) in c.profiles.iter_mut().zip(angles) {
                    p.base_to_flange.rotation =
                        UnitQuaternion::from_euler_angles(w * k, pp * k, r * k);
                }
            }
            Mistake::EulerSwapped => {
                // The first and the third angle trade places (its own inverse).
                for p in &mut c.profiles {
                    let (w, pp, r) = p.base_to_flange.rotation.euler_angles();
                    p.base_to_flange.rotation = UnitQuaternion::from_euler_angles(r, pp, w);
                }
            }
            Mistake::EulerProductOrder => {
                // Read: Rz(c) Ry(b) Rx(a); meant: Rx(a) Ry(b) Rz(c) = (Rz(-c) Ry(-b) Rx(-a))^-1.
                for p in &mut c.profiles {
                    let (a, b, cc) = p.base_to_flange.rotation.euler_angles();
                    p.base_to_flange.rotation =
                        UnitQuaternion::from_euler_angles(-a, -b, -cc).inverse();
                }
            }
            Mistake::Mirrored => {
                for p in &mut c.profiles {
                    mirror(&mut p.data);
                }
            }
            Mistake::EdgeSense => {
                c.edge_sense = Some(match caps.edge_sense? {
                    EdgeSense::Falling => EdgeSense::Rising,
                    EdgeSense::Rising => EdgeSense::Falling,
                });
            }
            Mistake::Radius(f) => c.specimen_radius = Some(caps.specimen_radius? * f),
        }
        Some(c)
    }
}

/// A profile's data seen by a sensor mirrored in x: columns in reverse order, x negated.
fn mirror(d: &mut ProfileData) {
    let flip = |v: &mut Vector2<f64>| v.x = -v.x;
    match d {
        ProfileData::Raw(p) => {
            p.points.reverse();
            for q in p.points.iter_mut().flatten() {
                q.x = -q.x;
            }
        }
        ProfileData::Chord { a, b } => {
            flip(a);
            flip(b);
            std::mem::swap(a, b);
        }
        ProfileData::Circle(c) => flip(&mut c.centre),
        ProfileData::Arc(ps) => {
            *ps = ps
                .iter()
                .rev()
                .map(|q| {
                    let mut q = *q;
                    flip(&mut q);
                    q
                })
                .collect();
        }
        ProfileData::EdgePoint(v) => flip(v),
    }
}

/// The residual RMS (mm) of `m`'s variant with the mistake undone, when that result is not
/// suspect.
fn refit(caps: &Captures, sensor: &SensorModel, a: &Assessed, m: Mistake) -> Option<f64> {
    let c = m.undo(caps)?;
    let r = assess_within(a.method, &c, sensor, REFIT_ITERATIONS).ok()?;
    (r.judged.verdict != Verdict::Suspect)
        .then_some(r.judged.quality.residual_rms_mm)
        .flatten()
}

/// The radius factor (0.5 to 2) that fits `a`'s variant best: a golden-section search on the
/// residual RMS over the factor's logarithm. None without a radius.
fn best_radius(caps: &Captures, sensor: &SensorModel, a: &Assessed) -> Option<(f64, f64)> {
    caps.specimen_radius?;
    let rms = |lf: f64| {
        Mistake::Radius(lf.exp())
            .undo(caps)
            .and_then(|c| assess_within(a.method, &c, sensor, REFIT_ITERATIONS).ok())
            .and_then(|r| r.judged.quality.residual_rms_mm)
            .unwrap_or(f64::INFINITY)
    };
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut lo, mut hi) = (0.5f64.ln(), 2f64.ln());
    let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut f1, mut f2) = (rms(x1), rms(x2));
    // To a factor within 1 % (the interval shrinks by 0.618 a step: 10 refits).
    while hi - lo > 1e-2 {
        if f1 <= f2 {
            hi = x2;
            (x2, f2) = (x1, f1);
            x1 = hi - g * (hi - lo);
            f1 = rms(x1);
        } else {
            lo = x1;
            (x1, f1) = (x2, f2);
            x2 = lo + g * (hi - lo);
            f2 = rms(x2);
        }
    }
    let f = (0.5 * (lo + hi)).exp();
    refit(caps, sensor, a, Mistake::Radius(f)).map(|r| (f, r))
}

/// The likely cause of `a` being suspect on `caps`: the correction among the gross mistakes that
/// fits clearly best and is not suspect, in words, or None (no residuals to compare, or no
/// correction helps).
pub fn likely_cause(caps: &Captures, sensor: &SensorModel, a: &Assessed) -> Option<String> {
    let before = a.judged.quality.residual_rms_mm?;
    let m = super::method(caps.method);
    let mut tries = [MOVES.as_slice(), TURNS.as_slice()].concat();
    // The any-pose estimators read the edge sense from the data: flipping the label refits the
    // same problem.
    if caps.edge_sense.is_some() && a.method.estimator != super::Estimator::AnyPose {
        tries.push(Mistake::EdgeSense);
    }
    // The refits are independent: side by side, collected in the order above.
    use rayon::prelude::*;
    let mut found: Vec<(Mistake, f64)> = tries
        .into_par_iter()
        .filter_map(|t| refit(caps, sensor, a, t).map(|r| (t, r)))
        .collect();
    if m.needs_radius()
        && let Some((f, r)) = best_radius(caps, sensor, a)
        && (f - 1.0).abs() > 1e-2
    {
        found.push((Mistake::Radius(f), r));
    }
    let (t, after) = found
        .into_iter()
        .filter(|(_, r)| r * CLEARLY_BETTER < before)
        .min_by(|x, y| x.1.total_cmp(&y.1))?;
    Some(t.explain(caps, a.method, before, after))
}

/// The likely cause where the kept result fits but is suspect and variants could not run (the
/// disk's closed form refuses a scan whose poses are paired one record apart: a pose of the next
/// scan's orientation): the correction with which `refused` runs, is not suspect and fits best,
/// in words, or None. Only `MOVES` are tried (a size, a sense or an Euler convention does not
/// stop a variant running).
pub fn lets_run(caps: &Captures, sensor: &SensorModel, refused: super::MethodId) -> Option<String> {
    use rayon::prelude::*;
    let (t, r) = MOVES
        .into_par_iter()
        .filter_map(|t| {
            let r = assess_within(refused, &t.undo(caps)?, sensor, REFIT_ITERATIONS).ok()?;
            (r.judged.verdict != Verdict::Suspect).then_some((t, r.judged.quality.residual_rms_mm?))
        })
        .collect::<Vec<_>>()
        .into_iter()
        .min_by(|x, y| x.1.total_cmp(&y.1))?;
    Some(t.explain_with(
        caps,
        &format!(
            "with that undone {refused}, which could not run, runs and fits (residual RMS {r:.4} \
             mm)"
        ),
    ))
}

/// A held clock offset the data contradict (scanning on the move, the offset taken as stated):
/// the variant (a closed form's refined one) re-run estimating the offset; when it then finds an
/// offset clearly off the stated one (beyond three of its sd) and is no longer suspect, that
/// names the cause. A reason, or None.
pub fn held_clock(caps: &Captures, sensor: &SensorModel, a: &Assessed) -> Option<String> {
    caps.timing.as_ref().filter(|t| !t.estimate_offset)?;
    let mut c = caps.clone();
    c.timing.as_mut()?.estimate_offset = true;
    let id = match a.method.estimator {
        super::Estimator::ClosedForm => {
            super::MethodId::new(a.method.kind, super::Estimator::Refined)
        }
        _ => a.method,
    };
    let b = assess(id, &c, sensor).ok()?;
    let clock = b.refined.as_ref()?.clock?;
    let stated = caps.timing.as_ref()?.offset_s;
    if b.judged.verdict == Verdict::Suspect
        || !clock.sd_s.is_finite()
        || clock.shift_s.abs() <= 3.0 * clock.sd_s
    {
        return None;
    }
    Some(format!(
        "likely cause: the profiles' clock offset: {id} estimating it finds {:+.3} ms (sd {:.3} \
         ms), {:+.3} ms from the stated {:+.3} ms, and is then judged {}; let lasercal estimate \
         it (leave out --hold-clock-offset, or set estimate_clock_offset) or state \
         profile_clock_offset_s = {:.6}",
        (stated + clock.shift_s) * 1e3,
        clock.sd_s * 1e3,
        clock.shift_s * 1e3,
        stated * 1e3,
        b.judged.verdict,
        stated + clock.shift_s
    ))
}

/// Labels that fit the profiles mirrored in x: the any-pose estimators infer the ball's side and
/// the scan's direction from the data, so profiles mirrored in x give them a transform turned
/// 180 deg about the sensor's z that maps every point correctly, and exit ok. The file's labels
/// (group signs, edge sense) tell: when the closed form, which uses them, fits its features
/// `CLEARLY_BETTER` times better on the profiles mirrored back and then agrees with `chosen`
/// turned 180 deg about z, either the profiles are mirrored or every label is the other way
/// round. A reason, or None.
pub fn mirrored_labels(
    caps: &Captures,
    sensor: &SensorModel,
    chosen: &Assessed,
    closed_form: Option<&Assessed>,
) -> Option<String> {
    let m = super::method(caps.method);
    if !(m.uses_group_signs() || caps.edge_sense.is_some())
        || chosen.method.estimator != super::Estimator::AnyPose
    {
        return None;
    }
    let id = super::MethodId::new(caps.method, super::Estimator::ClosedForm);
    // A closed form that agrees with the kept result says the labels fit: no refit needed.
    if closed_form.is_some_and(|cf| {
        cf.judged.verdict != Verdict::Suspect
            && within_bounds(
                &cf.calibration.flange_to_sensor,
                &cf.judged.quality,
                &chosen.calibration.flange_to_sensor,
                &chosen.judged.quality,
            )
    }) {
        return None;
    }
    let before = closed_form
        .filter(|a| a.judged.verdict != Verdict::Suspect)
        .and_then(|a| a.judged.quality.residual_rms_mm)
        .unwrap_or(f64::INFINITY);
    let mirrored = assess(id, &Mistake::Mirrored.undo(caps)?, sensor).ok()?;
    let after = mirrored.judged.quality.residual_rms_mm?;
    if mirrored.judged.verdict == Verdict::Suspect || !(after * CLEARLY_BETTER < before) {
        return None;
    }
    let turned = chosen.calibration.flange_to_sensor
        * nalgebra::UnitQuaternion::from_axis_angle(
            &nalgebra::Vector3::z_axis(),
            std::f64::consts::PI,
        );
    if !within_bounds(
        &mirrored.calibration.flange_to_sensor,
        &mirrored.judged.quality,
        &turned,
        &chosen.judged.quality,
    ) {
        return None;
    }
    let labels = if m.uses_group_signs() {
        "group signs"
    } else {
        "edge sense"
    };
    Some(format!(
        "the file's {labels} fit the profiles mirrored in x: {id}, which uses them, fits \
         {:.0} times better on the profiles mirrored back and then agrees with {} turned 180 deg \
         about the sensor's z. Either the profiles are mirrored (then {}'s sensor frame is the \
         data sheet's turned 180 deg about z: check the sensor's x direction and the exporter's \
         settings) or every label is the other way round",
        if before.is_finite() {
            before / after
        } else {
            f64::INFINITY
        },
        chosen.method,
        chosen.method,
    ))
}
