use super::common::load_scenario;
use anyhow::{Result, bail};
use lasercal::method::MethodId;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML)
    scenario: PathBuf,
    /// Capture file to write (JSON, docs/captures.md)
    #[arg(long)]
    out: PathBuf,
    /// Method whose captures to simulate (default: the scenario's first)
    #[arg(long)]
    method: Option<MethodId>,
    /// Seed (default: the scenario's)
    #[arg(long)]
    seed: Option<u64>,
    /// Trial index (the noise draw): the same captures `lasercal run --trial N` calibrates
    #[arg(long, default_value_t = 0)]
    trial: u64,
    /// Store the raw profiles' points in a compressed array beside the file (NAME.points.npy.gz,
    /// float32: about a tenth of the size)
    #[arg(long)]
    compact: bool,
}

pub fn run(a: Args) -> Result<()> {
    let sf = load_scenario(&a.scenario)?;
    let method = a.method.unwrap_or(sf.scenario.methods[0]);
    if !sf.scenario.methods.contains(&method) {
        bail!(
            "--method {method}: the scenario runs {}",
            sf.scenario
                .methods
                .iter()
                .map(|m| m.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let setup = sf.scenario.build(&sf.file)?;
    let seed = a.seed.unwrap_or(sf.scenario.seed);
    let (caps, _) = lasercal::trial::trial_captures(&setup, method.kind, seed, a.trial);
    let caps = caps?;
    let json = lasercal::io::captures::to_json(&caps, &setup.rig.sensor);
    lasercal::io::captures::write(&a.out, &json, a.compact)?;
    note!(
        "{method}: {} profiles in {} groups written to {}",
        caps.profiles.len(),
        caps.groups.len(),
        a.out.display()
    );
    Ok(())
}
