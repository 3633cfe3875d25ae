//! `splatloop sweep`: worlds x planners x seeds as separate episodes, locally, on Ray or
//! under Slurm, then the results.

use crate::commands::progress::Progress;
use crate::commands::run::RunOptions;
use crate::episode::PlannerChoice;
use anyhow::{Context, Result};
use clap::{Subcommand, ValueEnum};
use std::path::PathBuf;

/// `splatloop sweep`'s flags.
#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct SweepArgs {
    #[command(subcommand)]
    step: Option<SweepStep>,
    /// Worlds: files and quoted shell patterns, comma-separated ("worlds/suite/*.xml").
    #[arg(long, value_delimiter = ',', required = true)]
    worlds: Vec<String>,
    /// Planners, comma-separated (rtguide, fbe, agslam, survey, or python:MODULE:CLASS, your
    /// own written in Python; its folders and rows are named python-CLASS).
    #[arg(long, value_delimiter = ',', required = true, value_parser = parse_planner)]
    planners: Vec<PlannerChoice>,
    /// Seeds: a list (1,2,5), an inclusive range (1..4), or both (1..3,7).
    #[arg(long, required = true)]
    seeds: Option<String>,
    /// Simulated seconds of every episode.
    #[arg(long, conflicts_with = "budget_survey_factor")]
    budget: Option<f64>,
    /// Run the survey first in each world and seed, then give every planner F times the
    /// survey's time there (the comparison protocol).
    #[arg(long, value_name = "F")]
    budget_survey_factor: Option<f64>,
    /// The survey's own budget with --budget-survey-factor, simulated seconds.
    #[arg(long, default_value_t = 900.0)]
    survey_budget: f64,
    #[command(flatten)]
    options: RunOptions,
    /// The sweep's folder (a rerun with the same settings resumes it).
    #[arg(long, required = true)]
    out: Option<PathBuf>,
    /// Keep each complete episode's images (rgb/, depth/, their lists, transforms.json):
    /// `false` removes them once its metrics.json is written, and from episodes already
    /// complete on a rerun; the numbers, poses and maps stay. A benchmark sweep needs none of
    /// them, and they are most of its disk: about 0.2 GB an episode at 320x240 for 300 s.
    #[arg(long, action = clap::ArgAction::Set, num_args = 0..=1, default_value_t = true,
          default_missing_value = "true", value_name = "BOOL")]
    keep_frames: bool,
    /// Episodes at once (local backend; with ray, the most in flight).
    #[arg(long)]
    jobs: Option<usize>,
    /// local (child processes here), ray (a task per episode on a Ray cluster) or slurm
    /// (write an sbatch array script and its submit script; runs nothing).
    #[arg(long, value_enum, default_value = "local")]
    backend: SweepBackend,
    /// Ray cluster address (`ray start --head` prints it); none starts a local Ray for the
    /// sweep.
    #[arg(long)]
    ray_address: Option<String>,
    /// The Python with Ray (default: .venv/bin/python of the checkout, as scripts/setup.sh
    /// makes it, else python3).
    #[arg(long, env = "SPLATLOOP_PYTHON")]
    ray_python: Option<PathBuf>,
    /// CPUs each episode reserves (Ray's num_cpus, Slurm's --cpus-per-task).
    #[arg(long, default_value_t = 1)]
    cpus_per_episode: usize,
}

/// A sweep's single steps, for clusters and for gathering by hand.
#[derive(Subcommand)]
pub enum SweepStep {
    /// Run one episode of the sweep in OUT by its index (a Slurm array task's command);
    /// nothing when it is already complete.
    Episode {
        /// The sweep's folder.
        #[arg(long)]
        out: PathBuf,
        /// The episode's index (results.csv's `index`).
        #[arg(long)]
        index: usize,
    },
    /// Gather results.csv, summary.md, summary.png and coverage_over_time.png from the
    /// episodes in OUT (what a sweep does when it ends).
    Collect {
        /// The sweep's folder.
        #[arg(long)]
        out: PathBuf,
    },
}

#[derive(Clone, Copy, ValueEnum)]
/// Where a sweep's episodes run.
pub enum SweepBackend {
    /// Child processes on this machine, N at a time.
    Local,
    /// A task per episode on a Ray cluster.
    Ray,
    /// An sbatch array script (nothing runs now).
    Slurm,
}

/// Runs, resumes, or takes one step of a sweep; `Some(code)` (130 or 143) when a signal
/// stopped it: no new episode was started, the running ones were passed the signal, and
/// the same command resumes it.
pub fn sweep(args: SweepArgs) -> Result<Option<u8>> {
    use crate::episode::StopRequest;
    use crate::sweep::{self, Backend, Sweep, SweepSpec};
    let binary = std::env::current_exe().context("cannot find the splatloop binary")?;
    let stop = StopRequest::default();
    for (signal, code) in [
        (signal_hook::consts::SIGINT, StopRequest::SIGINT),
        (signal_hook::consts::SIGTERM, StopRequest::SIGTERM),
    ] {
        signal_hook::flag::register_usize(signal, stop.flag(), code)
            .context("cannot install the signal handlers")?;
    }
    let stopped_code = |code: usize| Some(u8::try_from(code).unwrap_or(1));
    let gathered = |sweep: &Sweep| -> Result<()> {
        let rows = sweep::results::collect(sweep)?;
        let complete = rows.iter().filter(|r| r.status == "complete").count();
        println!(
            "{}: {complete} of {} episodes complete; wrote results.csv, summary.md, summary.png and coverage_over_time.png",
            sweep.out.display(),
            rows.len()
        );
        Ok(())
    };
    match args.step {
        Some(SweepStep::Collect { out }) => {
            gathered(&Sweep::load(&out)?)?;
            return Ok(None);
        }
        Some(SweepStep::Episode { out, index }) => {
            let sweep = Sweep::load(&out)?;
            let outcome = sweep::run_one(&sweep, index, &binary, &stop)?;
            if let Some(code) = stop.requested() {
                eprintln!(
                    "episode {index}: stopped by a signal; rerun the same command to run it again"
                );
                return Ok(stopped_code(code));
            }
            return match outcome {
                None => {
                    println!(
                        "episode {index} is complete: {}",
                        sweep.folder(&sweep.episodes[index]).display()
                    );
                    Ok(None)
                }
                Some(error) => anyhow::bail!("episode {index} failed: {error}"),
            };
        }
        None => {}
    }
    let out = args.out.context("--out is required")?;
    let budget = match (args.budget, args.budget_survey_factor) {
        (Some(s), None) if s > 0.0 && s.is_finite() => sweep::Budget::Seconds(s),
        (None, Some(f)) if f > 0.0 && f.is_finite() => sweep::Budget::SurveyFactor {
            factor: f,
            survey_budget: args.survey_budget,
        },
        (None, None) => anyhow::bail!(
            "give each episode's budget: --budget SECONDS, or --budget-survey-factor F"
        ),
        _ => {
            anyhow::bail!("the budget must be a positive number of seconds (or a positive factor)")
        }
    };
    let run_options = match serde_json::to_value(&args.options)? {
        serde_json::Value::Object(map) => map,
        _ => anyhow::bail!("the run options did not serialise as an object"),
    };
    let spec = SweepSpec {
        worlds: sweep::resolve_worlds(&args.worlds)?,
        planners: args
            .planners
            .iter()
            .map(python_module_absolute)
            .collect::<Result<_>>()?,
        seeds: sweep::parse_seeds(args.seeds.as_deref().unwrap_or_default())?,
        budget,
        run_options,
        keep_frames: args.keep_frames,
    };
    let sweep = Sweep::open(&out, spec)?;
    let backend = match args.backend {
        SweepBackend::Local => Backend::Local {
            jobs: args.jobs.unwrap_or(1),
        },
        SweepBackend::Ray => Backend::Ray {
            address: args.ray_address,
            python: args
                .ray_python
                .unwrap_or_else(|| crate::commands::python::default_python(&binary)),
            jobs: args.jobs,
            cpus_per_episode: args.cpus_per_episode as f64,
        },
        SweepBackend::Slurm => {
            let files = sweep::slurm::write_slurm(&sweep, &binary, args.cpus_per_episode)?;
            println!(
                "wrote {} (array task N runs episode N of {}) and {}; submit with: bash {}",
                files.script.display(),
                sweep.episodes.len(),
                files.submit.display(),
                files.submit.display()
            );
            return Ok(None);
        }
    };
    let mut bar = Progress::new(
        sweep.episodes.len() as u64,
        "{spinner} sweep [{bar:30}] {msg} ({elapsed} wall)",
        "sweep",
    );
    let report = sweep::run_sweep(&sweep, &backend, &binary, &stop, &mut |p| {
        bar.update((p.complete + p.failed) as u64, || {
            let eta = p.eta_seconds.map_or(String::new(), |s| {
                format!(", about {} left", sweep::pace::human_duration(s))
            });
            format!(
                "{}/{} complete, {} running, {} failed{eta}",
                p.complete, p.total, p.running, p.failed
            )
        });
    })?;
    bar.finish();
    println!(
        "sweep: {} episodes: {} complete before, {} run now, {} failed",
        report.total,
        report.skipped,
        report.ran,
        report.failed.len()
    );
    gathered(&sweep)?;
    if let Some(code) = report.stopped {
        eprintln!(
            "sweep: stopped by {}: no episode was started after it, the running ones were written as interrupted; rerun the same command to resume",
            StopRequest::signal_name(code)
        );
        return Ok(stopped_code(code));
    }
    if !report.failed.is_empty() {
        for (index, error) in &report.failed {
            eprintln!(
                "episode {index} failed: {}",
                error.lines().next().unwrap_or("")
            );
        }
        anyhow::bail!(
            "{} episodes failed; results.csv and summary.md say which (rerun the same command to retry them)",
            report.failed.len()
        );
    }
    Ok(None)
}

/// `--planners`: built-in names or python:MODULE:CLASS.
fn parse_planner(text: &str) -> std::result::Result<PlannerChoice, String> {
    text.parse()
}

/// A planner as sweep.json keeps it: a Python planner's `.py` file made absolute, so the
/// episodes find it from wherever they run (a Ray worker, a Slurm node).
fn python_module_absolute(planner: &PlannerChoice) -> Result<String> {
    let PlannerChoice::Python(spec) = planner else {
        return Ok(planner.to_string());
    };
    if !spec.module.ends_with(".py") {
        return Ok(planner.to_string());
    }
    let file = std::path::Path::new(&spec.module);
    let absolute = std::fs::canonicalize(file)
        .with_context(|| format!("cannot find the Python planner's file {}", file.display()))?;
    Ok(format!("python:{}:{}", absolute.display(), spec.class))
}
