//! One trial: simulate the captures of a scenario, calibrate with a method, score against the
//! truth. Its numbers depend only on (scenario, seed, trial index).

use crate::calib::{PoseError, Status};
use crate::captures::{Calibration, CaptureProfile, Captures, Group, ProfileData, Role};
use crate::rng::{self, tag};
use crate::scenario::Setup;
use crate::sim::ball::BallTarget;
use crate::sim::disk::DiskTarget;
use crate::sim::disturb::Disturbance;
use crate::sim::flange_pose;
use nalgebra::Isometry3;

/// What a successful calibration gave.
#[derive(Debug, Clone, PartialEq)]
pub struct Score {
    pub estimate: Isometry3<f64>,
    pub error: PoseError,
    /// Distance of the reconstructed specimen centre from the true one (disk, ball), mm.
    pub centre_error_mm: Option<f64>,
    /// The method's own accuracy figure: the spread of the specimen centres (disk paper Sec.
    /// III-D, Eq. 56), mm.
    pub accuracy_mm: Option<f64>,
    /// Edge method: mean angle of the group edge directions from the global one (Table 1), deg.
    pub edge_angle_dev_deg: Option<f64>,
    /// Edge method: mean distance of the points from the fitted edge (Table 2), mm.
    pub edge_distance_mm: Option<f64>,
    /// Edge method: radius of the precision ball reconstructed with the estimate (Table 3), mm.
    pub sphere_radius_mm: Option<f64>,
    pub status: Status,
    /// Refined methods: the refinement (uncertainty, observability, costs).
    pub refined: Option<crate::calib::refine::Refined>,
}

impl Score {
    fn new(estimate: Isometry3<f64>, truth: &Isometry3<f64>, status: Status) -> Score {
        Score {
            error: PoseError::between(&estimate, truth),
            estimate,
            centre_error_mm: None,
            accuracy_mm: None,
            edge_angle_dev_deg: None,
            edge_distance_mm: None,
            sphere_radius_mm: None,
            status,
            refined: None,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct TrialOutcome {
    pub trial: u64,
    pub method: String,
    /// The score, or why the method failed on this trial's data.
    pub result: Result<Score, String>,
    /// Profiles in which the feature could not be found.
    pub missed_profiles: usize,
}

/// Run trial `trial` of `method` on a built scenario: simulate the captures, calibrate them with
/// `captures::calibrate` (the code a capture file from a real rig goes through), score.
pub fn run_trial(setup: &Setup, method: &str, seed: u64, trial: u64) -> TrialOutcome {
    let (caps, validation_seed) = trial_captures(setup, method, seed, trial);
    let (result, missed) = match caps {
        Err(e) => (Err(e), 0),
        Ok(caps) => match crate::captures::calibrate(&caps, &setup.rig.sensor) {
            Err(e) => (Err(e), 0),
            Ok(cal) => match refine_if_asked(method, cal) {
                Ok((cal, refined)) => {
                    let mut s = score(setup, method, &cal, validation_seed);
                    s.refined = refined;
                    (Ok(s), cal.missed)
                }
                Err(e) => (Err(e), 0),
            },
        },
    };
    TrialOutcome {
        trial,
        method: method.to_string(),
        result,
        missed_profiles: missed,
    }
}

/// For a "-refined" method, the joint refinement of the closed-form calibration (its estimate
/// and specimen pose replace the closed-form ones).
pub fn refine_if_asked(
    method: &str,
    mut cal: Calibration,
) -> Result<(Calibration, Option<crate::calib::refine::Refined>), String> {
    if !method.ends_with("-refined") {
        return Ok((cal, None));
    }
    let r = crate::captures::refine(&cal, &Default::default())?;
    cal.flange_to_sensor = r.flange_to_sensor;
    cal.status = r.status;
    cal.centre_in_base = match r.specimen {
        crate::calib::refine::SpecimenEstimate::Disk { centre, .. }
        | crate::calib::refine::SpecimenEstimate::Ball { centre } => Some(centre.coords),
        _ => cal.centre_in_base,
    };
    Ok((cal, Some(r)))
}

/// The captures of trial `trial` (exactly those `run_trial` calibrates) and the seed of its edge
/// Table 3 check.
pub fn trial_captures(
    setup: &Setup,
    method: &str,
    seed: u64,
    trial: u64,
) -> (Result<Captures, String>, u64) {
    let mut r = rng::stream(seed, &[tag::TRIAL, trial]);
    // The Table 3 scan of the edge method draws from its own stream.
    let validation_seed: u64 = rand::RngExt::random(&mut r);
    // Robot error and vibration draw from their own stream: switched off, nothing changes.
    let mut dist = Disturbance::new(
        &setup.rig.robot,
        setup.robot_error,
        setup.vibration,
        rng::stream(seed, &[tag::ROBOT_ERROR, trial]),
    );
    if let Some(d) = &setup.dynamics {
        let gains = crate::sim::dynamics::ServoGains {
            stiffness: d.stiffness,
            damping: d.damping,
        };
        match crate::sim::dynamics::ArmDynamics::new(&setup.rig.robot, gains, d.dt_ms * 1e-3) {
            Ok(arm) => {
                dist.dynamic = Some(crate::sim::disturb::Dynamic {
                    arm,
                    settle_s: d.settle_ms * 1e-3,
                    speed_fraction: d.speed_fraction,
                })
            }
            Err(e) => return (Err(e), validation_seed),
        }
    }
    // The specimen's imperfection likewise.
    let mut specimen_rng = rng::stream(seed, &[tag::SPECIMEN, trial]);
    (
        simulate(
            setup,
            crate::scenario::base_method(method),
            &mut r,
            &mut dist,
            &mut specimen_rng,
        ),
        validation_seed,
    )
}

/// Score a calibration of `method` against the scenario's truth.
pub fn score(setup: &Setup, method: &str, cal: &Calibration, validation_seed: u64) -> Score {
    let method = crate::scenario::base_method(method);
    let truth_centre = match method {
        "disk" => setup.disk.as_ref().map(|d| d.target.centre.coords),
        "ball" => setup.ball.as_ref().map(|b| b.target.centre.coords),
        _ => None,
    };
    let sphere = setup
        .edge
        .as_ref()
        .filter(|_| method == "edge")
        .and_then(|e| e.validation.as_ref())
        .and_then(|(ball, groups, translations, sigma)| {
            let mut vr = rng::stream(validation_seed, &[tag::SPECIMEN]);
            crate::sim::edge::ball_radius_check(
                &setup.rig,
                &cal.flange_to_sensor,
                ball,
                *groups,
                *translations,
                *sigma,
                0.1e-3,
                &mut vr,
            )
        });
    Score {
        centre_error_mm: cal
            .centre_in_base
            .zip(truth_centre)
            .map(|(c, t)| (c - t).norm() * 1e3),
        accuracy_mm: cal.accuracy.map(|a| a * 1e3),
        edge_angle_dev_deg: cal.edge_angle_dev.map(f64::to_degrees),
        edge_distance_mm: cal.edge_distance.map(|d| d * 1e3),
        sphere_radius_mm: sphere.map(|x| x * 1e3),
        ..Score::new(
            cal.flange_to_sensor,
            &setup.rig.flange_to_sensor,
            cal.status,
        )
    }
}

/// The captures of one trial of `method`: what the rig would record (features for the analytic
/// sources, raw profiles for the ray-cast ones), with the truth attached.
///
/// `specimen_rng` draws the specimen's imperfection: the true radius is nominal + z * tolerance (z
/// standard normal), then the form error; the captures carry the nominal radius (what the user was
/// told).
pub fn simulate(
    setup: &Setup,
    method: &str,
    r: &mut rng::Rng,
    dist: &mut Disturbance,
    specimen_rng: &mut rng::Rng,
) -> Result<Captures, String> {
    use crate::scene::FormError;
    let radius_z = crate::sensor::gauss(specimen_rng);
    let rig = &setup.rig;
    let robot = &rig.robot;
    // Profiles are numbered in the order they are taken (the vibration's clock).
    let mut k = 0usize;
    let mut actual = |f: &nalgebra::Isometry3<f64>| {
        let a = dist.actual(robot, f, k);
        k += 1;
        a
    };
    let noisy = !rig.sensor.noise.is_off();
    let mut groups = Vec::new();
    let mut profiles = Vec::new();
    let (kind, radius, sense) = match method {
        "disk" => {
            let d = setup.disk.as_ref().ok_or("the scenario has no disk plan")?;
            let target = DiskTarget {
                radius: d.target.radius + radius_z * d.radius_tolerance,
                ..d.target
            };
            let form = FormError::draw(&setup.specimen, &d.form, specimen_rng);
            let scene = with_form(
                with_radius(&setup.scene, target.radius, d.radius_tolerance),
                form,
            );
            for (i, p) in d.plans.iter().enumerate() {
                groups.push(Group {
                    id: i,
                    role: Role::Scan,
                    sign: crate::sim::disk::scan_sign(rig, p),
                });
                if d.raycast {
                    for j in 0..p.m {
                        let f = flange_pose(&p.r_tcp, &p.tcp(j));
                        let prof = rig.sensor.profile(
                            &scene,
                            &rig.base_to_sensor(&actual(&f)),
                            noisy.then_some(&mut *r),
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
                        Some((&setup.base_to_specimen, &form)),
                        p,
                        d.sigma,
                        r,
                        &mut |f, _| actual(f),
                    );
                    for ch in scan.chords {
                        let f = flange_pose(&p.r_tcp, &(p.t_start + (p.t_end - p.t_start) * ch.u));
                        profiles.push(CaptureProfile {
                            group: i,
                            base_to_flange: f,
                            data: ProfileData::Chord { a: ch.a, b: ch.b },
                        });
                    }
                }
            }
            (
                setup.specimen.name().to_string(),
                Some(d.target.radius),
                None,
            )
        }
        "ball" => {
            let b = setup.ball.as_ref().ok_or("the scenario has no ball plan")?;
            let target = BallTarget {
                radius: b.target.radius + radius_z * b.radius_tolerance,
                ..b.target
            };
            let (spec, frame) = &b.scene.specimens[0];
            let form = FormError::draw(spec, &b.form, specimen_rng);
            let scene = with_form(
                with_radius(&b.scene, target.radius, b.radius_tolerance),
                form,
            );
            let poses = b
                .plan
                .rotation_set
                .iter()
                .map(|p| (Role::Rotation, p, 1))
                .chain(
                    b.plan
                        .translation_set
                        .iter()
                        .map(|p| (Role::Translation, p, b.plan.arcs.max(1))),
                );
            let mut gid = 0;
            groups.push(Group {
                id: 0,
                role: Role::Rotation,
                sign: 0.0,
            });
            for (role, p, m) in poses {
                let f = flange_pose(&p.r_tcp, &p.t_tcp);
                let sign = crate::sim::ball::sign(&rig.base_to_sensor(&f), &target);
                let id = if role == Role::Rotation {
                    groups[0].sign = sign;
                    0
                } else {
                    gid += 1;
                    groups.push(Group {
                        id: gid,
                        role,
                        sign,
                    });
                    gid
                };
                for _ in 0..m {
                    let pose = rig.base_to_sensor(&actual(&f));
                    let data = if b.raycast {
                        ProfileData::Raw(rig.sensor.profile(
                            &scene,
                            &pose,
                            noisy.then_some(&mut *r),
                        ))
                    } else {
                        let arc = crate::sim::ball::analytic_arc_formed(
                            rig,
                            &target,
                            Some((frame, &form)),
                            &pose,
                            b.x_step,
                            b.sigma,
                            0.9,
                            r,
                        );
                        ProfileData::Arc(arc)
                    };
                    profiles.push(CaptureProfile {
                        group: id,
                        base_to_flange: f,
                        data,
                    });
                }
            }
            ("ball".to_string(), Some(b.target.radius), None)
        }
        "edge" => {
            let e = setup.edge.as_ref().ok_or("the scenario has no edge plan")?;
            let (spec, frame) = &e.scene.specimens[0];
            let form = FormError::draw(spec, &e.form, specimen_rng);
            let scene = with_form(std::borrow::Cow::Borrowed(&e.scene), form);
            for (g, p) in e.plans.iter().enumerate() {
                groups.push(Group {
                    id: g,
                    role: Role::RotationGroup,
                    sign: 0.0,
                });
                for t in &p.tcps {
                    let f = flange_pose(&p.r_tcp, t);
                    let pose = rig.base_to_sensor(&actual(&f));
                    let data = if e.raycast {
                        ProfileData::Raw(rig.sensor.profile(
                            &scene,
                            &pose,
                            noisy.then_some(&mut *r),
                        ))
                    } else {
                        let (nx, nz) = (
                            crate::sensor::gauss(r) * e.sigma,
                            crate::sensor::gauss(r) * e.sigma,
                        );
                        let q =
                            crate::sim::edge::exact_point_formed(&pose, &e.target, frame, &form)
                                .ok_or_else(|| {
                                    format!("group {g}: the laser plane is parallel to the edge")
                                })?;
                        ProfileData::EdgePoint(q + nalgebra::Vector2::new(nx, nz))
                    };
                    profiles.push(CaptureProfile {
                        group: g,
                        base_to_flange: f,
                        data,
                    });
                }
            }
            let kind = e
                .scene
                .specimens
                .first()
                .map(|s| s.0.name())
                .unwrap_or("parallel-bar")
                .to_string();
            (kind, None, Some(crate::sim::edge::sense(rig, &e.target)))
        }
        other => {
            return Err(format!(
                "method '{other}' is not available for this scenario"
            ));
        }
    };
    Ok(Captures {
        method: method.to_string(),
        sensor: rig.sensor.name.clone(),
        specimen_kind: kind,
        specimen_radius: radius,
        edge_sense: sense,
        truth: Some(rig.flange_to_sensor),
        groups,
        profiles,
    })
}

/// The scene with its first specimen's form error (the scene itself for a perfect part).
fn with_form(
    scene: std::borrow::Cow<'_, crate::scene::Scene>,
    form: crate::scene::FormError,
) -> std::borrow::Cow<'_, crate::scene::Scene> {
    if form.is_none() {
        return scene;
    }
    let mut s = scene.into_owned();
    s.set_form(0, form);
    std::borrow::Cow::Owned(s)
}

/// The scene with its first specimen's disk or ball radius set to `radius` (when the tolerance is
/// non-zero; otherwise the scene itself).
fn with_radius(
    scene: &crate::scene::Scene,
    radius: f64,
    tolerance: f64,
) -> std::borrow::Cow<'_, crate::scene::Scene> {
    use crate::scene::{Scene, SpecimenKind};
    if tolerance == 0.0 {
        return std::borrow::Cow::Borrowed(scene);
    }
    let mut out = Scene::new(scene.table);
    for (i, (spec, pose)) in scene.specimens.iter().enumerate() {
        let mut s = spec.clone();
        if i == 0 {
            match &mut s.kind {
                SpecimenKind::DiskOnCylinder { radius: r, .. }
                | SpecimenKind::DiskOnPaper { radius: r, .. }
                | SpecimenKind::BallOnPost { radius: r, .. } => *r = radius,
                _ => {}
            }
        }
        out.add(&s, *pose);
    }
    std::borrow::Cow::Owned(out)
}
