use super::common::{load_scenario, progress};
use anyhow::{Context, Result, bail};
use lasercal::io;
use lasercal::sweep::{self, Shard, SweepPlan};
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML) with a [sweep] section
    scenario: PathBuf,
    /// Output folder (default: out/<scenario name>)
    #[arg(long)]
    out: Option<PathBuf>,
    /// Trials per grid point (default: the scenario's)
    #[arg(long)]
    trials: Option<usize>,
    /// Seed (default: the scenario's)
    #[arg(long)]
    seed: Option<u64>,
}

pub fn run(a: Args) -> Result<()> {
    let sf = load_scenario(&a.scenario)?;
    if sf.scenario.sweep.is_none() {
        bail!(
            "{}: no [sweep] section; add one with trials and a grid, or use `lasercal run`",
            sf.file
        );
    }
    if a.trials == Some(0) {
        bail!("--trials must be at least 1");
    }
    let plan = SweepPlan::new(&sf, a.trials, a.seed)?;
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&sf.scenario.name));
    let shard = Shard::ALL;
    let total = plan.work(shard);
    eprintln!(
        "sweep {}: {} grid points x {} trials, {} threads, writing {}",
        sf.scenario.name,
        plan.points.len(),
        plan.trials,
        rayon::current_num_threads(),
        out.display()
    );
    let mut trials_csv = io::create(&out.join("trials.csv")).map_err(anyhow::Error::msg)?;
    trials_csv.write_all(io::csv::trials_header(&plan.grid_keys).as_bytes())?;
    let pb = progress(total as u64, &sf.scenario.name);
    let started = std::time::Instant::now();
    let summary = sweep::run(
        &plan,
        &sf.file,
        shard,
        |rows| {
            for r in rows {
                trials_csv.write_all(io::csv::trial_line(r).as_bytes())?;
            }
            Ok(())
        },
        &|done| pb.set_position(done as u64),
    )?;
    pb.finish_and_clear();
    trials_csv.flush().context("flushing trials.csv")?;
    io::write(
        &out.join("summary.csv"),
        io::csv::summary(&plan.grid_keys, &summary).as_bytes(),
    )
    .map_err(anyhow::Error::msg)?;
    if let Some(p) = sf.scenario.sweep.as_ref().and_then(|s| s.plot.as_ref()) {
        let fig = io::plot::from_summary(&summary, p, &sf.scenario.name);
        io::write(
            &out.join("plot.svg"),
            io::plot::svg(&fig).map_err(anyhow::Error::msg)?.as_bytes(),
        )
        .map_err(anyhow::Error::msg)?;
        io::plot::png(&fig, &out.join("plot.png")).map_err(anyhow::Error::msg)?;
    }
    let failures: usize = summary.iter().map(|s| s.failures).sum();
    eprintln!(
        "done: {total} trials in {:.1} s ({failures} failed); {}/summary.csv",
        started.elapsed().as_secs_f64(),
        out.display()
    );
    Ok(())
}
