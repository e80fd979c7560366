use super::common::load_scenario;
use anyhow::{Context, Result, bail};
use lasercal::method::Kind;
use lasercal::robot::Robot;
use lasercal::scene::SpecimenType;
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scenario file: robot, sensor, true mounting, specimen and table
    scenario: PathBuf,
    /// Joint angles J1..J6 in degrees, comma-separated
    #[arg(long, allow_hyphen_values = true, conflicts_with = "tcp_mm")]
    joints_deg: Option<String>,
    /// TCP (tool0) position x,y,z in mm (with --quat-wxyz)
    #[arg(long, allow_hyphen_values = true, requires = "quat_wxyz")]
    tcp_mm: Option<String>,
    /// TCP orientation quaternion w,x,y,z
    #[arg(long, allow_hyphen_values = true)]
    quat_wxyz: Option<String>,
    /// Which specimen to scan when a method has its own: disk, ball or edge
    #[arg(long)]
    method: Option<Kind>,
    /// Scan another specimen kind at the scenario's specimen position (its default size):
    /// disk-cylinder, disk-paper, ball, parallel-bar, scale, knife-blade
    #[arg(long)]
    specimen: Option<SpecimenType>,
    /// Apply the scenario's sensor noise with this seed
    #[arg(long)]
    noise_seed: Option<u64>,
    /// Write the profile as CSV here instead of printing it
    #[arg(long)]
    out: Option<PathBuf>,
}

fn list(s: &str, n: usize, what: &str) -> Result<Vec<f64>> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{what}: '{s}' is not a comma-separated list of numbers"))?;
    if v.len() != n || v.iter().any(|x| !x.is_finite()) {
        bail!("{what}: '{s}' must be {n} finite comma-separated numbers");
    }
    Ok(v)
}

pub fn run(a: Args) -> Result<()> {
    let sf = load_scenario(&a.scenario)?;
    let setup = sf.scenario.build(&sf.file)?;
    let robot: &Robot = &setup.rig.robot;
    let base_to_flange: Isometry3<f64> = if let Some(j) = &a.joints_deg {
        let q = list(j, 6, "--joints-deg")?;
        let q: [f64; 6] = std::array::from_fn(|i| q[i].to_radians());
        if !robot.within_limits(&q, 1e-12) {
            bail!(
                "--joints-deg {j}: outside the joint limits of {}",
                robot.name
            );
        }
        robot.fk(&q)
    } else if let (Some(t), Some(qs)) = (&a.tcp_mm, &a.quat_wxyz) {
        let t = list(t, 3, "--tcp-mm")?;
        let q = list(qs, 4, "--quat-wxyz")?;
        let quat = Quaternion::new(q[0], q[1], q[2], q[3]);
        if (quat.norm() - 1.0).abs() > 1e-3 {
            bail!(
                "--quat-wxyz {qs}: not a unit quaternion (norm {:.5})",
                quat.norm()
            );
        }
        let pose = Isometry3::from_parts(
            Translation3::new(t[0] * 1e-3, t[1] * 1e-3, t[2] * 1e-3),
            UnitQuaternion::from_quaternion(quat),
        );
        robot.ik(&pose, None).with_context(|| "the TCP pose")?;
        pose
    } else {
        // The middle of the first planned scan.
        match setup.plans.first() {
            Some((_, plan)) => plan.first_flange_pose(),
            None => bail!(
                "give --joints-deg or --tcp-mm and --quat-wxyz (the scenario plans no scan to default to)"
            ),
        }
    };
    let own_scene;
    let scene = match (&a.specimen, a.method) {
        (Some(kind), _) => {
            let mut sc = sf.scenario.clone();
            let s = &mut sc.specimen;
            s.kind = *kind;
            // The new kind's default size, with the disk/ball radius kept where it applies.
            (
                s.height_mm,
                s.paper_half_mm,
                s.post_radius_mm,
                s.post_height_mm,
            ) = (None, None, None, None);
            (s.length_mm, s.width_mm, s.thickness_mm, s.bevel_mm) = (None, None, None, None);
            if s.radius_mm.is_none() && kind.has_radius() {
                s.radius_mm = Some(50.0);
            }
            own_scene = sc.common(&sf.file)?.scene;
            &own_scene
        }
        (None, None) => &setup.scene,
        (None, Some(kind)) => setup
            .plan(kind)
            .with_context(|| format!("--method {kind}: the scenario has no [{kind}] plan"))?
            .scene(),
    };
    let base_to_sensor = setup.rig.base_to_sensor(&base_to_flange);
    let mut rng = a
        .noise_seed
        .map(|s| lasercal::rng::stream(s, &[lasercal::rng::tag::SENSOR_NOISE]));
    let profile = setup
        .rig
        .sensor
        .profile(scene, &base_to_sensor, rng.as_mut());
    let mut csv = String::from("column,x_mm,z_mm,intensity\n");
    for (k, p) in profile.points.iter().enumerate() {
        match p {
            Some(p) => {
                csv += &format!(
                    "{k},{},{},{}\n",
                    to_mm(p.x),
                    to_mm(p.z),
                    (p.intensity * 1e9).round() / 1e9
                )
            }
            None => csv += &format!("{k},,,\n"),
        }
    }
    note!(
        "{} profile: {} of {} columns see a surface ({} frame)",
        setup.rig.sensor.name,
        profile.valid(),
        setup.rig.sensor.columns,
        setup.rig.sensor.frame
    );
    match &a.out {
        Some(p) => lasercal::io::write(p, csv.as_bytes())?,
        None => std::io::stdout()
            .write_all(csv.as_bytes())
            .context("cannot write to standard output")?,
    }
    Ok(())
}

/// Metres as mm rounded to the picometre: a quantised z of -5.174 mm prints as such, not as the
/// -5.1739999999999995 its conversion gives.
fn to_mm(m: f64) -> f64 {
    (m * 1e12).round() / 1e9
}
