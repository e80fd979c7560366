//! Issue 13: the feature extraction and the methods on profiles lasercal's own ray caster did not
//! make (`testkit::fan`, an independent generator), for sensors declared by their geometry. The
//! poses and groups are lasercal's plans; every profile is replaced by the generator's.
//!
//! What holds today is asserted; the targets (noise-free features within 0.01 mm and the
//! calibration within 0.02 deg / 0.02 mm; at sigma 0.1 mm raw-profile errors within 1.5x those from
//! exact features) are printed beside them (`cargo test --test suite independent:: -- --nocapture`).

use crate::common;

use lasercal::captures::{Captures, ProfileData};
use lasercal::method::Kind;
use lasercal::scenario::{ScenarioFile, Setup};
use lasercal::sensor::SensorModel;
use lasercal::testkit::fan::{Fan, Noise, Solid, profile};
use lasercal::trial::trial_captures;
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion};

/// The sensor told of z noise `sigma_mm` at both ends of its range (what tunes the extraction).
fn with_sigma(sensor: &SensorModel, sigma_mm: f64) -> SensorModel {
    let mut s = sensor.clone();
    s.noise.z_sigma_near = sigma_mm * 1e-3;
    s.noise.z_sigma_far = sigma_mm * 1e-3;
    s
}

use common::regenerate;

/// Trials per case of the measured tests: `LASERCAL_INDEPENDENT_TRIALS` (default 2).
fn independent_trials() -> u64 {
    std::env::var("LASERCAL_INDEPENDENT_TRIALS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2)
}

/// The specimens of `solids` slid within +-1 mm along the base's x and y (a draw of its own
/// stream for each `trial`; the table stays). On one placement the part of the error the sensor's
/// columns make (where each rim or edge falls between two of them) is one draw, the same in every
/// trial, so trials that differ by noise alone would measure the bound against that one draw
/// (docs/verdict.md, "Measured"); placed anew, they count placements as users' rigs differ.
fn placed(solids: &[Solid], trial: u64) -> Vec<Solid> {
    let mut g = lasercal::testkit::rng(90_000 + trial);
    let mut u = || rand::RngExt::random_range(&mut g, -1e-3..=1e-3);
    let shift = nalgebra::Vector3::new(u(), u(), 0.0);
    let mut out = solids.to_vec();
    for solid in &mut out {
        match solid {
            Solid::DiskOnCylinder { frame, .. }
            | Solid::Bar { frame, .. }
            | Solid::Wedge { frame, .. } => frame.translation.vector += shift,
            Solid::Sphere { centre, .. } => *centre += shift,
            Solid::Table { .. } | Solid::Plane { .. } => {}
        }
    }
    out
}

fn scenario(name: &str, edit: &dyn Fn(String) -> String) -> Setup {
    let text = edit(std::fs::read_to_string(common::scen(name)).unwrap());
    let sf = ScenarioFile::parse(&text, name).unwrap();
    sf.scenario.build(&sf.file).unwrap()
}

/// The disk paper's disk on its cylinder, scanned along the sensor's y (as the ray-cast tests).
fn disk_case() -> (Setup, Fan, Vec<Solid>) {
    disk_case_with(common::fan_295())
}

/// The disk case seen by any fan whose frame is the Gocator's (origin at the range centre, z
/// toward the sensor).
fn disk_case_with(fan: Fan) -> (Setup, Fan, Vec<Solid>) {
    let s = scenario("chen2018-disk.toml", &|t| {
        t.replace("source = \"analytic\"", "source = \"raycast\"")
            .replace("directions_in_base", "directions_in_sensor")
            .replace("span_fraction = 0.9", "span_fraction = 0.8")
            .replace(
                "[[0.181, -0.246, -0.952], [0.287, -0.294, -0.912], [0.391, -0.593, -0.704], [0.164, -0.631, -0.758]]",
                "[[0.1, 1.0, -0.5], [-0.2, 1.0, -0.4], [0.2, 1.0, -0.6], [-0.1, 1.0, -0.45]]",
            )
            .replace("preset = \"gocator-2340\"", "preset = \"gocator-2340\"\nquantise = false")
    });
    let solids = vec![
        Solid::DiskOnCylinder {
            frame: s.base_to_specimen,
            radius: 0.050,
            height: 0.020,
        },
        Solid::Table { height: -0.00852 },
    ];
    (s, fan, solids)
}

/// The edge paper's parallel bar seen by a fan unlike the VLM350's: equal-angle rays, column 0 at
/// +x, z away from the sensor.
fn edge_case() -> (Setup, Fan, Vec<Solid>) {
    edge_case_with(Fan {
        apex_z: -0.030,
        dir_z: 1.0,
        half_angle: 12f64.to_radians(),
        columns: 1000,
        equal_angle: true,
        reversed: true,
        z_range: (0.060, 0.350),
        camera: Point3::new(0.0, 0.060, -0.030),
    })
}

/// The edge case seen by any fan whose frame is the VLM350's (origin at the sensor, z away).
fn edge_case_with(fan: Fan) -> (Setup, Fan, Vec<Solid>) {
    let s = scenario("xu2021-edge.toml", &|t| {
        t.replace("source = \"analytic\"", "source = \"raycast\"")
    });
    let (bar, pose) = (&s.scene.specimens[0].0, s.scene.specimens[0].1);
    let solids = vec![
        common::bar_solid(bar, pose),
        Solid::Table {
            height: s.scene.table.map(|t| t.height_m).unwrap_or(-10.0),
        },
    ];
    (s, fan, solids)
}

fn errors(caps: &Captures, s: &Setup, sensor: &SensorModel) -> Result<(f64, f64, usize), String> {
    let cal = lasercal::method::calibrate(caps, sensor).map_err(|e| e.to_string())?;
    let e = lasercal::calib::PoseError::between(&cal.flange_to_sensor, &s.rig.flange_to_sensor);
    Ok((e.rotation_error_deg, e.translation_error_mm, cal.missed))
}

#[test]
fn the_generator_agrees_with_the_fan_it_declares() {
    // The generator's rays are the declared sensor's rays (column by column).
    let (_, fan, _) = disk_case();
    let m = common::declared(&fan, "fan");
    for k in [0, 1, 639, 640, 1279] {
        let d = fan.ray(k);
        assert!(
            (d.x / (d.z * fan.dir_z) - m.column_tan(k)).abs() < 1e-12,
            "column {k}"
        );
    }
    // A flat table straight below: every column sees it, at the table's height.
    let table = [Solid::Table { height: 0.0 }];
    let pose = Isometry3::from_parts(
        Translation3::new(0.0, 0.0, 0.100),
        UnitQuaternion::identity(),
    );
    let p = profile(
        &fan,
        &table,
        &pose,
        Noise::default(),
        &mut lasercal::testkit::rng(1),
    );
    assert!(
        p.iter()
            .all(|q| q.is_some_and(|(_, z)| (z + 0.100).abs() < 1e-12))
    );
}

#[test]
fn disk_on_independent_profiles() {
    let (s, fan, solids) = disk_case();
    let sensor = common::declared(&fan, "fan-295");
    let caps = trial_captures(&s, Kind::Disk, 1, 0).0.unwrap();
    // Noise-free: every chord end against the exact chord.
    let exact_caps = regenerate(&caps, &s, &fan, &solids, Noise::default(), 1);
    let target = lasercal::sim::disk::DiskTarget::from_pose(&s.base_to_specimen, 0.050);
    let cfg = lasercal::features::SplitMerge::for_sensor(&sensor);
    let (mut worst, mut n, mut missed) = (0.0f64, 0, 0);
    for p in &exact_caps.profiles {
        let ProfileData::Raw(prof) = &p.data else {
            unreachable!()
        };
        let pose = p.base_to_flange * s.rig.flange_to_sensor;
        let Some((a, b)) = lasercal::sim::disk::exact_chord(&pose, &target) else {
            continue;
        };
        match lasercal::features::disk_chord_step(prof, &sensor, 0.050, &cfg) {
            Ok(ch) => {
                worst = worst.max((ch.a - a).norm()).max((ch.b - b).norm());
                n += 1;
            }
            Err(_) => missed += 1,
        }
    }
    let (rot, tr, _) = errors(&exact_caps, &s, &sensor).unwrap();
    eprintln!(
        "disk, noise-free: worst chord end {:.4} mm over {n} chords ({missed} missed); \
         calibration {rot:.4} deg / {tr:.4} mm (targets: 0.01 mm, 0.02 deg / 0.02 mm)",
        worst * 1e3
    );
    // Today: ends placed halfway between columns (at most half an x sample, 0.1 mm here), every
    // chord found, and the bound of lasercal's own ray-cast test.
    assert_eq!(missed, 0);
    assert!(worst < 0.11e-3, "worst chord end {} mm", worst * 1e3);
    assert!(rot < 0.05 && tr < 0.1, "{rot} deg, {tr} mm");
    for sigma_mm in [0.05, 0.1, 0.2] {
        let noisy = regenerate(
            &caps,
            &s,
            &fan,
            &solids,
            Noise {
                sigma_z: sigma_mm * 1e-3,
                dropout: 0.0,
                sigma_z_far: 0.0,
            },
            2,
        );
        let sensor = with_sigma(&sensor, sigma_mm);
        let e = errors(&noisy, &s, &sensor);
        eprintln!("disk, sigma {sigma_mm} mm: {e:?}");
        // Was 13.8 deg at 0.1 mm (long noisy faces split at random points, chords truncated):
        // now every chord is found and the error grows about linearly with the noise.
        let (rot, tr, missed) = e.unwrap();
        assert_eq!(missed, 0, "sigma {sigma_mm} mm");
        assert!(
            rot < 1.5 * sigma_mm && tr < 1.2 * sigma_mm,
            "sigma {sigma_mm} mm: {rot} deg, {tr} mm"
        );
    }
}

#[test]
fn edge_on_independent_profiles() {
    let (s, fan, solids) = edge_case();
    let sensor = common::declared(&fan, "fan-edge");
    let caps = trial_captures(&s, Kind::Edge, 1, 0).0.unwrap();
    let exact_caps = regenerate(&caps, &s, &fan, &solids, Noise::default(), 1);
    let plan = s.plan(Kind::Edge).unwrap();
    let target = plan
        .as_any()
        .downcast_ref::<lasercal::method::edge::EdgePlan>()
        .unwrap();
    let cfg = lasercal::features::SplitMerge {
        split_tol: 0.1e-3,
        jump: 0.5e-3,
        min_points: 4,
    };
    let (mut worst, mut n, mut missed) = (0.0f64, 0, 0);
    for p in &exact_caps.profiles {
        let ProfileData::Raw(prof) = &p.data else {
            unreachable!()
        };
        let pose = p.base_to_flange * s.rig.flange_to_sensor;
        let Some(q) = lasercal::sim::edge::exact_point(&pose, &target.target) else {
            continue;
        };
        match lasercal::features::edge_point(prof, &sensor, target.sense, &cfg) {
            Ok(e) => {
                worst = worst.max((e - q).norm());
                n += 1;
            }
            Err(_) => missed += 1,
        }
    }
    let cal = errors(&exact_caps, &s, &sensor);
    eprintln!(
        "edge, noise-free: worst edge point {:.4} mm over {n} profiles ({missed} missed); \
         calibration {cal:?} (targets: 0.01 mm, 0.02 deg / 0.02 mm)",
        worst * 1e3
    );
    // Today: the edge point at the corner of two fitted faces, every profile found.
    assert_eq!(missed, 0);
    assert!(worst < 0.05e-3, "worst edge point {} mm", worst * 1e3);
    let (rot, tr, _) = cal.unwrap();
    assert!(rot < 0.05 && tr < 0.05, "{rot} deg, {tr} mm");
}

#[test]
fn disk_with_dropout() {
    // Dropout used to break the disk's face into pieces (28 mm short chords, 2.7 deg at 0.2).
    let (s, fan, solids) = disk_case();
    let sensor = common::declared(&fan, "fan-295");
    let caps = trial_captures(&s, Kind::Disk, 1, 0).0.unwrap();
    let target = lasercal::sim::disk::DiskTarget::from_pose(&s.base_to_specimen, 0.050);
    let cfg = lasercal::features::SplitMerge::for_sensor(&sensor);
    for (dropout, bound_deg, bound_mm) in
        [(0.05, 0.1, 0.1), (0.2, 0.3, 0.3), (0.5, f64::NAN, f64::NAN)]
    {
        let noisy = regenerate(
            &caps,
            &s,
            &fan,
            &solids,
            Noise {
                sigma_z: 0.0,
                dropout,
                sigma_z_far: 0.0,
            },
            3,
        );
        let mut ends = Vec::new();
        for p in &noisy.profiles {
            let ProfileData::Raw(prof) = &p.data else {
                unreachable!()
            };
            let pose = p.base_to_flange * s.rig.flange_to_sensor;
            let Some((a, b)) = lasercal::sim::disk::exact_chord(&pose, &target) else {
                continue;
            };
            if let Ok(ch) = lasercal::features::disk_chord_step(prof, &sensor, 0.050, &cfg) {
                ends.push((ch.a - a).norm().max((ch.b - b).norm()));
            }
        }
        ends.sort_by(f64::total_cmp);
        let cal = errors(&noisy, &s, &sensor);
        eprintln!(
            "disk, dropout {dropout}: chord ends median {:.3} mm, worst {:.3} mm over {} chords; calibration {cal:?}",
            ends.get(ends.len() / 2).map_or(f64::NAN, |e| e * 1e3),
            ends.last().map_or(f64::NAN, |e| e * 1e3),
            ends.len()
        );
        if !bound_deg.is_finite() {
            // Half the points gone: refused with the reason, not a wrong transform.
            let e = cal.clone().unwrap_err();
            assert!(e.contains("have no point") && e.len() < 2000, "{e}");
        }
        if bound_deg.is_finite() {
            let (rot, tr, _) = cal.unwrap();
            assert!(
                rot < bound_deg && tr < bound_mm,
                "dropout {dropout}: {rot} deg, {tr} mm"
            );
        }
    }
}

/// A profile resampled onto the x grid `offset + m pitch` as a resampling profiler does (each slot
/// interpolated between two neighbouring rays that both saw something), written here apart from
/// lasercal's resampler. Returns (m, x, z), in increasing x.
fn resample(rays: &[Option<(f64, f64)>], pitch: f64, offset: f64) -> Vec<(i64, f64, f64)> {
    let mut slots = std::collections::BTreeMap::new();
    for w in rays.windows(2) {
        let (Some(a), Some(b)) = (w[0], w[1]) else {
            continue;
        };
        let (lo, hi) = if a.0 <= b.0 { (a, b) } else { (b, a) };
        let m0 = ((lo.0 - offset) / pitch).ceil() as i64;
        let m1 = ((hi.0 - offset) / pitch).floor() as i64;
        for m in m0..=m1 {
            let x = offset + m as f64 * pitch;
            let f = if hi.0 > lo.0 {
                (x - lo.0) / (hi.0 - lo.0)
            } else {
                0.0
            };
            slots.insert(m, (x, lo.1 + f * (hi.1 - lo.1)));
        }
    }
    slots.into_iter().map(|(m, (x, z))| (m, x, z)).collect()
}

#[test]
fn resampled_profiles_without_columns() {
    // A capture file from a profiler that resamples onto uniform x (pitch 0.1 mm, grid offset
    // 0.03 mm) and sends only the valid slots, without column indices, under the fan's declared
    // geometry: the grid is measured from the points and the ends placed between its slots.
    let (s, fan, solids) = disk_case();
    let sensor = common::declared(&fan, "fan-295");
    let caps = trial_captures(&s, Kind::Disk, 1, 0).0.unwrap();
    let (pitch, offset) = (0.1e-3, 0.03e-3);
    for sigma_mm in [0.0, 0.1] {
        let noise = Noise {
            sigma_z: sigma_mm * 1e-3,
            dropout: 0.0,
            sigma_z_far: 0.0,
        };
        let raw = regenerate(&caps, &s, &fan, &solids, noise, 4);
        let sensor = with_sigma(&sensor, sigma_mm);
        let mut doc: serde_json::Value =
            serde_json::from_str(&lasercal::io::captures::to_json(&raw, &sensor)).unwrap();
        for (p, rec) in raw
            .profiles
            .iter()
            .zip(doc["profiles"].as_array_mut().unwrap())
        {
            let ProfileData::Raw(prof) = &p.data else {
                unreachable!()
            };
            let rays: Vec<Option<(f64, f64)>> =
                prof.points.iter().map(|q| q.map(|q| (q.x, q.z))).collect();
            rec["points_mm"] = resample(&rays, pitch, offset)
                .into_iter()
                .map(|(_, x, z)| serde_json::json!([x * 1e3, z * 1e3]))
                .collect();
            rec.as_object_mut().unwrap().remove("intensity");
        }
        let (c, read) =
            lasercal::io::captures::from_json(&doc.to_string(), "resampled.json").unwrap();
        let grid = read.resampling().expect("the grid is measured");
        assert!(
            (grid.pitch - pitch).abs() < 1e-12 && (grid.offset - offset).abs() < 1e-12,
            "{grid:?}"
        );
        assert!(read.name.contains("resampled"), "{}", read.name);
        let (rot, tr, missed) = errors(&c, &s, &read).unwrap();
        let (rot_rays, tr_rays, _) = errors(&raw, &s, &sensor).unwrap();
        eprintln!(
            "disk, sigma {sigma_mm} mm, resampled to 0.1 mm: {rot:.4} deg / {tr:.4} mm, {missed} \
             missed (the rays themselves: {rot_rays:.4} deg / {tr_rays:.4} mm)"
        );
        assert_eq!(missed, 0);
        assert!(
            rot < 0.05 + 1.5 * sigma_mm && tr < 0.05 + 1.2 * sigma_mm,
            "{rot} deg, {tr} mm"
        );
    }
}

/// The disk paper's 69.5 mm ball on its post, ray-cast poses, the 295 mm equal-angle fan.
fn ball_case() -> (Setup, Fan, Vec<Solid>) {
    let (_, fan, _) = disk_case();
    let s = scenario("chen2018-ball.toml", &|t| {
        t.replace("source = \"analytic\"", "source = \"raycast\"")
            .replace(
                "preset = \"gocator-2340\"",
                "preset = \"gocator-2340\"\nquantise = false",
            )
    });
    let (centre, radius) = (s.plan(Kind::Ball).unwrap().true_centre().unwrap(), 0.0695);
    let post = Isometry3::from_parts(
        Translation3::from(centre.coords - nalgebra::Vector3::z() * 0.8 * radius),
        UnitQuaternion::identity(),
    );
    let solids = vec![
        Solid::Sphere { centre, radius },
        Solid::DiskOnCylinder {
            frame: post,
            radius: 0.008,
            height: 0.080,
        },
        Solid::Table { height: 0.0 },
    ];
    (s, fan, solids)
}

#[test]
fn ball_on_independent_profiles() {
    let (s, fan, solids) = ball_case();
    let sensor = common::declared(&fan, "fan-295");
    let caps = trial_captures(&s, Kind::Ball, 1, 0).0.unwrap();
    for (sigma_mm, bound_deg, bound_mm) in [(0.0, 1e-9, 1e-6), (0.1, 0.3, 0.5)] {
        let profiles = regenerate(
            &caps,
            &s,
            &fan,
            &solids,
            Noise {
                sigma_z: sigma_mm * 1e-3,
                dropout: 0.0,
                sigma_z_far: 0.0,
            },
            4,
        );
        let sensor = with_sigma(&sensor, sigma_mm);
        let e = errors(&profiles, &s, &sensor);
        eprintln!("ball, sigma {sigma_mm} mm: {e:?}");
        let (rot, tr, _) = e.unwrap();
        assert!(
            rot < bound_deg && tr < bound_mm,
            "sigma {sigma_mm}: {rot} deg, {tr} mm"
        );
    }
}

/// A closed form's response to an arm's kinematic errors, its features re-cast from each moved
/// pose (`Method::closed_form_recast`), against the closed form run on features cast anew from
/// every pose moved along the error's twists by `cast` (noise-free; central differences). The
/// worst relative difference over the 24 errors, and the same for the recorded poses moved
/// instead (the profiles kept): a closed form that takes a set's orientation as shared answers
/// those otherwise.
fn recast_against_cast(
    s: &Setup,
    kind: Kind,
    file: &Captures,
    sensor: &SensorModel,
    cast: &dyn Fn(&Captures) -> Captures,
    h: f64,
) -> (f64, f64) {
    use lasercal::method::{Estimator, MethodId, estimate, method, verdict::step_between};
    let k = lasercal::captures::Kinematic::new(
        "irb".into(),
        std::sync::Arc::new(s.rig.robot.clone()),
        1e-4,
        1e-2f64.to_radians(),
        file.profiles.iter().map(|p| (&p.base_to_flange, None)),
    )
    .unwrap();
    let id = MethodId::new(kind, Estimator::ClosedForm);
    let (cal, _) = estimate(id, file, sensor).unwrap();
    let recast = method(kind)
        .closed_form_recast(file, sensor, &cal, &|f| k.twists_at(f))
        .expect("the method re-casts");
    assert_eq!(recast.len(), 24);
    // One error's move of every pose by `h` of its twist: the features cast from there, or the
    // records moved with the features kept.
    let run = |e: usize, h: f64, cast_anew: bool| {
        let mut moved = file.clone();
        for p in &mut moved.profiles {
            let t = k.twists_at(&p.base_to_flange).unwrap()[e] * h;
            p.base_to_flange *= Isometry3::new(
                t.fixed_rows::<3>(3).into_owned(),
                t.fixed_rows::<3>(0).into_owned(),
            );
        }
        if cast_anew {
            let mut cast = cast(&moved);
            assert_eq!(cast.profiles.len(), file.profiles.len());
            for (p, q) in cast.profiles.iter_mut().zip(&file.profiles) {
                p.base_to_flange = q.base_to_flange;
            }
            moved = cast;
        }
        estimate(id, &moved, sensor).unwrap().0.flange_to_sensor
    };
    let mut moves = Vec::with_capacity(recast.len());
    for (e, r) in recast.iter().enumerate() {
        // Cast from the moved pose: the recorded pose's equivalent move is the opposite.
        let cast = -step_between(&run(e, -h, true), &run(e, h, true)) / (2.0 * h);
        let record = step_between(&run(e, -h, false), &run(e, h, false)) / (2.0 * h);
        moves.push((r, cast, record));
    }
    // Relative to the largest response: an error the closed form does not answer (a shift of
    // the whole arm) is zero in both to the solves' rounding.
    let scale = moves.iter().map(|(_, c, _)| c.norm()).fold(0.0, f64::max);
    let worst = moves
        .iter()
        .map(|(r, c, _)| (*r - c).norm())
        .fold(0.0, f64::max)
        / scale;
    let apart = moves
        .iter()
        .map(|(_, c, m)| (*m - c).norm())
        .fold(0.0, f64::max)
        / scale;
    println!(
        "{kind:?}: re-cast against cast, worst relative difference {worst:.2e}; moved records {apart:.2e}"
    );
    (worst, apart)
}

/// `recast_against_cast` on the kit's noise-free ray-cast profiles of `case`'s first trial,
/// the poses moved 3 mm or 3 mrad a unit error: a feature at a face's end falls between two
/// columns, a step the derivative does not see, so the move spans tens of columns.
fn recast_on_kit_profiles((s, fan, solids): (Setup, Fan, Vec<Solid>), kind: Kind) -> (f64, f64) {
    let sensor = common::declared(&fan, "fan-295");
    let caps = trial_captures(&s, kind, 1, 0).0.unwrap();
    let exact = Noise {
        sigma_z: 0.0,
        dropout: 0.0,
        sigma_z_far: 0.0,
    };
    let file = regenerate(&caps, &s, &fan, &solids, exact, 4);
    recast_against_cast(
        &s,
        kind,
        &file,
        &sensor,
        &|moved| regenerate(moved, &s, &fan, &solids, exact, 4),
        3e-3,
    )
}

/// The ball's arcs re-cast (each capture's centre moved in the sensor frame) against the
/// independent generator's profiles cast from the moved poses: the circles are exact whichever
/// rays hit. The recorded poses moved instead give another answer for the errors that turn the
/// flange: the rotation set takes its orientation as shared, so a turned record barely moves
/// it while a turned pose moves its centre.
#[test]
fn the_ball_closed_forms_recast_is_what_moved_poses_cast() {
    let (s, fan, solids) = ball_case();
    let sensor = common::declared(&fan, "fan-295");
    let caps = trial_captures(&s, Kind::Ball, 1, 0).0.unwrap();
    let exact = Noise {
        sigma_z: 0.0,
        dropout: 0.0,
        sigma_z_far: 0.0,
    };
    let file = regenerate(&caps, &s, &fan, &solids, exact, 4);
    let (worst, apart) = recast_against_cast(
        &s,
        Kind::Ball,
        &file,
        &sensor,
        &|moved| regenerate(moved, &s, &fan, &solids, exact, 4),
        1e-4,
    );
    assert!(worst < 1e-3, "re-cast {worst}");
    assert!(apart > 0.1, "moved records {apart}");
}

/// The disk's chords re-cast (each end slid along the rim into the moved laser plane) against
/// the exact chords of the paper's four scans cast from the moved poses (ray-cast ends fall
/// between columns, a step the derivative would not see).
#[test]
fn the_disk_closed_forms_recast_is_what_moved_poses_cast() {
    let (s, fan, _) = disk_case();
    let sensor = common::declared(&fan, "fan-295");
    let caps = trial_captures(&s, Kind::Disk, 1, 0).0.unwrap();
    let file = exact_features(&caps, &s, 0.0, 1);
    let (worst, apart) = recast_against_cast(
        &s,
        Kind::Disk,
        &file,
        &sensor,
        &|moved| exact_features(moved, &s, 0.0, 1),
        1e-4,
    );
    assert!(worst < 1e-3, "re-cast {worst}");
    assert!(apart > 0.1, "moved records {apart}");
}

/// The same on the independent kit's ray-cast profiles of the disk paper's four scans, from a fan
/// of 12,800 columns: a chord end falls between two columns, a step the derivative does not
/// see, so the poses are moved 3 mm or 3 mrad a unit error, about 30 columns (at 0.1 mm the
/// steps were 16 % of the move; at 3 mm the re-cast agrees to 0.7 %).
#[test]
fn the_disk_closed_forms_recast_holds_on_the_kits_profiles() {
    let fan = Fan {
        columns: 12_800,
        ..common::fan_295()
    };
    let (worst, apart) = recast_on_kit_profiles(disk_case_with(fan), Kind::Disk);
    assert!(worst < 0.02, "re-cast {worst}");
    assert!(apart > 0.1, "moved records {apart}");
}

/// The edge's points re-cast (each slid along the base-fixed edge into the moved laser plane)
/// against the exact edge points of the paper's 25 x 10 poses cast from the moved poses. The
/// recorded poses moved instead give another answer: the closed form takes each group's
/// orientation as shared.
#[test]
fn the_edge_closed_forms_recast_is_what_moved_poses_cast() {
    let (s, fan, _) = edge_case();
    let sensor = common::declared(&fan, "fan-295");
    let caps = trial_captures(&s, Kind::Edge, 1, 0).0.unwrap();
    let file = exact_features(&caps, &s, 0.0, 1);
    let (worst, apart) = recast_against_cast(
        &s,
        Kind::Edge,
        &file,
        &sensor,
        &|moved| exact_features(moved, &s, 0.0, 1),
        1e-4,
    );
    assert!(worst < 1e-3, "re-cast {worst}");
    assert!(apart > 0.1, "moved records {apart}");
}

/// The same on the independent kit's ray-cast profiles of the edge paper's 25 x 10 poses, from a
/// fan of 12,800 columns: the edge point falls between two columns, so the poses are moved 3 mm or
/// 3 mrad a unit error (as the disk's). The re-cast agrees to 2.6 % there; at 1 mm the columns'
/// steps leave 6.6 %, at 5 mm the moves' curvature 6.9 %; the moved records miss by 12.5 %.
#[test]
fn the_edge_closed_forms_recast_holds_on_the_kits_profiles() {
    let fan = Fan {
        columns: 12_800,
        ..edge_case().1
    };
    let (worst, apart) = recast_on_kit_profiles(edge_case_with(fan), Kind::Edge);
    assert!(worst < 0.05, "re-cast {worst}");
    assert!(apart > 0.1, "moved records {apart}");
}

/// The same captures with each profile's exact feature (chord ends, arc points, edge point) and the
/// profile's z noise on it: what the methods get from a sensor that reports features.
fn exact_features(caps: &Captures, s: &Setup, sigma: f64, seed: u64) -> Captures {
    use rand::RngExt;
    let mut rng = lasercal::testkit::rng(seed);
    let mut out = caps.clone();
    let kind = caps.method;
    let plan = s.plan(kind).unwrap();
    let disk = lasercal::sim::disk::DiskTarget::from_pose(&s.base_to_specimen, 0.050);
    out.profiles.retain_mut(|p| {
        let pose = p.base_to_flange * s.rig.flange_to_sensor;
        let mut dz = || sigma * rng.sample::<f64, _>(rand_distr::StandardNormal);
        let data = match kind {
            Kind::Disk => {
                lasercal::sim::disk::exact_chord(&pose, &disk).map(|(a, b)| ProfileData::Chord {
                    a: a + nalgebra::Vector2::new(0.0, dz()),
                    b: b + nalgebra::Vector2::new(0.0, dz()),
                })
            }
            Kind::Ball => {
                let ball = lasercal::sim::ball::BallTarget {
                    centre: plan.true_centre().unwrap(),
                    radius: 0.0695,
                };
                let mut r2 = lasercal::testkit::rng(seed ^ p.group as u64);
                let arc = lasercal::sim::ball::analytic_arc(
                    &s.rig, &ball, &pose, 0.15e-3, sigma, 0.9, &mut r2,
                );
                Some(ProfileData::Arc(arc.into()))
            }
            Kind::Edge => {
                let e = plan
                    .as_any()
                    .downcast_ref::<lasercal::method::edge::EdgePlan>()
                    .unwrap();
                lasercal::sim::edge::exact_point(&pose, &e.target)
                    .map(|q| ProfileData::EdgePoint(q + nalgebra::Vector2::new(0.0, dz())))
            }
            // The plane's features are its profiles' lines: the raw profiles are the baseline.
            Kind::Plane => None,
        };
        match data {
            Some(d) => {
                p.data = d;
                true
            }
            None => false,
        }
    });
    out
}

/// The best a per-profile extractor can do with these samples: the same (noisy) profiles, with the
/// specimen's points told by the truth (the columns whose noise-free hit lies on the disk face, the
/// sphere, or the bar's top face). Faces are fitted with a line and end halfway to the next column,
/// as lasercal places them; the ball's arc is those points. What is left is the sampling and the
/// noise, not the segmentation.
fn oracle_features(
    noisy: &Captures,
    clean: &Captures,
    s: &Setup,
    sensor: &SensorModel,
) -> Captures {
    use lasercal::features::Line2;
    use nalgebra::Vector2;
    let plan = s.plan(noisy.method).unwrap();
    let disk = lasercal::sim::disk::DiskTarget::from_pose(&s.base_to_specimen, 0.050);
    let mut out = noisy.clone();
    out.profiles.retain_mut(|p| {
        let q = clean
            .profiles
            .iter()
            .find(|q| q.base_to_flange == p.base_to_flange)
            .unwrap();
        let (ProfileData::Raw(n), ProfileData::Raw(c)) = (&p.data, &q.data) else {
            unreachable!()
        };
        let pose = p.base_to_flange * s.rig.flange_to_sensor;
        let on = |x: f64, z: f64| {
            let b = pose * Point3::new(x, 0.0, z);
            match noisy.method {
                Kind::Disk => {
                    disk.normal.dot(&(b - disk.centre)).abs() < 1e-9
                        && (b - disk.centre).norm() <= disk.radius + 1e-9
                }
                Kind::Ball => ((b - plan.true_centre().unwrap()).norm() - 0.0695).abs() < 1e-9,
                Kind::Edge => {
                    let e = &plan
                        .as_any()
                        .downcast_ref::<lasercal::method::edge::EdgePlan>()
                        .unwrap()
                        .target;
                    e.up.dot(&(b - e.point)).abs() < 1e-9 && e.outward.dot(&(b - e.point)) <= 1e-9
                }
                Kind::Plane => false,
            }
        };
        let cols: Vec<usize> = (0..c.points.len())
            .filter(|&k| c.points[k].is_some_and(|v| on(v.x, v.z)) && n.points[k].is_some())
            .collect();
        let pts: Vec<Vector2<f64>> = cols
            .iter()
            .map(|&k| n.points[k].map(|v| Vector2::new(v.x, v.z)).unwrap())
            .collect();
        if pts.len() < 5 {
            return false;
        }
        if noisy.method == Kind::Ball {
            p.data = ProfileData::Arc(pts.into());
            return true;
        }
        let line = Line2::fit(&pts).unwrap();
        let end = |k: usize, k2: f64| {
            let (o, d) = sensor.column_line(0.5 * (k as f64 + k2));
            line.intersect(&Line2 {
                point: Vector2::new(o[0], o[1]),
                dir: Vector2::new(d[0], d[1]),
            })
        };
        let (kf, kl) = (cols[0], *cols.last().unwrap());
        let (Some(a), Some(b)) = (end(kf, kf as f64 - 1.0), end(kl, kl as f64 + 1.0)) else {
            return false;
        };
        p.data = match noisy.method {
            Kind::Disk => {
                let (a, b) = if a.x <= b.x { (a, b) } else { (b, a) };
                ProfileData::Chord { a, b }
            }
            _ => {
                let want = lasercal::sim::edge::exact_point(
                    &pose,
                    &plan
                        .as_any()
                        .downcast_ref::<lasercal::method::edge::EdgePlan>()
                        .unwrap()
                        .target,
                )
                .unwrap();
                ProfileData::EdgePoint(if (a - want).norm() < (b - want).norm() {
                    a
                } else {
                    b
                })
            }
        };
        true
    });
    out
}

#[test]
fn raw_profiles_lose_nothing_to_segmentation() {
    // Against the oracle (the same profiles, the specimen's points told by the truth): noise-free
    // disk chords end where the oracle's do (the 0.03 deg left is the ray spacing, not the
    // extractor), and the ball's arcs under noise and dropout are the oracle's arcs (at dropout 0.2
    // the arcs used to break at dropped columns: 0.42 mm against the oracle's 0.15 mm).
    for (kind, case, sigma_mm, dropout, ratio) in [
        (
            Kind::Disk,
            disk_case as fn() -> (Setup, Fan, Vec<Solid>),
            0.0,
            0.0,
            1.0 + 1e-9,
        ),
        (Kind::Ball, ball_case, 0.1, 0.2, 1.05),
    ] {
        let (s, fan, solids) = case();
        let sensor = with_sigma(&common::declared(&fan, "fan"), sigma_mm);
        let caps = trial_captures(&s, kind, 1, 0).0.unwrap();
        let noise = Noise {
            sigma_z: sigma_mm * 1e-3,
            dropout,
            sigma_z_far: 0.0,
        };
        let noisy = regenerate(&caps, &s, &fan, &solids, noise, 100);
        let clean = regenerate(&caps, &s, &fan, &solids, Noise::default(), 100);
        let (r, t, missed) = errors(&noisy, &s, &sensor).unwrap();
        let oracle = oracle_features(&noisy, &clean, &s, &sensor);
        let (ro, to, _) = errors(&oracle, &s, &sensor).unwrap();
        eprintln!("{kind}: raw {r:.4} deg / {t:.4} mm, oracle {ro:.4} / {to:.4}");
        assert_eq!(missed, 0);
        assert!(
            r <= ratio * ro + 1e-9 && t <= ratio * to + 1e-9,
            "{kind}: raw {r} deg / {t} mm, oracle {ro} / {to}"
        );
    }
}

/// The table of raw-profile errors against exact-feature errors (README, issue 13):
/// `cargo test --release --test suite independent::raw_against_features -- --ignored --nocapture`.
#[test]
#[ignore]
fn raw_against_features() {
    let cases: [(Kind, fn() -> (Setup, Fan, Vec<Solid>)); 3] = [
        (Kind::Disk, disk_case),
        (Kind::Ball, ball_case),
        (Kind::Edge, edge_case),
    ];
    println!(
        "| specimen | sigma mm | dropout | raw: rotation deg / translation mm (median of 10) | oracle segmentation of the same profiles | exact features | missed profiles |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (kind, case) in cases {
        let (s, fan, solids) = case();
        for (sigma_mm, dropout) in [
            (0.0, 0.0),
            (0.05, 0.0),
            (0.1, 0.0),
            (0.2, 0.0),
            (0.1, 0.05),
            (0.1, 0.2),
        ] {
            let sensor = with_sigma(&common::declared(&fan, "fan"), sigma_mm);
            let (mut raw, mut feat, mut oracle, mut missed) =
                (Vec::new(), Vec::new(), Vec::new(), 0);
            for t in 0..10u64 {
                let caps = trial_captures(&s, kind, 1, t).0.unwrap();
                let noise = Noise {
                    sigma_z: sigma_mm * 1e-3,
                    dropout,
                    sigma_z_far: 0.0,
                };
                let noisy = regenerate(&caps, &s, &fan, &solids, noise, 100 + t);
                let clean = regenerate(&caps, &s, &fan, &solids, Noise::default(), 100 + t);
                if let Ok((r, tr, _)) =
                    errors(&oracle_features(&noisy, &clean, &s, &sensor), &s, &sensor)
                {
                    oracle.push((r, tr));
                }
                match errors(&noisy, &s, &sensor) {
                    Ok((r, tr, m)) => {
                        raw.push((r, tr));
                        missed += m;
                    }
                    Err(_) => raw.push((f64::INFINITY, f64::INFINITY)),
                }
                let f = exact_features(&caps, &s, sigma_mm * 1e-3, 200 + t);
                if let Ok((r, tr, _)) = errors(&f, &s, &sensor) {
                    feat.push((r, tr));
                }
            }
            let med = |v: &mut Vec<(f64, f64)>| {
                let mut a: Vec<f64> = v.iter().map(|x| x.0).collect();
                let mut b: Vec<f64> = v.iter().map(|x| x.1).collect();
                a.sort_by(f64::total_cmp);
                b.sort_by(f64::total_cmp);
                (a[a.len() / 2], b[b.len() / 2])
            };
            let (r, f, o) = (med(&mut raw), med(&mut feat), med(&mut oracle));
            println!(
                "| {kind} | {sigma_mm} | {dropout} | {:.4} / {:.4} | {:.4} / {:.4} | {:.4} / {:.4} | {missed} |",
                r.0, r.1, o.0, o.1, f.0, f.1
            );
        }
    }
}

#[test]
fn edge_over_a_tilted_table_and_with_noise() {
    let (s, fan, mut solids) = edge_case();
    let sensor = common::declared(&fan, "fan-edge");
    let caps = trial_captures(&s, Kind::Edge, 1, 0).0.unwrap();
    let e = s.plan(Kind::Edge).unwrap();
    let e = e
        .as_any()
        .downcast_ref::<lasercal::method::edge::EdgePlan>()
        .unwrap();
    // A table right under the bar (12 mm below its top face): in the fan's range.
    let table_z = e.target.point.z - 0.012;
    // What holds today is asserted (no point more than 1 mm off, at most 35 of 250 profiles
    // missed, the calibration within 0.2 deg and 0.1 mm); at sigma 0.2 over a table one point
    // still lands 1.8 mm off and the calibration 1.1 deg off (issue 13, open): printed only.
    for (label, tilt_deg, sigma_mm, holds) in [
        ("flat table, sigma 0.1", 0.0, 0.1, true),
        ("flat table, sigma 0.2", 0.0, 0.2, false),
        ("table tilted 10 deg", 10.0, 0.0, true),
        ("table tilted 20 deg", 20.0, 0.0, true),
        ("no table", f64::NAN, 0.0, true),
    ] {
        solids.truncate(1);
        if tilt_deg.is_finite() {
            let t = f64::to_radians(tilt_deg);
            solids.push(Solid::Plane {
                point: Point3::new(e.target.point.x, e.target.point.y, table_z),
                normal: nalgebra::Vector3::new(t.sin(), 0.0, t.cos()),
            });
        }
        let noise = Noise {
            sigma_z: sigma_mm * 1e-3,
            dropout: 0.0,
            sigma_z_far: 0.0,
        };
        let profiles = regenerate(&caps, &s, &fan, &solids, noise, 7);
        let sensor = with_sigma(&sensor, sigma_mm);
        let tuned = lasercal::features::SplitMerge::for_sensor(&sensor);
        let cfg = lasercal::features::SplitMerge {
            split_tol: if sigma_mm == 0.0 {
                0.1e-3
            } else {
                tuned.split_tol
            },
            jump: tuned.jump.max(0.5e-3),
            min_points: 4,
        };
        let mut off = Vec::new();
        let mut missed = 0;
        for p in &profiles.profiles {
            let ProfileData::Raw(prof) = &p.data else {
                unreachable!()
            };
            let pose = p.base_to_flange * s.rig.flange_to_sensor;
            let Some(q) = lasercal::sim::edge::exact_point(&pose, &e.target) else {
                continue;
            };
            match lasercal::features::edge_point(prof, &sensor, e.sense, &cfg) {
                Ok(x) => off.push((x - q).norm()),
                Err(_) => missed += 1,
            }
        }
        off.sort_by(f64::total_cmp);
        let far = off.iter().filter(|d| **d > 1e-3).count();
        let cal = errors(&profiles, &s, &sensor);
        eprintln!(
            "edge, {label}: points median {:.3} mm, worst {:.3} mm, {far} more than 1 mm off, {missed} missed; calibration {cal:?}",
            off[off.len() / 2] * 1e3,
            off[off.len() - 1] * 1e3,
        );
        if holds {
            let (rot, tr, _) = cal.unwrap();
            assert!(
                far == 0 && missed <= 35,
                "{label}: {far} off, {missed} missed"
            );
            assert!(rot < 0.2 && tr < 0.1, "{label}: {rot} deg, {tr} mm");
        }
    }
}

/// Chord-end errors and the calibration over sensor geometries, noise and dropout (README):
/// `cargo test --test suite independent::extraction_over_sensor_geometry -- --ignored --nocapture`.
#[test]
#[ignore]
fn extraction_over_sensor_geometry() {
    let fan =
        |apex_mm: f64, half_deg: f64, columns: usize, equal_angle: bool, reversed: bool| Fan {
            apex_z: apex_mm * 1e-3,
            dir_z: -1.0,
            half_angle: half_deg.to_radians(),
            columns,
            equal_angle,
            reversed,
            z_range: (-0.105, 0.105),
            camera: Point3::new(0.0, 0.120, apex_mm * 1e-3),
        };
    println!(
        "| fan | sigma mm | dropout | chord ends median / p95 / worst mm | missed | calibration deg / mm |"
    );
    println!("|---|---|---|---|---|---|");
    for (name, f) in [
        (
            "apex 295 mm, +-14 deg, 1280 rays equal in angle",
            fan(295.0, 14.0, 1280, true, false),
        ),
        (
            "apex 310.7 mm, +-13.1 deg, 1280 rays equal in tan (the 2340's)",
            fan(310.7, 13.13, 1280, false, false),
        ),
        (
            "apex 250 mm, +-18 deg, 640 rays equal in angle, reversed",
            fan(250.0, 18.0, 640, true, true),
        ),
        (
            "apex 400 mm, +-10 deg, 2048 rays equal in tan",
            fan(400.0, 10.0, 2048, false, false),
        ),
    ] {
        let (s, f, solids) = disk_case_with(f);
        let sensor = common::declared(&f, "fan");
        let caps = trial_captures(&s, Kind::Disk, 1, 0).0.unwrap();
        let target = lasercal::sim::disk::DiskTarget::from_pose(&s.base_to_specimen, 0.050);
        for (sigma_mm, dropout) in [(0.0, 0.0), (0.1, 0.0), (0.0, 0.2), (0.1, 0.2)] {
            let sensor = with_sigma(&sensor, sigma_mm);
            let cfg = lasercal::features::SplitMerge::for_sensor(&sensor);
            let noise = Noise {
                sigma_z: sigma_mm * 1e-3,
                dropout,
                sigma_z_far: 0.0,
            };
            let profiles = regenerate(&caps, &s, &f, &solids, noise, 11);
            let (mut ends, mut missed) = (Vec::new(), 0);
            for p in &profiles.profiles {
                let ProfileData::Raw(prof) = &p.data else {
                    unreachable!()
                };
                let pose = p.base_to_flange * s.rig.flange_to_sensor;
                let Some((a, b)) = lasercal::sim::disk::exact_chord(&pose, &target) else {
                    continue;
                };
                match lasercal::features::disk_chord_step(prof, &sensor, 0.050, &cfg) {
                    Ok(ch) => ends.push((ch.a - a).norm().max((ch.b - b).norm())),
                    Err(_) => missed += 1,
                }
            }
            ends.sort_by(f64::total_cmp);
            let q = |x: f64| {
                ends.get(((ends.len() as f64 - 1.0) * x) as usize)
                    .map_or(f64::NAN, |e| e * 1e3)
            };
            let cal = match errors(&profiles, &s, &sensor) {
                Ok((r, t, _)) => format!("{r:.3} / {t:.3}"),
                Err(e) => format!("refused: {}", e.chars().take(60).collect::<String>()),
            };
            println!(
                "| {name} | {sigma_mm} | {dropout} | {:.3} / {:.3} / {:.3} | {missed} | {cal} |",
                q(0.5),
                q(0.95),
                q(1.0)
            );
        }
    }
}

/// Edge points and the calibration over sensor geometries, noise and dropout (README):
/// `cargo test --test suite independent::edge_over_sensor_geometry -- --ignored --nocapture`.
#[test]
#[ignore]
fn edge_over_sensor_geometry() {
    let fan =
        |apex_mm: f64, half_deg: f64, columns: usize, equal_angle: bool, reversed: bool| Fan {
            apex_z: apex_mm * 1e-3,
            dir_z: 1.0,
            half_angle: half_deg.to_radians(),
            columns,
            equal_angle,
            reversed,
            z_range: (0.060, 0.350),
            camera: Point3::new(0.0, 0.060, apex_mm * 1e-3),
        };
    println!(
        "| fan | sigma mm | dropout | edge points median / p95 / worst mm | missed | calibration deg / mm |"
    );
    println!("|---|---|---|---|---|---|");
    for (name, f) in [
        (
            "apex -30 mm, +-12 deg, 1000 rays equal in angle, reversed",
            fan(-30.0, 12.0, 1000, true, true),
        ),
        (
            "apex -40 mm, +-11.5 deg, 980 rays equal in tan (the VLM350's)",
            fan(-40.0, 11.5, 980, false, false),
        ),
        (
            "apex -20 mm, +-15 deg, 2048 rays equal in tan",
            fan(-20.0, 15.0, 2048, false, false),
        ),
    ] {
        let (s, f, solids) = edge_case_with(f);
        let sensor = common::declared(&f, "fan");
        let caps = trial_captures(&s, Kind::Edge, 1, 0).0.unwrap();
        let plan = s.plan(Kind::Edge).unwrap();
        let e = plan
            .as_any()
            .downcast_ref::<lasercal::method::edge::EdgePlan>()
            .unwrap();
        for (sigma_mm, dropout) in [(0.0, 0.0), (0.1, 0.0), (0.0, 0.2), (0.1, 0.2)] {
            let sensor = with_sigma(&sensor, sigma_mm);
            let tuned = lasercal::features::SplitMerge::for_sensor(&sensor);
            let cfg = lasercal::features::SplitMerge {
                split_tol: if sigma_mm == 0.0 {
                    0.1e-3
                } else {
                    tuned.split_tol
                },
                jump: tuned.jump.max(0.5e-3),
                min_points: 4,
            };
            let noise = Noise {
                sigma_z: sigma_mm * 1e-3,
                dropout,
                sigma_z_far: 0.0,
            };
            let profiles = regenerate(&caps, &s, &f, &solids, noise, 13);
            let (mut off, mut missed) = (Vec::new(), 0);
            for p in &profiles.profiles {
                let ProfileData::Raw(prof) = &p.data else {
                    unreachable!()
                };
                let pose = p.base_to_flange * s.rig.flange_to_sensor;
                let Some(q) = lasercal::sim::edge::exact_point(&pose, &e.target) else {
                    continue;
                };
                match lasercal::features::edge_point(prof, &sensor, e.sense, &cfg) {
                    Ok(x) => off.push((x - q).norm()),
                    Err(_) => missed += 1,
                }
            }
            off.sort_by(f64::total_cmp);
            let q = |x: f64| {
                off.get(((off.len() as f64 - 1.0) * x) as usize)
                    .map_or(f64::NAN, |e| e * 1e3)
            };
            let cal = match errors(&profiles, &s, &sensor) {
                Ok((r, t, _)) => format!("{r:.3} / {t:.3}"),
                Err(e) => format!("refused: {}", e.chars().take(60).collect::<String>()),
            };
            println!(
                "| {name} | {sigma_mm} | {dropout} | {:.3} / {:.3} / {:.3} | {missed} | {cal} |",
                q(0.5),
                q(0.95),
                q(1.0)
            );
        }
    }
}

/// The ball over sensor geometries (README, issue 13): the arc circle's centre and radius against
/// the exact section of the sphere by the laser plane, and the calibration.
/// `cargo test --release --test suite independent::ball_over_sensor_geometry -- --ignored --nocapture`.
#[test]
#[ignore]
fn ball_over_sensor_geometry() {
    let fan =
        |apex_mm: f64, half_deg: f64, columns: usize, equal_angle: bool, reversed: bool| Fan {
            apex_z: apex_mm * 1e-3,
            dir_z: -1.0,
            half_angle: half_deg.to_radians(),
            columns,
            equal_angle,
            reversed,
            z_range: (-0.105, 0.105),
            camera: Point3::new(0.0, 0.120, apex_mm * 1e-3),
        };
    println!(
        "| fan | sigma mm | dropout | arc centre median / p95 / worst mm | missed | calibration deg / mm |"
    );
    println!("|---|---|---|---|---|---|");
    let (s, _, solids) = ball_case();
    let caps = trial_captures(&s, Kind::Ball, 1, 0).0.unwrap();
    let (centre, radius) = (s.plan(Kind::Ball).unwrap().true_centre().unwrap(), 0.0695);
    for (name, f) in [
        (
            "apex 295 mm, +-14 deg, 1280 rays equal in angle",
            fan(295.0, 14.0, 1280, true, false),
        ),
        (
            "apex 250 mm, +-18 deg, 640 rays equal in angle, reversed",
            fan(250.0, 18.0, 640, true, true),
        ),
        (
            "apex 400 mm, +-10 deg, 2048 rays equal in tan",
            fan(400.0, 10.0, 2048, false, false),
        ),
    ] {
        for (sigma_mm, dropout) in [(0.0, 0.0), (0.1, 0.0), (0.0, 0.2), (0.1, 0.2)] {
            let sensor = with_sigma(&common::declared(&f, "fan"), sigma_mm);
            let cfg = lasercal::features::SplitMerge::for_sensor(&sensor);
            let noise = Noise {
                sigma_z: sigma_mm * 1e-3,
                dropout,
                sigma_z_far: 0.0,
            };
            let profiles = regenerate(&caps, &s, &f, &solids, noise, 17);
            let (mut off, mut missed) = (Vec::new(), 0);
            for p in &profiles.profiles {
                let ProfileData::Raw(prof) = &p.data else {
                    unreachable!()
                };
                // The section: the sphere's centre dropped onto the laser plane (sensor y = 0).
                let c =
                    (p.base_to_flange * s.rig.flange_to_sensor).inverse_transform_point(&centre);
                if c.y.abs() >= radius {
                    continue;
                }
                match lasercal::features::ball_arc(prof, radius, &cfg) {
                    Ok(circle) => {
                        off.push((circle.centre - nalgebra::Vector2::new(c.x, c.z)).norm())
                    }
                    Err(_) => missed += 1,
                }
            }
            off.sort_by(f64::total_cmp);
            let q = |x: f64| {
                off.get(((off.len() as f64 - 1.0) * x) as usize)
                    .map_or(f64::NAN, |e| e * 1e3)
            };
            let cal = match errors(&profiles, &s, &sensor) {
                Ok((r, t, _)) => format!("{r:.3} / {t:.3}"),
                Err(e) => format!("refused: {}", e.chars().take(60).collect::<String>()),
            };
            println!(
                "| {name} | {sigma_mm} | {dropout} | {:.3} / {:.3} / {:.3} | {missed} | {cal} |",
                q(0.5),
                q(0.95),
                q(1.0)
            );
        }
    }
}

#[test]
fn ball_refinement_converges_on_independent_profiles() {
    // Issue 14 reports `ball-refined` stopping at its iteration limit on independent captures
    // (6 / 9 / 18 of 30 at sigma 0.05 / 0.1 / 0.2 mm). On these profiles every refinement
    // converges (as it did here with the former z residuals too: the discriminating case is the
    // 1 deg / 2.3 mm start in tests/suite/methods.rs) and ends ten times better than the closed form.
    let (s, fan, solids) = ball_case();
    for sigma_mm in [0.05, 0.1, 0.2] {
        let sensor = with_sigma(&common::declared(&fan, "fan"), sigma_mm);
        let (mut stalled, mut closed, mut refined) = (0, 0.0, 0.0);
        let n = 30;
        for t in 0..n {
            let caps = trial_captures(&s, Kind::Ball, 1, t).0.unwrap();
            let noise = Noise {
                sigma_z: sigma_mm * 1e-3,
                dropout: 0.0,
                sigma_z_far: 0.0,
            };
            let raw = regenerate(&caps, &s, &fan, &solids, noise, 300 + t);
            let cal = lasercal::method::calibrate(&raw, &sensor).unwrap();
            let r = cal
                .refinable
                .clone()
                .unwrap()
                .refine(
                    &cal.flange_to_sensor,
                    &lasercal::calib::refine::Options::default(),
                )
                .unwrap();
            if !matches!(r.status, lasercal::calib::Status::Converged { .. }) {
                stalled += 1;
            }
            let err = |x| {
                lasercal::calib::PoseError::between(x, &s.rig.flange_to_sensor).rotation_error_deg
            };
            closed += err(&cal.flange_to_sensor) / n as f64;
            refined += err(&r.flange_to_sensor) / n as f64;
        }
        eprintln!(
            "ball, sigma {sigma_mm} mm: {stalled} of {n} refinements stalled; mean rotation error \
             {closed:.4} deg closed form -> {refined:.4} deg refined"
        );
        assert_eq!(stalled, 0, "sigma {sigma_mm} mm");
        assert!(refined < 0.2 * closed, "{refined} vs {closed}");
    }
}

/// A robot-error row's name in the kit's tables.
fn row_name(robot_mm: f64, kinematic: Option<(f64, f64, bool)>) -> String {
    match kinematic {
        Some((l, z, true)) => format!("kinematic {l} mm / {z} deg"),
        Some((l, z, false)) => format!("kinematic {l} mm / {z} deg, arm named alone"),
        None => format!("{robot_mm} mm"),
    }
}

/// `robot` with the kinematic error an uncalibrated arm has, drawn from `seed` by this test's
/// own hand: each joint origin moved by `link` (m, one sd per axis), each zero by `zero_deg`.
fn uncalibrated(
    robot: &lasercal::robot::Robot,
    link: f64,
    zero_deg: f64,
    seed: u64,
) -> lasercal::robot::Robot {
    use rand_distr::{Distribution, StandardNormal};
    let mut g = lasercal::testkit::rng(seed);
    let mut z = || -> f64 { StandardNormal.sample(&mut g) };
    let mut arm = robot.clone();
    for j in &mut arm.joints {
        let d = nalgebra::Vector3::new(z(), z(), z()) * link;
        let turn = UnitQuaternion::from_axis_angle(&j.axis, z() * zero_deg.to_radians());
        j.prev_to_joint = Isometry3::from_parts(
            Translation3::from(j.prev_to_joint.translation.vector + d),
            j.prev_to_joint.rotation * turn,
        );
    }
    arm
}

/// One line per variant of a decided trial (`LASERCAL_INDEPENDENT_DIAG`): the true error's
/// squared Mahalanobis distance under the bound's covariance (`d2`, 6 on average where the
/// covariance is honest) and its degrees of freedom, the rotation and translation errors over
/// their bounds (`r`, `t`), the noise ratio, the scatter's and the groups' widening, the
/// carried kinematic part's sds (deg, mm), the rotation error and its bound (deg: `er`, `br`)
/// and the squared whitened error along each of the covariance's eigenvectors, the widest
/// first (`z2`: 1 on average in a direction where the covariance is honest). What the coverage counts cannot say: whether a
/// bound that over-covers is too wide in its covariance or in its quantile.
fn diagnose(name: &str, t: u64, d: &lasercal::method::verdict::Decision, truth: &Isometry3<f64>) {
    use lasercal::calib::PoseError;
    for (id, r) in &d.results {
        let Ok(v) = r.as_ref() else { continue };
        let q = &v.judged.quality;
        let f = &v.calibration.flange_to_sensor;
        // As the covariance: rotation rad in the sensor frame, translation m.
        let w = (truth.rotation.inverse() * f.rotation).scaled_axis();
        let dt = f.translation.vector - truth.translation.vector;
        let x = nalgebra::Vector6::new(w.x, w.y, w.z, dt.x, dt.y, dt.z);
        let (d2, dof) = q
            .bound_covariance
            .and_then(|(c, dof)| c.try_inverse().map(|ci| ((x.transpose() * ci * x)[0], dof)))
            .unwrap_or((f64::NAN, 0));
        // The whitened error along the covariance's eigenvectors, the widest first (each 1 on
        // average where the covariance is honest in that direction).
        let z2: Vec<f64> = q
            .bound_covariance
            .map(|(c, _)| {
                let e = c.symmetric_eigen();
                let mut order: Vec<usize> = (0..6).collect();
                order.sort_by(|&a, &b| e.eigenvalues[b].total_cmp(&e.eigenvalues[a]));
                order
                    .iter()
                    .map(|&i| e.eigenvectors.column(i).dot(&x).powi(2) / e.eigenvalues[i])
                    .collect()
            })
            .unwrap_or_default();
        let (br, bt) = q.own_error_bound();
        let e = PoseError::between(f, truth);
        let (kd, km) = q
            .kinematic
            .as_ref()
            .map_or((0.0, 0.0), |k| (k.sd_deg, k.sd_mm));
        println!(
            "diag {name} {t} {id} nr {:.3} d2 {d2:.3} dof {dof} r {:.3} t {:.3} inf {:.3} gw {:.3} \
             ksd {kd:.5} {km:.5} er {:.6} br {:.6} z2 {}",
            q.noise_ratio.unwrap_or(f64::NAN),
            e.rotation_error_deg / br,
            e.translation_error_mm / bt,
            q.inflation.unwrap_or(f64::NAN),
            q.group_widening.unwrap_or(f64::NAN),
            e.rotation_error_deg,
            br,
            z2.iter()
                .map(|v| format!("{v:.3}"))
                .collect::<Vec<_>>()
                .join(" "),
        );
    }
}

/// The verdict on the papers' own protocols as another generator makes them: the disk paper's
/// four scans, its ball's rotation and translation sets and the edge paper's 25 orientations of
/// 10 translations (its parallel bar), every profile from `testkit::fan`
/// (its own fan, declared as docs/sensors.md says) with z noise 0.1 mm; once with an exact arm
/// once with robot pose error (each profile cast from a pose moved up to 0.3 mm and 0.017 deg,
/// the file recording the commanded pose and stating that error as a repeatability of 0.1 mm,
/// each pose's own, with no accuracy common to the poses), and once with an
/// uncalibrated arm (`uncalibrated`: joint origins 0.1 mm, zeros 0.01 deg; the profiles cast
/// from where that arm goes at the configuration the nominal one needs, the file stating the arm
/// and its kinematic error), and once more with another (0.05 mm, 0.02 deg) whose file names
/// the arm and its accuracy alone (the verdict then assumes an error of that accuracy in its
/// own ratio, `Kinematic::assumed`). Every
/// variant run and judged as `calibrate` does (`verdict::decide`); the specimen placed anew each
/// trial (`placed`). Counts right answers called suspect (false alarms), wrong answers (more than
/// 1 deg or 1 mm off) judged ok, and how often the chosen result's 95 % bound, and each variant's
/// own, holds its error. Trials per case: `LASERCAL_INDEPENDENT_TRIALS` (default 2;
/// docs/verdict.md has a release run of 1,000); one case alone: `LASERCAL_INDEPENDENT_CASE`; the
/// robot rows whose names hold `LASERCAL_INDEPENDENT_ROWS` alone (`kinematic`: the two arms); each
/// variant's covariance against its true error with `LASERCAL_INDEPENDENT_DIAG` (`diagnose`).
#[test]
fn the_verdict_on_the_papers_protocols_from_another_generator() {
    use lasercal::calib::PoseError;
    use lasercal::method::verdict::{Verdict, decide};
    use rayon::prelude::*;
    let n = independent_trials();
    let cases: [(&str, Kind, fn() -> (Setup, Fan, Vec<Solid>)); 3] = [
        ("disk", Kind::Disk, disk_case),
        ("ball", Kind::Ball, ball_case),
        ("edge", Kind::Edge, edge_case),
    ];
    // One trial's outcome; trials run in parallel, each from its own seeds (`t`), so the counts
    // do not depend on the thread count.
    struct Outcome {
        refused: bool,
        right: bool,
        suspect: bool,
        imprecise: bool,
        ok: bool,
        covered: bool,
        /// Each variant that ran: its name and whether its own 95 % bound held its error.
        variants: Vec<(String, bool)>,
        what: String,
    }
    let (mut false_alarms, mut missed) = (Vec::new(), Vec::new());
    println!(
        "| specimen | robot error | results | right | suspect of right | imprecise of right | wrong | wrong judged ok | refused | covered | covered per variant |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    // One protocol alone: `LASERCAL_INDEPENDENT_CASE=disk` (ball, edge); all by default.
    let only = std::env::var("LASERCAL_INDEPENDENT_CASE").ok();
    for (name, kind, case) in cases {
        if only.as_deref().is_some_and(|c| c != name) {
            continue;
        }
        let (s, fan, solids) = case();
        let sensor = with_sigma(&common::declared(&fan, "fan-295"), 0.1);
        // (per-pose robot error mm, stated accuracy mm, stated repeatability mm, kinematic
        // error: link mm, zero deg, stated or the arm named alone). The per-pose error moves
        // each profile alone (0.1 mm per axis from the shift, 0.02 mm at the specimen from the
        // turn): a repeatability, with no error common to the poses. The last arm's errors are
        // in another ratio than the one lasercal assumes where they are not stated (0.1 mm per
        // 0.01 deg, `captures::ASSUMED_LINK_PER_ZERO`).
        for (robot_mm, stated_mm, repeat_mm, kinematic) in [
            (0.0, 0.0, 0.0, None),
            (0.3, 0.0, 0.1, None),
            (0.0, 0.0, 0.0, Some((0.1, 0.01, true))),
            (0.0, 0.0, 0.0, Some((0.05, 0.02, false))),
        ] {
            let rows = std::env::var("LASERCAL_INDEPENDENT_ROWS").ok();
            if rows.is_some_and(|r| !row_name(robot_mm, kinematic).contains(&r)) {
                continue;
            }
            let outcomes: Vec<Outcome> = (0..n)
                .into_par_iter()
                .map(|t| {
                    let caps = trial_captures(&s, kind, 27, t).0.unwrap();
                    let mut moved = caps.clone();
                    let mut g = lasercal::testkit::rng(5000 + t);
                    if robot_mm > 0.0 {
                        for p in &mut moved.profiles {
                            p.base_to_flange = lasercal::testkit::perturb(
                                &mut g,
                                &p.base_to_flange,
                                robot_mm * 1e-3 / 1.0,
                                robot_mm * 1e-3,
                            );
                        }
                    }
                    if let Some((link_mm, zero_deg, _)) = kinematic {
                        let arm = uncalibrated(&s.rig.robot, link_mm * 1e-3, zero_deg, 6000 + t);
                        let mut q = [0.0; 6];
                        for p in &mut moved.profiles {
                            q = s.rig.robot.ik_nearest(&p.base_to_flange, &q).unwrap();
                            p.base_to_flange = arm.fk(&q);
                        }
                    }
                    let noise = Noise {
                        sigma_z: 0.1e-3,
                        dropout: 0.0,
                        sigma_z_far: 0.0,
                    };
                    let solids = placed(&solids, t);
                    let mut file = regenerate(&moved, &s, &fan, &solids, noise, 7000 + t);
                    for (p, q) in file.profiles.iter_mut().zip(&caps.profiles) {
                        p.base_to_flange = q.base_to_flange;
                    }
                    file.judging.robot_accuracy = stated_mm * 1e-3;
                    file.judging.robot_repeatability = repeat_mm * 1e-3;
                    if let Some((link_mm, zero_deg, stated)) = kinematic {
                        let (link, zero) = (link_mm * 1e-3, f64::to_radians(zero_deg));
                        let k = lasercal::captures::Kinematic::new(
                            "irb".into(),
                            std::sync::Arc::new(s.rig.robot.clone()),
                            if stated { link } else { 0.0 },
                            if stated { zero } else { 0.0 },
                            file.profiles.iter().map(|p| (&p.base_to_flange, None)),
                        )
                        .unwrap();
                        // Named alone, the file states the arm's accuracy (its errors' point sd).
                        file.judging.robot_accuracy =
                            lasercal::captures::point_sd_of(&s.rig.robot, link, zero);
                        file.kinematic = Some(k);
                    }
                    let robot_mm = row_name(robot_mm, kinematic);
                    let Ok(d) = decide(&file, &sensor, None) else {
                        return Outcome {
                            refused: true,
                            right: false,
                            suspect: false,
                            imprecise: false,
                            ok: false,
                            covered: false,
                            variants: Vec::new(),
                            what: String::new(),
                        };
                    };
                    let truth = &s.rig.flange_to_sensor;
                    let holds = |f: &Isometry3<f64>, (br, bt): (f64, f64)| {
                        let e = PoseError::between(f, truth);
                        e.rotation_error_deg <= br && e.translation_error_mm <= bt
                    };
                    let a = d.assessed();
                    let e = PoseError::between(&a.calibration.flange_to_sensor, truth);
                    let (br, bt) = d.judged.quality.error_bound();
                    if std::env::var("LASERCAL_INDEPENDENT_DIAG").is_ok() {
                        diagnose(name, t, &d, truth);
                    }
                    let lines = d.judged.lines().cloned().collect::<Vec<_>>().join(" | ");
                    Outcome {
                        refused: false,
                        right: e.rotation_error_deg <= 1.0 && e.translation_error_mm <= 1.0,
                        suspect: d.judged.verdict == Verdict::Suspect,
                        imprecise: d.judged.verdict == Verdict::Imprecise,
                        ok: d.judged.verdict == Verdict::Ok,
                        covered: e.rotation_error_deg <= br && e.translation_error_mm <= bt,
                        variants: d
                            .results
                            .iter()
                            .filter_map(|(id, r)| {
                                let v = r.as_ref().ok()?;
                                Some((
                                    id.to_string(),
                                    holds(
                                        &v.calibration.flange_to_sensor,
                                        v.judged.quality.own_error_bound(),
                                    ),
                                ))
                            })
                            .collect(),
                        what: format!(
                            "{name}, robot {robot_mm}, trial {t}: {} {:.4} deg / {:.4} mm \
                             (bound {br:.4} / {bt:.4}): {lines}",
                            d.method(),
                            e.rotation_error_deg,
                            e.translation_error_mm
                        ),
                    }
                })
                .collect();
            let count = |f: &dyn Fn(&Outcome) -> bool| outcomes.iter().filter(|o| f(o)).count();
            let mut per_variant: Vec<(String, usize, usize)> = Vec::new();
            for o in &outcomes {
                for (v, held) in &o.variants {
                    match per_variant.iter_mut().find(|(w, ..)| w == v) {
                        Some(e) => {
                            e.1 += 1;
                            e.2 += usize::from(*held);
                        }
                        None => per_variant.push((v.clone(), 1, usize::from(*held))),
                    }
                }
            }
            for o in outcomes.iter().filter(|o| !o.refused && !o.covered) {
                println!("  not covered: {}", o.what);
            }
            false_alarms.extend(
                outcomes
                    .iter()
                    .filter(|o| o.right && o.suspect)
                    .map(|o| o.what.clone()),
            );
            missed.extend(
                outcomes
                    .iter()
                    .filter(|o| !o.refused && !o.right && o.ok)
                    .map(|o| o.what.clone()),
            );
            let robot_mm = row_name(robot_mm, kinematic);
            println!(
                "| {name} | {robot_mm} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                outcomes.len(),
                count(&|o| o.right),
                count(&|o| o.right && o.suspect),
                count(&|o| o.right && o.imprecise),
                count(&|o| !o.refused && !o.right),
                count(&|o| !o.refused && !o.right && o.ok),
                count(&|o| o.refused),
                count(&|o| o.covered),
                per_variant
                    .iter()
                    .map(|(v, k, h)| format!("{v} {h}/{k}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    assert!(missed.is_empty(), "wrong answers judged ok: {missed:#?}");
    assert!(
        false_alarms.is_empty(),
        "right answers called suspect: {false_alarms:#?}"
    );
}

/// The gross mistakes of docs/verdict.md (`verdict::mistake`: pairing one record apart, metres,
/// quaternion order, mirrored profiles, the radius 5 % and 20 % off, every orientation 3 deg off)
/// made on the papers' protocols as another generator makes them (the disk paper's four scans,
/// its ball's rotation and translation sets, the edge paper's parallel bar; `testkit::fan`, z
/// noise 0.1 mm, the specimen placed anew each trial), every variant run and judged as
/// `calibrate` does: each wrong answer (more than 1 deg or 1 mm off) must be flagged (suspect or
/// imprecise) or refused. Trials per case: `LASERCAL_INDEPENDENT_TRIALS` (default 1;
/// docs/verdict.md has a release run); one protocol: `LASERCAL_INDEPENDENT_CASE`; the mistakes
/// whose names hold `LASERCAL_MISTAKE`.
#[test]
fn gross_mistakes_on_the_papers_protocols_from_another_generator_are_flagged() {
    use crate::verdict::mistake;
    use lasercal::calib::PoseError;
    use lasercal::method::verdict::{Verdict, decide};
    use rayon::prelude::*;
    // One placement a case by default: an edge file turned 3 deg takes 13 s of a release build
    // to judge, far longer in CI's debug build (docs/verdict.md).
    let n: u64 = std::env::var("LASERCAL_INDEPENDENT_TRIALS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1);
    let mistakes = mistake::ALL;
    let cases: [(&str, Kind, fn() -> (Setup, Fan, Vec<Solid>)); 3] = [
        ("disk", Kind::Disk, disk_case),
        ("ball", Kind::Ball, ball_case),
        ("edge", Kind::Edge, edge_case),
    ];
    // results, wrong, wrong flagged, refused, suspect, suspect naming the cause
    let mut all = [0usize; 6];
    let mut missed = Vec::new();
    let mut unnamed = Vec::new();
    println!(
        "| mistake | protocol | results | wrong | wrong, flagged | refused | suspect | cause named first |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    // One protocol alone (`LASERCAL_INDEPENDENT_CASE=edge`) and the mistakes whose names hold
    // `LASERCAL_MISTAKE` (`radians`); all by default.
    let only = std::env::var("LASERCAL_INDEPENDENT_CASE").ok();
    let only_mistake = std::env::var("LASERCAL_MISTAKE").ok();
    for (name, kind, case) in cases {
        if only.as_deref().is_some_and(|c| c != name) {
            continue;
        }
        let (s, fan, solids) = case();
        let sensor = with_sigma(&common::declared(&fan, "fan-295"), 0.1);
        let truth = s.rig.flange_to_sensor;
        // The trials' files, made once and mistaken seven ways.
        let files: Vec<Captures> = (0..n)
            .into_par_iter()
            .map(|t| {
                let caps = trial_captures(&s, kind, 27, t).0.unwrap();
                let noise = Noise {
                    sigma_z: 0.1e-3,
                    dropout: 0.0,
                    sigma_z_far: 0.0,
                };
                regenerate(&caps, &s, &fan, &placed(&solids, t), noise, 7000 + t)
            })
            .collect();
        for (what, cause, mutate) in &mistakes {
            if files[0].specimen_radius.is_none() && what.starts_with("radius")
                || only_mistake.as_deref().is_some_and(|m| !what.contains(m))
            {
                continue;
            }
            let rows: Vec<([usize; 6], Option<String>)> = files
                .par_iter()
                .enumerate()
                .map(|(t, file)| {
                    let mut row = [1, 0, 0, 0, 0, 0];
                    let mut file = file.clone();
                    mutate(&mut file);
                    let Ok(d) = decide(&file, &sensor, None) else {
                        row[3] = 1;
                        return (row, None);
                    };
                    let e = PoseError::between(&d.assessed().calibration.flange_to_sensor, &truth);
                    let wrong = !(e.rotation_error_deg <= 1.0 && e.translation_error_mm <= 1.0);
                    let mut missed = None;
                    if wrong {
                        row[1] = 1;
                        if d.judged.verdict != Verdict::Ok {
                            row[2] = 1;
                        } else {
                            let lines = d.judged.lines().cloned().collect::<Vec<_>>().join(" | ");
                            missed = Some(format!(
                                "{what}, {name} trial {t}: {} {:.3} deg / {:.3} mm off, judged ok: {lines}",
                                d.method(),
                                e.rotation_error_deg,
                                e.translation_error_mm
                            ));
                        }
                    }
                    if d.judged.verdict == Verdict::Suspect {
                        row[4] = 1;
                        row[5] = usize::from(!cause.is_empty() && d.judged.reasons[0].contains(cause));
                        if row[5] == 0 && !cause.is_empty() {
                            println!("  {what}, {name} trial {t}: {}", d.judged.reasons[0]);
                        }
                    }
                    (row, missed)
                })
                .collect();
            let mut sum = [0usize; 6];
            for (row, m) in rows {
                for k in 0..6 {
                    sum[k] += row[k];
                }
                missed.extend(m);
            }
            println!(
                "| {what} | {name} | {} | {} | {} | {} | {} | {} |",
                sum[0], sum[1], sum[2], sum[3], sum[4], sum[5]
            );
            // Every mistake with a correction is named where the result is suspect, even where
            // the kept variant absorbs it (the any-pose disk fits a radius 5 % off at the noise,
            // the closed forms do not) or other variants cannot run (a disk scan paired one
            // record apart holds a pose of the next scan's orientation).
            if !cause.is_empty() && sum[5] < sum[4] {
                unnamed.push(format!("{what}, {name}: {} of {}", sum[4] - sum[5], sum[4]));
            }
            for k in 0..6 {
                all[k] += sum[k];
            }
        }
    }
    println!(
        "| all | | {} | {} | {} | {} | {} | {} |",
        all[0], all[1], all[2], all[3], all[4], all[5]
    );
    assert!(
        all[1] > 0,
        "no mistake gave a wrong answer: the cases test nothing"
    );
    assert!(
        missed.is_empty(),
        "{} of {} wrong answers judged ok:\n{}",
        missed.len(),
        all[1],
        missed.join("\n")
    );
    assert!(
        unnamed.is_empty(),
        "suspect without the mistake named: {}",
        unnamed.join("; ")
    );
}

/// The disk paper's four scans from the independent generator with z noise growing from 0.02 mm
/// at the near end of the fan's range to 0.25 mm at the far end, the file stating one number
/// (0.25 mm) for the whole range, as a datasheet's headline does: `disk-full` reads how the
/// noise grows from the profiles (`method::DepthNoise`) and its bound holds the error. Trials:
/// `LASERCAL_INDEPENDENT_TRIALS` (default 2; docs/verdict.md has a release run of 100).
#[test]
fn depth_dependent_noise_from_another_generator_is_read_and_bounded() {
    use lasercal::calib::PoseError;
    use lasercal::method::verdict::{Verdict, judge, quality};
    use lasercal::method::{Estimator, MethodId};
    let n = independent_trials();
    let (s, fan, solids) = disk_case();
    let sensor = with_sigma(&common::declared(&fan, "fan-295"), 0.25);
    let id = MethodId::new(Kind::Disk, Estimator::FullProfile);
    let (mut covered, mut ok, mut errors) = (0, 0, Vec::new());
    for t in 0..n {
        let caps = trial_captures(&s, Kind::Disk, 27, t).0.unwrap();
        let noise = Noise {
            sigma_z: 0.02e-3,
            dropout: 0.0,
            sigma_z_far: 0.25e-3,
        };
        let file = regenerate(&caps, &s, &fan, &placed(&solids, t), noise, 9000 + t);
        let (cal, r) = lasercal::method::estimate(id, &file, &sensor).unwrap();
        let j = judge(quality(&cal, r.as_ref(), id.estimator, &file, &sensor));
        let e = PoseError::between(&cal.flange_to_sensor, &s.rig.flange_to_sensor);
        let (br, bt) = j.quality.error_bound();
        assert!(
            e.rotation_error_deg < 0.05 && e.translation_error_mm < 0.05,
            "trial {t}: {e:?}"
        );
        assert_ne!(j.verdict, Verdict::Suspect, "trial {t}: {:?}", j.reasons);
        covered += usize::from(e.rotation_error_deg <= br && e.translation_error_mm <= bt);
        ok += usize::from(j.verdict == Verdict::Ok);
        errors.push((e.rotation_error_deg, e.translation_error_mm));
    }
    errors.sort_by(|a, b| a.0.total_cmp(&b.0));
    let median_rot = errors[errors.len() / 2].0;
    errors.sort_by(|a, b| a.1.total_cmp(&b.1));
    let median_tr = errors[errors.len() / 2].1;
    eprintln!(
        "depth-dependent noise, disk-full on the independent generator: {covered} of {n} \
         covered, {ok} ok; median error {median_rot:.4} deg / {median_tr:.4} mm"
    );
    // Two trials in CI, both held; a measured run says how often (docs/verdict.md).
    assert!(
        covered as f64 >= 0.85 * n as f64,
        "{covered} of {n} covered"
    );
}

/// The few-scans note (`verdict::few_scans`) on another generator's captures: the disk paper's
/// four scans get it once a robot accuracy is stated, the edge paper's 25 orientations never,
/// nor the disk stating none.
#[test]
fn the_few_scans_note_on_the_papers_protocols_from_another_generator() {
    use lasercal::method::verdict::decide;
    let note = "scans, each at one flange orientation";
    let cases: [(Kind, fn() -> (Setup, Fan, Vec<Solid>), f64, bool); 3] = [
        (Kind::Disk, disk_case, 0.2, true),
        (Kind::Disk, disk_case, 0.0, false),
        (Kind::Edge, edge_case, 0.2, false),
    ];
    for (kind, case, stated_mm, want) in cases {
        let (s, fan, solids) = case();
        let sensor = with_sigma(&common::declared(&fan, "fan-295"), 0.1);
        let caps = trial_captures(&s, kind, 27, 0).0.unwrap();
        let noise = Noise {
            sigma_z: 0.1e-3,
            dropout: 0.0,
            sigma_z_far: 0.0,
        };
        let mut file = regenerate(&caps, &s, &fan, &placed(&solids, 0), noise, 7000);
        file.judging.robot_accuracy = stated_mm * 1e-3;
        let d = decide(&file, &sensor, None).unwrap();
        let lines: Vec<&String> = d.judged.lines().collect();
        assert_eq!(
            lines.iter().any(|l| l.contains(note)),
            want,
            "{kind:?} stating {stated_mm} mm: {lines:#?}"
        );
    }
}
