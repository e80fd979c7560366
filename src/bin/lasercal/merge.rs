use super::sweep::{Meta, finish};
use anyhow::{Context, Result, bail};
use lasercal::io;
use lasercal::method::MethodId;
use lasercal::scenario::ScenarioFile;
use lasercal::sweep::{SweepPlan, summarise_metrics};
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Shard folders written by `lasercal sweep --shard K/N`
    #[arg(required = true)]
    dirs: Vec<PathBuf>,
    /// Output folder (default: out/<scenario name>)
    #[arg(long)]
    out: Option<PathBuf>,
}

pub fn run(a: Args) -> Result<()> {
    let mut metas = Vec::new();
    for d in &a.dirs {
        let p = d.join("sweep.json");
        let text = std::fs::read_to_string(&p)
            .with_context(|| format!("{}: cannot read (is this a sweep folder?)", p.display()))?;
        let m: Meta = serde_json::from_str(&text)
            .with_context(|| format!("{}: not a lasercal sweep record", p.display()))?;
        metas.push((d.clone(), m));
    }
    let first = &metas[0].1;
    for (d, m) in &metas {
        if m.scenario_text != first.scenario_text
            || m.seed != first.seed
            || m.trials != first.trials
            || m.shards != first.shards
        {
            bail!(
                "{}: a different sweep (scenario, seed, trials or shard count differ from {})",
                d.display(),
                metas[0].0.display()
            );
        }
    }
    let mut have: Vec<usize> = metas.iter().map(|(_, m)| m.shard).collect();
    have.sort();
    let want: Vec<usize> = (1..=first.shards).collect();
    if have != want {
        bail!(
            "shards given: {have:?}; a complete merge needs each of 1..={} exactly once",
            first.shards
        );
    }
    let sf = ScenarioFile::parse(&first.scenario_text, &first.scenario_file)?;
    let plan = SweepPlan::new(&sf, Some(first.trials), Some(first.seed));
    let method_rank = |m: MethodId| {
        sf.scenario
            .methods
            .iter()
            .position(|x| *x == m)
            .unwrap_or(usize::MAX)
    };
    let mut rows = Vec::new();
    for (d, _) in &metas {
        let p = d.join("trials.csv");
        let f = std::fs::File::open(&p).with_context(|| format!("{}: cannot read", p.display()))?;
        for row in io::csv::read_trials(f, &plan.grid_keys, &p.display().to_string())? {
            rows.push(row?);
        }
    }
    rows.sort_by_key(|(m, _)| (m.point, method_rank(m.method), m.trial));
    let expected = plan.work(lasercal::sweep::Shard::ALL);
    if rows.len() != expected {
        bail!(
            "the shards hold {} trials, the sweep has {expected}: a shard folder is incomplete",
            rows.len()
        );
    }
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&sf.scenario.name));
    let trials_path = out.join("trials.csv");
    let mut csv = io::csv::TrialsWriter::new(
        io::create(&trials_path)?,
        &plan.grid_keys,
        &trials_path.display().to_string(),
    )?;
    for (_, record) in &rows {
        csv.write_raw(record)?;
    }
    csv.finish()?
        .flush()
        .with_context(|| format!("{}: cannot write", trials_path.display()))?;
    let metrics: Vec<_> = rows.into_iter().map(|(m, _)| m).collect();
    let summary = summarise_metrics(&metrics, &plan.points);
    finish(&out, &sf, &plan, &summary)?;
    let meta = Meta {
        shard: 1,
        shards: 1,
        ..serde_json::from_str(&serde_json::to_string(first)?)?
    };
    io::write(
        &out.join("sweep.json"),
        serde_json::to_string_pretty(&meta)?.as_bytes(),
    )?;
    eprintln!(
        "merged {} shards ({} trials) into {}",
        metas.len(),
        metrics.len(),
        out.display()
    );
    Ok(())
}
