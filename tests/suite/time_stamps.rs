//! Capture files with time: a controller's pose stream and profiles given by their time stamps,
//! the flange pose interpolated at each (linear in position, spherical in rotation).

use crate::common::{lasercal, scen};
use lasercal::math::pose_at;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use serde_json::{Value, json};
use std::path::Path;

/// A simulated disk capture file (analytic chords) in `dir`, parsed.
fn disk_file(dir: &Path) -> (std::path::PathBuf, Value) {
    let path = dir.join("disk.json");
    let (code, _, err) = lasercal(&[
        "simulate",
        &scen("chen2018-disk.toml"),
        "--out",
        path.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let doc = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    (path, doc)
}

/// The same file with each profile's pose replaced by its time (`dt_s` apart, in file order,
/// shifted by `-offset_s` and the file saying `profile_clock_offset_s = offset_s`) and a pose
/// stream of every third profile's pose plus each group's first and last: the scans are straight
/// moves at one orientation, so interpolation between samples of one scan gives the poses back.
fn timed(doc: &Value, dt_s: f64, offset_s: f64) -> Value {
    let mut doc = doc.clone();
    let profiles = doc["profiles"].as_array_mut().unwrap();
    let mut stream = Vec::new();
    for (i, p) in profiles.iter_mut().enumerate() {
        let t = i as f64 * dt_s;
        let group = p["group"].clone();
        let o = p.as_object_mut().unwrap();
        let pos = o.remove("tcp_position_mm").unwrap();
        let quat = o.remove("tcp_quaternion_wxyz").unwrap();
        o.insert("t_s".into(), json!(t - offset_s));
        stream.push((t, group, pos, quat));
    }
    let n = stream.len();
    let samples: Vec<Value> = (0..n)
        .filter(|&i| {
            i % 3 == 0 || i + 1 == n || stream[i + 1].1 != stream[i].1 || stream[i - 1].1 != stream[i].1
        })
        .map(|i| json!({"t_s": stream[i].0, "tcp_position_mm": stream[i].2, "tcp_quaternion_wxyz": stream[i].3}))
        .collect();
    assert!(
        samples.len() < n,
        "the stream must be sparser than the profiles to test anything"
    );
    doc["pose_stream"] = Value::Array(samples);
    if offset_s != 0.0 {
        doc["profile_clock_offset_s"] = json!(offset_s);
    }
    doc
}

fn write(dir: &Path, name: &str, doc: &Value) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, serde_json::to_string(doc).unwrap()).unwrap();
    p
}

#[test]
fn profiles_given_by_time_get_the_poses_back_and_the_same_calibration() {
    let dir = tempfile::tempdir().unwrap();
    let (plain, doc) = disk_file(dir.path());
    let (want, _) = lasercal::io::captures::read(&plain).unwrap();
    for offset_s in [0.0, 0.0123] {
        let file = write(dir.path(), "timed.json", &timed(&doc, 0.004, offset_s));
        let (got, _) = lasercal::io::captures::read(&file).unwrap();
        assert_eq!(got.profiles.len(), want.profiles.len());
        for (a, b) in got.profiles.iter().zip(&want.profiles) {
            let d = a.base_to_flange.inverse() * b.base_to_flange;
            assert!(
                d.translation.vector.norm() < 1e-12 && d.rotation.angle() < 1e-12,
                "offset {offset_s}: {:?} vs {:?}",
                a.base_to_flange,
                b.base_to_flange
            );
        }
        // And the calibration through the binary agrees with the plain file's.
        let json_of = |f: &Path| {
            let out = dir.path().join("result.json");
            let (code, _, err) = lasercal(&[
                "calibrate",
                f.to_str().unwrap(),
                "--method",
                "disk",
                "--json",
                out.to_str().unwrap(),
            ]);
            assert!(code == 0 || code == 4, "{err}");
            let v: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
            v["flange_to_sensor"].clone()
        };
        let (a, b) = (json_of(&file), json_of(&plain));
        // The verdict says the profiles were placed by time while moving, and what a clock
        // offset error would do; the plain file has no such note.
        let note = "placed on the pose log by their time stamps";
        let said = |f: &Path| {
            let (_, out, err) = lasercal(&["calibrate", f.to_str().unwrap(), "--method", "disk"]);
            out + &err
        };
        let (timed_out, plain_out) = (said(&file), said(&plain));
        assert!(
            timed_out.contains(note) && timed_out.contains("mm/s"),
            "{timed_out}"
        );
        assert!(!plain_out.contains(note), "{plain_out}");
        let flat = |v: &Value| -> Vec<f64> {
            v.as_array()
                .unwrap()
                .iter()
                .flat_map(|r| r.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()))
                .collect()
        };
        for (x, y) in flat(&a).iter().zip(flat(&b)) {
            assert!((x - y).abs() < 1e-9, "{a} vs {b}");
        }
    }
}

/// Slerp is the geodesic: a rotation at constant rate about one axis with a straight move is
/// interpolated exactly between samples of a 250 Hz stream.
#[test]
fn interpolation_is_exact_for_a_steady_turn_and_move() {
    let axis = Vector3::new(0.3, -0.5, 0.8).normalize();
    let (w, v) = (0.7, Vector3::new(0.1, -0.05, 0.02)); // rad/s, m/s
    let r0 = UnitQuaternion::from_euler_angles(3.0, -0.2, 1.1);
    let p0 = Vector3::new(0.4, -0.3, 0.5);
    let truth = |t: f64| {
        Isometry3::from_parts(
            Translation3::from(p0 + v * t),
            UnitQuaternion::from_scaled_axis(axis * (w * t)) * r0,
        )
    };
    let stream: Vec<(f64, Isometry3<f64>)> = (0..=250)
        .map(|k| (k as f64 / 250.0, truth(k as f64 / 250.0)))
        .collect();
    for k in 0..1000 {
        let t = k as f64 / 1000.0 * 0.9993 + 0.0003;
        let d = pose_at(&stream, t).unwrap().inverse() * truth(t);
        assert!(
            d.translation.vector.norm() < 1e-14 && d.rotation.angle() < 1e-12,
            "t {t}: {d:?}"
        );
    }
    // Its own samples come back as they are; nothing outside the stream is extrapolated.
    assert_eq!(pose_at(&stream, 0.5).unwrap(), stream[125].1);
    assert_eq!(pose_at(&stream, 1.0).unwrap(), stream[250].1);
    assert!(pose_at(&stream, -1e-9).is_none() && pose_at(&stream, 1.0 + 1e-9).is_none());
    assert!(pose_at(&stream, f64::NAN).is_none() && pose_at(&[], 0.0).is_none());
}

/// A log with its quaternions' signs flipped between samples (one rotation, two quaternions)
/// interpolates the short way.
#[test]
fn a_quaternion_sign_flip_in_the_log_changes_nothing() {
    let a = Isometry3::from_parts(
        Translation3::new(0.1, 0.2, 0.3),
        UnitQuaternion::from_euler_angles(0.1, 0.2, 0.3),
    );
    let b = Isometry3::from_parts(
        Translation3::new(0.1, 0.2, 0.31),
        UnitQuaternion::from_euler_angles(0.1, 0.2, 0.32),
    );
    let flipped = Isometry3::from_parts(
        b.translation,
        UnitQuaternion::new_unchecked(-b.rotation.into_inner()),
    );
    let one = pose_at(&[(0.0, a), (1.0, b)], 0.5).unwrap();
    let two = pose_at(&[(0.0, a), (1.0, flipped)], 0.5).unwrap();
    assert!(one.rotation.angle_to(&two.rotation) < 1e-12);
    assert!(one.rotation.angle_to(&a.rotation) < 0.011);
}

#[test]
fn bad_time_stamps_are_refused_with_the_field_and_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let (_, doc) = disk_file(dir.path());
    let good = timed(&doc, 0.004, 0.0);
    let cases: Vec<(&str, Box<dyn Fn(&mut Value)>, &[&str])> = vec![
        (
            "a profile after the log ends",
            Box::new(|d: &mut Value| d["profiles"][3]["t_s"] = json!(1e6)),
            &[
                "profiles[3].t_s",
                "outside the pose stream",
                "start logging poses",
            ],
        ),
        (
            "the log out of order",
            Box::new(|d: &mut Value| d["pose_stream"][2]["t_s"] = json!(-5.0)),
            &["pose_stream[2].t_s", "strictly increasing", "sort the log"],
        ),
        (
            "time without a log",
            Box::new(|d: &mut Value| {
                d.as_object_mut().unwrap().remove("pose_stream");
            }),
            &["profiles[0].t_s", "needs the file's pose_stream"],
        ),
        (
            "both a pose and a time",
            Box::new(|d: &mut Value| {
                d["profiles"][1]["tcp_position_mm"] = json!([0.0, 0.0, 0.0]);
                d["profiles"][1]["tcp_quaternion_wxyz"] = json!([1.0, 0.0, 0.0, 0.0]);
            }),
            &["profiles[1].t_s", "not both"],
        ),
        (
            "a one-sample log",
            Box::new(|d: &mut Value| {
                let first = d["pose_stream"][0].clone();
                d["pose_stream"] = json!([first]);
            }),
            &["pose_stream", "at least two"],
        ),
        (
            "a bad quaternion in the log",
            Box::new(|d: &mut Value| {
                d["pose_stream"][1]["tcp_quaternion_wxyz"] = json!([2.0, 0.0, 0.0, 0.0])
            }),
            &["pose_stream[1].tcp_quaternion_wxyz", "unit quaternion"],
        ),
        (
            "a drift with the offset held",
            Box::new(|d: &mut Value| {
                d["estimate_clock_drift"] = json!(true);
                d["estimate_clock_offset"] = json!(false);
            }),
            &["estimate_clock_drift", "set estimate_clock_offset true"],
        ),
        (
            "clock estimation asked of a file without a log",
            Box::new(|d: &mut Value| {
                d.as_object_mut().unwrap().remove("pose_stream");
                d["estimate_clock_offset"] = json!(false);
            }),
            &[
                "estimate_clock_offset",
                "without a pose_stream",
                "leave the field out",
            ],
        ),
    ];
    for (what, change, want) in cases {
        let mut d = good.clone();
        change(&mut d);
        let file = write(dir.path(), "bad.json", &d);
        let (code, _, err) = lasercal(&["calibrate", file.to_str().unwrap(), "--method", "disk"]);
        assert_eq!(code, 2, "{what}: {err}");
        for w in want {
            assert!(err.contains(w), "{what}: want '{w}' in: {err}");
        }
    }
}
