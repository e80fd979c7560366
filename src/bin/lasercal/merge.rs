use super::sweep::{Meta, begin, done, finish};
use anyhow::{Context, Result, bail};
use lasercal::io;
use lasercal::method::MethodId;
use lasercal::scenario::ScenarioFile;
use lasercal::sweep::SweepPlan;
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
    let metas = read_metas(&a.dirs)?;
    let first = &metas[0].1;
    let sf = ScenarioFile::parse(&first.scenario_text, &first.scenario_file)?;
    let plan = SweepPlan::new(&sf, Some(first.trials), Some(first.seed));
    let method_rank = |m: MethodId| {
        sf.scenario
            .methods
            .iter()
            .position(|x| *x == m)
            .unwrap_or(usize::MAX)
    };
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&sf.scenario.name));
    // The output must not be one of the shards it reads (it would overwrite them).
    let same = |x: &PathBuf, y: &PathBuf| match (x.canonicalize(), y.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => x == y,
    };
    if let Some((d, _)) = metas.iter().find(|(d, _)| same(d, &out)) {
        bail!(
            "--out {}: that is shard folder {}; merge into a new folder",
            out.display(),
            d.display()
        );
    }
    let mut streams = Vec::with_capacity(metas.len());
    for (d, m) in &metas {
        streams.push(shard_rows(d, m, &plan, &sf)?);
    }
    begin(&out, "lasercal merge")?;
    let trials_path = out.join("trials.csv");
    let (pending, w) = io::Pending::create(&trials_path)?;
    let mut csv =
        io::csv::TrialsWriter::new(w, &plan.grid_keys, &trials_path.display().to_string())?;
    let mut summariser = lasercal::sweep::Summariser::new(&plan.values);
    let mut merged = 0usize;
    loop {
        // The next row in run order over the shards' heads (k-way merge: memory per shard, not
        // per trial).
        let mut best: Option<(usize, (usize, usize, u64))> = None;
        for (i, (_, s)) in streams.iter_mut().enumerate() {
            match s.peek() {
                None => {}
                Some(Err(_)) => {
                    if let Some(Err(e)) = s.next() {
                        return Err(e);
                    }
                }
                Some(Ok((r, _))) => {
                    let key = (r.point, method_rank(r.method), r.trial);
                    if best.is_none_or(|(_, b)| key < b) {
                        best = Some((i, key));
                    }
                }
            }
        }
        let Some((i, _)) = best else { break };
        let Some(Ok((r, rec))) = streams[i].1.next() else {
            continue;
        };
        csv.write_raw(&rec)?;
        summariser.add(&r);
        merged += 1;
    }
    let expected = plan.work(lasercal::sweep::Shard::ALL);
    if merged != expected {
        bail!(
            "the shards hold {merged} trials, the sweep has {expected}: a shard folder is incomplete \
             ({} left INCOMPLETE)",
            out.display()
        );
    }
    pending.commit(csv.finish()?)?;
    let summary = summariser.finish();
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
    done(&out)?;
    note!(
        "merged {} shards ({merged} trials) into {}",
        metas.len(),
        out.display()
    );
    Ok(())
}

/// Each shard folder's sweep record, refused unless they are the shards of one sweep, each once.
fn read_metas(dirs: &[PathBuf]) -> Result<Vec<(PathBuf, Meta)>> {
    let mut metas = Vec::new();
    for d in dirs {
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
    Ok(metas)
}

/// One row of a shard's trials.csv, parsed and as read.
type Row = (lasercal::sweep::MetricRow, csv::StringRecord);

/// A shard's rows (`d`, its record `m`), checked as they stream: the shard owns the trial, the
/// point, method and trial exist, the order is the run's (which also refuses a duplicate), every
/// figure finite. With the file's name for messages.
fn shard_rows(
    d: &std::path::Path,
    m: &Meta,
    plan: &SweepPlan,
    sf: &ScenarioFile,
) -> Result<(
    String,
    std::iter::Peekable<Box<dyn Iterator<Item = Result<Row>>>>,
)> {
    let p = d.join("trials.csv");
    let name = p.display().to_string();
    let f = std::fs::File::open(&p).with_context(|| format!("{name}: cannot read"))?;
    let shard = lasercal::sweep::Shard {
        index: m.shard - 1,
        count: m.shards,
    };
    let (points, trials, methods) = (plan.n_points(), plan.trials, sf.scenario.methods.clone());
    let rank = move |m: MethodId| methods.iter().position(|x| *x == m);
    let mut last: Option<(usize, usize, u64)> = None;
    let file = name.clone();
    let rows = io::csv::read_trials(f, &plan.grid_keys, &name)?.map(move |row| {
        let (r, rec) = row?;
        let line = rec.position().map_or(0, |p| p.line());
        let at = format!("{file}: line {line}");
        let Some(k) = rank(r.method) else {
            bail!("{at}: method {} is not in the scenario's methods", r.method);
        };
        if r.point >= points || r.trial as usize >= trials {
            bail!(
                "{at}: point {} trial {} lies outside the sweep ({points} points x {trials} \
                 trials)",
                r.point,
                r.trial
            );
        }
        if !shard.owns(r.trial as usize) {
            bail!(
                "{at}: trial {} belongs to shard {}/{}, not {}/{} (a trials.csv copied from \
                 another shard?)",
                r.trial,
                r.trial as usize % shard.count + 1,
                shard.count,
                shard.index + 1,
                shard.count
            );
        }
        let key = (r.point, k, r.trial);
        if last.is_some_and(|l| l >= key) {
            bail!(
                "{at}: point {} {} trial {} repeats or is out of order (a duplicated row?)",
                r.point,
                r.method,
                r.trial
            );
        }
        last = Some(key);
        if let Some((m, v)) = r.metrics.present().find(|(_, v)| !v.is_finite()) {
            bail!("{at}: {} = {v} is not a finite number", m.name());
        }
        Ok((r, rec))
    });
    Ok((
        name,
        (Box::new(rows) as Box<dyn Iterator<Item = Result<Row>>>).peekable(),
    ))
}
