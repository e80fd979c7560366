//! Fuzzing the parsers (issue 15, item 5): seeded mutations of valid inputs (byte flips, deleted
//! and duplicated lines, extreme numbers, NaN, huge arrays, deep nesting) for the scenario, capture,
//! URDF and CSV parsers. Each input must give a result or an error: no panic, no hang, no NaN in a
//! successful output. `LASERCAL_FUZZ_INPUTS` sets the inputs per parser (default 10,000).

use lasercal::rng::Rng;
use rand::RngExt;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::mpsc;
use std::time::Duration;

fn inputs() -> usize {
    std::env::var("LASERCAL_FUZZ_INPUTS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10_000)
}

/// Numbers a mutation puts in place of a number.
const EXTREME: &[&str] = &[
    "nan",
    "NaN",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e-320",
    "5e-324",
    "0",
    "-0",
    "-1",
    "1e9",
    "4294967296",
    "18446744073709551616",
    "-9223372036854775809",
    "1e400",
    "0.0",
    "99999999999999999999999",
    "1",
    "2",
    "3",
];

/// One seeded mutation of `text`.
fn mutate(text: &str, r: &mut Rng) -> String {
    let mut b = text.as_bytes().to_vec();
    let rounds = 1 + r.random_range(0..3);
    for _ in 0..rounds {
        match r.random_range(0..8) {
            // Flip a byte.
            0 if !b.is_empty() => {
                let i = r.random_range(0..b.len());
                b[i] ^= 1 << r.random_range(0..8);
            }
            // Delete a line.
            1 => {
                let s = String::from_utf8_lossy(&b).into_owned();
                let mut lines: Vec<&str> = s.lines().collect();
                if !lines.is_empty() {
                    lines.remove(r.random_range(0..lines.len()));
                }
                b = lines.join("\n").into_bytes();
            }
            // Duplicate a line.
            2 => {
                let s = String::from_utf8_lossy(&b).into_owned();
                let mut lines: Vec<&str> = s.lines().collect();
                if !lines.is_empty() {
                    let i = r.random_range(0..lines.len());
                    let l = lines[i];
                    lines.insert(i, l);
                }
                b = lines.join("\n").into_bytes();
            }
            // Replace a number by an extreme one.
            3 | 4 => {
                let s = String::from_utf8_lossy(&b).into_owned();
                let starts: Vec<usize> = s
                    .char_indices()
                    .filter(|(i, c)| {
                        c.is_ascii_digit()
                            && (*i == 0 || !s.as_bytes()[i - 1].is_ascii_alphanumeric())
                    })
                    .map(|(i, _)| i)
                    .collect();
                if !starts.is_empty() {
                    let i = starts[r.random_range(0..starts.len())];
                    let end = s[i..]
                        .find(|c: char| !(c.is_ascii_digit() || matches!(c, '.' | 'e' | '-')))
                        .map_or(s.len(), |k| i + k);
                    let x = EXTREME[r.random_range(0..EXTREME.len())];
                    b = format!("{}{x}{}", &s[..i], &s[end..]).into_bytes();
                }
            }
            // A huge array where an array starts.
            5 => {
                let s = String::from_utf8_lossy(&b).into_owned();
                if let Some(i) = s.find('[').filter(|_| r.random_bool(0.5)) {
                    let many = "1, ".repeat(20_000);
                    b = format!("{}[{many}{}", &s[..i], &s[i + 1..]).into_bytes();
                }
            }
            // Deep nesting.
            6 => {
                let s = String::from_utf8_lossy(&b).into_owned();
                let i = r.random_range(0..=s.len());
                let i = (0..=i).rev().find(|&k| s.is_char_boundary(k)).unwrap_or(0);
                let (open, close) = match r.random_range(0..3) {
                    0 => ("[".repeat(5000), "]".repeat(5000)),
                    1 => ("{\"a\":".repeat(5000), "}".repeat(5000)),
                    _ => ("<a>".repeat(5000), "</a>".repeat(5000)),
                };
                b = format!("{}{open}{close}{}", &s[..i], &s[i..]).into_bytes();
            }
            // Truncate.
            _ => {
                if !b.is_empty() {
                    let n = r.random_range(0..b.len());
                    b.truncate(n);
                }
            }
        }
    }
    String::from_utf8_lossy(&b).into_owned()
}

/// Feed `n` mutations of `seed_text` to `parse` (which returns whether a successful output was
/// free of NaN) on a watchdog thread: no panic, no NaN, each input done within `per_input`.
fn fuzz(
    name: &'static str,
    seed_text: String,
    seed: u64,
    parse: fn(&str) -> Option<bool>,
) -> (usize, usize) {
    let n = inputs();
    let (tx, rx) = mpsc::channel::<Result<(usize, usize), String>>();
    let (beat_tx, beat_rx) = mpsc::channel::<usize>();
    std::thread::spawn(move || {
        let mut r = lasercal::rng::stream(seed, &[15]);
        let (mut ok, mut refused) = (0, 0);
        // The unmutated input parses.
        assert_eq!(
            parse(&seed_text),
            Some(true),
            "{name}: the seed input must parse"
        );
        for i in 0..n {
            let input = mutate(&seed_text, &mut r);
            let _ = beat_tx.send(i);
            match catch_unwind(AssertUnwindSafe(|| parse(&input))) {
                Err(_) => {
                    let _ = tx.send(Err(format!(
                        "{name}: input {i} panicked:\n{}",
                        &input[..input.len().min(2000)]
                    )));
                    return;
                }
                Ok(Some(true)) => ok += 1,
                Ok(Some(false)) => {
                    let _ = tx.send(Err(format!(
                        "{name}: input {i} parsed with a NaN or infinity in the result:\n{}",
                        &input[..input.len().min(2000)]
                    )));
                    return;
                }
                Ok(None) => refused += 1,
            }
        }
        let _ = tx.send(Ok((ok, refused)));
    });
    // A hang: no progress for 20 s.
    let mut last = 0;
    loop {
        match rx.recv_timeout(Duration::from_millis(200)) {
            Ok(Ok(counts)) => return counts,
            Ok(Err(msg)) => panic!("{msg}"),
            Err(mpsc::RecvTimeoutError::Disconnected) => panic!("{name}: the fuzz thread died"),
            Err(mpsc::RecvTimeoutError::Timeout) => {
                let mut moved = false;
                while let Ok(i) = beat_rx.try_recv() {
                    last = i;
                    moved = true;
                }
                if !moved {
                    match beat_rx.recv_timeout(Duration::from_secs(20)) {
                        Ok(i) => last = i,
                        Err(_) => {
                            // The result may have arrived meanwhile.
                            if let Ok(Ok(c)) = rx.try_recv() {
                                return c;
                            }
                            panic!("{name}: input {last} hangs (no progress for 20 s)");
                        }
                    }
                }
            }
        }
    }
}

fn finite(vs: impl IntoIterator<Item = f64>) -> bool {
    vs.into_iter().all(f64::is_finite)
}

fn scenario_parse(text: &str) -> Option<bool> {
    let sf = lasercal::scenario::ScenarioFile::parse(text, "fuzz.toml").ok()?;
    fn walk(v: &toml::Value) -> bool {
        match v {
            toml::Value::Float(f) => f.is_finite(),
            toml::Value::Table(t) => t.values().all(walk),
            toml::Value::Array(a) => a.iter().all(walk),
            _ => true,
        }
    }
    Some(sf.raw.values().all(walk))
}

fn capture_parse(text: &str) -> Option<bool> {
    let (c, s) = lasercal::io::captures::from_json(text, "fuzz.json").ok()?;
    let poses = c.profiles.iter().all(|p| {
        finite(p.base_to_flange.translation.vector.iter().copied())
            && finite(p.base_to_flange.rotation.coords.iter().copied())
    });
    let points = c.profiles.iter().all(|p| match &p.data {
        lasercal::captures::ProfileData::Raw(prof) => prof
            .points
            .iter()
            .flatten()
            .all(|q| q.x.is_finite() && q.z.is_finite()),
        lasercal::captures::ProfileData::Chord { a, b } => {
            finite(a.iter().chain(b.iter()).copied())
        }
        lasercal::captures::ProfileData::Arc(v) => v.iter().all(|q| finite(q.iter().copied())),
        lasercal::captures::ProfileData::EdgePoint(q) => finite(q.iter().copied()),
        lasercal::captures::ProfileData::Circle(c) => {
            c.radius.is_finite() && finite(c.centre.iter().copied())
        }
    });
    Some(
        poses
            && points
            && c.specimen_radius.is_none_or(f64::is_finite)
            && s.depth_far.is_finite()
            && s.noise.z_sigma_far.is_finite(),
    )
}

fn urdf_parse(text: &str) -> Option<bool> {
    let r = lasercal::robot::Robot::from_urdf_str(text, "fuzz.urdf").ok()?;
    let (lo, hi) = (r.lower(), r.upper());
    let mid: [f64; 6] = std::array::from_fn(|i| (lo[i] + hi[i]) / 2.0);
    let tool0 = r.fk(&mid);
    Some(
        finite(tool0.translation.vector.iter().copied())
            && finite(tool0.rotation.coords.iter().copied())
            && finite(r.lower().iter().copied())
            && finite(r.upper().iter().copied())
            && finite(r.max_speed().iter().copied()),
    )
}

fn pose_csv_parse(text: &str) -> Option<bool> {
    let (_, rows) = lasercal::io::csv::pose_list(text.as_bytes(), "fuzz.csv").ok()?;
    Some(rows.iter().all(|r| finite(r.iter().copied())))
}

fn read(path: &str) -> String {
    std::fs::read_to_string(format!("{}/{path}", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

#[test]
fn fuzz_scenario_parser() {
    let (ok, refused) = fuzz(
        "scenario",
        read("scenarios/comparison.toml"),
        1,
        scenario_parse,
    );
    println!("scenario: {ok} parsed, {refused} refused");
}

#[test]
fn fuzz_capture_parser() {
    // A small capture file: the edge paper's analytic edge points.
    let text = read("scenarios/xu2021-edge.toml");
    let sf = lasercal::scenario::ScenarioFile::parse(&text, "xu2021-edge.toml").unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    let caps = lasercal::trial::trial_captures(&setup, lasercal::method::Kind::Edge, 1, 0)
        .0
        .unwrap();
    let json = lasercal::io::captures::to_json(&caps, &setup.rig.sensor);
    let (ok, refused) = fuzz("capture", json, 2, capture_parse);
    println!("capture: {ok} parsed, {refused} refused");
}

#[test]
fn fuzz_urdf_parser() {
    let (ok, refused) = fuzz("urdf", read("robots/irb120_3_58.urdf"), 3, urdf_parse);
    println!("urdf: {ok} parsed, {refused} refused");
}

#[test]
fn fuzz_pose_csv_parser() {
    let mut csv = String::from("x_mm,y_mm,z_mm,qw,qx,qy,qz\n");
    for i in 0..12 {
        let a = i as f64 * 0.2;
        csv += &format!(
            "{},{},{},{},{},{},0\n",
            300.0 + i as f64,
            -20.0 * a,
            400.0,
            (a / 2.0).cos(),
            (a / 2.0).sin(),
            0.0
        );
    }
    let (ok, refused) = fuzz("pose csv", csv, 4, pose_csv_parse);
    println!("pose csv: {ok} parsed, {refused} refused");
}

fn pose_file_parse(text: &str) -> Option<bool> {
    let format = lasercal::io::poses::detect(text)?;
    let list = lasercal::io::poses::read(text, "fuzz.ls", format).ok()?;
    Some(list.rows.iter().all(|r| finite(r.iter().copied())))
}

fn profile_file_parse(text: &str) -> Option<bool> {
    let a = lasercal::io::poses::opencv_profile(text, "fuzz.yml").ok();
    let b = lasercal::io::poses::two_row_profile(text, "fuzz.txt").ok();
    if a.is_none() && b.is_none() {
        return None;
    }
    let all = a.into_iter().chain(b).flatten().flatten().flatten();
    Some(finite(all))
}

/// The controllers' own pose files (a FANUC `.ls` program, RAPID robtargets, a JSON list) and the
/// profilers' own profile files (OpenCV YAML, two-row text).
#[test]
fn fuzz_pose_and_profile_files() {
    let mut ls = String::from("/PROG  CALIB\n/MN\n   1:L P[1] 100mm/sec FINE ;\n/POS\n");
    let mut rapid = String::from("MODULE M\n");
    let mut json = Vec::new();
    for i in 0..6 {
        let x = 300.0 + 10.0 * i as f64;
        ls += &format!(
            "P[{}]{{\n   GP1:\n\tUF : 0, UT : 1,\t\tCONFIG : 'N U T, 0, 0, 0',\n\tX = {x} mm,\t\
             Y = -20.0 mm,\tZ = 400.0 mm,\n\tW = 180.0 deg,\tP = {} deg,\tR = 0.0 deg\n}};\n",
            i + 1,
            i as f64
        );
        rapid +=
            &format!("  CONST robtarget p{i}:=[[{x},-20,400],[0,1,0,0],[0,0,0,0],[9E9,9E9]];\n");
        json.push(vec![x, -20.0, 400.0, 180.0, i as f64, 0.0]);
    }
    ls += "/END\n";
    rapid += "ENDMODULE\n";
    for (i, text) in [ls, rapid, serde_json::to_string(&json).unwrap()]
        .into_iter()
        .enumerate()
    {
        let (ok, refused) = fuzz("pose file", text, 5 + i as u64, pose_file_parse);
        println!("pose file {i}: {ok} parsed, {refused} refused");
    }
    let pts: Vec<String> = (0..40)
        .map(|i| format!("{}, 0., {}", i as f64 * 0.1, 300.0 + (i as f64 * 0.3).sin()))
        .collect();
    let yml = format!(
        "%YAML:1.0\n---\nfeature: !!opencv-matrix\n   rows: 1\n   cols: 3\n   dt: d\n   data: [ 1., \
         0., 2. ]\nprofile: !!opencv-matrix\n   rows: 40\n   cols: 3\n   dt: d\n   data: [ {} ]\n",
        pts.join(",\n       ")
    );
    let (ok, refused) = fuzz("opencv yaml", yml, 8, profile_file_parse);
    println!("opencv yaml: {ok} parsed, {refused} refused");
    let two = "0.1 0.2 0.3 0.4\n300.1 300.2 0 300.4\n".to_string();
    let (ok, refused) = fuzz("two-row", two, 9, profile_file_parse);
    println!("two-row: {ok} parsed, {refused} refused");
}
