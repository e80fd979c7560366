use anyhow::{Context, Result};
use lasercal::math::quat_wxyz;
use lasercal::robot::Robot;

#[derive(clap::Args)]
pub struct Args {
    /// irb120, irb2600 or the path of a .urdf file
    robot: String,
    /// Joint angles J1..J6 in degrees
    #[arg(num_args = 6, allow_negative_numbers = true, value_names = ["J1", "J2", "J3", "J4", "J5", "J6"])]
    joints_deg: Vec<f64>,
}

pub fn run(a: Args) -> Result<()> {
    let robot = Robot::resolve(&a.robot)?;
    let q: [f64; 6] = std::array::from_fn(|i| a.joints_deg[i].to_radians());
    if let Some((j, v)) = robot
        .joints
        .iter()
        .zip(&a.joints_deg)
        .find(|(j, v)| !v.is_finite() || !robot.within_limits_one(j, v.to_radians()))
    {
        anyhow::bail!(
            "{} = {} deg is outside its limits [{:.1}, {:.1}] deg",
            j.name,
            v,
            j.lower_rad.to_degrees(),
            j.upper_rad.to_degrees()
        );
    }
    let t = robot.fk(&q);
    let p = t.translation.vector * 1000.0;
    let out = serde_json::json!({
        "position_mm": [round9(p.x), round9(p.y), round9(p.z)],
        "quaternion_wxyz": quat_wxyz(&t.rotation).map(round9),
    });
    say!(
        "{}",
        serde_json::to_string(&out).context("serialising the pose")?
    );
    Ok(())
}

/// Round away float noise such as 6.123e-17 so printed poses read cleanly.
pub fn round9(x: f64) -> f64 {
    let r = (x * 1e9).round() / 1e9;
    if r == 0.0 { 0.0 } else { r }
}
