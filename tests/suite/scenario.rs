//! Scenario files: every file in scenarios/ parses and validates; bad input names file, key, value.

use lasercal::scenario::{ScenarioError, ScenarioFile};

fn base() -> String {
    std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/chen2018-disk.toml"
    ))
    .unwrap()
}

#[test]
fn every_scenario_file_parses_and_builds() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios");
    let mut n = 0;
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "toml") {
            let sf = ScenarioFile::load(&p).unwrap_or_else(|e| panic!("{e}"));
            // Building checks reachability and plans; the first grid point is enough here.
            let first = sf.point(0).unwrap();
            first
                .scenario
                .build(&sf.file)
                .unwrap_or_else(|e| panic!("{e}"));
            n += 1;
        }
    }
    assert!(n >= 2);
}

fn err_of(text: &str) -> ScenarioError {
    ScenarioFile::parse(text, "test.toml").unwrap_err()
}

#[test]
fn unknown_key_is_named() {
    let e = err_of(&base().replace("[specimen]", "[specimen]\nradius_inch = 2.0"));
    let s = e.to_string();
    assert!(s.contains("test.toml") && s.contains("radius_inch"), "{s}");
    let e = err_of(&format!("bogus_top = 1\n{}", base()));
    assert!(e.to_string().contains("bogus_top"), "{e}");
}

#[test]
fn bad_values_name_file_key_and_value() {
    for (from, to, key, value) in [
        (
            "radius_mm = 50.0",
            "radius_mm = -5.0",
            "specimen.radius_mm",
            "-5",
        ),
        ("chords = 100", "chords = 2", "disk.chords", "2"),
        (
            "preset = \"gocator-2340\"",
            "preset = \"gocator-9999\"",
            "sensor.preset",
            "gocator-9999",
        ),
        (
            "kind = \"disk-cylinder\"",
            "kind = \"donut\"",
            "specimen.kind",
            "donut",
        ),
        (
            "coverage = \"whole\"",
            "coverage = \"most\"",
            "disk.coverage",
            "most",
        ),
        ("name = \"irb120\"", "name = \"irb9\"", "robot.name", "irb9"),
        ("sigma_mm = 0.1", "sigma_mm = -0.1", "disk.sigma_mm", "-0.1"),
    ] {
        let text = base().replace(from, to);
        let e = match ScenarioFile::parse(&text, "test.toml") {
            Err(e) => e,
            // The robot is resolved when the scenario is built.
            Ok(sf) => sf.scenario.build(&sf.file).unwrap_err(),
        };
        let s = e.to_string();
        assert!(
            s.contains("test.toml") && s.contains(key) && s.contains(value),
            "{to}: {s}"
        );
    }
}

#[test]
fn syntax_error_names_the_line() {
    let e = err_of(&base().replace("chords = 100", "chords = = 100"));
    assert!(matches!(e, ScenarioError::Syntax { .. }));
    assert!(e.to_string().contains("line"), "{e}");
}

#[test]
fn unreachable_plan_is_a_clear_error() {
    // Move the disk 2 m away: the IRB 120 cannot reach the scan poses.
    let text = base()
        .replace(
            "position_mm = [-319.622, -304.086, 11.48]",
            "position_mm = [-2319.622, -304.086, 11.48]",
        )
        .replace("centre_tcp_mm", "# centre_tcp_mm");
    let sf = ScenarioFile::parse(&text, "far.toml").unwrap();
    let e = sf.scenario.build(&sf.file).unwrap_err().to_string();
    assert!(
        e.contains("far.toml") && e.contains("not reachable") && e.contains("out of reach"),
        "{e}"
    );
}

#[test]
fn grid_keys_must_name_scenario_values() {
    let text = format!(
        "{}\n[sweep]\ntrials = 3\n[sweep.grid]\n\"disk.sigmaa_mm\" = [0.1, 0.2]\n",
        base()
    );
    let e = err_of(&text).to_string();
    assert!(e.contains("disk.sigmaa_mm"), "{e}");
}

#[test]
fn a_plot_over_names_is_refused_not_drawn_empty() {
    let text = format!(
        "{}\n[sweep]\ntrials = 3\n[sweep.grid]\n\"disk.coverage\" = [\"whole\", \"half\"]\n\
         [sweep.plot]\ntitle = \"t\"\nx = \"disk.coverage\"\ny = \"rotation_error_deg_median\"\n",
        base()
    );
    let e = err_of(&text).to_string();
    assert!(
        e.contains("sweep.plot.x") && e.contains("disk.coverage") && e.contains("series"),
        "{e}"
    );
}
