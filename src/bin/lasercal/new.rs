//! `lasercal new`: a commented starter scenario for a rig from a few choices. The specimen is
//! placed where the arm reaches it and every pose of the plan sees it (the scenario is built and
//! one trial calibrated before the file is written), so the file runs as written.

use anyhow::{Result, bail};
use lasercal::scene::SpecimenType;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scenario file to write (TOML)
    #[arg(long)]
    out: PathBuf,
    /// Robot: irb120, irb2600 or the path of a .urdf
    #[arg(long, default_value = "irb120")]
    robot: String,
    /// Sensor preset (gocator-2320 ... gocator-2380, vlm350)
    #[arg(long, default_value = "gocator-2340")]
    sensor: String,
    /// Specimen: disk-cylinder, disk-paper, ball, parallel-bar, scale, knife-blade, ridge,
    /// v-groove, fillet, step, or plane (the table's face)
    #[arg(long, default_value = "ball")]
    specimen: String,
    /// What the sweep varies: noise (the sensor's, x 0.5 / 1 / 2), poses (their number) or none
    #[arg(long, default_value = "noise")]
    sweep: String,
    /// Scenario name (default: the file's stem)
    #[arg(long)]
    name: Option<String>,
    /// Replace the file if it exists
    #[arg(long)]
    force: bool,
}

/// How far above the table the specimen's frame origin sits (mm) at its default size, and the
/// method section's generated poses (tilt range deg, spread mm).
fn placement(kind: SpecimenType) -> (f64, (f64, f64), f64) {
    match kind {
        SpecimenType::Ball => (150.5, (0.0, 35.0), 20.0),
        SpecimenType::DiskCylinder => (20.0, (10.0, 30.0), 10.0),
        SpecimenType::DiskPaper => (0.5, (10.0, 30.0), 10.0),
        SpecimenType::ParallelBar => (12.0, (10.0, 30.0), 20.0),
        SpecimenType::Scale => (1.0, (10.0, 30.0), 20.0),
        SpecimenType::KnifeBlade => (0.3, (10.0, 30.0), 20.0),
        SpecimenType::Ridge => (15.0, (10.0, 30.0), 20.0),
        SpecimenType::VGroove => (10.5, (10.0, 30.0), 20.0),
        SpecimenType::Fillet => (15.0, (10.0, 30.0), 20.0),
        SpecimenType::Step => (20.0, (10.0, 30.0), 20.0),
        SpecimenType::Plane => (0.0, (10.0, 30.0), 40.0),
    }
}

/// The method section's name and the any-pose estimator that takes generated poses.
fn method_of(kind: SpecimenType) -> (&'static str, &'static str) {
    match kind {
        SpecimenType::Ball => ("ball", "ball-any-pose"),
        SpecimenType::DiskCylinder | SpecimenType::DiskPaper => ("disk", "disk-any-pose"),
        SpecimenType::Plane => ("plane", "plane-any-pose"),
        _ => ("edge", "edge-any-pose"),
    }
}

struct Choice<'a> {
    name: &'a str,
    robot: &'a str,
    sensor: &'a str,
    kind: SpecimenType,
    sweep: &'a str,
}

/// The scenario's text with the specimen at (x, y) mm on a table at z = 0.
fn text(c: &Choice, x: f64, y: f64) -> String {
    let (z, tilt, spread) = placement(c.kind);
    let (section, method) = method_of(c.kind);
    let mut s = format!(
        "# A starter scenario written by `lasercal new`: {robot}, {sensor}, {kind}, {method} from 16
# generated poses. Edit it to match your rig, then `lasercal run {name}.toml` for one trial or
# `lasercal sweep {name}.toml` for the sweep at the end. The keys: docs/guide/scenarios.md.
name = \"{name}\"
description = \"{kind} on {robot} with {sensor}: {method} from 16 generated poses\"
seed = 1
methods = [\"{method}\"]

[robot]
name = \"{robot}\"                 # irb120, irb2600, or a .urdf path relative to this file

[sensor]
preset = \"{sensor}\"
quantise = true
# The true mounting (flange_to_sensor): replace it with your drawing's. Rows of the rotation,
# then the sensor frame's origin in the flange frame (mm).
mount_rotation = [[0.99996, -0.00547, -0.00716], [-0.00544, -0.99998, 0.00288], [-0.00718, -0.00284, -0.99997]]
mount_position_mm = [6.0252, 54.18211, 364.25534]
# The preset's noise is used; to state your profiler's, uncomment (one standard deviation, mm):
# [sensor.noise]
# z_sigma_near_mm = 0.02
# z_sigma_far_mm = 0.06

[table]
height_mm = 0.0

",
        robot = c.robot,
        sensor = c.sensor,
        kind = c.kind,
        name = c.name,
    );
    if c.kind == SpecimenType::Plane {
        // The plane method's plane is the table; a specimen stands well away from the aim.
        s += &format!(
            "[specimen]                       # out of the way: the poses look at the table
kind = \"ball\"
radius_mm = 25.0
position_mm = [{:.1}, {:.1}, 105.0]

[plane]
aim_mm = [{x:.1}, {y:.1}]            # where on the table the poses aim (base x, y)
",
            -x, -y
        );
    } else {
        let radius = match c.kind {
            SpecimenType::Ball => "radius_mm = 25.0                 # the ball's radius\n",
            k if k.has_radius() => "radius_mm = 50.0                 # the disk's radius\n",
            _ => "",
        };
        let post = if c.kind == SpecimenType::Ball {
            "post_height_mm = 125.0\n"
        } else {
            ""
        };
        s += &format!(
            "[specimen]                       # at its default size; see docs/guide/scenarios.md for its keys
kind = \"{kind}\"
{radius}{post}position_mm = [{x:.1}, {y:.1}, {z:.1}]   # its frame's origin in the base frame, standing on the table
rpy_deg = [0.0, 0.0, 30.0]

[{section}]
source = \"raycast\"
",
            kind = c.kind
        );
    }
    s += &format!(
        "
[{section}.poses]
count = 16                       # generated; or tcp_mm_wxyz = [[x, y, z, qw, qx, qy, qz], ...] or joints_deg
tilt_deg = [{:.1}, {:.1}]         # the laser's tilt from the specimen's normal
spread_mm = {spread:.1}                # the aim moved up to this far along the laser line
",
        tilt.0, tilt.1
    );
    match c.sweep {
        "noise" => {
            s += &format!(
                "
# The sweep: the sensor's noise at half, once and twice the preset's (causes.scale).
[causes]
only = \"sensor\"
scale = 1.0

[sweep]
trials = 100

[sweep.grid]
\"causes.scale\" = [0.5, 1.0, 2.0]

[sweep.plot]
title = \"{name}: rotation error median vs sensor noise (x the preset's)\"
x = \"causes.scale\"
y = \"rotation_error_deg_median\"
",
                name = c.name
            )
        }
        "poses" => {
            s += &format!(
                "
# The sweep: how many poses it takes.
[sweep]
trials = 100

[sweep.grid]
\"{section}.poses.count\" = [8, 12, 16, 24, 32]

[sweep.plot]
title = \"{name}: translation error p95 vs number of poses\"
x = \"{section}.poses.count\"
y = \"translation_error_mm_p95\"
",
                name = c.name
            )
        }
        _ => {}
    }
    s
}

pub fn run(a: Args) -> Result<()> {
    let kind: SpecimenType = match serde_json::from_value(serde_json::json!(a.specimen)) {
        Ok(k) => k,
        Err(_) => bail!(
            "--specimen {}: use one of {}, plane",
            a.specimen,
            SpecimenType::ALL
                .iter()
                .map(|k| k.name())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    if kind == SpecimenType::DiskPaper {
        bail!(
            "--specimen disk-paper: a disk on paper is read by the disk paper's protocol (four \
             scans of parallel moves), which `new` does not write: start from \
             scenarios/chen2018-disk-raycast.toml with [specimen] kind = \"disk-paper\", or \
             choose disk-cylinder (any poses)"
        );
    }
    if !matches!(a.sweep.as_str(), "noise" | "poses" | "none") {
        bail!("--sweep {}: use noise, poses or none", a.sweep);
    }
    if a.out.exists() && !a.force {
        bail!(
            "{}: exists; give another --out, or --force to replace it",
            a.out.display()
        );
    }
    let stem = a
        .out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "my-rig".into());
    let name = a.name.clone().unwrap_or(stem);
    let choice = Choice {
        name: &name,
        robot: &a.robot,
        sensor: &a.sensor,
        kind,
        sweep: &a.sweep,
    };
    // A URDF path is relative to the scenario file: check the candidates from its folder.
    let file = a.out.display().to_string();
    let (section, method) = method_of(kind);
    let id: lasercal::method::MethodId = method.parse()?;
    let mut last = None;
    // Candidate places: nearer the base first, around it, until one builds and calibrates.
    for d in [300.0, 400.0, 500.0, 650.0, 800.0, 1000.0, 1200.0, 1500.0] {
        for az in [-135.0f64, -45.0, 0.0, 45.0, 135.0, 180.0, -90.0, 90.0] {
            let (x, y) = (d * az.to_radians().cos(), d * az.to_radians().sin());
            let t = text(&choice, x, y);
            let sf = match lasercal::scenario::ScenarioFile::parse(&t, &file) {
                Ok(sf) => sf,
                // A wrong robot, sensor or the like: no place will mend it.
                Err(e) => bail!("{e}"),
            };
            let setup = match sf.scenario.build(&sf.file) {
                Ok(s) => s,
                Err(e) => {
                    last = Some(e.to_string());
                    continue;
                }
            };
            let out = lasercal::trial::run_trial(&setup, id, sf.scenario.seed, 0);
            match &out.result {
                Ok(score) if score.error().rotation_error_deg < 1.0 => {
                    lasercal::io::write(&a.out, t.as_bytes())?;
                    say!(
                        "{}: {} with {}, a {} at ({x:.0}, {y:.0}) mm, {method} from 16 generated \
                         poses ([{section}.poses]); trial 0 calibrates to {:.4} deg / {:.4} mm. \
                         Next: lasercal run {} ; lasercal sweep {} --out out/{name}",
                        a.out.display(),
                        a.robot,
                        a.sensor,
                        kind,
                        score.error().rotation_error_deg,
                        score.error().translation_error_mm,
                        a.out.display(),
                        a.out.display()
                    );
                    return Ok(());
                }
                Ok(score) => {
                    last = Some(format!(
                        "trial 0 was {:.2} deg off",
                        score.error().rotation_error_deg
                    ))
                }
                Err(e) => last = Some(e.to_string()),
            }
        }
    }
    bail!(
        "no place within 1.5 m of {}'s base lets it scan the {kind} with {} (the last try: {}); \
         write the scenario by hand from docs/guide/scenarios.md",
        a.robot,
        a.sensor,
        last.unwrap_or_default()
    )
}
