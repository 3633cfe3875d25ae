//! `splatloop sweep`: the cross product of worlds, planners and seeds as separate episodes,
//! each `splatloop run` in its own folder `OUT/WORLD/PLANNER/SEED/`, with the results gathered
//! into one table, a summary and charts.
//!
//! - `cli` — the command's flags and its output for a person.
//! - `spec` — what a sweep is (sweep.json), its episodes in a fixed order, their folders, their
//!   state on disk and their command lines.
//! - `execute` — running a batch of episodes: locally N at a time, or as Ray tasks; the
//!   bookkeeping of one finished episode (its log, its recorded failure) is shared.
//! - `pace` — the time a running sweep has left, for its progress line.
//! - `slurm` — the sbatch array script and its per-task command.
//! - `results` — results.csv and summary.md from the episodes' metrics.json.
//! - `charts` — summary.png and coverage_over_time.png.

pub mod charts;
pub mod cli;
pub mod execute;
pub mod pace;
pub mod results;
pub mod slurm;
pub mod spec;

pub use execute::{run_one, run_sweep, Backend, SweepProgress, SweepReport};
pub use spec::{parse_seeds, resolve_worlds, Budget, Episode, EpisodeState, Sweep, SweepSpec};
