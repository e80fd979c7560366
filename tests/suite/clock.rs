//! The profiles' clock offset estimated with the transform (`calib::refine::timed`), on the
//! independent generator's random rigs scanned on the move (`testkit::pose_log`): each pose
//! passed through at its own steady twist, its profile ray-cast where the log puts the flange at
//! the profile's true time, and time-stamped late by a clock offset the capture does not state.

use crate::any_pose::{Setup, random_bar_setup, random_plane_setup, random_setup};
use crate::common;
use lasercal::calib::PoseError;
use lasercal::captures::Timing;
use lasercal::math::pose_at;
use lasercal::method::{Estimator, Kind, MethodId};
use lasercal::rng::{Rng, gauss};
use lasercal::testkit::fan::{Noise, profile};
use lasercal::testkit::pose_log;
use nalgebra::{Isometry3, Vector3};
use rand::RngExt;

fn uniform(rng: &mut Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

/// A random vector of length `lo`-`hi`.
fn random_vector(rng: &mut Rng, lo: f64, hi: f64) -> Vector3<f64> {
    let d = Vector3::new(gauss(rng), gauss(rng), gauss(rng)).normalize();
    d * uniform(rng, lo, hi)
}

/// `s` scanned on the move: pose i passed at time i s with `twist(rng, pose)` (angular rad/s,
/// linear m/s, in the flange frame), its profile taken up to 5 ms either side and time-stamped
/// `late_s` late; the capture placed by the stamps with no offset stated.
fn on_the_move(
    s: Setup,
    seed: u64,
    late_s: f64,
    sigma: f64,
    twist: &dyn Fn(&mut Rng, &Isometry3<f64>) -> (Vector3<f64>, Vector3<f64>),
) -> Setup {
    drifting(s, seed, late_s, 0.0, sigma, twist)
}

/// `on_the_move` with the profiler's clock also running fast by `rate` (s per s) about the
/// stamps' mean: a profile stamped at u was taken at u - late - rate (u - mean).
fn drifting(
    mut s: Setup,
    seed: u64,
    late_s: f64,
    rate: f64,
    sigma: f64,
    twist: &dyn Fn(&mut Rng, &Isometry3<f64>) -> (Vector3<f64>, Vector3<f64>),
) -> Setup {
    let mut rng = lasercal::testkit::rng(seed ^ 0xc10c);
    let passes: Vec<_> = (s.caps.profiles.iter())
        .map(|p| {
            let (w, v) = twist(&mut rng, &p.base_to_flange);
            (p.base_to_flange, w, v)
        })
        .collect();
    let log = pose_log(&passes, 1.0, 0.1, 250.0);
    let stamps: Vec<f64> = (0..s.caps.profiles.len())
        .map(|i| i as f64 + uniform(&mut rng, -0.005, 0.005) + late_s)
        .collect();
    let mean = stamps.iter().sum::<f64>() / stamps.len() as f64;
    for (p, &stamp) in s.caps.profiles.iter_mut().zip(&stamps) {
        let t = stamp - late_s - rate * (stamp - mean);
        let actual = pose_at(&log, t).unwrap();
        let noise = Noise {
            sigma_z: sigma,
            dropout: 0.0,
            sigma_z_far: 0.0,
        };
        p.data = common::raw(profile(
            &s.fan,
            &s.solids,
            &(actual * s.truth),
            noise,
            &mut rng,
        ));
        p.base_to_flange = pose_at(&log, stamp).unwrap();
    }
    s.caps.timing = Some(Timing {
        stream: log,
        stamps,
        offset_s: 0.0,
        estimate_offset: true,
        estimate_drift: false,
    });
    s
}

/// A steady scan: 50-200 mm/s along a random direction, turning at 0.05-0.3 rad/s.
fn scanning(rng: &mut Rng, _pose: &Isometry3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    (random_vector(rng, 0.05, 0.3), random_vector(rng, 0.05, 0.2))
}

const BALL: MethodId = MethodId::new(Kind::Ball, Estimator::AnyPose);
const PLANE: MethodId = MethodId::new(Kind::Plane, Estimator::AnyPose);
const EDGE: MethodId = MethodId::new(Kind::Edge, Estimator::AnyPose);

/// `id` on `rigs` noise-free random rigs on the move (`setup(seed)`), the stamps 0-20 ms late:
/// the offset recovered to 1e-6 s and the transform to 1e-9; returns the worst of each.
fn exact_on_the_move(id: MethodId, rigs: u64, setup: impl Fn(u64) -> Setup) -> (f64, f64) {
    let mut worst = (0.0f64, 0.0f64);
    for seed in 0..rigs {
        let late = 0.02 * lasercal::testkit::rng(seed).random::<f64>();
        let s = on_the_move(setup(seed), seed, late, 0.0, &scanning);
        let what = format!("{id} seed {seed}, {:.2} ms late", late * 1e3);
        let (cal, r) = lasercal::method::estimate(id, &s.caps, &s.sensor)
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        let clock = r
            .unwrap()
            .clock
            .unwrap_or_else(|| panic!("{what}: no clock"));
        let e = PoseError::between(&cal.flange_to_sensor, &s.truth);
        let off = (clock.shift_s + late).abs();
        assert!(
            off < 1e-6 && e.rotation_error_deg < 1e-9 && e.translation_error_mm < 1e-9,
            "{what}: offset off by {off} s, {e:?}"
        );
        worst = (worst.0.max(off), worst.1.max(e.translation_error_mm));
    }
    eprintln!(
        "{id}: worst offset error {:.1e} s, translation {:.1e} mm",
        worst.0, worst.1
    );
    worst
}

#[test]
fn noise_free_offsets_and_transforms_are_exact_for_the_ball_plane_and_edge() {
    // The rigs (and pose counts) the static exact suites use (`any_pose`).
    let n = |seed: u64| 7 + (seed as usize * 7) % 44;
    exact_on_the_move(BALL, 12, |seed| random_setup(1000 + seed, n(seed), 0, 0.0));
    exact_on_the_move(PLANE, 12, |seed| {
        random_plane_setup(2000 + seed, n(seed), false, 0.0)
    });
    exact_on_the_move(EDGE, 12, |seed| random_bar_setup(8000 + seed, n(seed), 0.0));
}

/// The clock shift's Jacobian column (the flange's velocity through every model's transform
/// columns) against finite differences.
#[test]
fn the_clock_column_matches_finite_differences() {
    for (id, s) in [
        (BALL, random_setup(7300, 10, 0, 0.0)),
        (PLANE, random_plane_setup(7301, 10, false, 0.0)),
        (EDGE, random_bar_setup(7302, 12, 0.0)),
    ] {
        let s = on_the_move(s, 1, 0.012, 0.0, &scanning);
        let (cal, _) = lasercal::method::estimate(id, &s.caps, &s.sensor).unwrap();
        let p = cal.refinable.as_ref().unwrap();
        // Away from the optimum, so every residual moves.
        let x = lasercal::testkit::perturb(&mut lasercal::testkit::rng(3), &s.truth, 0.01, 0.002);
        // The clock's column (the last) by central differences.
        let (_, j) = p.residuals_and_jacobian(&x);
        let (c, h) = (j.ncols() - 1, 1e-6);
        let mut dx = nalgebra::DVector::zeros(j.ncols());
        dx[c] = h;
        let rp = p.residuals_after_step(&x, &dx);
        dx[c] = -h;
        let fd = (rp - p.residuals_after_step(&x, &dx)) / (2.0 * h);
        let worst = (fd - j.column(c)).amax() / j.column(c).amax();
        assert!(worst < 1e-5, "{id}: the clock's column off by {worst}");
    }
}

/// A plane scanned with every move along the plane and no turn: a lag moves the points within
/// the plane, where no residual sees it. The offset is not estimated and the verdict says what
/// motion would determine it.
#[test]
fn a_motion_that_cannot_show_the_offset_is_said_so() {
    let s = random_plane_setup(7400, 14, false, 0.0);
    let normal = s.solids.iter().find_map(|x| match x {
        lasercal::testkit::fan::Solid::Plane { normal, .. } => Some(*normal),
        _ => None,
    });
    let normal = normal.unwrap();
    let along_plane = move |rng: &mut Rng, pose: &Isometry3<f64>| {
        let v = random_vector(rng, 0.05, 0.2);
        let v = v - normal * normal.dot(&v);
        (Vector3::zeros(), pose.rotation.inverse() * v)
    };
    let mut s = on_the_move(s, 2, 0.01, 0.0, &along_plane);
    s.caps.judging.scan_speed = Some(0.2);
    let (_, r) = lasercal::method::estimate(PLANE, &s.caps, &s.sensor).unwrap();
    let clock = r.unwrap().clock.unwrap();
    assert!(
        clock.sd_s.is_infinite() && clock.shift_s == 0.0,
        "{clock:?}"
    );
    let d = lasercal::method::verdict::decide(&s.caps, &s.sensor, Some(PLANE)).unwrap();
    let text = d.judged.lines().cloned().collect::<Vec<_>>().join("\n");
    assert!(text.contains("cannot determine the offset"), "{text}");
}

/// A profiler clock that also runs at another rate (200-1,000 ppm over the rig's 7-50 s):
/// with the drift estimated too, noise-free shift, drift and transform come back exactly.
#[test]
fn a_drifting_clock_is_estimated_exactly_without_noise() {
    let n = |seed: u64| 7 + (seed as usize * 7) % 44;
    for (id, seed) in [(BALL, 1001), (PLANE, 2002), (EDGE, 8003)] {
        let s = match id.kind {
            Kind::Ball => random_setup(seed, n(seed), 0, 0.0),
            Kind::Plane => random_plane_setup(seed, n(seed), false, 0.0),
            _ => random_bar_setup(seed, n(seed), 0.0),
        };
        let (late, rate) = (
            0.008,
            2e-4 + 8e-4 * lasercal::testkit::rng(seed).random::<f64>(),
        );
        let mut s = drifting(s, seed, late, rate, 0.0, &scanning);
        s.caps.timing.as_mut().unwrap().estimate_drift = true;
        let (cal, r) = lasercal::method::estimate(id, &s.caps, &s.sensor).unwrap();
        let c = r.unwrap().clock.unwrap();
        let (drift, _) = c.drift.expect("a drift");
        let e = PoseError::between(&cal.flange_to_sensor, &s.truth);
        assert!(
            (c.shift_s + late).abs() < 1e-9
                && (drift + rate).abs() < 1e-9
                && e.rotation_error_deg < 1e-9
                && e.translation_error_mm < 1e-9,
            "{id}: {c:?} for {late} s, {rate} s/s; {e:?}"
        );
    }
}

/// A pose log of an arm standing still at every profile: no offset moves anything, so none is
/// estimated (and the transform is the one without time).
#[test]
fn a_flange_standing_still_estimates_no_offset() {
    let still = |_: &mut Rng, _: &Isometry3<f64>| (Vector3::zeros(), Vector3::zeros());
    let s = on_the_move(
        random_plane_setup(2003, 14, false, 0.0),
        3,
        0.01,
        0.0,
        &still,
    );
    let (cal, r) = lasercal::method::estimate(PLANE, &s.caps, &s.sensor).unwrap();
    let c = r.unwrap().clock.unwrap();
    assert!(c.sd_s.is_infinite() && c.shift_s == 0.0, "{c:?}");
    let e = PoseError::between(&cal.flange_to_sensor, &s.truth);
    assert!(e.translation_error_mm < 1e-9, "{e:?}");
}

/// A pose log that starts at the first profile's stamp and ends at the last's: the estimate
/// (the stamps 10 ms late) would put the first profile before the log, where no pose places it.
/// The offset is held, the verdict says why and gives the estimate.
#[test]
fn an_estimate_beyond_the_pose_log_is_held_and_said_so() {
    let mut s = on_the_move(random_setup(7500, 12, 0, 0.0), 4, 0.01, 0.0, &scanning);
    let t = s.caps.timing.as_mut().unwrap();
    let (first, last) = t
        .stamps
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &u| (a.min(u), b.max(u)));
    let kept: Vec<_> = t
        .stream
        .iter()
        .filter(|(u, _)| *u > first && *u < last)
        .copied()
        .collect();
    // The log's ends exactly at the first and last stamp (as the reader interpolates them).
    t.stream = std::iter::once((first, pose_at(&t.stream, first).unwrap()))
        .chain(kept)
        .chain(std::iter::once((last, pose_at(&t.stream, last).unwrap())))
        .collect();
    // As a capture file's reader sets it from the log.
    s.caps.judging.scan_speed = Some(0.2);
    let (_, r) = lasercal::method::estimate(BALL, &s.caps, &s.sensor).unwrap();
    let clock = r.unwrap().clock.unwrap();
    let off = clock.off_log.expect("held for the log's span");
    assert!(
        clock.sd_s.is_infinite() && (off + 0.01).abs() < 1e-3,
        "{clock:?}"
    );
    let d = lasercal::method::verdict::decide(&s.caps, &s.sensor, Some(BALL)).unwrap();
    let text = d.judged.lines().cloned().collect::<Vec<_>>().join("\n");
    assert!(text.contains("outside the pose log's span"), "{text}");
    assert!(!text.contains("cannot determine the offset"), "{text}");
}

/// A group left out (the verdict's leave-one-out runs) takes its profiles' time stamps with it:
/// a stamp is found by its profile's index, and with every stamp kept the reduced run could not
/// place its profiles by time (the clock was then not estimated at all).
#[test]
fn a_group_left_out_takes_its_time_stamps_with_it() {
    let s = on_the_move(random_setup(1003, 12, 0, 0.0), 3, 0.01, 0.0, &scanning);
    let (caps, t) = (&s.caps, s.caps.timing.as_ref().unwrap());
    assert!(caps.groups.len() >= 3, "{} groups", caps.groups.len());
    let id = caps.groups[1].id;
    let c = caps.without_group(id);
    let ct = c.timing.as_ref().unwrap();
    let kept: Vec<_> = (caps.profiles.iter().zip(&t.stamps))
        .filter(|(p, _)| p.group != id)
        .collect();
    assert!(kept.len() < caps.profiles.len());
    assert_eq!(
        (c.profiles.len(), ct.stamps.len()),
        (kept.len(), kept.len())
    );
    for ((p, stamp), (q, reduced)) in kept.into_iter().zip(c.profiles.iter().zip(&ct.stamps)) {
        assert_eq!((p, stamp), (q, reduced));
    }
    assert!(c.groups.iter().all(|g| g.id != id));
    assert_eq!(c.groups.len(), caps.groups.len() - 1);
    assert_eq!((ct.stream.len(), ct.offset_s), (t.stream.len(), t.offset_s));
}
