//! Issue 13, part 1: a sensor is data. The presets are records; a scenario or a capture file can
//! declare any fan (apex, extent, spacing, columns, range, frame, camera) and simulation,
//! occlusion and feature extraction all take the sensor from it.

use crate::common;

use lasercal::method::MethodId;
use lasercal::scenario::ScenarioFile;
use lasercal::schema::sensor::GeometrySection;
use lasercal::sensor::{RaySpacing, SensorModel};
use lasercal::trial::{run_trial, trial_captures};

const PRESETS: [&str; 7] = [
    "gocator-2340",
    "gocator-2320",
    "gocator-2330",
    "gocator-2350",
    "gocator-2370",
    "gocator-2380",
    "vlm350",
];

/// A fan like another maker's: apex 295 mm above the range centre, rays evenly spaced in angle over
/// +-14 deg (not the Gocator 2340's 310.7 mm apex and equal-tan columns over +-13.1 deg).
const FAN_295: &str = r#"[sensor.geometry]
name = "fan-295"
columns = 1280
spacing = "equal-angle"
z_axis = "toward"
apex_z_mm = 295.0
half_angle_deg = 14.0
range_z_mm = [-105.0, 105.0]
camera_mm = [0.0, 120.0, 295.0]
"#;

fn disk_raycast_text(sensor: &str) -> String {
    // The ray-cast disk setup of sweep.rs's disk_raycast_recovers_truth: moves mostly along the
    // sensor's y so the chords stay in the range.
    std::fs::read_to_string(common::scen("chen2018-disk.toml"))
        .unwrap()
        .replace("source = \"analytic\"", "source = \"raycast\"")
        .replace("directions_in_base", "directions_in_sensor")
        .replace("span_fraction = 0.9", "span_fraction = 0.8")
        .replace(
            "[[0.181, -0.246, -0.952], [0.287, -0.294, -0.912], [0.391, -0.593, -0.704], [0.164, -0.631, -0.758]]",
            "[[0.1, 1.0, -0.5], [-0.2, 1.0, -0.4], [0.2, 1.0, -0.6], [-0.1, 1.0, -0.45]]",
        )
        .replace("preset = \"gocator-2340\"\n", "quantise = false\n")
        + "\n"
        + sensor
}

#[test]
fn presets_are_records_that_pass_their_own_checks() {
    for name in PRESETS {
        let g = SensorModel::preset_geometry(name).unwrap();
        let m = SensorModel::from_geometry(g.clone()).unwrap();
        assert_eq!(m, SensorModel::preset(name).unwrap(), "{name}");
        assert!(m.is_preset(), "{name}");
        // As written in a file (mm, degrees) and read back: the same rays to rounding.
        let back =
            SensorModel::from_geometry(GeometrySection::from_geometry(&g).to_geometry().unwrap())
                .unwrap();
        assert!(!back.is_preset() || back == m);
        for k in [0, m.columns / 3, m.columns - 1] {
            assert!(
                (back.column_tan(k) - m.column_tan(k)).abs() < 1e-12,
                "{name} column {k}"
            );
        }
        assert!((back.apex_z - m.apex_z).abs() < 1e-12 && back.dir_z == m.dir_z);
        assert!((back.depth_near - m.depth_near).abs() < 1e-12);
        assert!((back.depth_far - m.depth_far).abs() < 1e-12);
    }
}

#[test]
fn spacing_laws_and_column_order() {
    let sec: toml::Table = toml::from_str(FAN_295).unwrap();
    let g: GeometrySection = sec["sensor"]["geometry"].clone().try_into().unwrap();
    let m = SensorModel::from_geometry(g.to_geometry().unwrap()).unwrap();
    assert_eq!(m.spacing, RaySpacing::EqualAngle);
    let angle = |k: usize| m.column_tan(k).atan();
    let step = angle(1) - angle(0);
    assert!((step - 28f64.to_radians() / 1279.0).abs() < 1e-12);
    for k in 1..m.columns {
        assert!((angle(k) - angle(k - 1) - step).abs() < 1e-12, "column {k}");
    }
    assert!((angle(0) + 14f64.to_radians()).abs() < 1e-12);
    // The same fan given by the line's width at two z values, and reversed.
    let by_width = GeometrySection {
        apex_z_mm: None,
        half_angle_deg: None,
        x_range_mm: Some([
            // z toward the sensor: the near end (190 mm from the apex) at z = +105.
            [105.0, 2.0 * 190.0 * 14f64.to_radians().tan()],
            [-105.0, 2.0 * 400.0 * 14f64.to_radians().tan()],
        ]),
        x_reversed: true,
        ..g.clone()
    };
    let r = SensorModel::from_geometry(by_width.to_geometry().unwrap()).unwrap();
    assert!(
        (r.apex_z - m.apex_z).abs() < 1e-12,
        "{} vs {}",
        r.apex_z,
        m.apex_z
    );
    for k in 0..m.columns {
        assert!((r.column_tan(k) - m.column_tan(m.columns - 1 - k)).abs() < 1e-12);
    }
}

#[test]
fn bad_geometry_names_the_field() {
    let base = disk_raycast_text(FAN_295);
    for (from, to, key) in [
        ("columns = 1280", "columns = 1", "columns"),
        ("columns = 1280", "columns = 1000000000", "columns"),
        (
            "half_angle_deg = 14.0",
            "half_angle_deg = 95.0",
            "half_angle",
        ),
        (
            "half_angle_deg = 14.0",
            "half_angle_deg = 14.0\nx_range_mm = [[0.0, 10.0], [10.0, 20.0]]",
            "apex_z_mm",
        ),
        (
            "range_z_mm = [-105.0, 105.0]",
            "range_z_mm = [300.0, 400.0]",
            "range_z_mm",
        ),
        (
            "camera_mm = [0.0, 120.0, 295.0]",
            "camera_mm = [0.0, 120.0, nan]",
            "camera_mm",
        ),
        (
            "quantise = false",
            "quantise = false\npreset = \"vlm350\"",
            "not both",
        ),
    ] {
        assert!(base.contains(from), "{from}");
        let e = ScenarioFile::parse(&base.replacen(from, to, 1), "s.toml")
            .unwrap_err()
            .to_string();
        eprintln!("{e}");
        assert!(e.contains("sensor") && e.contains(key), "{to}: {e}");
    }
}

#[test]
fn a_declared_fan_simulates_and_calibrates_through_its_own_rays() {
    let sf = ScenarioFile::parse(&disk_raycast_text(FAN_295), "fan.toml").unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    assert_eq!(setup.rig.sensor.name, "fan-295");
    let method: MethodId = "disk".parse().unwrap();
    let out = run_trial(&setup, method, 1, 0);
    let s = out.result.unwrap();
    eprintln!(
        "declared fan: {:?}, missed {}",
        s.error(),
        out.missed_profiles
    );
    // The bound of the preset's noise-free ray-cast test (half an x sample per chord end).
    assert_eq!(out.missed_profiles, 0);
    assert!(
        s.error().translation_error_mm < 0.1 && s.error().rotation_error_deg < 0.05,
        "{:?}",
        s.error()
    );
    // The capture file carries the declared sensor, and calibrates to the same transform.
    let (caps, _) = trial_captures(&setup, method.kind, 1, 0);
    let caps = caps.unwrap();
    let json = lasercal::io::captures::to_json(&caps, &setup.rig.sensor);
    assert!(
        json.contains("\"equal-angle\""),
        "the file must describe the fan"
    );
    let (back, sensor) = lasercal::io::captures::from_json(&json, "c.json").unwrap();
    assert_eq!(sensor.name, "fan-295");
    let a = lasercal::method::calibrate(&caps, &setup.rig.sensor).unwrap();
    let b = lasercal::method::calibrate(&back, &sensor).unwrap();
    let e = lasercal::calib::PoseError::between(&a.flange_to_sensor, &b.flange_to_sensor);
    assert!(
        e.rotation_error_deg < 1e-9 && e.translation_error_mm < 1e-9,
        "{e:?}"
    );
}

#[test]
fn the_same_profiles_read_with_the_wrong_fan_place_ends_off_the_rays() {
    // Why the sensor must be declared: profiles of the 295 mm equal-angle fan, extracted with the
    // Gocator 2340's rays, put chord ends between the wrong rays.
    let sf = ScenarioFile::parse(&disk_raycast_text(FAN_295), "fan.toml").unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    let (caps, _) = trial_captures(&setup, lasercal::method::Kind::Disk, 1, 0);
    let caps = caps.unwrap();
    let right = lasercal::method::calibrate(&caps, &setup.rig.sensor).unwrap();
    let wrong = lasercal::method::calibrate(&caps, &SensorModel::gocator_2340().ideal());
    let truth = setup.rig.flange_to_sensor;
    let e_right = lasercal::calib::PoseError::between(&right.flange_to_sensor, &truth);
    match wrong {
        Ok(w) => {
            let e_wrong = lasercal::calib::PoseError::between(&w.flange_to_sensor, &truth);
            eprintln!("right fan {e_right:?}, wrong fan {e_wrong:?}");
            assert!(e_wrong.translation_error_mm > 2.0 * e_right.translation_error_mm);
        }
        Err(e) => eprintln!("right fan {e_right:?}, wrong fan refused: {e}"),
    }
}

#[test]
fn raw_profiles_of_any_length() {
    // Profiles as the valid points only (as many profilers send them), with or without their
    // columns: placed on the declared fan's rays, they calibrate exactly as the full records.
    let sf = ScenarioFile::parse(&disk_raycast_text(FAN_295), "fan.toml").unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    let (caps, _) = trial_captures(&setup, lasercal::method::Kind::Disk, 1, 0);
    let json = lasercal::io::captures::to_json(&caps.unwrap(), &setup.rig.sensor);
    let full: serde_json::Value = serde_json::from_str(&json).unwrap();
    let reference = {
        let (c, s) = lasercal::io::captures::from_json(&json, "full.json").unwrap();
        lasercal::method::calibrate(&c, &s)
            .unwrap()
            .flange_to_sensor
    };
    let compact = |with_columns: bool| {
        let mut doc = full.clone();
        let mut lengths = Vec::new();
        for p in doc["profiles"].as_array_mut().unwrap() {
            let pts = p["points_mm"].as_array().unwrap().clone();
            let kept: Vec<(usize, serde_json::Value)> = pts
                .into_iter()
                .enumerate()
                .filter(|(_, q)| !q.is_null())
                .collect();
            lengths.push(kept.len());
            p["points_mm"] = kept.iter().map(|(_, q)| q.clone()).collect();
            p.as_object_mut().unwrap().remove("intensity");
            if with_columns {
                p["columns"] = kept.iter().map(|(k, _)| serde_json::json!(k)).collect();
            }
        }
        (doc, lengths)
    };
    for with_columns in [false, true] {
        let (doc, lengths) = compact(with_columns);
        assert!(lengths.iter().any(|&n| n > 300 && n < 1280), "{lengths:?}");
        let (c, s) = lasercal::io::captures::from_json(&doc.to_string(), "compact.json").unwrap();
        let x = lasercal::method::calibrate(&c, &s)
            .unwrap()
            .flange_to_sensor;
        let e = lasercal::calib::PoseError::between(&x, &reference);
        assert!(
            e.rotation_error_deg < 1e-9 && e.translation_error_mm < 1e-9,
            "{e:?}"
        );
    }
    // A point between the rays, without columns: an error naming it and the fix.
    let (mut doc, _) = compact(false);
    doc["profiles"][0]["points_mm"][3][0] =
        serde_json::json!(doc["profiles"][0]["points_mm"][3][0].as_f64().unwrap() + 0.05);
    let e = lasercal::io::captures::from_json(&doc.to_string(), "bad.json")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("profiles[0].points_mm[3]") && e.contains("columns"),
        "{e}"
    );
}

#[test]
fn a_resampling_sensor_reports_on_its_grid_and_calibrates() {
    // The same fan with resampled output (x_pitch_mm): every reported point lies on the grid
    // x = 0.02 + 0.1 m mm, and the disk calibrates from those profiles as from the rays.
    let text = disk_raycast_text(&format!("{FAN_295}x_pitch_mm = 0.1\nx_offset_mm = 0.02\n"));
    let sf = ScenarioFile::parse(&text, "resampled.toml").unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    let sensor = &setup.rig.sensor;
    let grid = sensor.resampling().unwrap();
    assert!((grid.pitch - 0.1e-3).abs() < 1e-15 && (grid.offset - 0.02e-3).abs() < 1e-15);
    // Slots across the far field of view: 2 x 400 mm x tan 14 deg / 0.1 mm.
    let want = 2.0 * 0.400 * 14f64.to_radians().tan() / 0.1e-3;
    assert!(
        (sensor.columns as f64 - want).abs() <= 1.0,
        "{}",
        sensor.columns
    );
    let method: MethodId = "disk".parse().unwrap();
    let (caps, _) = trial_captures(&setup, method.kind, 1, 0);
    let caps = caps.unwrap();
    let mut seen = 0;
    for p in &caps.profiles {
        let lasercal::captures::ProfileData::Raw(prof) = &p.data else {
            panic!("raw profiles expected")
        };
        for (k, q) in prof.points.iter().enumerate() {
            let Some(q) = q else { continue };
            let m = (q.x - 0.02e-3) / 0.1e-3;
            assert!(
                (m - m.round()).abs() < 1e-6,
                "x {} mm off the grid",
                q.x * 1e3
            );
            assert!((sensor.column_of(q.x, q.z).unwrap() - k as f64).abs() < 1e-6);
            seen += 1;
        }
    }
    assert!(seen > 100_000, "{seen} points");
    let out = run_trial(&setup, method, 1, 0);
    let e = out.result.unwrap().error();
    eprintln!("resampled fan: {e:?}, missed {}", out.missed_profiles);
    assert_eq!(out.missed_profiles, 0);
    assert!(
        e.rotation_error_deg < 0.05 && e.translation_error_mm < 0.1,
        "{e:?}"
    );
    // The capture file carries the grid, and reads back to the same transform.
    let json = lasercal::io::captures::to_json(&caps, sensor);
    assert!(
        json.contains("\"x_pitch_mm\""),
        "the file must carry the grid"
    );
    let (back, read) = lasercal::io::captures::from_json(&json, "r.json").unwrap();
    let a = lasercal::method::calibrate(&caps, sensor).unwrap();
    let b = lasercal::method::calibrate(&back, &read).unwrap();
    let d = lasercal::calib::PoseError::between(&a.flange_to_sensor, &b.flange_to_sensor);
    assert!(
        d.rotation_error_deg < 1e-9 && d.translation_error_mm < 1e-9,
        "{d:?}"
    );
}
