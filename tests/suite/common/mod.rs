//! Helpers shared by the end-to-end tests.
#![allow(dead_code)]

/// Run the `lasercal` binary (with CI set, so no progress bar): exit code, stdout, stderr.
pub fn lasercal(args: &[&str]) -> (i32, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lasercal"))
        .args(args)
        .env("CI", "1")
        .output()
        .expect("run lasercal");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// `lasercal calibrate FILE --json JSON`: exit code, stdout, stderr and the JSON written (null
/// where none was).
pub fn calibrate_json(
    file: &std::path::Path,
    json: &std::path::Path,
) -> (i32, String, String, serde_json::Value) {
    let (code, out, err) = lasercal(&[
        "calibrate",
        file.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    let doc = std::fs::read_to_string(json)
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or(serde_json::Value::Null);
    (code, out, err, doc)
}

/// Path of a file in scenarios/.
pub fn scen(name: &str) -> String {
    format!("{}/scenarios/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// The sensor lasercal is told: the independent generator's fan as a geometry record.
pub fn declared(fan: &lasercal::testkit::fan::Fan, name: &str) -> lasercal::sensor::SensorModel {
    use lasercal::sensor::{RaySpacing, SensorGeometry, SensorModel};
    let depth = |z: f64| fan.dir_z * (z - fan.apex_z);
    let (a, b) = (depth(fan.z_range.0), depth(fan.z_range.1));
    SensorModel::from_geometry(SensorGeometry {
        name: name.into(),
        frame: "independent fan".into(),
        apex_z: fan.apex_z,
        dir_z: fan.dir_z,
        depth_near: a.min(b),
        depth_far: a.max(b),
        tan_half_fov: fan.half_angle.tan(),
        columns: fan.columns,
        spacing: if fan.equal_angle {
            RaySpacing::EqualAngle
        } else {
            RaySpacing::EqualTan
        },
        x_reversed: fan.reversed,
        z_quantum: None,
        camera: fan.camera,
        resample: None,
    })
    .unwrap()
}

/// A generator profile ((x, z) per column) as a raw capture.
pub fn raw(points: Vec<Option<(f64, f64)>>) -> lasercal::captures::ProfileData {
    use lasercal::sensor::{Profile, ProfilePoint};
    lasercal::captures::ProfileData::Raw(Profile {
        points: points
            .into_iter()
            .map(|q| {
                q.map(|(x, z)| ProfilePoint {
                    x,
                    z,
                    intensity: 1.0,
                })
            })
            .collect(),
    })
}

/// `lasercal simulate` of a scenario into `dir`/`name`: the capture file's path and its JSON.
pub fn simulated_capture(
    dir: &std::path::Path,
    scenario: &str,
    name: &str,
) -> (std::path::PathBuf, serde_json::Value) {
    simulated_at(dir, &scen(scenario), name)
}

/// `lasercal simulate` of a scenario given as TOML text (a scenario of scenarios/ with a field
/// changed), written beside the capture file `name` in `dir`: its path and its JSON.
pub fn simulated_from_text(
    dir: &std::path::Path,
    toml: &str,
    name: &str,
) -> (std::path::PathBuf, serde_json::Value) {
    let scenario = dir.join(format!("{name}.toml"));
    std::fs::write(&scenario, toml).unwrap();
    simulated_at(dir, scenario.to_str().unwrap(), name)
}

fn simulated_at(
    dir: &std::path::Path,
    scenario: &str,
    name: &str,
) -> (std::path::PathBuf, serde_json::Value) {
    let caps = dir.join(name);
    let (code, _, err) = lasercal(&["simulate", scenario, "--out", caps.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let doc = serde_json::from_str(&std::fs::read_to_string(&caps).unwrap()).unwrap();
    (caps, doc)
}

/// A sweep's outputs that a merge of its shards must reproduce byte for byte.
pub const SWEEP_OUTPUTS: [&str; 5] = [
    "trials.csv",
    "summary.csv",
    "plot.svg",
    "plot.png",
    "report.md",
];

/// The sweep outputs in folders `a` and `b` are byte for byte the same (`what` names the case).
pub fn assert_same_sweep_outputs(a: &std::path::Path, b: &std::path::Path, what: &str) {
    for f in SWEEP_OUTPUTS {
        let read = |d: &std::path::Path| {
            std::fs::read(d.join(f)).unwrap_or_else(|e| panic!("{}: {e}", d.join(f).display()))
        };
        assert!(
            read(a) == read(b),
            "{what}: {f} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

/// Replace every profile of `caps` by the independent generator's (`testkit::fan`), seen from the
/// true mounting.
pub fn regenerate(
    caps: &lasercal::captures::Captures,
    s: &lasercal::scenario::Setup,
    fan: &lasercal::testkit::fan::Fan,
    solids: &[lasercal::testkit::fan::Solid],
    noise: lasercal::testkit::fan::Noise,
    seed: u64,
) -> lasercal::captures::Captures {
    use lasercal::sensor::{Profile, ProfilePoint};
    let mut rng = lasercal::testkit::rng(seed);
    let mut out = caps.clone();
    for p in &mut out.profiles {
        let base_to_sensor = p.base_to_flange * s.rig.flange_to_sensor;
        let pts = lasercal::testkit::fan::profile(fan, solids, &base_to_sensor, noise, &mut rng);
        p.data = lasercal::captures::ProfileData::Raw(Profile {
            points: pts
                .into_iter()
                .map(|q| {
                    q.map(|(x, z)| ProfilePoint {
                        x,
                        z,
                        intensity: 1.0,
                    })
                })
                .collect(),
        });
    }
    out
}

/// The independent generator's fan like the Gocator 2340's (apex 295 mm, +-14 deg, 1280 rays
/// equal in angle, the camera 120 mm off the laser plane): the disk's independent profiles.
pub fn fan_295() -> lasercal::testkit::fan::Fan {
    lasercal::testkit::fan::Fan {
        apex_z: 0.295,
        dir_z: -1.0,
        half_angle: 14f64.to_radians(),
        columns: 1280,
        equal_angle: true,
        reversed: false,
        z_range: (-0.105, 0.105),
        camera: nalgebra::Point3::new(0.0, 0.120, 0.295),
    }
}

/// The independent generator's box for a parallel bar of lasercal's scene at `pose`.
pub fn bar_solid(
    bar: &lasercal::scene::Specimen,
    pose: nalgebra::Isometry3<f64>,
) -> lasercal::testkit::fan::Solid {
    let lasercal::scene::SpecimenKind::ParallelBar {
        length,
        width,
        height,
    } = bar.kind
    else {
        panic!("a parallel bar was expected, not {:?}", bar.kind);
    };
    lasercal::testkit::fan::Solid::Bar {
        frame: pose,
        lx: length,
        ly: width,
        lz: height,
    }
}

/// The poses of a simulated capture file (`doc`) written into `dir` in the controllers' and
/// vision libraries' own formats: a FANUC `.ls` program (`cell.ls`, user frame 1, tool frame 2),
/// ABB RAPID robtargets (`cell.mod`), a JSON list, a JSON object holding it and text lines of
/// x y z w p r (`poses.json`, `robposes.rob`, `poses.txt`) and folders of HALCON pose files
/// (`halcon/pose_N.dat` of type 0, `halcon-abg` of type 2, `halcon-rodriguez` of type 4).
/// Returns their names.
pub fn pose_files(doc: &serde_json::Value, dir: &std::path::Path) -> Vec<&'static str> {
    use nalgebra::UnitQuaternion;
    let poses: Vec<(Vec<f64>, UnitQuaternion<f64>)> = doc["profiles"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            let t: Vec<f64> = serde_json::from_value(p["tcp_position_mm"].clone()).unwrap();
            let q: Vec<f64> = serde_json::from_value(p["tcp_quaternion_wxyz"].clone()).unwrap();
            let q = nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]);
            (t, UnitQuaternion::from_quaternion(q))
        })
        .collect();
    // FANUC W, P, R: R = Rz(r) Ry(p) Rx(w), nalgebra's roll, pitch, yaw.
    let wpr = |q: &UnitQuaternion<f64>| {
        let (w, p, r) = q.euler_angles();
        [w.to_degrees(), p.to_degrees(), r.to_degrees()]
    };
    let mut ls = String::from("/PROG  CALIB\n/MN\n");
    for i in 0..poses.len() {
        ls += &format!("   {}:L P[{}] 100mm/sec FINE ;\n", i + 1, i + 1);
    }
    ls += "/POS\n";
    for (i, (t, q)) in poses.iter().enumerate() {
        let [w, p, r] = wpr(q);
        ls += &format!(
            "P[{}:\"scan\"]{{\n   GP1:\n\tUF : 1, UT : 2,\t\tCONFIG : 'N U T, 0, 0, 0',\n\t\
             X = {} mm,\tY = {} mm,\tZ = {} mm,\n\tW = {w} deg,\tP = {p} deg,\tR = {r} deg\n}};\n",
            i + 1,
            t[0],
            t[1],
            t[2]
        );
    }
    ls += "/END\n";
    let mut rapid = String::from("MODULE Calib\n");
    for (i, (t, q)) in poses.iter().enumerate() {
        rapid += &format!(
            "  CONST robtarget p{i}:=[[{},{},{}],[{},{},{},{}],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n",
            t[0], t[1], t[2], q.w, q.i, q.j, q.k
        );
    }
    rapid += "ENDMODULE\n";
    let rows: Vec<Vec<f64>> = poses
        .iter()
        .map(|(t, q)| [t[0], t[1], t[2]].into_iter().chain(wpr(q)).collect())
        .collect();
    let text: String = rows
        .iter()
        .map(|r| {
            r.iter()
                .map(|v| v.to_string())
                .collect::<Vec<_>>()
                .join(" ")
                + "\n"
        })
        .collect();
    std::fs::write(dir.join("cell.ls"), ls).unwrap();
    std::fs::write(dir.join("cell.mod"), rapid).unwrap();
    std::fs::write(
        dir.join("poses.json"),
        serde_json::to_string(&rows).unwrap(),
    )
    .unwrap();
    std::fs::write(
        dir.join("robposes.rob"),
        serde_json::json!({ "RobPoses": rows }).to_string(),
    )
    .unwrap();
    std::fs::write(dir.join("poses.txt"), text).unwrap();
    // A controller's log while moving (`log.csv`: t_s then the ABB columns, each profile's pose
    // at 2 i s and another 5 mm off at 2 i + 1 s) and the profiles' time stamps (`times.csv`).
    let (mut log, mut times) = (
        String::from("t_s,x_mm,y_mm,z_mm,qw,qx,qy,qz\n"),
        String::from("t_s\n"),
    );
    for (i, (t, q)) in poses.iter().enumerate() {
        for (dt, dz) in [(0.0, 0.0), (1.0, 5.0)] {
            log += &format!(
                "{},{},{},{},{},{},{},{}\n",
                2.0 * i as f64 + dt,
                t[0],
                t[1],
                t[2] + dz,
                q.w,
                q.i,
                q.j,
                q.k
            );
        }
        times += &format!("{}\n", 2.0 * i as f64);
    }
    std::fs::write(dir.join("log.csv"), log).unwrap();
    std::fs::write(dir.join("times.csv"), times).unwrap();
    // HALCON pose files of types 0 ('gba'), 2 ('abg') and 4 ('rodriguez'); t in metres.
    for (folder, kind) in [("halcon", 0), ("halcon-abg", 2), ("halcon-rodriguez", 4)] {
        let halcon = dir.join(folder);
        std::fs::create_dir_all(&halcon).unwrap();
        for (i, (t, q)) in poses.iter().enumerate() {
            let m = q.to_rotation_matrix().into_inner();
            let r = match kind {
                // R = Rx(a) Ry(b) Rz(g): m02 = sin b, a = atan2(-m12, m22), g = atan2(-m01, m00).
                0 => [
                    (-m[(1, 2)]).atan2(m[(2, 2)]).to_degrees(),
                    m[(0, 2)].asin().to_degrees(),
                    (-m[(0, 1)]).atan2(m[(0, 0)]).to_degrees(),
                ],
                // R = Rz(g) Ry(b) Rx(a): nalgebra's roll, pitch, yaw.
                2 => wpr(q),
                // tan(angle / 2) times the axis.
                _ => {
                    let (axis, angle) = q.axis_angle().unwrap();
                    (axis.into_inner() * (angle / 2.0).tan()).into()
                }
            };
            std::fs::write(
                halcon.join(format!("pose_{i}.dat")),
                format!(
                    "# 3D POSE PARAMETERS: rotation and translation\n\n# Used representation \
                     type:\nf {kind}\n\n# Rotation angles [deg] or Rodriguez vector:\n\
                     r {} {} {}\n\n# Translational vector (x y z [m]):\nt {} {} {}\n",
                    r[0],
                    r[1],
                    r[2],
                    t[0] / 1e3,
                    t[1] / 1e3,
                    t[2] / 1e3
                ),
            )
            .unwrap();
        }
    }
    vec![
        "cell.ls",
        "cell.mod",
        "poses.json",
        "robposes.rob",
        "poses.txt",
        "halcon",
        "halcon-abg",
        "halcon-rodriguez",
    ]
}

/// A simulated capture file's recording (`doc`) written into `dir` as a rig would have it: the
/// poses as `poses.csv` (x_mm, y_mm, z_mm, qw, qx, qy, qz) and one profile CSV per pose in
/// `profiles/` (x_mm, z_mm; an empty row where the sensor saw nothing), named `pose_N.csv` with N
/// unpadded (natural order puts pose_2 before pose_10). Returns the two paths.
pub fn rig_recording(
    doc: &serde_json::Value,
    dir: &std::path::Path,
) -> (std::path::PathBuf, std::path::PathBuf) {
    let per_pose = dir.join("profiles");
    std::fs::create_dir_all(&per_pose).unwrap();
    let mut poses = String::from("x_mm,y_mm,z_mm,qw,qx,qy,qz\n");
    for (i, p) in doc["profiles"].as_array().unwrap().iter().enumerate() {
        let (t, q) = (&p["tcp_position_mm"], &p["tcp_quaternion_wxyz"]);
        poses += &format!(
            "{},{},{},{},{},{},{}\n",
            t[0], t[1], t[2], q[0], q[1], q[2], q[3]
        );
        let mut csv = String::from("x_mm,z_mm\n");
        for pt in p["points_mm"].as_array().unwrap() {
            match pt.as_array() {
                Some(xz) => csv += &format!("{},{}\n", xz[0], xz[1]),
                None => csv += ",\n",
            }
        }
        std::fs::write(per_pose.join(format!("pose_{i}.csv")), csv).unwrap();
    }
    let pose_list = dir.join("poses.csv");
    std::fs::write(&pose_list, poses).unwrap();
    (pose_list, per_pose)
}

/// A refinement problem's analytic Jacobian at `x` against central differences (step 1e-6 in
/// each parameter): the largest residual there, and the worst column's difference relative to
/// that column's largest entry (at least 1e-3).
pub fn jacobian_error(
    p: &dyn lasercal::calib::refine::Refinable,
    x: &nalgebra::Isometry3<f64>,
) -> (f64, f64) {
    let (r0, j) = p.residuals_and_jacobian(x);
    let h = 1e-6;
    let mut worst: f64 = 0.0;
    for c in 0..j.ncols() {
        let mut dx = nalgebra::DVector::zeros(j.ncols());
        dx[c] = h;
        let rp = p.residuals_after_step(x, &dx);
        dx[c] = -h;
        let rm = p.residuals_after_step(x, &dx);
        let fd = (rp - rm) / (2.0 * h);
        worst = worst.max((fd - j.column(c)).amax() / j.column(c).amax().max(1e-3));
    }
    (r0.amax(), worst)
}
