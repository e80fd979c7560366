//! The verdict: on wrong inputs (a flipped group sign, a specimen radius 5 % off, the
//! wrong edge sense, three edge groups) and on correct captures at the papers' noise levels, the
//! verdict must flag (suspect or imprecise) the results that are off by more than 1 deg or 1 mm and
//! call at most 1 % of the correct ones suspect (a correct but imprecise one is no false alarm).
//! `LASERCAL_VERDICT_TRIALS` sets the trials per case (default 12); `--nocapture` prints the
//! table the README quotes.

use lasercal::calib::PoseError;
use lasercal::captures::{Captures, Role};
use lasercal::features::EdgeSense;
use lasercal::method::verdict::{Verdict, judge, quality};
use lasercal::method::{Estimator, Kind, MethodId, estimate};
use lasercal::scenario::{ScenarioFile, Setup};
use lasercal::trial::trial_captures;

fn setup(name: &str, edit: &dyn Fn(&str) -> String) -> Setup {
    let path = format!("{}/scenarios/{name}.toml", env!("CARGO_MANIFEST_DIR"));
    let text = edit(&std::fs::read_to_string(&path).unwrap());
    let sf = ScenarioFile::parse(&text, &path).unwrap();
    sf.scenario.build(&sf.file).unwrap()
}

fn trials() -> u64 {
    std::env::var("LASERCAL_VERDICT_TRIALS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(12)
}

/// Counts of one case: results off by more than 1 deg or 1 mm (bad) or not, flagged or not, and
/// refusals (an error is no confident answer).
#[derive(Default, Debug, Clone, Copy)]
struct Tally {
    bad_flagged: usize,
    bad_passed: usize,
    good_flagged: usize,
    /// Right answers judged imprecise: their bound exceeds the tolerance, no false alarm.
    good_imprecise: usize,
    good_passed: usize,
    refused: usize,
}

fn run_case(
    s: &Setup,
    method: MethodId,
    mutate: &dyn Fn(&mut Captures),
    tally: &mut Tally,
) -> Vec<String> {
    let mut missed = Vec::new();
    for t in 0..trials() {
        let mut caps = trial_captures(s, method.kind, 11, t).0.unwrap();
        mutate(&mut caps);
        let truth = caps.truth.unwrap();
        let Ok((cal, refined)) = estimate(method, &caps, &s.rig.sensor) else {
            tally.refused += 1;
            continue;
        };
        let j = judge(quality(
            &cal,
            refined.as_ref(),
            method.estimator,
            &caps,
            &s.rig.sensor,
        ));
        let e = PoseError::between(&cal.flange_to_sensor, &truth);
        let bad = !(e.rotation_error_deg <= 1.0 && e.translation_error_mm <= 1.0);
        // Imprecise is no confident answer either: only `ok` passes.
        let flagged = j.verdict != Verdict::Ok;
        match (bad, flagged) {
            (true, true) => tally.bad_flagged += 1,
            (true, false) => {
                tally.bad_passed += 1;
                missed.push(format!(
                    "{method} trial {t}: {:.3} deg / {:.3} mm off, judged ok ({:?})",
                    e.rotation_error_deg, e.translation_error_mm, j.quality
                ));
            }
            (false, true) if j.verdict == Verdict::Imprecise => tally.good_imprecise += 1,
            (false, true) => {
                tally.good_flagged += 1;
                missed.push(format!(
                    "{method} trial {t}: {:.4} deg / {:.4} mm off, judged {}: {}",
                    e.rotation_error_deg,
                    e.translation_error_mm,
                    j.verdict,
                    j.lines().cloned().collect::<Vec<_>>().join(" | ")
                ));
            }
            (false, false) => tally.good_passed += 1,
        }
    }
    missed
}

fn flip_first_sign(c: &mut Captures) {
    if let Some(g) = c.groups.iter_mut().find(|g| g.sign != 0.0) {
        g.sign = -g.sign;
    }
}

fn radius_off(c: &mut Captures) {
    c.specimen_radius = c.specimen_radius.map(|r| r * 1.05);
}

fn wrong_sense(c: &mut Captures) {
    c.edge_sense = c.edge_sense.map(|s| match s {
        EdgeSense::Falling => EdgeSense::Rising,
        EdgeSense::Rising => EdgeSense::Falling,
    });
}

fn three_groups(c: &mut Captures) {
    let keep: Vec<usize> = c
        .groups
        .iter()
        .filter(|g| g.role == Role::RotationGroup)
        .map(|g| g.id)
        .take(3)
        .collect();
    c.groups.retain(|g| keep.contains(&g.id));
    c.profiles.retain(|p| keep.contains(&p.group));
}

fn unchanged(_: &mut Captures) {}

/// (what, scenario, a line added to its `[sensor.noise]`, method, capture mutation).
type Case = (
    &'static str,
    &'static str,
    &'static str,
    MethodId,
    fn(&mut Captures),
);

const CF: Estimator = Estimator::ClosedForm;

fn wrong_cases() -> Vec<Case> {
    vec![
        (
            "flipped sign",
            "comparison",
            "",
            MethodId::new(Kind::Disk, CF),
            flip_first_sign,
        ),
        (
            "flipped sign",
            "comparison",
            "",
            MethodId::new(Kind::Ball, CF),
            flip_first_sign,
        ),
        (
            "radius +5 %",
            "comparison",
            "",
            MethodId::new(Kind::Disk, CF),
            radius_off,
        ),
        (
            "radius +5 %",
            "comparison",
            "",
            MethodId::new(Kind::Ball, CF),
            radius_off,
        ),
        (
            "radius +5 %",
            "comparison",
            "",
            MethodId::new(Kind::Ball, Estimator::AnyPose),
            radius_off,
        ),
        (
            "wrong edge sense",
            "comparison",
            "",
            MethodId::new(Kind::Edge, CF),
            wrong_sense,
        ),
        (
            "three edge groups",
            "xu2021-edge",
            "",
            MethodId::new(Kind::Edge, CF),
            three_groups,
        ),
        (
            "dropout 0.05",
            "comparison",
            "dropout = 0.05",
            MethodId::new(Kind::Disk, CF),
            unchanged,
        ),
        (
            "dropout 0.2",
            "comparison",
            "dropout = 0.2",
            MethodId::new(Kind::Disk, CF),
            unchanged,
        ),
        (
            "dropout 0.5",
            "comparison",
            "dropout = 0.5",
            MethodId::new(Kind::Disk, CF),
            unchanged,
        ),
        (
            "dropout 0.2",
            "comparison",
            "dropout = 0.2",
            MethodId::new(Kind::Ball, CF),
            unchanged,
        ),
        (
            "dropout 0.5",
            "comparison",
            "dropout = 0.5",
            MethodId::new(Kind::Ball, CF),
            unchanged,
        ),
        (
            "dropout 0.2",
            "comparison",
            "dropout = 0.2",
            MethodId::new(Kind::Edge, CF),
            unchanged,
        ),
        (
            "dropout 0.5",
            "comparison",
            "dropout = 0.5",
            MethodId::new(Kind::Edge, CF),
            unchanged,
        ),
    ]
}

fn correct_cases() -> Vec<Case> {
    let mut v: Vec<Case> = Vec::new();
    for k in [Kind::Disk, Kind::Ball, Kind::Edge] {
        for &e in k.estimators() {
            v.push(("correct", "comparison", "", MethodId::new(k, e), unchanged));
        }
    }
    v.push((
        "correct",
        "xu2021-edge",
        "",
        MethodId::new(Kind::Edge, CF),
        unchanged,
    ));
    let refined = MethodId::new(Kind::Edge, Estimator::Refined);
    v.push(("correct", "xu2021-edge", "", refined, unchanged));
    v
}

fn table(cases: &[Case]) -> (Tally, Vec<String>) {
    let mut total = Tally::default();
    let mut notes = Vec::new();
    for (what, scenario, noise, method, mutate) in cases {
        let s = setup(scenario, &|t| {
            t.replace("[sensor.noise]", &format!("[sensor.noise]\n{noise}"))
        });
        let mut t = Tally::default();
        notes.extend(run_case(&s, *method, mutate, &mut t));
        println!(
            "| {what} | {scenario} | {method} | {} | {} | {} | {} | {} | {} |",
            t.bad_flagged, t.bad_passed, t.good_flagged, t.good_imprecise, t.good_passed, t.refused
        );
        total.bad_flagged += t.bad_flagged;
        total.bad_passed += t.bad_passed;
        total.good_flagged += t.good_flagged;
        total.good_imprecise += t.good_imprecise;
        total.good_passed += t.good_passed;
        total.refused += t.refused;
    }
    (total, notes)
}

#[test]
fn the_verdict_flags_wrong_inputs_that_give_wrong_answers() {
    println!(
        "| input | scenario | method | off, flagged | off, passed | right, suspect | right, imprecise | right, ok | refused |"
    );
    let (t, notes) = table(&wrong_cases());
    let bad = t.bad_flagged + t.bad_passed;
    assert!(
        bad > 0,
        "no wrong input gave a wrong answer: the cases test nothing"
    );
    assert!(
        t.bad_passed as f64 <= 0.01 * bad as f64,
        "{} of {bad} wrong answers judged ok:\n{}",
        t.bad_passed,
        notes.join("\n")
    );
}

#[test]
fn the_verdict_passes_correct_captures() {
    let (t, notes) = table(&correct_cases());
    let good = t.good_flagged + t.good_imprecise + t.good_passed;
    assert!(good > 0);
    assert_eq!(t.bad_flagged + t.bad_passed, 0, "{}", notes.join("\n"));
    assert!(
        t.good_flagged as f64 <= 0.01 * good as f64,
        "{} of {good} correct results judged suspect:\n{}",
        t.good_flagged,
        notes.join("\n")
    );
}

use crate::common;

/// A simulated capture file of `scenario`'s `method`, edited by `edit`.
fn capture_file(
    dir: &std::path::Path,
    scenario: &str,
    method: &str,
    edit: impl Fn(&mut serde_json::Value),
) -> String {
    let file = dir.join(format!("{scenario}-{method}.json"));
    let f = file.to_str().unwrap().to_string();
    let (code, _, err) = common::lasercal(&[
        "simulate",
        &common::scen(&format!("{scenario}.toml")),
        "--method",
        method,
        "--out",
        &f,
    ]);
    assert_eq!(code, 0, "{err}");
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    edit(&mut doc);
    std::fs::write(&file, doc.to_string()).unwrap();
    f
}

#[test]
fn calibrate_runs_every_variant_prints_the_verdict_and_exits_3_when_suspect() {
    let dir = tempfile::tempdir().unwrap();
    // Correct captures: every variant in a table, the best kept, its figures and verdict printed
    // and in the JSON; exit 0.
    let good = capture_file(dir.path(), "comparison", "disk", |_| {});
    let json = dir.path().join("out.json");
    let (code, out, err) =
        common::lasercal(&["calibrate", &good, "--json", json.to_str().unwrap()]);
    assert_eq!(code, 0, "{out} {err}");
    for v in [
        "disk ",
        "disk-refined",
        "disk-full",
        "disk-any-pose",
        "chosen: ",
        "verdict ok",
    ] {
        assert!(out.contains(v), "{v}: {out}");
    }
    assert!(
        out.contains("x the stated noise") && out.contains("predicted sd"),
        "{out}"
    );
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let q = &doc["quality"];
    assert_eq!(q["verdict"], "ok", "{q}");
    assert_eq!(q["covariance_rad_m"].as_array().unwrap().len(), 6, "{q}");
    assert_eq!(q["correlations"][2][2].as_f64(), Some(1.0), "{q}");
    // The bounds' own covariance: each axis's 95 % bound is one Student's t (at `bound_dof`)
    // times its sd, the same t on every axis, at least the normal's 1.96.
    let c = &q["bound_covariance_rad_m"];
    assert!(q["bound_dof"].as_u64().is_some_and(|d| d >= 1), "{q}");
    let ratios: Vec<f64> = (0..6)
        .map(|i| {
            let (bound, unit) = match i {
                0..3 => (
                    q["bound_rotation_deg"][i].as_f64().unwrap(),
                    1f64.to_degrees(),
                ),
                _ => (q["bound_translation_mm"][i - 3].as_f64().unwrap(), 1e3),
            };
            bound / (c[i][i].as_f64().unwrap().sqrt() * unit)
        })
        .collect();
    for r in &ratios {
        assert!(
            *r >= 1.959 && (r - ratios[0]).abs() <= 1e-9 * r,
            "{ratios:?} {q}"
        );
    }
    let loo = &q["leave_one_out"];
    assert!(loo["runs"].as_u64() == Some(4), "{q}");
    // Each group's move per axis; the one named as the largest is the move it reports.
    let moves = loo["moves"].as_array().unwrap();
    assert_eq!(moves.len(), 4, "{loo}");
    let norm = |v: &serde_json::Value| {
        let v: Vec<f64> = v
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        v.iter().map(|x| x * x).sum::<f64>().sqrt()
    };
    let worst = moves.iter().find(|m| m["group"] == loo["group"]).unwrap();
    let (r, t) = (
        loo["rotation_deg"].as_f64().unwrap(),
        loo["translation_mm"].as_f64().unwrap(),
    );
    assert!(
        (norm(&worst["rotation_deg"]) - r).abs() <= 1e-9 * r.max(1e-9),
        "{loo}"
    );
    assert!(
        (norm(&worst["translation_mm"]) - t).abs() <= 1e-9 * t.max(1e-9),
        "{loo}"
    );
    assert_eq!(doc["variants"].as_array().unwrap().len(), 4, "{doc}");

    // A flipped group sign: the label-free variants still find the transform, and the verdict
    // names the contradicted sign (exit 3), with the closed form alone or with every variant.
    let flipped = capture_file(dir.path(), "comparison", "disk", |d| {
        let s = d["groups"][0]["sign"].as_f64().unwrap();
        d["groups"][0]["sign"] = serde_json::json!(-s);
    });
    for args in [
        vec!["calibrate", &flipped],
        vec!["calibrate", &flipped, "--method", "disk"],
    ] {
        let (code, out, err) = common::lasercal(&args);
        assert_eq!(code, 3, "{args:?}: {out} {err}");
        assert!(out.contains("verdict suspect"), "{out}");
    }
    let (_, out, _) = common::lasercal(&["calibrate", &flipped]);
    assert!(out.contains("sign of group 0 flipped"), "{out}");
    let (_, out, _) = common::lasercal(&["calibrate", &flipped, "--method", "disk"]);
    assert!(out.contains("the residuals do not fit the model"), "{out}");

    // A ball 5 % smaller than the file says: every variant's residuals say so.
    let radius = capture_file(dir.path(), "comparison", "ball", |d| {
        let r = d["specimen"]["radius_mm"].as_f64().unwrap();
        d["specimen"]["radius_mm"] = serde_json::json!(r * 1.05);
    });
    let (code, out, err) = common::lasercal(&["calibrate", &radius]);
    assert_eq!(code, 3, "{out} {err}");
    assert!(out.contains("specimen's size"), "{out}");
}

#[test]
fn nearly_collinear_translations_are_refused_relative_to_their_length() {
    // A public data set's rotation set: translations that leave their line by 0.04 mm over
    // 33 mm passed an absolute 1e-9 test and gave 131 deg. Relative to the length they are a
    // line (ratio about 1e-3).
    use lasercal::calib::ball::{BallCapture, rotation_from_translations};
    use nalgebra::{Rotation3, Vector3};
    let dir = Vector3::new(0.6, -0.3, 0.74).normalize();
    let side = dir.cross(&Vector3::z()).normalize();
    let set: Vec<BallCapture> = (0..6)
        .map(|i| BallCapture {
            r_tcp: Rotation3::identity(),
            t_tcp: Vector3::new(0.4, 0.1, 0.5)
                + dir * (0.033 * i as f64 / 5.0)
                + side * (if i % 2 == 0 { 4e-5 } else { -4e-5 }),
            q_in_sensor: Vector3::zeros(),
        })
        .collect();
    // The ball fixed in the base, the sensor frame the flange's: q = centre - t.
    let seen = |set: &mut Vec<BallCapture>| {
        for c in set.iter_mut() {
            c.q_in_sensor = Vector3::new(0.45, 0.12, 0.8) - c.t_tcp;
        }
    };
    let mut set = set;
    seen(&mut set);
    let err = rotation_from_translations(&set, 0.1)
        .unwrap_err()
        .to_string();
    assert!(err.contains("collinear") && err.contains("ratio"), "{err}");
    // The same moves with a 5 mm second direction are accepted.
    let mut wide = set.clone();
    for (i, c) in wide.iter_mut().enumerate() {
        c.t_tcp += side * (if i % 2 == 0 { 5e-3 } else { -5e-3 });
    }
    seen(&mut wide);
    let r = rotation_from_translations(&wide, 0.1);
    assert!(r.is_ok(), "{r:?}");
}

/// Gross mistakes made as a file would make them: each returns the captures as a reader would
/// take them from a file with that mistake (independent of `method::cause`, which undoes them).
pub(crate) mod mistake {
    use lasercal::captures::{Captures, ProfileData};
    use nalgebra::{Quaternion, Rotation3, UnitQuaternion, Vector3};

    /// Each mistake: its name, the words a reason naming its cause holds ("": none undoes
    /// it) and how a file makes it.
    pub type Mutate = fn(&mut Captures);
    pub const ALL: [(&str, &str, Mutate); 10] = [
        (
            "paired one record apart",
            "paired one record apart",
            pairing,
        ),
        ("positions in metres", "in metres", metres),
        ("quaternions x, y, z, w", "x, y, z, w order", xyzw),
        ("angles in radians", "in radians, not degrees", radians),
        (
            "Euler A, B, C as W, P, R",
            "listed in the other order",
            abc_as_wpr,
        ),
        (
            "Euler Rx Ry Rz as Rz Ry Rx",
            "compose the other way",
            xyz_as_zyx,
        ),
        ("profiles mirrored in x", "mirrored in x", mirrored),
        ("radius +5 %", "specimen's size", radius_5),
        ("radius +20 %", "specimen's size", radius_20),
        ("every orientation 3 deg off", "", turned_3deg),
    ];

    /// Each profile logged with the pose of the next record (the last one dropped).
    pub fn pairing(c: &mut Captures) {
        let poses: Vec<_> = c.profiles.iter().map(|p| p.base_to_flange).collect();
        for (i, p) in c.profiles.iter_mut().enumerate().take(poses.len() - 1) {
            p.base_to_flange = poses[i + 1];
        }
        c.profiles.pop();
    }

    /// Positions written in metres in the millimetre field.
    pub fn metres(c: &mut Captures) {
        for p in &mut c.profiles {
            p.base_to_flange.translation.vector *= 1e-3;
        }
    }

    /// Quaternions written x, y, z, w in the w, x, y, z field.
    pub fn xyzw(c: &mut Captures) {
        for p in &mut c.profiles {
            let q = *p.base_to_flange.rotation.quaternion();
            p.base_to_flange.rotation =
                UnitQuaternion::from_quaternion(Quaternion::new(q.i, q.j, q.k, q.w));
        }
    }

    /// W, P, R (R = Rz(r) Ry(p) Rx(w)) written in radians in a list of degrees.
    pub fn radians(c: &mut Captures) {
        for p in &mut c.profiles {
            let (w, pp, r) = p.base_to_flange.rotation.euler_angles();
            let d = |v: f64| v.to_radians();
            p.base_to_flange.rotation = UnitQuaternion::from_euler_angles(d(w), d(pp), d(r));
        }
    }

    /// KUKA's A, B, C (R = Rz(a) Ry(b) Rx(c), listed a, b, c) read as W, P, R.
    pub fn abc_as_wpr(c: &mut Captures) {
        for p in &mut c.profiles {
            let (roll, pitch, yaw) = p.base_to_flange.rotation.euler_angles();
            let (a, b, cc) = (yaw, pitch, roll);
            p.base_to_flange.rotation = UnitQuaternion::from_euler_angles(a, b, cc);
        }
    }

    /// Angles of R = Rx(a) Ry(b) Rz(c), listed a, b, c, read as W, P, R (R = Rz(r) Ry(p) Rx(w)).
    pub fn xyz_as_zyx(c: &mut Captures) {
        for p in &mut c.profiles {
            // R^-1 = Rz(-c) Ry(-b) Rx(-a).
            let (na, nb, nc) = p.base_to_flange.rotation.inverse().euler_angles();
            p.base_to_flange.rotation = UnitQuaternion::from_euler_angles(-na, -nb, -nc);
        }
    }

    /// Profiles from a sensor whose x runs the other way.
    pub fn mirrored(c: &mut Captures) {
        for p in &mut c.profiles {
            match &mut p.data {
                ProfileData::Raw(r) => {
                    r.points.reverse();
                    r.points.iter_mut().flatten().for_each(|q| q.x = -q.x);
                }
                ProfileData::Chord { a, b } => {
                    (a.x, b.x) = (-b.x, -a.x);
                    (a.y, b.y) = (b.y, a.y);
                }
                ProfileData::Circle(k) => k.centre.x = -k.centre.x,
                ProfileData::Arc(ps) => {
                    *ps = ps
                        .iter()
                        .map(|q| nalgebra::Vector2::new(-q.x, q.y))
                        .collect();
                }
                ProfileData::EdgePoint(q) => q.x = -q.x,
            }
        }
    }

    pub fn radius_5(c: &mut Captures) {
        c.specimen_radius = c.specimen_radius.map(|r| r * 1.05);
    }

    pub fn radius_20(c: &mut Captures) {
        c.specimen_radius = c.specimen_radius.map(|r| r * 1.2);
    }

    /// Every pose's orientation 3 deg off about an axis of its own (a fixed, seeded pattern).
    pub fn turned_3deg(c: &mut Captures) {
        for (i, p) in c.profiles.iter_mut().enumerate() {
            let a = i as f64 * 2.399;
            let axis = Vector3::new(a.cos(), a.sin(), (0.7 * a).cos()).normalize();
            let r = Rotation3::from_scaled_axis(axis * 3f64.to_radians());
            p.base_to_flange.rotation =
                UnitQuaternion::from_rotation_matrix(&r) * p.base_to_flange.rotation;
        }
    }
}

/// The gross mistakes of docs/verdict.md on every specimen: each wrong answer (more than 1 deg
/// or 1 mm off) must be flagged (suspect or imprecise) or refused, and a suspect result should
/// name the mistake that was made. `LASERCAL_MISTAKE_TRIALS` sets the trials per case (default
/// 1); `--nocapture` prints the table docs/verdict.md quotes.
#[test]
fn gross_mistakes_are_flagged_and_their_cause_named() {
    use lasercal::method::verdict::decide;
    let n: u64 = std::env::var("LASERCAL_MISTAKE_TRIALS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1);
    let mistakes = mistake::ALL;
    // The disk and the edge from analytic features (the ray-cast comparison rig's, with every
    // variant and refit over raw profiles, cost a minute a case in a debug build; release runs of
    // them are in docs/verdict.md).
    let rigs = [
        ("chen2018-disk", Kind::Disk),
        ("comparison", Kind::Ball),
        ("xu2021-edge", Kind::Edge),
        ("plane-8-poses", Kind::Plane),
    ];
    let (mut wrong, mut flagged, mut refused, mut named, mut suspect) = (0, 0, 0, 0, 0);
    let mut missed = Vec::new();
    println!(
        "| mistake | rig | results | wrong | wrong, flagged | refused | suspect | cause named |"
    );
    for (rig, kind) in rigs {
        let s = setup(rig, &|t| t.to_string());
        for (what, cause, mutate) in &mistakes {
            let started = std::time::Instant::now();
            let mut row = [0usize; 6];
            for t in 0..n {
                let mut caps = trial_captures(&s, kind, 27, t).0.unwrap();
                if caps.specimen_radius.is_none() && what.starts_with("radius") {
                    continue;
                }
                mutate(&mut caps);
                let truth = caps.truth.unwrap();
                row[0] += 1;
                let Ok(d) = decide(&caps, &s.rig.sensor, None) else {
                    row[3] += 1;
                    continue;
                };
                let e = PoseError::between(&d.assessed().calibration.flange_to_sensor, &truth);
                let bad = !(e.rotation_error_deg <= 1.0 && e.translation_error_mm <= 1.0);
                let lines = d.judged.lines().cloned().collect::<Vec<_>>().join(" | ");
                if bad {
                    row[1] += 1;
                    if d.judged.verdict != Verdict::Ok {
                        row[2] += 1;
                    } else {
                        missed.push(format!(
                            "{what}, {rig} {kind} trial {t}: {} {:.3} deg / {:.3} mm off, judged \
                             ok: {lines}",
                            d.method(),
                            e.rotation_error_deg,
                            e.translation_error_mm
                        ));
                    }
                }
                if d.judged.verdict == Verdict::Suspect {
                    row[4] += 1;
                    if !cause.is_empty() && d.judged.reasons[0].contains(cause) {
                        row[5] += 1;
                    } else {
                        println!("  {what}, {rig} {kind} trial {t}: {lines}");
                    }
                }
            }
            println!(
                "| {what} | {rig} {kind} | {} | {} | {} | {} | {} | {} | ({:.1} s)",
                row[0],
                row[1],
                row[2],
                row[3],
                row[4],
                row[5],
                started.elapsed().as_secs_f64()
            );
            wrong += row[1];
            flagged += row[2];
            refused += row[3];
            suspect += row[4];
            named += row[5];
        }
    }
    println!(
        "all: {wrong} wrong answers, {flagged} flagged; {refused} refused; {suspect} suspect, \
         {named} with the cause named"
    );
    assert!(
        wrong > 0,
        "no mistake gave a wrong answer: the cases test nothing"
    );
    // Every mistake but the turned orientations has a correction that undoes it.
    let nameable = suspect - rigs.len() * n as usize;
    assert!(
        named as f64 >= 0.8 * nameable as f64,
        "the cause named in {named} of {nameable} suspect results"
    );
    assert!(
        flagged as f64 >= 0.99 * wrong as f64,
        "{} of {wrong} wrong answers judged ok:\n{}",
        wrong - flagged,
        missed.join("\n")
    );
}

#[test]
fn calibrate_names_mirrored_profiles_and_checks_the_nominal_mounting() {
    let dir = tempfile::tempdir().unwrap();
    // The ball's profiles mirrored in x: ball-any-pose fits them with the frame turned 180 deg
    // about z; the nominal mounting the simulated file states tells it.
    let mirrored = capture_file(dir.path(), "comparison", "ball", |d| {
        assert!(d["nominal_flange_to_sensor_mm"].is_array(), "{d}");
        for p in d["profiles"].as_array_mut().unwrap() {
            if let Some(pts) = p["points_mm"].as_array_mut() {
                pts.reverse();
                for q in pts.iter_mut().filter(|q| q.is_array()) {
                    q[0] = serde_json::json!(-q[0].as_f64().unwrap());
                }
            }
        }
    });
    let (code, out, err) = common::lasercal(&["calibrate", &mirrored]);
    assert_eq!(code, 3, "{out} {err}");
    assert!(out.contains("mirrored in x"), "{out}");
    // A nominal that is no rigid transform: refused, naming the field.
    let bad = capture_file(dir.path(), "comparison", "edge", |d| {
        d["nominal_flange_to_sensor_mm"][0][0] = serde_json::json!(2.0);
    });
    let (code, _, err) = common::lasercal(&["calibrate", &bad]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("nominal_flange_to_sensor_mm") && err.contains("rotation matrix"),
        "{err}"
    );
}

/// Leaving a group out refits the variant's own problem from the full result (a jackknife's
/// warm start): on the disk paper's four scans, three scans re-solved from scratch by the
/// any-pose estimator settled in another minimum 130 deg away and called a right answer
/// suspect. Every group's run must now stay within the bounds, and the chord-end refinement,
/// whose closed form needs all four scans, is tested too.
#[test]
fn leaving_a_group_out_refits_from_the_full_result() {
    use lasercal::method::verdict::decide;
    let s = setup("comparison", &|t| t.to_string());
    let caps = trial_captures(&s, Kind::Disk, 1, 0).0.unwrap();
    let truth = caps.truth.unwrap();
    for estimator in [Estimator::AnyPose, Estimator::Refined] {
        let id = MethodId {
            kind: Kind::Disk,
            estimator,
        };
        let d = decide(&caps, &s.rig.sensor, Some(id)).unwrap();
        let e = PoseError::between(&d.assessed().calibration.flange_to_sensor, &truth);
        assert!(
            e.rotation_error_deg < 0.05 && e.translation_error_mm < 0.1,
            "{id}: {e:?}"
        );
        let loo = d.leave_one_out.as_ref().unwrap();
        assert_eq!((loo.runs, loo.failed), (4, 0), "{id}: {loo:?}");
        assert!(loo.outlier.is_some(), "{id}: no run judged: {loo:?}");
        assert!(
            loo.rotation_deg < 0.1 && loo.translation_mm < 0.1,
            "{id}: one group moves the result too far: {loo:?}"
        );
        assert_eq!(
            d.judged.verdict,
            Verdict::Ok,
            "{id}: {:?}",
            d.judged.reasons
        );
    }
}

/// The edge paper's knife blade: its 1 mm bevel, 0.3 mm deep, is resolved only in part under the
/// sensor's 0.1 mm quantum, so the top face's end lies between the bevel's start and its tip
/// depending on the view: a systematic error no variant's own bound holds (each covered 0 of 20
/// trials, docs/verdict.md). The variants then lie farther apart than their bounds allow, and the
/// chosen result's bound is widened to what the others' bounds imply: its translation is held
/// (20 of 20 trials), its rotation, which the others do not move, not always (5 of 20). Since
/// the orientation groups widen the direction they share (thirty-fifth session) the chosen
/// variant's own translation bound holds 10 of the 20 (trial 0 among them): the test takes the
/// first trial whose own bound misses.
#[test]
fn variants_beyond_each_others_bounds_widen_the_chosen_bound() {
    use lasercal::method::verdict::decide;
    let s = setup("xu2021-rotations", &|t| {
        t.replace("kind = \"parallel-bar\"", "kind = \"knife-blade\"")
    });
    // The first of 20 trials whose chosen variant's own bound misses the translation.
    let mut held = Vec::new();
    let (caps, d, e) = (0..20)
        .find_map(|t| {
            let caps = trial_captures(&s, Kind::Edge, 2021, t).0.unwrap();
            let truth = caps.truth.unwrap();
            let d = decide(&caps, &s.rig.sensor, None).unwrap();
            let a = d.assessed();
            let e = PoseError::between(&a.calibration.flange_to_sensor, &truth);
            let (_, own_t) = a.judged.quality.own_error_bound();
            if e.translation_error_mm <= own_t {
                held.push(t);
                return None;
            }
            eprintln!("trial {t}: {} off {e:?}, own bound {own_t} mm", a.method);
            Some((caps, d, e))
        })
        .unwrap_or_else(|| panic!("every trial's own bound held: {held:?}"));
    eprintln!("own bounds held in trials {held:?}");
    let a = d.assessed();
    let (_, t) = d.judged.quality.error_bound();
    assert!(
        e.translation_error_mm <= t,
        "{}: the widened bound {t} mm misses {e:?}",
        a.method
    );
    let v = d.judged.quality.between_variants.as_ref().unwrap();
    assert_ne!(v.method, a.method);
    assert!(
        d.judged
            .notes
            .iter()
            .any(|n| n.contains("the bound is widened")),
        "{:?}",
        d.judged.notes
    );
    // A variant judged alone has no other to widen it.
    let alone = decide(&caps, &s.rig.sensor, Some(a.method)).unwrap();
    assert!(alone.judged.quality.between_variants.is_none());
    assert_eq!(
        alone.judged.quality.error_bound(),
        a.judged.quality.own_error_bound()
    );
}

/// A simulated rig states its specimen's radius tolerance in the file it writes (read back
/// the same), the bound includes what it moves the result, and a value beyond a tenth of the
/// radius is refused naming the field.
#[test]
fn a_stated_radius_tolerance_is_written_read_and_checked() {
    let s = setup("ball-causes", &|t| t.to_string());
    let caps = trial_captures(&s, Kind::Ball, 3, 0).0.unwrap();
    assert!((caps.judging.radius_tolerance - 0.005e-3).abs() < 1e-12);
    let text = lasercal::io::captures::to_json(&caps, &s.rig.sensor);
    let (back, sensor) = lasercal::io::captures::from_json(&text, "ball.json").unwrap();
    assert!((back.judging.radius_tolerance - caps.judging.radius_tolerance).abs() < 1e-12);
    let method = MethodId {
        kind: Kind::Ball,
        estimator: Estimator::Refined,
    };
    let (cal, refined) = estimate(method, &back, &sensor).unwrap();
    let with = quality(&cal, refined.as_ref(), method.estimator, &back, &sensor);
    let mut exact = back.clone();
    exact.judging.radius_tolerance = 0.0;
    let without = quality(&cal, refined.as_ref(), method.estimator, &exact, &sensor);
    assert!(with.radius_shift.is_some() && without.radius_shift.is_none());
    assert!(with.error_bound().1 > without.error_bound().1);
    let bad = text.replace(
        "\"radius_tolerance_mm\":0.005",
        "\"radius_tolerance_mm\":50.0",
    );
    assert_ne!(bad, text, "the file states the tolerance");
    let e = lasercal::io::captures::from_json(&bad, "ball.json")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("ball.json") && e.contains("specimen.radius_tolerance_mm") && e.contains("50"),
        "{e}"
    );
}

/// A simulated edge rig states its edge's straightness and length in the file it writes (read
/// back the same); with the bow alone moving the result (`edge-causes`' specimen row), the
/// bound without it misses the error and with it holds it; a tolerance beyond 1 mm, or one on
/// a specimen without an edge, is refused naming the field.
#[test]
fn a_stated_straightness_is_written_read_and_in_the_bound() {
    let s = setup("edge-causes", &|t| {
        t.replace("only = \"all\"", "only = \"specimen\"")
            .replace("scale = 1.0", "scale = 4.0")
    });
    let caps = trial_captures(&s, Kind::Edge, 2021, 0).0.unwrap();
    assert!(
        (caps.judging.straightness - 0.04e-3).abs() < 1e-12,
        "{:?}",
        caps.judging
    );
    assert!(caps.judging.edge_length.is_some_and(|l| l > 0.05));
    let text = lasercal::io::captures::to_json(&caps, &s.rig.sensor);
    let (back, sensor) = lasercal::io::captures::from_json(&text, "edge.json").unwrap();
    assert_eq!(back.judging.straightness, caps.judging.straightness);
    assert_eq!(back.judging.edge_length, caps.judging.edge_length);
    let truth = caps.truth.unwrap();
    for estimator in [Estimator::ClosedForm, Estimator::Refined] {
        let method = MethodId {
            kind: Kind::Edge,
            estimator,
        };
        let (cal, refined) = estimate(method, &back, &sensor).unwrap();
        let e = PoseError::between(&cal.flange_to_sensor, &truth);
        let with = quality(&cal, refined.as_ref(), estimator, &back, &sensor);
        let mut straight = back.clone();
        straight.judging.straightness = 0.0;
        let without = quality(&cal, refined.as_ref(), estimator, &straight, &sensor);
        assert!(with.bow_shift.is_some() && without.bow_shift.is_none());
        let (b, n) = (with.error_bound(), without.error_bound());
        assert!(
            e.rotation_error_deg <= b.0 && e.translation_error_mm <= b.1,
            "{estimator:?}: {e:?} beyond {b:?}"
        );
        assert!(
            !(e.rotation_error_deg <= n.0 && e.translation_error_mm <= n.1),
            "{estimator:?}: {e:?} within {n:?} without the bow"
        );
    }
    let bad = text.replace("\"straightness_mm\":0.04", "\"straightness_mm\":5.0");
    assert_ne!(bad, text, "the file states the straightness");
    let e = lasercal::io::captures::from_json(&bad, "edge.json")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("edge.json") && e.contains("specimen.straightness_mm") && e.contains('5'),
        "{e}"
    );
    let ball = setup("ball-causes", &|t| t.to_string());
    let ball_caps = trial_captures(&ball, Kind::Ball, 3, 0).0.unwrap();
    let text = lasercal::io::captures::to_json(&ball_caps, &ball.rig.sensor).replace(
        "\"radius_tolerance_mm\":0.005",
        "\"radius_tolerance_mm\":0.005,\"straightness_mm\":0.01",
    );
    let e = lasercal::io::captures::from_json(&text, "ball.json")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("specimen.straightness_mm") && e.contains("none"),
        "{e}"
    );
}

/// A disk scan whose last profile carries the next scan's pose (poses and profiles paired one
/// record apart): the closed form refuses it naming that capture and its turn, not a scan
/// direction the disk cannot have. (On raw profiles, where `disk-any-pose` runs and is
/// suspect, the verdict names the pairing: `independent::gross_mistakes_...`.)
#[test]
fn a_disk_scan_paired_one_record_apart_is_named() {
    let s = setup("chen2018-disk", &|t| t.to_string());
    let mut caps = trial_captures(&s, Kind::Disk, 27, 0).0.unwrap();
    let last_of_first = caps.profiles.iter().filter(|p| p.group == 0).count() - 1;
    mistake::pairing(&mut caps);
    let err = estimate(
        MethodId::new(Kind::Disk, Estimator::ClosedForm),
        &caps,
        &s.rig.sensor,
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains(&format!("scan 0: capture {last_of_first} is"))
            && err.contains("from the scan's mean orientation")
            && err.contains("pairing"),
        "{err}"
    );
}

/// The disk paper's four scans on an arm with link-length and joint-zero errors (docs/verdict.md,
/// "The disk's four scans with an uncalibrated arm"): where the file states the arm's kinematic
/// error the bound carries it and a note says how much; where it states only an accuracy, the
/// rotation's bound cannot hold what each scan shares, and a note says so; not where the
/// robot's accuracy is stated as 0, nor for poses of many orientations (the 16 free ball poses
/// of `verdict-coverage`).
#[test]
fn a_few_scans_with_robot_error_carry_the_arms_kinematic_error_or_are_told_of_it() {
    let dir = tempfile::tempdir().unwrap();
    let note = "scans, each at one flange orientation";
    let run = |scenario: &str, method: &str, extra: &[&str]| {
        let (caps, _) = common::simulated_capture(dir.path(), scenario, "caps.json");
        let mut args = vec!["calibrate", caps.to_str().unwrap(), "--method", method];
        args.extend_from_slice(extra);
        let (code, out, err) = common::lasercal(&args);
        assert!([0, 3, 4].contains(&code), "{scenario}: {err}");
        out
    };
    // The simulated rig states its arm and kinematic error: the bound carries them, a note
    // says how much, and the scans need no warning.
    let kinematic = "the arm's stated kinematic error (robots/irb120_3_58.urdf";
    let out = run("disk-kinematic-error.toml", "disk-refined", &[]);
    assert!(out.contains(kinematic) && !out.contains(note), "{out}");
    // The same file stating the arm's kinematic error as 0 (a calibrated arm): the stated
    // accuracy alone, whose rotation bound misses what the scans share, and the note says so.
    let none = ["--link-error-mm", "0", "--joint-offset-error-deg", "0"];
    let out = run("disk-kinematic-error.toml", "disk-refined", &none);
    assert!(
        out.contains(&format!("the poses are 4 {note}"))
            && out.contains("rotation's bound")
            && !out.contains(kinematic),
        "{out}"
    );
    // The file naming the arm without its kinematic error: an uncalibrated arm's of the stated
    // accuracy is assumed and carried, and the note says so.
    let (caps, doc) = common::simulated_capture(dir.path(), "disk-kinematic-error.toml", "k.json");
    let mut named = doc.clone();
    for f in ["link_error_mm", "joint_offset_error_deg"] {
        named.as_object_mut().unwrap().remove(f).unwrap();
    }
    std::fs::write(&caps, named.to_string()).unwrap();
    let json = dir.path().join("named.json");
    let (code, out, err, result) = common::calibrate_json(&caps, &json);
    assert!([0, 3, 4].contains(&code), "{err}");
    assert!(
        out.contains("no kinematic error is stated for robots/irb120_3_58.urdf")
            && out.contains("an uncalibrated arm's of the stated accuracy")
            && !out.contains("rotation's bound does not hold it"),
        "{out}"
    );
    let k = &result["quality"]["kinematic"];
    assert_eq!(k["assumed"], true, "{k}");
    assert!(k["sd_deg"].as_f64().unwrap() > 0.0, "{k}");
    // Stating no robot error at all: nothing to warn of.
    let out = run(
        "disk-kinematic-error.toml",
        "disk-refined",
        &[&none[..], &["--robot-accuracy-mm", "0"]].concat(),
    );
    assert!(!out.contains(note), "{out}");
    let out = run("verdict-coverage.toml", "ball-any-pose", &[]);
    assert!(!out.contains(note), "{out}");
    // A file without joints: the arm's other configurations are weighed too (the plane's 48
    // poses: within 1.25 times the assumed ones, so no note asks for the joints).
    let (caps, _) = common::simulated_capture(dir.path(), "plane-48-circle.toml", "plane.json");
    let json = dir.path().join("plane-result.json");
    let (code, out, err, doc) = common::calibrate_json(&caps, &json);
    assert!([0, 3, 4].contains(&code), "{err}");
    assert!(
        out.contains(kinematic) && !out.contains("joints_deg"),
        "{out}"
    );
    let k = &doc["quality"]["kinematic"];
    let (deg, mm) = (
        &k["other_configurations_sd_deg"],
        &k["other_configurations_sd_mm"],
    );
    assert!(
        deg.as_f64().unwrap() > 0.0 && mm.as_f64().unwrap() > 0.0,
        "{k}"
    );
}

/// An arm named alone on poses that are no few scans (the plane's 48 poses on a circle): the
/// bound carries an uncalibrated arm's error of the stated accuracy, not the accuracy as an
/// error common to every pose (docs/verdict.md, "Forty-second session"). The simulated arm's
/// errors are in the assumed ratio and the file's accuracy is their point sd, so the split the
/// poses' steps show is near the assumed one and the bounds within 5 % of the stated ones;
/// stated as 0 (a calibrated arm), the accuracy alone, wider here.
#[test]
fn an_arm_named_alone_carries_an_uncalibrated_arms_error_on_any_pose_set() {
    let dir = tempfile::tempdir().unwrap();
    let (caps, doc) = common::simulated_capture(dir.path(), "plane-48-circle.toml", "p.json");
    let bound = |file: &std::path::Path, name: &str| {
        let json = dir.path().join(name);
        let (code, out, err, result) = common::calibrate_json(file, &json);
        assert!([0, 3, 4].contains(&code), "{err}");
        let q = &result["quality"];
        let b = (
            q["error_bound_deg"].as_f64().unwrap(),
            q["error_bound_mm"].as_f64().unwrap(),
        );
        (b, out, q["kinematic"].clone())
    };
    let (stated, ..) = bound(&caps, "stated.json");
    let named_path = dir.path().join("named.json");
    let mut named = doc.clone();
    for f in ["link_error_mm", "joint_offset_error_deg"] {
        named.as_object_mut().unwrap().remove(f).unwrap();
    }
    std::fs::write(&named_path, named.to_string()).unwrap();
    let (assumed, out, k) = bound(&named_path, "named.json");
    assert!(
        out.contains("no kinematic error is stated for robots/irb120_3_58.urdf, so the arm's")
            && !out.contains("a few scans"),
        "{out}"
    );
    assert_eq!(k["assumed"], true, "{k}");
    // The split the steps show is near the assumed one, and the bounds near the stated ones.
    let share = k["link_share_read"].as_f64().unwrap();
    let share_sd = k["link_share_read_sd"].as_f64().unwrap();
    let assumed_share =
        lasercal::captures::assumed_link_share(&lasercal::robot::Robot::resolve("irb120").unwrap());
    assert!(
        (share - assumed_share).abs() < 2.0 * share_sd && share_sd < 0.3,
        "{share} ± {share_sd} against {assumed_share}"
    );
    assert!(
        out.contains("split between them as the poses' steps show"),
        "{out}"
    );
    let close = |a: f64, b: f64| (a - b).abs() <= 0.05 * b;
    assert!(
        close(assumed.0, stated.0) && close(assumed.1, stated.1),
        "assumed {assumed:?} against stated {stated:?}"
    );
    let calibrated_path = dir.path().join("calibrated.json");
    let mut calibrated = named.clone();
    calibrated["link_error_mm"] = 0.0.into();
    calibrated["joint_offset_error_deg"] = 0.0.into();
    std::fs::write(&calibrated_path, calibrated.to_string()).unwrap();
    let (alone, out, k) = bound(&calibrated_path, "calibrated.json");
    assert!(k.is_null() && !out.contains("no kinematic error"), "{out}");
    assert!(
        alone.1 > assumed.1,
        "accuracy alone {alone:?}, assumed {assumed:?}"
    );
}

/// Where the arm's kinematic error the bound carries makes most of an imprecise bound, the
/// reason names it (more poses of the same arm do not average it away) rather than the robot's
/// accuracy or the scatter between poses, and the widening printed is the scatter's beyond the
/// arm's patterns (which make the poses of one orientation move alike): the edge paper's 25 x
/// 10 poses on an IRB 2600 whose joint origins are off by 0.2 mm and zeros by 0.02 deg
/// (`edge-causes` with the kinematic error alone at 4 times), 0.2 mm asked for. Stated as none,
/// the reason does not name it.
#[test]
fn an_imprecise_bound_the_arms_kinematic_error_makes_names_it() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(common::scen("edge-causes.toml")).unwrap();
    let text = text
        .replace("only = \"all\"", "only = \"kinematic\"")
        .replace("scale = 1.0", "scale = 4.0");
    let (caps, _) = common::simulated_from_text(dir.path(), &text, "caps.json");
    let json = dir.path().join("result.json");
    let calibrate = |extra: &[&str]| {
        let mut args = vec![
            "calibrate",
            caps.to_str().unwrap(),
            "--method",
            "edge-refined",
            "--tolerance-mm",
            "0.2",
            "--json",
            json.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let (code, out, err) = common::lasercal(&args);
        let doc: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        (code, out, err, doc)
    };
    let named = "most of it is the arm's kinematic error (robots/irb2600_12_165.urdf: joint \
                 origins 0.200 mm per axis";
    let (code, out, err, doc) = calibrate(&[]);
    assert_eq!(code, 4, "{out}{err}");
    assert!(
        out.contains(named)
            && out.contains("do not average it away")
            && !out.contains("the robot's stated accuracy")
            && !out.contains("shared by poses of one orientation"),
        "{out}"
    );
    // The poses' scatter beyond the arm's patterns is near the noise's; the patterns alone
    // had read as 3.7 times it, 3.15 of that shared by the orientations' poses.
    let inflation = doc["quality"]["inflation"].as_f64().unwrap();
    assert!((1.0..1.5).contains(&inflation), "{inflation}");
    // The same captures with the arm's error stated as none: no kinematic reason.
    let (code, out, err, _) = calibrate(&["--link-error-mm", "0", "--joint-offset-error-deg", "0"]);
    assert!([0, 3, 4].contains(&code), "{err}");
    assert!(!out.contains(named), "{out}");
}

/// The arm and its kinematic error in a capture file: written by `simulate`, read back, and
/// every bad statement refused with the field, the value and the fix (a file whose poses the
/// named arm cannot reach, an error without an arm, an unknown arm, errors out of range).
#[test]
fn the_arms_kinematic_error_is_read_checked_and_refused_when_wrong() {
    let dir = tempfile::tempdir().unwrap();
    let (caps, doc) = common::simulated_capture(dir.path(), "disk-kinematic-error.toml", "k.json");
    assert_eq!(doc["robot"], "robots/irb120_3_58.urdf");
    assert_eq!(doc["link_error_mm"], 0.1);
    assert_eq!(doc["joint_offset_error_deg"], 0.01);
    let edited = |f: &dyn Fn(&mut serde_json::Value)| {
        let mut d = doc.clone();
        f(&mut d);
        let p = dir.path().join("edited.json");
        std::fs::write(&p, d.to_string()).unwrap();
        let (code, _, err) = common::lasercal(&["calibrate", p.to_str().unwrap()]);
        (code, err)
    };
    let refused = |f: &dyn Fn(&mut serde_json::Value), want: &[&str]| {
        let (code, err) = edited(f);
        assert_eq!(code, 2, "{err}");
        for w in want {
            assert!(err.contains(w), "{w}: {err}");
        }
    };
    refused(
        &|d| {
            d.as_object_mut()
                .unwrap()
                .remove("robot")
                .map(|_| ())
                .unwrap()
        },
        &["robot: missing", "irb120, irb2600 or a URDF"],
    );
    refused(
        &|d| d["robot"] = "irb2600".into(),
        &["profiles[0]", "out of reach of irb2600"],
    );
    refused(
        &|d| d["robot"] = "ur5".into(),
        &["robot:", "unknown robot 'ur5'"],
    );
    refused(
        &|d| d["link_error_mm"] = 11.0.into(),
        &["link_error_mm: 11", "from 0 to 10"],
    );
    refused(
        &|d| d["joint_offset_error_deg"] = (-0.1).into(),
        &["joint_offset_error_deg: -0.1", "from 0 to 1"],
    );
    // The arm named alone: its reach checked, nothing added to the bound.
    let (code, err) = edited(&|d| {
        let o = d.as_object_mut().unwrap();
        o.remove("link_error_mm");
        o.remove("joint_offset_error_deg");
    });
    assert!([0, 3, 4].contains(&code), "{err}");
    // The flags say theirs.
    let (code, _, err) = common::lasercal(&[
        "calibrate",
        caps.to_str().unwrap(),
        "--joint-offset-error-deg",
        "2",
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("--joint-offset-error-deg: 2"), "{err}");
}

/// A robot's repeatability (each pose's own error) beside its accuracy (common to the poses):
/// read from the file and the flag, reported in the JSON, and judged as each pose's own. On 8
/// plane poses (too few to measure their scatter in every direction) a stated repeatability
/// raises the bound above the noise's alone, and less than the same figure stated as an
/// accuracy, which adds a common error on top; a bad value is refused with the field.
#[test]
fn a_stated_repeatability_is_read_checked_and_taken_as_each_poses_own() {
    let dir = tempfile::tempdir().unwrap();
    let (caps, doc) = common::simulated_capture(dir.path(), "plane-8-poses.toml", "p.json");
    let caps = caps.to_str().unwrap();
    let bounds = |file: &str, extra: &[&str]| {
        let json = dir.path().join("out.json");
        let mut args = vec!["calibrate", file, "--method", "plane-any-pose", "--json"];
        args.push(json.to_str().unwrap());
        args.extend_from_slice(extra);
        let (code, _, err) = common::lasercal(&args);
        assert!([0, 4].contains(&code), "{extra:?}: {err}");
        let q: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let q = &q["quality"];
        let b = |k: &str| q[k].as_f64().unwrap_or_else(|| panic!("{k}: {q}"));
        (
            b("error_bound_deg"),
            b("error_bound_mm"),
            b("robot_repeatability_mm"),
        )
    };
    let noise = bounds(caps, &["--robot-accuracy-mm", "0"]);
    let own = bounds(
        caps,
        &[
            "--robot-accuracy-mm",
            "0",
            "--robot-repeatability-mm",
            "0.3",
        ],
    );
    let common = bounds(caps, &["--robot-accuracy-mm", "0.3"]);
    assert_eq!((noise.2, own.2), (0.0, 0.3));
    assert!(
        own.0 > 1.5 * noise.0 && own.1 > 1.5 * noise.1,
        "{noise:?} {own:?}"
    );
    assert!(own.0 < common.0 && own.1 < common.1, "{own:?} {common:?}");
    // The file's field reads as the flag does.
    let mut d = doc.clone();
    d["robot_accuracy_mm"] = serde_json::json!(0.0);
    d["robot_repeatability_mm"] = serde_json::json!(0.3);
    let edited = dir.path().join("edited.json");
    std::fs::write(&edited, d.to_string()).unwrap();
    assert_eq!(bounds(edited.to_str().unwrap(), &[]), own);
    d["robot_repeatability_mm"] = serde_json::json!(-0.3);
    std::fs::write(&edited, d.to_string()).unwrap();
    let (code, _, err) = common::lasercal(&["calibrate", edited.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("robot_repeatability_mm") && err.contains("-0.3") && err.contains("RP"),
        "{err}"
    );
    let (code, _, err) = common::lasercal(&["calibrate", caps, "--robot-repeatability-mm", "NaN"]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("--robot-repeatability-mm") && err.contains("NaN"),
        "{err}"
    );
}

/// `verdict::noise_response`, the closed form's covariance under the stated noise that a closed
/// form's bound under per-pose error puts in the offset's variance, is what the closed form does
/// under that noise: the ball paper's eight poses (analytic arcs), its 16 small seeded draws
/// against 400 draws of the whole noise added to the arcs' depths. Its trace per block within
/// 0.6-1.6 of the Monte Carlo's (16 rank-one terms: about +-20 % on a trace; a scale error in the
/// draws, such as the hundredth not scaled back, is 100 times off).
#[test]
fn the_noise_response_is_the_closed_forms_covariance_under_the_noise() {
    use lasercal::captures::ProfileData;
    use lasercal::method::verdict::{noise_response, step_between};
    use nalgebra::{Matrix6, Vector2};
    let s = setup("chen2018-ball", &|t| t.to_string());
    let caps = trial_captures(&s, Kind::Ball, 11, 0).0.unwrap();
    assert!(
        caps.profiles
            .iter()
            .all(|p| matches!(p.data, ProfileData::Arc(_))),
        "the scenario's arcs"
    );
    let id = MethodId::new(Kind::Ball, Estimator::ClosedForm);
    let sensor = &s.rig.sensor;
    let (cal, _) = estimate(id, &caps, sensor).unwrap();
    let sd = 0.1e-3;
    let v = noise_response(&cal, Estimator::ClosedForm, &caps, sensor, sd).unwrap();
    let mut g = lasercal::testkit::rng(51);
    let n = 400;
    let mut emp = Matrix6::zeros();
    for _ in 0..n {
        let mut moved = caps.clone();
        for p in &mut moved.profiles {
            if let ProfileData::Arc(points) = &mut p.data {
                let shifted: Vec<Vector2<f64>> = points
                    .iter()
                    .map(|q| q + Vector2::new(0.0, sd * lasercal::rng::gauss(&mut g)))
                    .collect();
                *points = shifted.into();
            }
        }
        let (run, _) = estimate(id, &moved, sensor).unwrap();
        let w = step_between(&cal.flange_to_sensor, &run.flange_to_sensor);
        emp += w * w.transpose() / n as f64;
    }
    for (block, name) in [(0, "rotation"), (3, "translation")] {
        let trace = |m: &Matrix6<f64>| m.fixed_view::<3, 3>(block, block).trace();
        let ratio = trace(&v) / trace(&emp);
        eprintln!("{name}: noise_response / Monte Carlo trace {ratio:.3}");
        assert!((0.6..=1.6).contains(&ratio), "{name}: {ratio}");
    }
}
