use super::common::{load_scenario, progress};
use anyhow::{Context, Result, bail};
use lasercal::io;
use lasercal::scenario::ScenarioFile;
use lasercal::sweep::{self, Shard, SummaryRow, SweepPlan};
use std::path::{Path, PathBuf};

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
    /// Also record the plotted curves as scalar series into a Rerun .rrd file
    #[arg(long)]
    rerun: Option<PathBuf>,
    /// Run only shard K of N (1 <= K <= N): trials t with t mod N = K - 1; combine with `lasercal merge`
    #[arg(long)]
    shard: Option<String>,
    /// With --rerun: record the curves of this finished sweep folder of the same scenario
    /// instead of running the trials again (nothing in the folder is written)
    #[arg(long, requires = "rerun")]
    from: Option<PathBuf>,
}

/// What a sweep folder holds besides its CSVs, so shards can be checked and merged.
#[derive(serde::Serialize, serde::Deserialize, PartialEq, Debug)]
pub struct Meta {
    pub format: String,
    pub version: u32,
    pub scenario_file: String,
    pub scenario_text: String,
    pub seed: u64,
    pub trials: usize,
    pub shard: usize,
    pub shards: usize,
    pub lasercal_version: String,
}

fn parse_shard(s: &str) -> Result<Shard> {
    let (k, n) = s
        .split_once('/')
        .with_context(|| format!("--shard {s}: write it as K/N, e.g. 3/10"))?;
    let (k, n): (usize, usize) = (
        k.trim()
            .parse()
            .with_context(|| format!("--shard {s}: K is not a number"))?,
        n.trim()
            .parse()
            .with_context(|| format!("--shard {s}: N is not a number"))?,
    );
    if n == 0 || k == 0 || k > n {
        bail!("--shard {s}: need 1 <= K <= N");
    }
    Ok(Shard {
        index: k - 1,
        count: n,
    })
}

/// The files a sweep or merge writes into its folder.
const OUTPUTS: [&str; 6] = [
    "trials.csv",
    "summary.csv",
    "plot.svg",
    "plot.png",
    "report.md",
    "sweep.json",
];
/// Present while a sweep or merge writes its folder: a folder holding it is incomplete.
pub const INCOMPLETE: &str = "INCOMPLETE";

/// Start writing a sweep folder: the previous run's outputs are removed (a re-run never mixes old
/// summaries with new trials) and the INCOMPLETE marker says what is running until `done`.
pub fn begin(out: &Path, what: &str) -> Result<()> {
    std::fs::create_dir_all(out)
        .with_context(|| format!("{}: cannot create the folder", out.display()))?;
    let old: Vec<&str> = OUTPUTS
        .iter()
        .copied()
        .filter(|f| out.join(f).exists())
        .collect();
    if !old.is_empty() {
        note!(
            "{}: replacing the previous run's {}",
            out.display(),
            old.join(", ")
        );
        for f in old {
            std::fs::remove_file(out.join(f))
                .with_context(|| format!("{}: cannot remove", out.join(f).display()))?;
        }
    }
    io::write(
        &out.join(INCOMPLETE),
        format!(
            "{what} is writing this folder (process {}); if that run is gone, the folder is \
             incomplete: run it again\n",
            std::process::id()
        )
        .as_bytes(),
    )?;
    Ok(())
}

/// Finish writing a sweep folder: the marker goes.
pub fn done(out: &Path) -> Result<()> {
    std::fs::remove_file(out.join(INCOMPLETE))
        .with_context(|| format!("{}: cannot remove", out.join(INCOMPLETE).display()))
}

/// summary.csv, plots and report.md: the same bytes for a whole run and for merged shards.
pub fn finish(
    out: &Path,
    sf: &ScenarioFile,
    plan: &SweepPlan,
    summary: &[SummaryRow],
) -> Result<()> {
    io::write(
        &out.join("summary.csv"),
        &io::csv::summary(&plan.grid_keys, summary)?,
    )?;
    let plot = sf.scenario.sweep.as_ref().and_then(|s| s.plot.as_ref());
    if let Some(p) = plot {
        let fig = io::plot::from_summary(summary, p, &sf.scenario.name);
        io::write(&out.join("plot.svg"), io::plot::svg(&fig)?.as_bytes())?;
        io::plot::png(&fig, &out.join("plot.png"))?;
    }
    let name = Path::new(&sf.file)
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let report = io::report::report(
        &sf.scenario,
        &name,
        plan.seed,
        plan.trials,
        &plan.grid_keys,
        summary,
        plot.is_some(),
    );
    io::write(&out.join("report.md"), report.as_bytes())?;
    Ok(())
}

pub fn run(a: Args) -> Result<()> {
    let sf = load_scenario(&a.scenario)?;
    if sf.scenario.sweep.is_none() {
        bail!(
            "{}: no [sweep] section; add one with trials and a grid, or use `lasercal run`",
            sf.file
        );
    }
    if let (Some(dir), Some(rrd)) = (&a.from, &a.rerun) {
        return curves_from(dir, rrd, &a.scenario, &sf);
    }
    let max = lasercal::schema::validator::MAX_TRIALS;
    if let Some(t) = a.trials.filter(|&t| t == 0 || t > max) {
        bail!("--trials {t}: from 1 to {max} trials per grid point");
    }
    let shard = a
        .shard
        .as_deref()
        .map(parse_shard)
        .transpose()?
        .unwrap_or(Shard::ALL);
    let trials = super::common::trials_cap(
        a.trials
            .or(sf.scenario.sweep.as_ref().map(|s| s.trials))
            .unwrap_or(1),
    );
    let plan = SweepPlan::new(&sf, Some(trials), a.seed);
    // The plot's keys checked before any trial runs (a typo gave an empty plot and exit 0).
    if let Some(p) = sf.scenario.sweep.as_ref().and_then(|s| s.plot.as_ref()) {
        let grid = plan.grid_keys.join(", ");
        for (key, v) in [("x", Some(&p.x)), ("series", p.series.as_ref())] {
            if let Some(v) = v.filter(|v| !plan.grid_keys.contains(v)) {
                bail!(
                    "{}: sweep.plot.{key} = \"{v}\": not a grid key; use one of: {grid}",
                    sf.file
                );
            }
        }
        if !io::csv::is_summary_column(&plan.grid_keys, &p.y) {
            bail!(
                "{}: sweep.plot.y = \"{}\": not a summary column; use one of: {}",
                sf.file,
                p.y,
                lasercal::metrics::summary_columns()
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&sf.scenario.name));
    let total = plan.work(shard);
    note!(
        "sweep {}: {} grid points x {} trials{}, {} threads, writing {}",
        sf.scenario.name,
        plan.n_points(),
        plan.trials,
        if shard.count > 1 {
            format!(
                " (shard {}/{}: {total} trials)",
                shard.index + 1,
                shard.count
            )
        } else {
            String::new()
        },
        rayon::current_num_threads(),
        out.display()
    );
    begin(&out, &format!("lasercal sweep {}", a.scenario.display()))?;
    let trials_path = out.join("trials.csv");
    let (pending, w) = io::Pending::create(&trials_path)?;
    let mut trials_csv =
        io::csv::TrialsWriter::new(w, &plan.grid_keys, &trials_path.display().to_string())?;
    let pb = progress(total as u64, &sf.scenario.name);
    let started = std::time::Instant::now();
    let summary = sweep::run(
        &plan,
        &sf.file,
        shard,
        |rows| {
            for r in rows {
                trials_csv.write(r)?;
            }
            Ok(())
        },
        &|done| pb.set_position(done as u64),
    )?;
    pb.finish_and_clear();
    pending.commit(trials_csv.finish()?)?;
    let meta = Meta {
        format: "lasercal-sweep".into(),
        version: 1,
        scenario_file: sf.file.clone(),
        scenario_text: std::fs::read_to_string(&a.scenario)
            .with_context(|| format!("re-reading {}", sf.file))?,
        seed: plan.seed,
        trials: plan.trials,
        shard: shard.index + 1,
        shards: shard.count,
        lasercal_version: env!("CARGO_PKG_VERSION").into(),
    };
    io::write(
        &out.join("sweep.json"),
        serde_json::to_string_pretty(&meta)?.as_bytes(),
    )?;
    let failures: usize = summary.iter().map(|s| s.failures).sum();
    if shard.count == 1 {
        finish(&out, &sf, &plan, &summary)?;
        done(&out)?;
        if let Some(p) = &a.rerun {
            record_curves(p, &sf, &summary)?;
        }
        note!(
            "done: {total} trials in {:.1} s ({failures} failed); {}/report.md",
            started.elapsed().as_secs_f64(),
            out.display()
        );
    } else {
        done(&out)?;
        note!(
            "shard {}/{} done: {total} trials in {:.1} s ({failures} failed); combine the shards with `lasercal merge DIR...`",
            shard.index + 1,
            shard.count,
            started.elapsed().as_secs_f64()
        );
    }
    Ok(())
}

/// `--from DIR --rerun FILE`: the curves of a finished sweep, from its trials.csv (the summaries
/// recomputed as `merge` does), without running a trial.
fn curves_from(dir: &Path, rrd: &Path, scenario: &Path, sf: &ScenarioFile) -> Result<()> {
    let p = dir.join("sweep.json");
    let text = std::fs::read_to_string(&p)
        .with_context(|| format!("{}: cannot read (is this a sweep folder?)", p.display()))?;
    let meta: Meta = serde_json::from_str(&text)
        .with_context(|| format!("{}: not a lasercal sweep record", p.display()))?;
    let now =
        std::fs::read_to_string(scenario).with_context(|| format!("re-reading {}", sf.file))?;
    if meta.scenario_text != now {
        bail!(
            "--from {}: that sweep ran another version of {} (its text differs): run the sweep \
             again, or give the scenario it ran",
            dir.display(),
            sf.file
        );
    }
    if meta.shards != 1 || dir.join(INCOMPLETE).exists() {
        bail!(
            "--from {}: not a finished, whole sweep (shard {}/{}{}); merge the shards first",
            dir.display(),
            meta.shard,
            meta.shards,
            if dir.join(INCOMPLETE).exists() {
                ", still running or interrupted"
            } else {
                ""
            }
        );
    }
    let plan = SweepPlan::new(sf, Some(meta.trials), Some(meta.seed));
    let csv = dir.join("trials.csv");
    let name = csv.display().to_string();
    let f = std::fs::File::open(&csv).with_context(|| format!("{name}: cannot read"))?;
    let mut s = lasercal::sweep::Summariser::new(&plan.values);
    for row in io::csv::read_trials(f, &plan.grid_keys, &name)? {
        s.add(&row?.0);
    }
    record_curves(rrd, sf, &s.finish())?;
    note!(
        "{}: the curves of {} recorded",
        rrd.display(),
        dir.display()
    );
    Ok(())
}

#[cfg(feature = "rerun")]
fn record_curves(path: &Path, sf: &ScenarioFile, summary: &[SummaryRow]) -> Result<()> {
    let Some(plot) = sf.scenario.sweep.as_ref().and_then(|s| s.plot.as_ref()) else {
        bail!("--rerun: the scenario's sweep has no [sweep.plot] saying which curves to record");
    };
    let fig = io::plot::from_summary(summary, plot, &sf.scenario.name);
    let r = io::rerun::Recorder::save(path)?;
    Ok(r.log_curves(&fig)?)
}

#[cfg(not(feature = "rerun"))]
fn record_curves(_: &Path, _: &ScenarioFile, _: &[SummaryRow]) -> Result<()> {
    bail!(
        "this lasercal was built without the `rerun` feature: rebuild with default features for --rerun"
    )
}
