//! Sweeps: determinism, the reduced Fig. 15 slopes, the ray-cast disk path, the CLI end to end.

use crate::common;
use common::lasercal;

use lasercal::scenario::ScenarioFile;
use lasercal::sweep::{self, Shard, SweepPlan, TrialRow};
use lasercal::trial::run_trial;

fn base() -> String {
    std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/chen2018-disk.toml"
    ))
    .unwrap()
}

fn run_sweep(text: &str, trials: usize) -> (Vec<TrialRow>, Vec<sweep::SummaryRow>) {
    let sf = ScenarioFile::parse(text, "reduced.toml").unwrap();
    let plan = SweepPlan::new(&sf, Some(trials), None);
    let mut rows = Vec::new();
    let summary = sweep::run(
        &plan,
        &sf.file,
        Shard::ALL,
        |r| {
            rows.extend_from_slice(r);
            Ok(())
        },
        &|_| {},
    )
    .unwrap();
    (rows, summary)
}

fn slope(xs: &[f64], ys: &[f64]) -> f64 {
    let lx: Vec<f64> = xs.iter().map(|x| x.ln()).collect();
    let ly: Vec<f64> = ys.iter().map(|y| y.ln()).collect();
    let (mx, my) = (
        lx.iter().sum::<f64>() / lx.len() as f64,
        ly.iter().sum::<f64>() / ly.len() as f64,
    );
    let num: f64 = lx.iter().zip(&ly).map(|(a, b)| (a - mx) * (b - my)).sum();
    let den: f64 = lx.iter().map(|a| (a - mx).powi(2)).sum();
    num / den
}

#[test]
fn reduced_fig15_sweep_slopes() {
    let sigmas = [0.1, 0.2, 0.4, 0.8];
    let ms = [10, 20, 40, 80, 160];
    let text = format!(
        "{}\n[sweep]\ntrials = 300\n[sweep.grid]\n\"disk.sigma_mm\" = {:?}\n\"disk.chords\" = {:?}\n",
        base(),
        sigmas,
        ms
    );
    let (_, summary) = run_sweep(&text, 300);
    let e = |si: usize, mi: usize| {
        lasercal::io::csv::summary_value(&summary[si * ms.len() + mi], "centre_error_mm_std")
            .unwrap()
    };
    for (mi, m) in ms.iter().enumerate() {
        let s = slope(
            &sigmas,
            &sigmas
                .iter()
                .enumerate()
                .map(|(si, _)| e(si, mi))
                .collect::<Vec<_>>(),
        );
        eprintln!("m = {m}: d log e / d log sigma = {s:.3}");
        assert!((s - 1.0).abs() <= 0.15, "sigma slope {s} at m = {m}");
    }
    for (si, sg) in sigmas.iter().enumerate() {
        let xs: Vec<f64> = ms.iter().map(|m| *m as f64).collect();
        let s = slope(
            &xs,
            &ms.iter()
                .enumerate()
                .map(|(mi, _)| e(si, mi))
                .collect::<Vec<_>>(),
        );
        eprintln!("sigma = {sg}: d log e / d log m = {s:.3}");
        assert!((s + 0.5).abs() <= 0.15, "m slope {s} at sigma = {sg}");
    }
}

#[test]
fn results_do_not_depend_on_thread_count() {
    let text = format!(
        "{}\n[sweep]\ntrials = 40\n[sweep.grid]\n\"disk.sigma_mm\" = [0.2, 0.5]\n",
        base()
    );
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| run_sweep(&text, 40));
    let four = rayon::ThreadPoolBuilder::new()
        .num_threads(4)
        .build()
        .unwrap()
        .install(|| run_sweep(&text, 40));
    // Compare what users get: the CSV bytes (NaN statistics of unused metrics compare unequal as
    // floats).
    let bytes = |r: &(Vec<TrialRow>, Vec<sweep::SummaryRow>)| {
        let keys = vec!["disk.sigma_mm".to_string()];
        let mut w = lasercal::io::csv::TrialsWriter::new(Vec::new(), &keys, "trials.csv").unwrap();
        r.0.iter().for_each(|row| w.write(row).unwrap());
        (
            w.finish().unwrap(),
            lasercal::io::csv::summary(&keys, &r.1).unwrap(),
        )
    };
    assert_eq!(bytes(&one), bytes(&four));
    // And a trial is the same whether run alone (with its point's seed) or in a sweep.
    let sf = ScenarioFile::parse(&text, "t.toml").unwrap();
    let p = &sf.point(1).unwrap();
    let setup = p.scenario.build(&sf.file).unwrap();
    let seed = sweep::point_seed(&SweepPlan::new(&sf, Some(40), None), &p.values);
    let alone = run_trial(&setup, "disk".parse().unwrap(), seed, 17);
    assert_eq!(
        alone,
        one.0
            .iter()
            .find(|r| r.point == 1 && r.outcome.trial == 17)
            .unwrap()
            .outcome
    );
}

#[test]
fn disk_raycast_recovers_truth() {
    // Noise-free ray-cast profiles through the Gocator model (no quantisation): the only error left
    // is where the rim falls between two columns, at most half an x sample (0.075 mm at the far end
    // of the range) on each chord end, i.e. like Eq. 52 noise of sigma <= 0.15 / sqrt(12) = 0.043 mm.
    // At m = 100 the analytic sweep gives a translation RMS of 0.045 mm per 0.1 mm sigma, so bound
    // the error by that level for sigma = 0.15 mm: 0.1 mm and 0.05 deg.
    // Table I's moves run mostly along the sensor's z and would carry the chords out of the 210 mm
    // range: sweep mostly along the sensor's y instead.
    let text = base()
        .replace("source = \"analytic\"", "source = \"raycast\"")
        .replace("directions_in_base", "directions_in_sensor")
        .replace("span_fraction = 0.9", "span_fraction = 0.8")
        .replace("[[0.181, -0.246, -0.952], [0.287, -0.294, -0.912], [0.391, -0.593, -0.704], [0.164, -0.631, -0.758]]", "[[0.1, 1.0, -0.5], [-0.2, 1.0, -0.4], [0.2, 1.0, -0.6], [-0.1, 1.0, -0.45]]")
        .replace("preset = \"gocator-2340\"", "preset = \"gocator-2340\"\nquantise = false");
    let sf = ScenarioFile::parse(&text, "raycast.toml").unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    let out = run_trial(&setup, "disk".parse().unwrap(), 1, 0);
    let s = out.result.unwrap();
    eprintln!(
        "ray-cast: {:?}, centre {:?} mm, missed {}",
        s.error(),
        s.metrics.get(lasercal::metrics::Metric::CentreError),
        out.missed_profiles
    );
    assert_eq!(out.missed_profiles, 0);
    assert!(
        s.error().translation_error_mm < 0.1 && s.error().rotation_error_deg < 0.05,
        "{:?}",
        s.error()
    );
}

#[test]
fn cli_run_writes_json() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("r.json");
    let scen = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/chen2018-disk.toml");
    let (code, out, err) =
        lasercal(&["run", scen, "--seed", "7", "--json", json.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("recovered flange_to_sensor"));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    for k in [
        "flange_to_sensor",
        "truth",
        "rotation_error_deg",
        "translation_error_mm",
    ] {
        assert!(!v[k].is_null(), "{k} missing in {v}");
    }
    let truth: Vec<Vec<f64>> = serde_json::from_value(v["truth"].clone()).unwrap();
    assert!((truth[2][3] - 364.25534).abs() < 1e-9);
    assert!(v["rotation_error_deg"].as_f64().unwrap() < 0.2);
}

#[test]
fn cli_sweep_writes_csvs_and_plots() {
    let dir = tempfile::tempdir().unwrap();
    let scen = dir.path().join("s.toml");
    std::fs::write(&scen, format!("{}\n[sweep]\ntrials = 500\n[sweep.grid]\n\"disk.sigma_mm\" = [0.1, 0.3]\n\"disk.chords\" = [10, 50]\n[sweep.plot]\nx = \"disk.chords\"\nseries = \"disk.sigma_mm\"\ny = \"centre_error_mm_std\"\n", base())).unwrap();
    let out = dir.path().join("out");
    let (code, _, err) = lasercal(&[
        "sweep",
        scen.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--trials",
        "20",
    ]);
    assert_eq!(code, 0, "{err}");
    let trials = std::fs::read_to_string(out.join("trials.csv")).unwrap();
    assert_eq!(trials.lines().count(), 1 + 4 * 20);
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    assert_eq!(summary.lines().count(), 1 + 4);
    assert!(
        summary
            .lines()
            .next()
            .unwrap()
            .contains("centre_error_mm_p95")
    );
    assert!(
        std::fs::read_to_string(out.join("plot.svg"))
            .unwrap()
            .contains("<svg")
    );
    assert!(
        std::fs::read(out.join("plot.png"))
            .unwrap()
            .starts_with(b"\x89PNG")
    );
    // A scenario without a sweep is refused with a clear message.
    let (code, _, err) = lasercal(&[
        "sweep",
        concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/chen2018-disk.toml"),
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("no [sweep] section"), "{err}");
}

/// `[sweep] draws`: independent (the default) gives each grid point its own draws (derived from
/// its grid values), so the analytic disk's errors at sigma 0.2 and 0.4 are uncorrelated trial by
/// trial, the same for any thread count; common gives trial t the same draws at every point
/// (correlation near 1).
#[test]
fn grid_points_share_draws_only_when_asked() {
    let grid = "[sweep.grid]\n\"disk.sigma_mm\" = [0.2, 0.4]\n";
    let common = format!(
        "{}\n[sweep]\ntrials = 30\ndraws = \"common\"\n{grid}",
        base()
    );
    let independent = format!("{}\n[sweep]\ntrials = 30\n{grid}", base());
    let correlation_of = |text: &str| -> f64 {
        let (rows, _) = run_sweep(text, 30);
        let err = |p: usize, t: u64| {
            rows.iter()
                .find(|r| r.point == p && r.outcome.trial == t)
                .unwrap()
                .outcome
                .result
                .as_ref()
                .unwrap()
                .metrics
                .get(lasercal::metrics::Metric::CentreError)
                .unwrap()
        };
        let (a, b): (Vec<f64>, Vec<f64>) = (0..30).map(|t| (err(0, t), err(1, t))).unzip();
        correlation(&a, &b)
    };
    let c = correlation_of(&common);
    assert!(c > 0.9, "common draws: correlation {c}");
    let r = correlation_of(&independent);
    assert!(r.abs() < 0.5, "independent draws: correlation {r}");
    // Deterministic: the same again, and the same on one thread.
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| correlation_of(&independent));
    assert_eq!(r, one);
    // A trial of a point is reproduced alone with the point's seed.
    let sf = ScenarioFile::parse(&independent, "t.toml").unwrap();
    let plan = SweepPlan::new(&sf, Some(30), None);
    let p = sf.point(1).unwrap();
    let seed = sweep::point_seed(&plan, &p.values);
    assert_ne!(seed, sf.scenario.seed);
    let setup = p.scenario.build(&sf.file).unwrap();
    let (rows, _) = run_sweep(&independent, 30);
    let alone = run_trial(&setup, "disk".parse().unwrap(), seed, 7);
    assert_eq!(
        alone,
        rows.iter()
            .find(|r| r.point == 1 && r.outcome.trial == 7)
            .unwrap()
            .outcome
    );
}

fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let cov: f64 = a.iter().zip(b).map(|(x, y)| (x - ma) * (y - mb)).sum();
    let va: f64 = a.iter().map(|x| (x - ma).powi(2)).sum();
    let vb: f64 = b.iter().map(|y| (y - mb).powi(2)).sum();
    cov / (va * vb).sqrt()
}

/// summary.csv leaves out a metric no result has (a disk sweep's edge figures and sphere radius)
/// instead of columns of NaN; every column it keeps has a number somewhere.
#[test]
fn summary_columns_hold_numbers() {
    let text = format!(
        "{}\n[sweep]\ntrials = 4\n[sweep.grid]\n\"disk.sigma_mm\" = [0.1, 0.2]\n",
        base()
    );
    let (_, summary) = run_sweep(&text, 4);
    let keys = vec!["disk.sigma_mm".to_string()];
    let bytes = lasercal::io::csv::summary(&keys, &summary).unwrap();
    let mut rd = csv::Reader::from_reader(bytes.as_slice());
    let header = rd.headers().unwrap().clone();
    let rows: Vec<csv::StringRecord> = rd.records().map(|r| r.unwrap()).collect();
    assert!(
        !header.iter().any(|h| h.starts_with("edge_angle_dev")),
        "{header:?}"
    );
    for (k, h) in header.iter().enumerate() {
        assert!(
            rows.iter().any(|r| r[k] != *"NaN"),
            "column {h} is NaN in every row"
        );
    }
}

/// The trials run on a thread of their own while the sink writes: a sink that fails stops the
/// sweep with its error, after no further chunk reaches it.
#[test]
fn a_failing_sink_stops_the_sweep_with_its_error() {
    let text = format!(
        "{}\n[sweep]\ntrials = 4\n[sweep.grid]\n\"disk.sigma_mm\" = [0.1, 0.2, 0.3, 0.4, 0.5]\n",
        base()
    );
    let sf = ScenarioFile::parse(&text, "reduced.toml").unwrap();
    let plan = SweepPlan::new(&sf, None, None);
    let mut calls = 0;
    let result = sweep::run(
        &plan,
        &sf.file,
        Shard::ALL,
        |_| {
            calls += 1;
            if calls == 2 {
                return Err(lasercal::error::Error::NoPlan {
                    method: lasercal::id::Kind::Edge,
                });
            }
            Ok(())
        },
        &|_| {},
    );
    let err = result.expect_err("the sink's error");
    assert!(err.to_string().contains("no edge plan"), "{err}");
    assert_eq!(calls, 2);
}
