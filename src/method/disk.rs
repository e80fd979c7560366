//! The disk method (Chen et al. 2018): a planar disk of arbitrary orientation scanned by straight
//! moves (Sec. III-A); its `[disk]` scenario section, plan, simulation, chord features and the
//! transformation solution (Eqs. 14-19), with the chord-end refinement model.

use super::{DepthNoise, Estimator, Kind, Method, Plan, Sim};
use crate::calib::disk::{DiskChord, DiskProblem, DiskScan};
use crate::calib::disk_any::DiskView;
use crate::calib::refine::disk::{DiskModel, DiskPose, face_weights};
use crate::calib::refine::{Problem, Refined};
use crate::captures::{CaptureError, CaptureProfile, Captures, Group, ProfileData, Role};
use crate::error::Error;
use crate::features::{self, SplitMerge};
use crate::math::rot_zyx;
use crate::metrics::{Metric, Metrics};
use crate::scene::{FormError, FormTolerance, Scene, Specimen, SpecimenKind, SpecimenType};
use crate::schema::disk::CoverageKey;
use crate::schema::{Common, Scenario, ScenarioError, Source, Validator};
use crate::sensor::SensorModel;
use crate::sim::disk::{Coverage, Direction, DiskPlanSpec, DiskScanPlan, DiskTarget, ScanRequest};
use crate::sim::{Rig, flange_pose};
use nalgebra::{Isometry3, Point3, Translation3, Vector2, Vector3};

/// The disk method.
pub struct Disk;

impl Method for Disk {
    fn kind(&self) -> Kind {
        Kind::Disk
    }

    fn validate(&self, sc: &Scenario, v: &Validator) -> Result<(), ScenarioError> {
        let d = v.section(sc.disk.as_ref(), Kind::Disk)?;
        if !sc.specimen_kind(v)?.is_disk() {
            return Err(v.bad(
                "specimen.kind",
                format!("\"{}\"", sc.specimen.kind),
                "the disk method needs disk-cylinder or disk-paper",
            ));
        }
        if let Some(m) = sc
            .methods
            .iter()
            .find(|m| m.kind == Kind::Disk && m.estimator == Estimator::AnyPose)
        {
            super::check_any_pose_source(sc, Kind::Disk, d.source, v)?;
            if !matches!(sc.specimen_kind(v)?, SpecimenKind::DiskOnCylinder { .. }) {
                return Err(v.bad(
                    "specimen.kind",
                    format!("\"{}\"", sc.specimen.kind),
                    format!(
                        "{m} finds the rim by the step of a disk on a cylinder: use disk-cylinder"
                    ),
                ));
            }
        }
        if super::check_free_poses(
            sc,
            Kind::Disk,
            d.poses.as_ref(),
            crate::calib::plane::MIN_VIEWS,
            "disk.chords and the scans' orientations",
            v,
        )? {
            return Ok(());
        }
        v.at_least(
            "disk.chords",
            d.chords,
            3,
            "at least 3 chords per scan are needed for the ellipse fit",
        )?;
        let n = d.orientations_rpy_rad.len();
        if n < 4 {
            return Err(v.bad(
                "disk.orientations_rpy_rad",
                format!("{n} orientations"),
                "the disk method needs at least 4 sensing data",
            ));
        }
        v.open_interval("disk.span_fraction", d.span_fraction, 0.0, 1.0)?;
        v.non_negative("disk.sigma_mm", d.sigma_mm)?;
        validate_motion(d, v)?;
        if !(d.min_angle_deg >= 0.0 && d.min_angle_deg < 45.0) {
            return Err(v.bad("disk.min_angle_deg", d.min_angle_deg, "must be in [0, 45)"));
        }
        v.one_of(
            ("disk.directions_in_base", d.directions_in_base.is_some()),
            (
                "disk.directions_in_sensor",
                d.directions_in_sensor.is_some(),
            ),
            "the move direction of each scan",
        )?;
        for (k, list) in [
            ("disk.centre_tcp_mm", &d.centre_tcp_mm),
            ("disk.directions_in_base", &d.directions_in_base),
            ("disk.directions_in_sensor", &d.directions_in_sensor),
        ] {
            if let Some(l) = list
                && l.len() != n
            {
                return Err(v.bad(
                    k,
                    format!("{} entries", l.len()),
                    format!("give one per orientation ({n})"),
                ));
            }
        }
        Ok(())
    }

    fn plan(
        &self,
        sc: &Scenario,
        common: &Common,
        v: &Validator,
    ) -> Result<Box<dyn Plan>, ScenarioError> {
        let d = v.section(sc.disk.as_ref(), Kind::Disk)?;
        let radius = common.specimen.disk_radius().ok_or_else(|| {
            v.bad(
                "specimen.kind",
                common.specimen.name(),
                "the disk method needs disk-cylinder or disk-paper",
            )
        })?;
        let target = DiskTarget::from_pose(&common.base_to_specimen, radius);
        let scans = d
            .orientations_rpy_rad
            .iter()
            .enumerate()
            .map(|(i, r)| ScanRequest {
                r_tcp: rot_zyx(r[0], r[1], r[2]),
                centre_tcp: d.centre_tcp_mm.as_ref().map(|c| Vector3::from(c[i]) * 1e-3),
                direction: match (&d.directions_in_base, &d.directions_in_sensor) {
                    (Some(b), _) => Direction::InBase(Vector3::from(b[i])),
                    (None, Some(s)) => Direction::InSensor(Vector3::from(s[i])),
                    (None, None) => Direction::InSensor(Vector3::y()),
                },
            })
            .collect();
        let spec = DiskPlanSpec {
            scans,
            coverage: match d.coverage {
                CoverageKey::Whole => Coverage::Whole,
                CoverageKey::Half => Coverage::Half,
            },
            span_fraction: d.span_fraction,
            m: d.chords,
            min_angle: d.min_angle_deg.to_radians(),
        };
        let (plans, free) = match &d.poses {
            None => (
                crate::sim::disk::plan(&common.rig, &target, &spec)
                    .map_err(|e| v.bad("disk.orientations_rpy_rad", "..", e.to_string()))?,
                Vec::new(),
            ),
            Some(ps) => {
                let source = ps.source("disk.poses", crate::calib::plane::MIN_VIEWS, v)?;
                // The laser plane up to 0.6 R from the centre: chords of 80 % of the diameter
                // or more.
                let aim = crate::sim::poses::Aim {
                    point: target.centre,
                    normal: target.normal.into_inner(),
                    off_plane: 0.6 * radius,
                    crossing: None,
                    sense: None,
                };
                let mut g = crate::rng::stream(sc.seed, &[crate::rng::tag::PLAN, 6]);
                let poses = crate::sim::poses::poses(&common.rig, &aim, &source, &mut g)
                    .map_err(|e| v.bad("disk.poses", "..", e.to_string()))?;
                (Vec::new(), poses)
            }
        };
        Ok(Box::new(DiskPlan {
            target,
            plans,
            free,
            raycast: d.source == Source::Raycast,
            sigma: d.sigma_mm * 1e-3,
            speed: d.scan_speed_mm_s * 1e-3,
            clock: StampClock {
                offset: d.clock_offset_ms * 1e-3,
                drift: d.clock_drift_ppm * 1e-6,
                jitter: d.clock_jitter_ms * 1e-3,
                exposure: d.exposure_ms * 1e-3,
            },
            estimate_clock_offset: d.estimate_clock_offset,
            estimate_clock_drift: d.estimate_clock_drift,
            accel: d.scan_accel_mm_s2 * 1e-3,
            pose_log_hz: d.pose_log_hz,
            passing: match &d.poses {
                Some(ps) => ps.passing("disk.poses", v)?,
                None => None,
            },
            radius_tolerance: sc.specimen.radius_tolerance_mm.unwrap_or(0.0) * 1e-3,
            form: sc.specimen.form(),
            scene: common.scene.clone(),
            specimen: common.specimen.clone(),
            base_to_specimen: common.base_to_specimen,
        }))
    }

    fn calibrate(&self, c: &Captures, sensor: &SensorModel) -> Result<super::Calibration, Error> {
        calibrate(c, sensor)
    }

    fn closed_form_feature_noise(
        &self,
        c: &Captures,
        sensor: &SensorModel,
        sd: f64,
    ) -> Option<nalgebra::Matrix6<f64>> {
        feature_noise(c, sensor, sd)
    }

    fn closed_form_recast(
        &self,
        c: &Captures,
        sensor: &SensorModel,
        cal: &super::Calibration,
        twists: &dyn Fn(&Isometry3<f64>) -> Option<Vec<nalgebra::Vector6<f64>>>,
    ) -> Option<Vec<nalgebra::Vector6<f64>>> {
        recast(c, sensor, cal, twists)
    }

    fn calibrate_any_pose(
        &self,
        c: &Captures,
        sensor: &SensorModel,
        censored_iterations: usize,
    ) -> Result<(super::Calibration, Refined), Error> {
        any_pose(c, sensor, censored_iterations)
    }

    fn profile_features(
        &self,
        c: &Captures,
        sensor: &SensorModel,
    ) -> Vec<Option<super::ProfileFeature>> {
        let cfg = SplitMerge::for_sensor(sensor);
        super::each_profile(c, |g, p| {
            let radius = c.specimen_radius?;
            // The closed form's chord, else the any-pose estimator's reading (free poses).
            let (ch, face) = match (chord_of(c, g, p, sensor, radius, &cfg), &p.data) {
                (Ok(Ok(found)), _) => (found.chord, found.face),
                (_, ProfileData::Raw(prof)) if c.specimen_kind != SpecimenType::DiskPaper => {
                    match features::disk_profile(prof, sensor, radius, &cfg) {
                        Ok(d) => (d.chord, d.face),
                        // The face alone (the rim out of view): its line, no feature.
                        Err(_) => {
                            let face = features::largest_segment(prof, &cfg);
                            return (face.len() >= 3).then_some(super::ProfileFeature {
                                features: Vec::new(),
                                surface: face,
                            });
                        }
                    }
                }
                _ => return None,
            };
            Some(super::ProfileFeature {
                features: vec![ch.a, ch.b],
                surface: face,
            })
        })
    }

    fn fit_mapped(
        &self,
        features: &[Vec<Point3<f64>>],
        surface: &[Vec<Point3<f64>>],
    ) -> Option<super::view::Fitted> {
        super::view::fit_disk_face(features, surface)
    }

    fn needs_radius(&self) -> bool {
        true
    }

    fn uses_group_signs(&self) -> bool {
        true
    }
}

/// `[disk]`'s scanning on the move: the speed, the move and the log, the profiler's clock.
fn validate_motion(d: &crate::schema::disk::Section, v: &Validator) -> Result<(), ScenarioError> {
    v.within(
        "disk.scan_speed_mm_s",
        d.scan_speed_mm_s,
        (0.0, 10_000.0),
        "must be in [0, 10000] mm/s (0: stop and go)",
    )?;
    v.within(
        "disk.clock_offset_ms",
        d.clock_offset_ms,
        (-1000.0, 1000.0),
        "must be within +-1000 ms (a profiler's latency is milliseconds)",
    )?;
    v.within(
        "disk.scan_accel_mm_s2",
        d.scan_accel_mm_s2,
        (0.0, 1e6),
        "must be in [0, 1e6] mm/s^2 (0: at the scan speed throughout)",
    )?;
    if d.pose_log_hz != 0.0 {
        v.within(
            "disk.pose_log_hz",
            d.pose_log_hz,
            (1.0, 10_000.0),
            "must be 0 (the moves' start and end only) or in [1, 10000] Hz",
        )?;
    }
    v.within(
        "disk.clock_drift_ppm",
        d.clock_drift_ppm,
        (-10_000.0, 10_000.0),
        "must be within +-10000 ppm (a crystal drifts by tens to hundreds)",
    )?;
    v.within(
        "disk.clock_jitter_ms",
        d.clock_jitter_ms,
        (0.0, 100.0),
        "must be in [0, 100] ms (a standard deviation)",
    )?;
    v.within(
        "disk.exposure_ms",
        d.exposure_ms,
        (0.0, 1000.0),
        "must be in [0, 1000] ms",
    )?;
    if d.estimate_clock_drift && !(d.scan_speed_mm_s > 0.0 && d.estimate_clock_offset) {
        return Err(v.bad(
            "disk.estimate_clock_drift",
            true,
            "a drift is estimated with the offset, on profiles taken on the move: give \
             scan_speed_mm_s and leave estimate_clock_offset true",
        ));
    }
    for (key, value) in [
        ("disk.clock_drift_ppm", d.clock_drift_ppm),
        ("disk.clock_jitter_ms", d.clock_jitter_ms),
        ("disk.exposure_ms", d.exposure_ms),
    ] {
        if value != 0.0 && d.poses.is_some() {
            return Err(v.bad(
                key,
                value,
                "acts on the paper's scans on the move, not on free poses: leave it out \
                 with [disk.poses]",
            ));
        }
    }
    if d.clock_offset_ms != 0.0 && d.poses.is_some() {
        return Err(v.bad(
            "disk.clock_offset_ms",
            d.clock_offset_ms,
            "free poses are taken at rest (no move for a clock offset to act on): leave it \
             out with [disk.poses]",
        ));
    }
    Ok(())
}

/// The disk method's plan on one rig.
#[derive(Debug)]
pub struct DiskPlan {
    pub target: DiskTarget,
    /// The paper's scans, or (when not empty) `free` flange poses, one profile each.
    pub plans: Vec<DiskScanPlan>,
    pub free: Vec<Isometry3<f64>>,
    pub raycast: bool,
    /// Eq. 52 sigma, metres.
    pub sigma: f64,
    /// The scans' speed (m/s; 0: stop and go) and the profiler's stamps against the truth.
    pub speed: f64,
    pub clock: StampClock,
    /// Whether the estimators estimate the clock offset and its drift
    /// (`captures::Timing::estimate_offset`, `estimate_drift`).
    pub estimate_clock_offset: bool,
    pub estimate_clock_drift: bool,
    /// Each move's acceleration (m/s^2; 0: at `speed` throughout) and the pose log's rate (Hz;
    /// 0: each move's start and end only).
    pub accel: f64,
    pub pose_log_hz: f64,
    /// Scanning on the move through the free poses (`[disk.poses] scan_speed_mm_s`).
    pub passing: Option<crate::sim::poses::Passing>,
    /// Standard deviation of the true radius (metres).
    pub radius_tolerance: f64,
    pub form: FormTolerance,
    pub scene: Scene,
    pub specimen: Specimen,
    pub base_to_specimen: Isometry3<f64>,
}

impl Plan for DiskPlan {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn scene(&self) -> &Scene {
        &self.scene
    }

    fn first_flange_pose(&self) -> Isometry3<f64> {
        if let Some(f) = self.free.first() {
            return *f;
        }
        let p = &self.plans[0];
        flange_pose(&p.r_tcp, &p.tcp(p.m / 2))
    }

    fn true_centre(&self) -> Option<Point3<f64>> {
        Some(self.target.centre)
    }

    fn simulate(&self, rig: &Rig, sim: &mut Sim) -> Result<Captures, Error> {
        let target = DiskTarget {
            radius: self.target.radius + sim.radius_z * self.radius_tolerance,
            ..self.target
        };
        let form = FormError::draw(&self.specimen, &self.form, sim.specimen_rng);
        let scene = crate::scene::with_form(
            crate::scene::with_radius(&self.scene, target.radius, self.radius_tolerance),
            form,
        );
        let noisy = !rig.sensor.noise.is_off();
        let (mut groups, mut profiles) = (
            Vec::with_capacity(self.free.len() + self.plans.len()),
            Vec::with_capacity(self.free.len() + self.plans.iter().map(|p| p.m).sum::<usize>()),
        );
        let Sim { rng, mover, .. } = sim;
        let mut actual = |f: &Isometry3<f64>| mover.actual(&rig.robot, f);
        for (i, f) in self.free.iter().enumerate() {
            groups.push(Group {
                id: i,
                role: Role::Pose,
                sign: 0.0,
            });
            let prof = rig.sensor.profile(
                &scene,
                &rig.base_to_sensor(&actual(f)),
                noisy.then_some(&mut **rng),
            );
            profiles.push(CaptureProfile {
                group: i,
                base_to_flange: *f,
                data: ProfileData::Raw(prof),
            });
        }
        // Each stamp's jitter from its own stream (drawn only when there is jitter, so that a
        // scenario without it keeps its noise draws).
        let mut jitter = (self.clock.jitter > 0.0).then(|| {
            use rand::{RngExt, SeedableRng};
            crate::rng::Rng::seed_from_u64(rng.random::<u64>())
        });
        let starts = self.scan_starts();
        for (i, p) in self.plans.iter().enumerate() {
            groups.push(Group {
                id: i,
                role: Role::Scan,
                sign: crate::sim::disk::scan_sign(rig, p),
            });
            let mut actual = |f: &Isometry3<f64>| {
                let z = jitter.as_mut().map_or(0.0, crate::rng::gauss);
                actual(&(self.taken_back(p, starts[i], f, z) * f))
            };
            if self.raycast {
                for j in 0..p.m {
                    let f = flange_pose(&p.r_tcp, &p.tcp(j));
                    let prof = rig.sensor.profile(
                        &scene,
                        &rig.base_to_sensor(&actual(&f)),
                        noisy.then_some(&mut **rng),
                    );
                    profiles.push(CaptureProfile {
                        group: i,
                        base_to_flange: f,
                        data: ProfileData::Raw(prof),
                    });
                }
            } else {
                let scan = crate::sim::disk::analytic_scan_with(
                    rig,
                    &target,
                    Some((&self.base_to_specimen, &form)),
                    p,
                    self.sigma,
                    rng,
                    &mut |f, _| actual(f),
                );
                mostly_in_view(rig, &scan, i, p)?;
                // `flange_pose`'s rotation, once per scan.
                let r_tcp = nalgebra::UnitQuaternion::from_rotation_matrix(&p.r_tcp);
                // Written in place by `extend` (a pushed profile, built on the stack and copied,
                // stalled its loads on its own stores).
                profiles.extend(scan.chords.iter().map(|ch| CaptureProfile {
                    group: i,
                    base_to_flange: Isometry3::from_parts(
                        (p.t_start + (p.t_end - p.t_start) * ch.u).into(),
                        r_tcp,
                    ),
                    data: ProfileData::Chord { a: ch.a, b: ch.b },
                }));
            }
        }
        let timing = self.timing(&profiles);
        let mut caps = Captures {
            timing,
            kinematic: None,
            orientation_tolerance_deg: crate::calib::ORIENTATION_TOLERANCE_DEG,
            feature_sigma: (!self.raycast).then_some(self.sigma),
            judging: crate::captures::Judging {
                radius_tolerance: self.radius_tolerance,
                ..Default::default()
            },
            method: Kind::Disk,
            sensor: rig.sensor.name.clone(),
            specimen_kind: self.specimen.kind.specimen_type(),
            specimen_radius: Some(self.target.radius),
            edge_sense: None,
            truth: Some(rig.flange_to_sensor),
            groups,
            profiles,
        };
        if let Some(m) = self.passing.as_ref().filter(|_| !self.free.is_empty()) {
            m.apply(&mut caps);
        }
        Ok(caps)
    }
}

impl DiskPlan {
    /// From the pose scan `p` (its move starting at `t0` on the controller's clock) recorded a
    /// profile at (`f`) back to where it was taken: `clock.back` earlier along the move, with
    /// this stamp's jitter draw `z`.
    fn taken_back(
        &self,
        p: &DiskScanPlan,
        t0: f64,
        f: &Isometry3<f64>,
        z: f64,
    ) -> Translation3<f64> {
        if !(self.speed > 0.0) {
            return Translation3::identity();
        }
        let d = (p.t_end - p.t_start).try_normalize(0.0).unwrap_or_default();
        let s = (f.translation.vector - p.t_start).dot(&d);
        match self.scan_move(p) {
            Some(m) => {
                let local = m.time_at(s);
                let taken = m.position(local - self.clock.back(t0 + local, z));
                Translation3::from(d * (taken - s))
            }
            None => {
                let back = self.clock.back(t0 + s / self.speed, z);
                Translation3::from(-d * (self.speed * back))
            }
        }
    }

    /// How long the log runs before each move's start and after its end (s): past the
    /// profiles, by more than their clock can put them off their stamps.
    fn log_margin(&self) -> f64 {
        let c = &self.clock;
        let span: f64 = (self.plans.iter())
            .map(|p| self.scan_duration(p) + 2.0)
            .sum();
        0.1 + c.offset.abs() + 0.5 * c.exposure + 5.0 * c.jitter + c.drift.abs() * span
    }

    /// Scan `p`'s move's duration (s; the speed is above 0).
    fn scan_duration(&self, p: &DiskScanPlan) -> f64 {
        let length = (p.t_end - p.t_start).norm();
        self.scan_move(p)
            .map_or(length / self.speed, |m| m.duration())
    }

    /// Each scan's move's start on the controller's clock: the log runs `log_margin` either
    /// side of each move, the moves a second apart.
    fn scan_starts(&self) -> Vec<f64> {
        if !(self.speed > 0.0) {
            return vec![0.0; self.plans.len()];
        }
        let margin = self.log_margin();
        let mut t0 = margin;
        (self.plans.iter())
            .map(|p| {
                let start = t0;
                t0 += self.scan_duration(p) + 2.0 * margin + 1.0;
                start
            })
            .collect()
    }

    /// Scan `p`'s move from rest to rest, when an acceleration is set.
    fn scan_move(&self, p: &DiskScanPlan) -> Option<ScanMove> {
        (self.accel > 0.0 && self.speed > 0.0).then(|| ScanMove {
            length: (p.t_end - p.t_start).norm(),
            speed: self.speed,
            accel: self.accel,
        })
    }

    /// Scanning on the move: the controller's log of each scan (its straight move at `speed`,
    /// scans a second apart, logged at `POSE_STREAM_HZ` from before the first profile to after
    /// the last) and each profile's stamp, the time the log shows its recorded pose (the profile
    /// itself taken `clock_offset` earlier, `lead` back along the move). None when stopping.
    fn timing(&self, profiles: &[CaptureProfile]) -> Option<crate::captures::Timing> {
        if !(self.speed > 0.0) || self.plans.is_empty() || !self.free.is_empty() {
            return None;
        }
        let margin = self.log_margin();
        let starts = self.scan_starts();
        let mut stream = Vec::new();
        let mut moves = Vec::new();
        for (p, &t0) in self.plans.iter().zip(&starts) {
            let d = (p.t_end - p.t_start).normalize();
            let scan = self.scan_move(p);
            moves.push((t0, p.t_start, d, scan));
            // Where the flange is at t: at the speed throughout, or from rest to rest.
            let at = |t: f64| {
                let s = scan.map_or(self.speed * (t - t0), |m| m.position(t - t0));
                p.t_start + d * s
            };
            let span = self.scan_duration(p) + 2.0 * margin;
            // At the log's rate from before the first profile to after the last, or the move's
            // two ends only.
            let (samples, step) = if self.pose_log_hz > 0.0 {
                (
                    (span * self.pose_log_hz).ceil() as usize,
                    1.0 / self.pose_log_hz,
                )
            } else {
                (1, span)
            };
            for k in 0..=samples {
                let t = t0 - margin + k as f64 * step;
                stream.push((t, flange_pose(&p.r_tcp, &at(t))));
            }
        }
        let stamps = profiles
            .iter()
            .map(|c| {
                let (t0, start, d, scan) = moves[c.group];
                let s = (c.base_to_flange.translation.vector - start).dot(&d);
                t0 + scan.map_or(s / self.speed, |m| m.time_at(s))
            })
            .collect();
        Some(crate::captures::Timing {
            stream,
            stamps,
            offset_s: 0.0,
            estimate_offset: self.estimate_clock_offset,
            estimate_drift: self.estimate_clock_drift,
        })
    }
}

/// The profiler's time stamps against the controller's clock (s): a profile stamped u (on the
/// controller's clock, from the capture's start) was taken `back(u, z)` before u.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StampClock {
    /// How late the stamps are (s), how fast the profiler's clock runs (s per s), each stamp's
    /// own error's standard deviation (s) and the exposure (s), whose start the stamp marks.
    pub offset: f64,
    pub drift: f64,
    pub jitter: f64,
    pub exposure: f64,
}

impl StampClock {
    /// How long before its stamp `u` a profile was taken, with its jitter draw `z` (standard
    /// normal): the profile is the image at the exposure's middle.
    fn back(&self, u: f64, z: f64) -> f64 {
        self.offset + self.drift * u + self.jitter * z - 0.5 * self.exposure
    }
}

/// Scan `i` (`p`) from the analytic source, which (as the paper's simulation) does not clip
/// chords to the sensor's view: the paper's own poses reach up to 17 mm beyond the modelled
/// Gocator 2340's far range. A scan mostly out of view is refused, not calibrated.
fn mostly_in_view(rig: &Rig, scan: &DiskScan, i: usize, p: &DiskScanPlan) -> Result<(), Error> {
    let seen = |v: &nalgebra::Vector2<f64>| rig.sensor.sees(v.x, v.y);
    let visible = scan
        .chords
        .iter()
        .filter(|c| seen(&c.a) && seen(&c.b))
        .count();
    if 2 * visible < p.m.max(1) {
        let (z0, z1) = rig.sensor.z_range();
        return Err(crate::sim::PlanError::BadScan {
            scan: i,
            reason: format!(
                "only {} of {} chords lie within the sensor's view (z {:.1} to {:.1} \
                 mm, fan +-{:.1} deg): the disk is out of range; check the mounting \
                 (mount_position_mm) and the scan poses",
                visible,
                p.m,
                z0 * 1e3,
                z1 * 1e3,
                rig.sensor.tan_half_fov.atan().to_degrees()
            ),
        }
        .into());
    }
    Ok(())
}

/// Unit normal of the plane through the chord ends, seen through `flange_to_sensor`.
fn plane_normal(
    ends: &[(Isometry3<f64>, Vector2<f64>)],
    flange_to_sensor: &Isometry3<f64>,
    apex: &Point3<f64>,
) -> Vector3<f64> {
    let Some((first, _)) = ends.first() else {
        return Vector3::z();
    };
    let apex_in_flange = (flange_to_sensor * apex).coords;
    // Within a run of one flange orientation an end (x, z) lies at M (x, z) + R t + t_f in the
    // base (M: the first and third columns of R R_x, R the flange's rotation, t R_x's offset):
    // a sweep's millions of ends then cost a product each, not two transforms. The moments are
    // taken about the first pose's origin, near every end (no cancellation against the base's
    // metres).
    let origin = first.translation.vector;
    type Run = (
        nalgebra::Vector4<f64>,
        nalgebra::Matrix3x2<f64>,
        Vector3<f64>,
        Vector3<f64>,
    );
    let mut run: Option<Run> = None;
    let (mut sum, mut second) = (Vector3::zeros(), [0.0; 6]);
    // The sensors' side from the apexes' mean (each pose once): the sign of the sum of their
    // offsets from the face is that of their mean's.
    let (mut apex_sum, mut poses) = (Vector3::zeros(), 0usize);
    // Pose by pose (a chord's two ends share theirs).
    for pose in ends.chunk_by(|a, b| a.0 == b.0) {
        let f = &pose[0].0;
        let (m, offset, apex) = match run {
            Some((q, m, offset, apex)) if q == f.rotation.coords => (m, offset, apex),
            _ => {
                let r = (f.rotation * flange_to_sensor.rotation).to_rotation_matrix();
                let m = nalgebra::Matrix3x2::from_columns(&[
                    r.matrix().column(0).into_owned(),
                    r.matrix().column(2).into_owned(),
                ]);
                let offset = f.rotation * flange_to_sensor.translation.vector;
                let apex = f.rotation * apex_in_flange;
                run = Some((f.rotation.coords, m, offset, apex));
                (m, offset, apex)
            }
        };
        let t = f.translation.vector - origin;
        let c = offset + t;
        for (_, p) in pose {
            let q = m * p + c;
            sum += q;
            for (k, (a, b)) in [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]
                .into_iter()
                .enumerate()
            {
                second[k] += q[a] * q[b];
            }
        }
        apex_sum += apex + t;
        poses += 1;
    }
    let second = nalgebra::Matrix3::new(
        second[0], second[1], second[2], second[1], second[3], second[4], second[2], second[4],
        second[5],
    );
    let count = ends.len() as f64;
    let mean = sum / count;
    let cov = second - mean * sum.transpose();
    let eig = nalgebra::SymmetricEigen::new(0.5 * (cov + cov.transpose()));
    let k = eig.eigenvalues.imin();
    let apexes = apex_sum / poses.max(1) as f64;
    super::toward_points(eig.eigenvectors.column(k).into_owned(), &mean, [apexes])
}

/// The full-profile refinement's rim and its weights (residuals scaled to the face points' noise).
#[derive(Debug, Default)]
struct Rim {
    ends: Vec<(Isometry3<f64>, Vector2<f64>)>,
    end_weights: Vec<f64>,
    walls: Vec<(Isometry3<f64>, Vector2<f64>, f64)>,
}

/// Beyond each chord end, the points of the cylinder's wall (`super::wall_points`); where at least
/// `WALL_MIN_POINTS` show, they replace the end. An end that stays is weighted by the face's z sigma at its depth
/// over its own spread: the rim lies anywhere between the last column on the face and the next,
/// uniformly, so the end's distance from the rim spreads by the column step (times the cosine
/// between chord and radius, at least 0.3) over sqrt(12), whatever the noise (the face's line is
/// fitted to hundreds of points); at least 0.25.
fn rim_of(
    ends: &[(Isometry3<f64>, Vector2<f64>)],
    beyond: &[[Vec<Vector2<f64>>; 2]],
    flange_to_sensor: &Isometry3<f64>,
    disk: &DiskPose,
    radius: f64,
    sensor: &SensorModel,
    noise: Option<&DepthNoise>,
) -> Rim {
    let weight = |p: &Vector2<f64>| DepthNoise::weight_or_one(noise, sensor, p);
    let n = disk.normal();
    let mut rim = Rim::default();
    let in_disk = |base_to_sensor: &Isometry3<f64>, p: &Vector2<f64>| {
        let v = (base_to_sensor * Point3::new(p.x, 0.0, p.y)).coords - disk.centre;
        let h = n.dot(&v);
        (h, v - n * h)
    };
    for (k, (flange, end)) in ends.iter().enumerate() {
        let base_to_sensor = flange * flange_to_sensor;
        let past = beyond.get(k / 2).map_or(&[][..], |b| &b[k % 2][..]);
        let wall = super::wall_points(past, &base_to_sensor, |q| {
            let v = q - disk.centre;
            let h = n.dot(&v);
            let w = v - n * h;
            (h, w.norm() - radius, w.normalize())
        });
        if wall.len() >= super::WALL_MIN_POINTS {
            rim.walls
                .extend((wall.into_iter()).map(|(p, wt)| (*flange, p, wt * weight(&p))));
            continue;
        }
        // The chord's direction at this end (toward the other end) against the radius.
        let other = ends[k ^ 1].1;
        let along = base_to_sensor.rotation
            * Vector3::new(other.x - end.x, 0.0, other.y - end.y).normalize();
        let (_, w) = in_disk(&base_to_sensor, end);
        let cos = (w.normalize().dot(&along)).abs().max(0.3);
        let depth = sensor.depth(&Point3::new(end.x, 0.0, end.y));
        let spread = sensor.x_step_at_depth(depth) * cos / 12f64.sqrt();
        // Where the face's rows are weighted by depth, all share the spread `top`.
        let sigma = match noise {
            Some(n) => n.top(),
            None => sensor.noise.z_sigma_at(sensor, depth),
        };
        rim.ends.push((*flange, *end));
        rim.end_weights.push((sigma / spread).max(0.25));
    }
    rim
}

/// `DepthNoise` from the scans' noise readings (one list per scan), the scans left out dropped.
fn kept_noise(
    samples: &[Vec<(f64, f64, f64)>],
    reports: &[super::GroupReport],
) -> Option<DepthNoise> {
    let kept = (samples.iter().zip(reports)).filter(|(_, r)| !r.left_out);
    DepthNoise::fit(
        &kept
            .flat_map(|(s, _)| s.iter().copied())
            .collect::<Vec<_>>(),
    )
}

/// A chord with, from a raw profile of a disk on a cylinder, the face points it was fitted to and
/// the points beyond its ends (`features::DiskProfile::beyond`).
struct Found {
    chord: features::Chord,
    face: Vec<Vector2<f64>>,
    beyond: [Vec<Vector2<f64>>; 2],
}

impl Found {
    fn chord(chord: features::Chord) -> Found {
        Found {
            chord,
            face: Vec::new(),
            beyond: [Vec::new(), Vec::new()],
        }
    }
}

/// The chord of one capture: given, or extracted from the raw profile.
// Inlined: its nested result, returned through memory, stalled the caller's loads on every
// profile (a store-forwarding failure, 3 % of the Fig. 15 sweep).
#[inline(always)]
fn chord_of(
    c: &Captures,
    g: &Group,
    p: &CaptureProfile,
    sensor: &SensorModel,
    radius: f64,
    cfg: &SplitMerge,
) -> Result<Result<Found, features::FeatureError>, CaptureError> {
    Ok(match &p.data {
        // A chord of no length says nothing about the disk (a recording error): left out.
        ProfileData::Chord { a, b } if no_length(a, b, radius) => {
            Err(features::FeatureError::NoChord {
                reason: "the chord has zero length".into(),
            })
        }
        ProfileData::Chord { a, b } => Ok(Found::chord(features::Chord { a: *a, b: *b })),
        ProfileData::Raw(prof) => {
            if c.specimen_kind == SpecimenType::DiskPaper {
                features::disk_chord_intensity(prof, sensor, cfg.min_points).map(Found::chord)
            } else {
                features::disk_profile(prof, sensor, radius, cfg).map(|d| Found {
                    chord: d.chord,
                    face: d.face,
                    beyond: d.beyond,
                })
            }
        }
        _ => {
            return Err(CaptureError::WrongData {
                group: g.id,
                method: Kind::Disk,
                need: "a chord or raw points",
            });
        }
    })
}

/// One raw profile of the disk from any pose: its face's line and the rim's intervals.
fn disk_view(
    c: &Captures,
    g: &Group,
    p: &CaptureProfile,
    sensor: &SensorModel,
    radius: f64,
    cfg: &SplitMerge,
) -> Result<Result<DiskView, CaptureError>, CaptureError> {
    let ProfileData::Raw(prof) = &p.data else {
        return Err(CaptureError::WrongData {
            group: g.id,
            method: Kind::Disk,
            need: "raw points (points_mm): the any-pose estimator fits the disk's face",
        });
    };
    if c.specimen_kind == SpecimenType::DiskPaper {
        return Err(CaptureError::WrongData {
            group: g.id,
            method: Kind::Disk,
            need: "a disk on a cylinder: on paper the rim is told by intensity, which the any-pose \
                   estimator does not use",
        });
    }
    Ok(features::disk_profile(prof, sensor, radius, cfg)
        .map_err(CaptureError::from)
        .and_then(|d| {
            Ok(DiskView {
                face: super::face_view(p.base_to_flange, d.face)?,
                rim: d.rim.to_vec(),
            })
        }))
}

/// The disk's face and rim from any poses, whatever the groups (`calib::disk_any`).
fn any_pose(
    c: &Captures,
    sensor: &SensorModel,
    censored_iterations: usize,
) -> Result<(super::Calibration, Refined), Error> {
    let cfg = SplitMerge::for_sensor(sensor);
    let radius = c
        .specimen_radius
        .ok_or(CaptureError::MissingRadius { method: Kind::Disk })?;
    let (views, reports) = super::free_views(c, Kind::Disk, |g, p| {
        disk_view(c, g, p, sensor, radius, &cfg)
    })?;
    let samples: Vec<_> = (views.iter())
        .filter_map(|v| DepthNoise::sample(sensor, &v.face.points))
        .collect();
    let noise = DepthNoise::fit(&samples);
    let weight = |p: &Vector2<f64>| DepthNoise::weight_or_one(noise.as_ref(), sensor, p);
    let sol = crate::calib::disk_any::solve(
        &views,
        radius,
        &sensor.apex().coords,
        &weight,
        censored_iterations,
    )?;
    let cal = super::any_pose_calibration(
        &sol.refined,
        Some(sol.disk.centre),
        reports,
        std::sync::Arc::new(sol.problem),
    );
    Ok((cal, sol.refined))
}

/// The scans of captures that give none (one group per pose, as an import writes them): each run
/// of consecutive profiles at one orientation (within the orientation tolerance) is a scan, and
/// its sign s_i (Eq. 3) is whether its move follows the sensor's +y, read with
/// `disk-any-pose`'s rotation: labels the data determine.
fn inferred_scans(c: &Captures, sensor: &SensorModel) -> Result<Captures, Error> {
    // Without the any-pose estimator (features given, not raw profiles) nothing reads the signs.
    let Ok((any, _)) = any_pose(c, sensor, crate::calib::refine::CENSORED_ITERATIONS) else {
        return Err(CaptureError::MissingSign {
            group: c.groups[0].id,
            method: Kind::Disk,
        }
        .into());
    };
    let tol = c.orientation_tolerance_deg.to_radians();
    let mut out = c.clone();
    out.groups = Vec::new();
    let mut start = 0;
    while start < out.profiles.len() {
        let first = out.profiles[start].base_to_flange;
        let end = (start..out.profiles.len())
            .take_while(|&i| {
                out.profiles[i]
                    .base_to_flange
                    .rotation
                    .angle_to(&first.rotation)
                    <= tol
            })
            .last()
            .unwrap_or(start);
        let id = out.groups.len();
        let moved = out.profiles[end].base_to_flange.translation.vector - first.translation.vector;
        let y = (first * any.flange_to_sensor).rotation * nalgebra::Vector3::y();
        out.groups.push(Group {
            id,
            role: Role::Scan,
            sign: if moved.dot(&y) < 0.0 { -1.0 } else { 1.0 },
        });
        for p in &mut out.profiles[start..=end] {
            p.group = id;
        }
        start = end + 1;
    }
    Ok(out)
}

/// Eq. 2's scan is a straight move at one orientation: a capture turned away (a pose paired with
/// the next scan's profile, a scan split wrongly) is named, not read as a scan direction the disk
/// cannot have.
fn same_orientation(c: &Captures, scan: usize, ps: &[&CaptureProfile]) -> Result<(), Error> {
    let Some(first) = ps.first() else {
        return Ok(());
    };
    // Equal quaternions (simulated scans, a controller holding the orientation) need no mean:
    // the check costs nothing per trial in a sweep.
    let r0 = first.base_to_flange.rotation;
    if ps.iter().all(|p| p.base_to_flange.rotation == r0) {
        return Ok(());
    }
    let rotations: Vec<_> = ps
        .iter()
        .map(|p| p.base_to_flange.rotation.to_rotation_matrix())
        .collect();
    crate::calib::shared_orientation(&rotations, c.orientation_tolerance_deg).map_err(
        |(i, angle)| crate::calib::CalibError::Degenerate {
            method: crate::calib::disk::METHOD,
            what: format!(
                "scan {scan}: capture {i} is {angle:.3} deg from the scan's mean orientation \
                 (tolerance {} deg)",
                c.orientation_tolerance_deg
            ),
            part: "rotation",
            fix: "keep the orientation fixed during a scan (check the pairing of poses and \
                  profiles at the scan's ends), allow the controller's jitter (calibrate \
                  --orientation-tolerance-deg), or use disk-any-pose",
        },
    )?;
    Ok(())
}

/// Whether a given chord has no length next to the disk's `radius` (a recording error).
fn no_length(a: &Vector2<f64>, b: &Vector2<f64>, radius: f64) -> bool {
    (b - a).norm() <= 1e-9 * radius
}

/// A chord's two ends seen from `flange`, set in place field by field: a pushed pair is built on
/// the stack first, and its copy's wide loads straddled the narrower stores that built it (a
/// store-forwarding stall per end, 4 % of the Fig. 15 sweep).
fn push_ends(
    ends: &mut Vec<(Isometry3<f64>, Vector2<f64>)>,
    flange: &Isometry3<f64>,
    chord: [&Vector2<f64>; 2],
) {
    let n = ends.len();
    ends.resize(n + 2, (Isometry3::identity(), Vector2::zeros()));
    for (e, q) in ends[n..].iter_mut().zip(chord) {
        e.0 = *flange;
        e.1 = *q;
    }
}

/// A flange pose and a point in the sensor's x-z plane.
type SeenPoint = (Isometry3<f64>, Vector2<f64>);
/// A chord's wall points beyond each end.
type Walls = [Vec<Vector2<f64>>; 2];
/// A scan's range of ends and of face points in the closed form's lists.
type Span = (std::ops::Range<usize>, std::ops::Range<usize>);
/// The closed form's scans, chord ends, face points and walls (by a chord's first end).
type Lists = (
    Vec<DiskScan>,
    Vec<SeenPoint>,
    Vec<SeenPoint>,
    Vec<(usize, Walls)>,
);

/// The closed form's lists without the scans `left_out` (`spans`: each scan's range of ends and
/// of face points, in scan order); a kept chord's walls (index of its first end) move back by
/// the ends dropped before it.
fn without_scans(left_out: &[bool], spans: &[Span], lists: Lists) -> Lists {
    let (scans, ends, face, walls) = lists;
    let kept = |list: Vec<SeenPoint>, range: fn(&Span) -> &std::ops::Range<usize>| {
        let mut out = Vec::with_capacity(list.len());
        for (span, &dropped) in spans.iter().zip(left_out) {
            if !dropped {
                out.extend_from_slice(&list[range(span).clone()]);
            }
        }
        out
    };
    // Ends dropped before each scan's first end.
    let mut gone = 0;
    let shift: Vec<usize> = spans
        .iter()
        .zip(left_out)
        .map(|((e, _), &dropped)| {
            let before = gone;
            gone += if dropped { e.len() } else { 0 };
            before
        })
        .collect();
    let walls = walls
        .into_iter()
        .filter_map(|(e, w)| {
            let k = spans.iter().position(|(r, _)| r.contains(&e))?;
            (!left_out[k]).then(|| (e - shift[k], w))
        })
        .collect();
    let scans = (scans.into_iter().zip(left_out))
        .filter(|(_, dropped)| !**dropped)
        .map(|(s, _)| s)
        .collect();
    (scans, kept(ends, |s| &s.0), kept(face, |s| &s.1), walls)
}

/// The closed form's scans of chords from the captures (the scans inferred where the file
/// gives poses alone), with every chord end seen from its flange pose (two a chord, in the
/// scans' order), the face points, each end's walls, the groups' reports, each kept scan's
/// face noise samples and the profiles whose chord was not found.
struct Built {
    problem: DiskProblem,
    ends: Vec<SeenPoint>,
    face: Vec<SeenPoint>,
    beyond: Vec<Walls>,
    reports: Vec<super::GroupReport>,
    samples: Vec<Vec<(f64, f64, f64)>>,
    missed: usize,
}

/// Chords from every scan: the closed form's problem.
fn build(c: &Captures, sensor: &SensorModel) -> Result<Built, Error> {
    let inferred;
    let c = if !c.groups.is_empty() && c.groups.iter().all(|g| g.role == Role::Pose) {
        inferred = inferred_scans(c, sensor)?;
        &inferred
    } else {
        c
    };
    let cfg = SplitMerge::for_sensor(sensor);
    let mut missed = 0;
    let radius = c
        .specimen_radius
        .ok_or(CaptureError::MissingRadius { method: Kind::Disk })?;
    // Every scan's chord ends, face points and wall points in one list each (a scan's share is
    // its range): no copy per scan, and no empty walls kept for chords that have none.
    let (mut scans, mut reports, mut spans) = (Vec::new(), Vec::new(), Vec::new());
    let (mut ends, mut face) = (Vec::with_capacity(2 * c.profiles.len()), Vec::new());
    // (index of the chord's first end, its walls) where a chord has any.
    let mut walls: Vec<(usize, [Vec<Vector2<f64>>; 2])> = Vec::new();
    let keep = super::face_points(c.profiles.len());
    // Each scan's profiles' face noise at their depths (`DepthNoise`), dropped with the scan.
    let mut samples: Vec<Vec<(f64, f64, f64)>> = Vec::new();
    for g in &c.groups {
        // A scan's sign not recorded: the closed form needs it, the any-pose estimator does not.
        if g.sign != 1.0 && g.sign != -1.0 {
            return Err(CaptureError::MissingSign {
                group: g.id,
                method: Kind::Disk,
            }
            .into());
        }
        let ps = c.group_profiles(g.id);
        let (Some(first), Some(last)) = (ps.first(), ps.last()) else {
            continue;
        };
        same_orientation(c, g.id, &ps)?;
        let (t0, t1) = (
            first.base_to_flange.translation.vector,
            last.base_to_flange.translation.vector,
        );
        let span = t1 - t0;
        let mut chords = Vec::with_capacity(ps.len());
        let (ends_from, face_from) = (ends.len(), face.len());
        let mut report = super::GroupReport::new(g.id);
        let mut noise_samples = Vec::new();
        for p in &ps {
            let flange = &p.base_to_flange;
            let u = if span.norm_squared() > 0.0 {
                (flange.translation.vector - t0).dot(&span) / span.norm_squared()
            } else {
                0.0
            };
            // A chord as given: none of a raw profile's extraction, face or walls to carry
            // (their empty lists, moved through the nested result, stalled every profile).
            if let ProfileData::Chord { a, b } = &p.data
                && !no_length(a, b, radius)
            {
                report.count(&Ok::<(), &str>(()));
                push_ends(&mut ends, flange, [a, b]);
                chords.push(DiskChord { u, a: *a, b: *b });
                continue;
            }
            let chord = chord_of(c, g, p, sensor, radius, &cfg)?;
            report.count(&chord);
            match chord {
                Ok(Found {
                    chord: ch,
                    face: points,
                    beyond: past,
                }) => {
                    // Each profile's face noise at its depth, before thinning.
                    noise_samples.extend(DepthNoise::sample(sensor, &points));
                    if !points.is_empty() {
                        // The full-profile refinement's face points: up to FACE_POINTS per
                        // profile, spread over the chord (more cost than information beyond).
                        let stride = crate::calib::stride_for(points.len(), keep);
                        face.extend(points.into_iter().step_by(stride).map(|q| (*flange, q)));
                    }
                    if past.iter().any(|b| !b.is_empty()) {
                        walls.push((ends.len(), past));
                    }
                    push_ends(&mut ends, flange, [&ch.a, &ch.b]);
                    chords.push(DiskChord {
                        u,
                        a: ch.a,
                        b: ch.b,
                    })
                }
                Err(_) => missed += 1,
            }
        }
        scans.push(DiskScan {
            r_tcp: first.base_to_flange.rotation.to_rotation_matrix(),
            t_start: t0,
            t_end: t1,
            s: g.sign,
            chords,
        });
        spans.push((ends_from..ends.len(), face_from..face.len()));
        reports.push(report);
        samples.push(noise_samples);
    }
    // A scan with fewer than 3 chords cannot give its ellipse: left out, if 4 scans remain.
    super::leave_out_thin_groups(&mut reports, 3, 4, Kind::Disk)?;
    if reports.iter().any(|r| r.left_out) {
        let left_out: Vec<bool> = reports.iter().map(|r| r.left_out).collect();
        (scans, ends, face, walls) = without_scans(&left_out, &spans, (scans, ends, face, walls));
    }
    let mut beyond = Vec::new();
    if !face.is_empty() {
        beyond.resize_with(ends.len() / 2, <[Vec<Vector2<f64>>; 2]>::default);
        for (e, w) in walls {
            beyond[e / 2] = w;
        }
    }
    let mut problem = DiskProblem::new(radius, scans);
    problem.min_scan_angle = 0.5f64.to_radians();
    Ok(Built {
        problem,
        ends,
        face,
        beyond,
        reports,
        samples,
        missed,
    })
}

/// The closed form's response to errors that move each profile's actual flange pose, its chords
/// re-cast from there (`Method::closed_form_recast`): each chord end is where the laser plane
/// cuts the disk's rim, a circle fixed in the base (the closed form's centre, the ends' plane
/// and the stated radius), so it moves as the moved plane's cut of the rim does
/// (`recast::plane_cut_move`); the closed form is solved again from the moved ends
/// (`super::recast_responses`).
fn recast(
    c: &Captures,
    sensor: &SensorModel,
    cal: &super::Calibration,
    twists: &dyn Fn(&Isometry3<f64>) -> Option<Vec<nalgebra::Vector6<f64>>>,
) -> Option<Vec<nalgebra::Vector6<f64>>> {
    use crate::calib::recast::plane_cut_move;
    let Built { problem, ends, .. } = build(c, sensor).ok()?;
    let chords: usize = problem.scans.iter().map(|s| s.chords.len()).sum();
    if ends.len() != 2 * chords {
        return None;
    }
    let at = crate::calib::disk::solve(&problem).ok()?.flange_to_sensor;
    let centre = cal.centre_in_base?;
    let normal = plane_normal(&ends, &at, &sensor.apex());
    // Each end's move per unit of each error, its pose's twists asked for once a run of ends.
    let mut moves: Vec<Vec<Vector2<f64>>> = Vec::with_capacity(ends.len());
    let mut last: Option<(Isometry3<f64>, Vec<nalgebra::Vector6<f64>>)> = None;
    for (f, q) in &ends {
        let t = match &last {
            Some((g, t)) if g == f => t.clone(),
            _ => {
                let t = twists(f)?;
                last = Some((*f, t.clone()));
                t
            }
        };
        let to_base = f * at;
        let p_in_base = to_base * Point3::new(q.x, 0.0, q.y);
        let tangent = to_base.rotation.inverse() * normal.cross(&(p_in_base.coords - centre));
        moves.push(
            t.iter()
                .map(|xi| plane_cut_move(&at, q, &tangent, xi))
                .collect::<Option<_>>()?,
        );
    }
    let errors = moves.first()?.len();
    if moves.iter().any(|m| m.len() != errors) {
        return None;
    }
    super::recast_responses(errors, |e, h| {
        let mut moved = problem.clone();
        let chords = moved.scans.iter_mut().flat_map(|s| s.chords.iter_mut());
        for (chord, m) in chords.zip(moves.chunks_exact(2)) {
            chord.a += m[0][e] * h;
            chord.b += m[1][e] * h;
        }
        crate::calib::disk::solve(&moved)
            .ok()
            .map(|s| s.flange_to_sensor)
    })
}

/// The disk closed form's covariance under an error of sd `sd` on each chord end's x and z
/// (`Method::closed_form_feature_noise`): the closed form solved again with every end moved by
/// a hundredth of a seeded draw of it (the solves are smooth at that size), its moves scaled
/// back and their mean square taken over `verdict::FEATURE_NOISE_DRAWS` draws.
fn feature_noise(c: &Captures, sensor: &SensorModel, sd: f64) -> Option<nalgebra::Matrix6<f64>> {
    if !(sd > 0.0) {
        return None;
    }
    let Built { problem, .. } = build(c, sensor).ok()?;
    let at = crate::calib::disk::solve(&problem).ok()?.flange_to_sensor;
    let h = 1e-2;
    let mut sum = nalgebra::Matrix6::zeros();
    for m in 0..super::verdict::FEATURE_NOISE_DRAWS {
        let mut g = crate::rng::stream(super::verdict::NOISE_SEED, &[m]);
        let mut moved = problem.clone();
        for chord in moved.scans.iter_mut().flat_map(|s| s.chords.iter_mut()) {
            for end in [&mut chord.a, &mut chord.b] {
                end.x += h * sd * crate::rng::gauss(&mut g);
                end.y += h * sd * crate::rng::gauss(&mut g);
            }
        }
        let sol = crate::calib::disk::solve(&moved).ok()?;
        let w = super::verdict::step_between(&at, &sol.flange_to_sensor) / h;
        sum += w * w.transpose();
    }
    let v = sum / super::verdict::FEATURE_NOISE_DRAWS as f64;
    v.iter().all(|x| x.is_finite()).then_some(v)
}

/// Chords from every scan, the disk paper's transformation solution, and the refinement problem.
fn calibrate(c: &Captures, sensor: &SensorModel) -> Result<super::Calibration, Error> {
    let Built {
        problem,
        ends,
        face,
        beyond,
        reports,
        samples,
        missed,
    } = build(c, sensor)?;
    let radius = problem.radius;
    let sol = crate::calib::disk::solve(&problem)?;
    let normal = plane_normal(&ends, &sol.flange_to_sensor, &sensor.apex());
    let specimen = DiskPose::new(sol.centre_in_base.into(), &normal);
    let full_profile = (!face.is_empty()).then(|| {
        let noise = kept_noise(&samples, &reports);
        let rim = rim_of(
            &ends,
            &beyond,
            &sol.flange_to_sensor,
            &specimen,
            radius,
            sensor,
            noise.as_ref(),
        );
        std::sync::Arc::new(Problem {
            model: DiskModel {
                rims: Vec::new(),
                rim_weights: Vec::new(),
                walls: rim.walls,
                end_weights: rim.end_weights,
                radius,
                ends: rim.ends,
                face_weights: face_weights(&face, |p| {
                    DepthNoise::weight_or_one(noise.as_ref(), sensor, p)
                }),
                face,
            },
            specimen,
        }) as std::sync::Arc<dyn crate::calib::refine::Refinable>
    });
    Ok(super::Calibration {
        refinable: Some(std::sync::Arc::new(Problem {
            model: DiskModel {
                rims: Vec::new(),
                rim_weights: Vec::new(),
                walls: Vec::new(),
                end_weights: Vec::new(),
                radius,
                ends,
                face: Vec::new(),
                face_weights: Vec::new(),
            },
            specimen,
        })),
        full_profile,
        flange_to_sensor: sol.flange_to_sensor,
        centre_in_base: Some(sol.centre_in_base),
        figures: Metrics::default().with(Metric::Accuracy, Some(sol.accuracy * 1e3)),
        status: sol.status,
        missed,
        groups: reports,
    })
}

/// A straight move of `length` (m) from rest to rest, at most `speed` (m/s), speeding up and
/// braking at `accel` (m/s^2): a trapezoid of speed, a triangle when too short to reach it. At
/// rest at its start before time 0 and at its end after `duration`.
#[derive(Debug, Clone, Copy)]
struct ScanMove {
    length: f64,
    speed: f64,
    accel: f64,
}

impl ScanMove {
    /// The highest speed reached and the time to reach it.
    fn ramp(&self) -> (f64, f64) {
        let top = self.speed.min((self.accel * self.length).sqrt());
        (top, top / self.accel)
    }

    fn duration(&self) -> f64 {
        let (top, ramp) = self.ramp();
        2.0 * ramp + (self.length - top * ramp) / top
    }

    /// Distance from the start at time `t`.
    fn position(&self, t: f64) -> f64 {
        let (top, ramp) = self.ramp();
        let end = self.duration();
        let t = t.clamp(0.0, end);
        if t < ramp {
            0.5 * self.accel * t * t
        } else if t <= end - ramp {
            0.5 * top * ramp + top * (t - ramp)
        } else {
            let left = end - t;
            self.length - 0.5 * self.accel * left * left
        }
    }

    /// The time the move is `s` from its start (the first such time).
    fn time_at(&self, s: f64) -> f64 {
        let (top, ramp) = self.ramp();
        let s = s.clamp(0.0, self.length);
        let ramped = 0.5 * top * ramp;
        if s <= ramped {
            (2.0 * s / self.accel).sqrt()
        } else if s <= self.length - ramped {
            ramp + (s - ramped) / top
        } else {
            self.duration() - (2.0 * (self.length - s) / self.accel).sqrt()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::ScanMove;

    #[test]
    fn a_move_from_rest_to_rest_reaches_each_point_once_at_its_time() {
        // A trapezoid (reaches 0.1 m/s) and a triangle (too short to).
        for m in [
            ScanMove {
                length: 0.12,
                speed: 0.1,
                accel: 0.5,
            },
            ScanMove {
                length: 0.01,
                speed: 0.1,
                accel: 0.5,
            },
        ] {
            let end = m.duration();
            assert_eq!(m.position(-1.0), 0.0);
            assert!((m.position(end + 1.0) - m.length).abs() < 1e-15);
            for k in 0..=100 {
                let s = m.length * k as f64 / 100.0;
                let t = m.time_at(s);
                assert!((0.0..=end + 1e-12).contains(&t));
                assert!((m.position(t) - s).abs() < 1e-12, "{m:?} at {s}");
            }
            // Never faster than the speed, never accelerating harder than the limit.
            let h = 1e-4;
            let v = |t: f64| (m.position(t + h) - m.position(t)) / h;
            for k in 0..200 {
                let t = end * k as f64 / 200.0;
                assert!(v(t) <= m.speed * (1.0 + 1e-9));
                assert!((v(t + h) - v(t)).abs() / h <= m.accel * 1.01);
            }
        }
    }
}
