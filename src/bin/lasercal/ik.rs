use anyhow::{Result, bail};
use lasercal::robot::Robot;
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};

#[derive(clap::Args)]
pub struct Args {
    /// irb120, irb2600 or the path of a .urdf file
    robot: String,
    /// tool0 position (mm) and orientation quaternion: X_MM Y_MM Z_MM QW QX QY QZ
    #[arg(num_args = 7, allow_negative_numbers = true, value_names = ["X_MM", "Y_MM", "Z_MM", "QW", "QX", "QY", "QZ"])]
    pose: Vec<f64>,
    /// Seed configuration J1..J6 in degrees: solutions are listed nearest it first
    #[arg(long, allow_hyphen_values = true, value_delimiter = ',')]
    seed_deg: Option<Vec<f64>>,
}

pub fn run(a: Args) -> Result<()> {
    let robot = Robot::resolve(&a.robot)?;
    let v = &a.pose;
    if v.iter().any(|x| !x.is_finite()) {
        bail!("the pose has a non-finite number: {v:?}");
    }
    let q = Quaternion::new(v[3], v[4], v[5], v[6]);
    let n = q.norm();
    if (n - 1.0).abs() > 1e-3 {
        bail!(
            "the quaternion (w, x, y, z) = ({}, {}, {}, {}) has norm {n:.6}; give a unit quaternion",
            v[3],
            v[4],
            v[5],
            v[6]
        );
    }
    let pose = Isometry3::from_parts(
        Translation3::new(v[0] / 1000.0, v[1] / 1000.0, v[2] / 1000.0),
        UnitQuaternion::from_quaternion(q),
    );
    let seed = match a.seed_deg {
        Some(s) if s.len() != 6 => bail!(
            "--seed-deg takes six comma-separated angles, got {}",
            s.len()
        ),
        Some(s) => Some(std::array::from_fn::<f64, 6, _>(|i| s[i].to_radians())),
        None => None,
    };
    let sols = robot.ik(&pose, seed.as_ref())?;
    let deg: Vec<Vec<f64>> = sols
        .iter()
        .map(|s| {
            s.iter()
                .map(|x| super::fk::round9(x.to_degrees()))
                .collect()
        })
        .collect();
    say!("{}", serde_json::json!({ "solutions_deg": deg }));
    Ok(())
}
