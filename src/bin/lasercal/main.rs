//! The `lasercal` command line: one module per subcommand.

/// `println!` that returns an error instead of panicking when standard output is gone (a closed
/// pipe, a full disk): the enclosing function returns `anyhow::Result`.
/// While set (`calibrate --ros2`), the report goes to standard error so that standard output
/// holds only the command a shell captures.
static REPORT_TO_STDERR: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        if crate::REPORT_TO_STDERR.load(std::sync::atomic::Ordering::Relaxed) {
            writeln!(std::io::stderr(), $($t)*)
                .map_err(|e| anyhow::anyhow!("cannot write to standard error: {e}"))?;
        } else {
            writeln!(std::io::stdout(), $($t)*)
                .map_err(|e| anyhow::anyhow!("cannot write to standard output: {e}"))?;
        }
    }};
}

/// `eprintln!` that does not panic when standard error is gone (`lasercal run ... 2>&1 | head`):
/// a note nobody can read is dropped.
macro_rules! note {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($t)*);
    }};
}

mod calibrate;
mod check;
mod common;
mod compare;
mod fk;
mod ik;
mod import;
mod merge;
mod new;
mod run;
mod scan;
mod simulate;
mod sweep;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "lasercal",
    version,
    about = "Hand-eye calibration test bench for 2D laser profile scanners on robots"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Forward kinematics: tool0 pose in the base frame for six joint angles in degrees.
    Fk(fk::Args),
    /// Inverse kinematics: every joint solution (degrees) for a tool0 pose.
    Ik(ik::Args),
    /// Simulate a scenario once, calibrate, and print the recovered transform and its error.
    Run(run::Args),
    /// Run a scenario's sweep grid: trials.csv, summary.csv and plots.
    Sweep(sweep::Args),
    /// Simulate one trial's captures and write them as a capture file (JSON).
    Simulate(simulate::Args),
    /// Calibrate from a capture file (a real rig's or a simulated one) with the code `run` uses;
    /// exit 0 when the result is judged ok, 3 when suspect, 2 on bad input.
    Calibrate(calibrate::Args),
    /// Build a capture file from a pose list (any controller's convention) and profile CSVs.
    Import(import::Args),
    /// Score other flange-to-sensor transforms (a vendor's, a colleague's, another tool's) on a
    /// capture file beside lasercal's: how well each predicts every pose from the others.
    Compare(compare::Args),
    /// Combine the folders of a sharded sweep into the files an unsharded run writes.
    Merge(merge::Args),
    /// One profile as the sensor sees it, as CSV (x, z in the sensor frame).
    Scan(scan::Args),
    /// CI gate: exit 0 when a percentile of the errors is within bounds, 1 when not, 2 on bad input.
    Check(check::Args),
    /// Write a commented starter scenario for a rig (robot, sensor, specimen, what to sweep)
    New(new::Args),
}

fn main() {
    // Argument errors as one line (clap's own message, without the usage block); help and
    // version print in full.
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => match e.kind() {
            clap::error::ErrorKind::DisplayHelp
            | clap::error::ErrorKind::DisplayVersion
            | clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => e.exit(),
            _ => {
                // The message up to the usage block: its first line, and for a missing argument
                // the lines that name it.
                let msg = e.to_string();
                let head: Vec<&str> = msg
                    .lines()
                    .skip_while(|l| l.trim().is_empty())
                    .take_while(|l| !l.trim().is_empty())
                    .map(str::trim)
                    .collect();
                let text = if head.is_empty() {
                    "invalid arguments".to_string()
                } else {
                    head.join(" ")
                };
                note!("{text} (see lasercal --help)");
                std::process::exit(2);
            }
        },
    };
    let result = match cli.command {
        Command::Check(a) => match check::run(a) {
            Ok(code) => std::process::exit(code),
            Err(e) => Err(e),
        },
        Command::Scan(a) => scan::run(a),
        Command::New(a) => new::run(a),
        Command::Merge(a) => merge::run(a),
        Command::Import(a) => import::run(a),
        Command::Compare(a) => compare::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Calibrate(a) => match calibrate::run(a) {
            Ok(code) => std::process::exit(code),
            Err(e) => Err(e),
        },
        Command::Fk(a) => fk::run(a),
        Command::Ik(a) => ik::run(a),
        Command::Run(a) => run::run(a),
        Command::Sweep(a) => sweep::run(a),
    };
    if let Err(e) = result {
        note!("error: {e:#}");
        std::process::exit(2);
    }
}
