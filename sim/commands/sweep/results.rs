//! A sweep's results from its episodes' folders: results.csv (one row per episode: where, who,
//! how it stands, and every figure of its metrics.json) and summary.md (per planner the mean
//! and spread of each figure, a per-world table, and each planner against RT-GuIDE and the
//! survey over matched episodes).

use super::spec::{option_words, Budget, EpisodeState, Sweep};
use crate::error::{Result, SimError};
use serde_json::Value;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// results.csv's columns that measure the machine rather than the episode: wall times and
/// memory. Two backends that run the same episodes agree on every other column.
pub const TIMING_COLUMNS: &[&str] = &[
    "wall_seconds",
    "real_time_factor",
    "mapping.median",
    "mapping.p95",
    "planning.median",
    "planning.p95",
    "camera.median",
    "camera.p95",
    "physics.median",
    "physics.p95",
    "peak_memory_bytes",
];

/// The columns every row has, before the metrics.
const KEY_COLUMNS: [&str; 9] = [
    "index", "world", "kind", "planner", "seed", "spawn", "budget", "status", "error",
];

/// Metrics kept out of the table: the planner's settings go in as one JSON cell, the coverage
/// series is for the plot.
const NESTED: [&str; 3] = ["planner_settings", "coverage_over_time", "psnr_over_time"];

/// One episode's row.
#[derive(Debug, Clone)]
pub struct Row {
    /// Episode index.
    pub index: usize,
    /// World name.
    pub world: String,
    /// World kind.
    pub kind: String,
    /// Planner.
    pub planner: String,
    /// Seed.
    pub seed: u64,
    /// complete, failed or not run.
    pub status: &'static str,
    /// The cells by column name.
    pub cells: BTreeMap<String, String>,
    /// The coverage series (`[t, coverage]`), empty unless complete.
    pub coverage_over_time: Vec<[f64; 2]>,
    /// The PSNR series (`[t, dB]`, on a few hidden views), empty unless complete (and for
    /// episodes written before it was measured).
    pub psnr_over_time: Vec<[f64; 2]>,
}

impl Row {
    /// A numeric cell.
    pub fn number(&self, column: &str) -> Option<f64> {
        self.cells.get(column).and_then(|c| c.parse::<f64>().ok())
    }
}

/// The rows of every episode, in the sweep's order, and the table's columns.
pub fn gather(sweep: &Sweep) -> (Vec<String>, Vec<Row>) {
    let mut columns: Vec<String> = KEY_COLUMNS.iter().map(|c| c.to_string()).collect();
    let mut rows = Vec::new();
    for e in &sweep.episodes {
        let mut cells = BTreeMap::new();
        let mut series = Vec::new();
        let mut psnr_series = Vec::new();
        let state = sweep.state(e);
        let status = match &state {
            EpisodeState::Complete { .. } => "complete",
            EpisodeState::Failed { .. } => "failed",
            EpisodeState::NotRun => "not run",
        };
        cells.insert("index".into(), e.index.to_string());
        cells.insert("world".into(), e.world_name.clone());
        cells.insert("kind".into(), e.kind.clone());
        cells.insert("planner".into(), e.label.clone());
        cells.insert("seed".into(), e.seed.to_string());
        cells.insert("status".into(), status.into());
        if let EpisodeState::Failed { error } = &state {
            cells.insert("error".into(), error.trim().to_string());
        }
        if let Some(episode) = read_json(&sweep.folder(e).join("episode.json")) {
            let pose = &episode["start_pose"];
            if let (Some(x), Some(y), Some(t)) = (
                pose["x"].as_f64(),
                pose["y"].as_f64(),
                pose["theta"].as_f64(),
            ) {
                cells.insert("spawn".into(), format!("{x:.3},{y:.3},{t:.3}"));
            }
            if let Some(b) = episode["config"]["budget"].as_f64() {
                cells.insert("budget".into(), b.to_string());
            }
        }
        if let EpisodeState::Complete { metrics } = &state {
            let mut flat = Vec::new();
            flatten("", metrics, &mut flat);
            for (key, value) in flat {
                if !columns.contains(&key) {
                    columns.push(key.clone());
                }
                cells.insert(key, value);
            }
            series = time_series(&metrics["coverage_over_time"]);
            psnr_series = time_series(&metrics["psnr_over_time"]);
        }
        rows.push(Row {
            index: e.index,
            world: e.world_name.clone(),
            kind: e.kind.clone(),
            planner: e.label.clone(),
            seed: e.seed,
            status,
            cells,
            coverage_over_time: series,
            psnr_over_time: psnr_series,
        });
    }
    (columns, rows)
}

/// `[[t, value], ...]` from metrics.json (nulls skipped).
fn time_series(value: &Value) -> Vec<[f64; 2]> {
    value.as_array().map_or_else(Vec::new, |points| {
        points
            .iter()
            .filter_map(|p| Some([p[0].as_f64()?, p[1].as_f64()?]))
            .collect()
    })
}

/// Scalar leaves of metrics.json as `a.b` columns; the planner's settings as one JSON cell.
fn flatten(prefix: &str, value: &Value, out: &mut Vec<(String, String)>) {
    let Value::Object(map) = value else { return };
    for (key, v) in map {
        let name = if prefix.is_empty() {
            key.clone()
        } else {
            format!("{prefix}.{key}")
        };
        match v {
            _ if prefix.is_empty() && key == NESTED[0] => out.push((name, v.to_string())),
            _ if prefix.is_empty() && NESTED.contains(&key.as_str()) => {}
            Value::Object(_) => flatten(&name, v, out),
            Value::String(s) => out.push((name, s.clone())),
            Value::Number(n) => out.push((name, n.to_string())),
            Value::Bool(b) => out.push((name, b.to_string())),
            Value::Array(_) | Value::Null => {}
        }
    }
}

fn read_json(path: &Path) -> Option<Value> {
    serde_json::from_slice(&std::fs::read(path).ok()?).ok()
}

/// Writes OUT/results.csv.
pub fn write_csv(path: &Path, columns: &[String], rows: &[Row]) -> Result<()> {
    let fail = |e: csv::Error| SimError::io("cannot write", path, std::io::Error::other(e));
    let mut writer = csv::Writer::from_path(path).map_err(fail)?;
    writer.write_record(columns).map_err(fail)?;
    for row in rows {
        writer
            .write_record(
                columns
                    .iter()
                    .map(|c| row.cells.get(c).map_or("", String::as_str)),
            )
            .map_err(fail)?;
    }
    writer
        .flush()
        .map_err(|e| SimError::io("cannot write", path, e))
}

/// Mean, sample standard deviation, minimum and maximum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    /// Values.
    pub n: usize,
    /// Mean.
    pub mean: f64,
    /// Sample standard deviation (0 for one value).
    pub sd: f64,
    /// Smallest.
    pub min: f64,
    /// Largest.
    pub max: f64,
}

/// The spread of `values`; none when empty.
pub fn spread(values: &[f64]) -> Option<Spread> {
    if values.is_empty() {
        return None;
    }
    let n = values.len();
    let mean = values.iter().sum::<f64>() / n as f64;
    let sd = if n > 1 {
        (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
    } else {
        0.0
    };
    let min = values.iter().copied().fold(f64::INFINITY, f64::min);
    let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Some(Spread {
        n,
        mean,
        sd,
        min,
        max,
    })
}

/// The figures of the per-world and matched tables: column, heading, scale to the shown unit.
const HEADLINE: [(&str, &str, f64); 8] = [
    ("evaluation.coverage", "coverage %", 100.0),
    ("evaluation.psnr", "PSNR dB", 1.0),
    ("evaluation.ssim", "SSIM", 1.0),
    ("evaluation.depth_rmse", "depth RMSE m", 1.0),
    ("evaluation.depth_mae", "depth MAE m", 1.0),
    ("path_length", "path m", 1.0),
    ("collision_steps", "collision steps", 1.0),
    ("simulated_seconds", "sim s", 1.0),
];

/// A number at a precision that suits its size.
fn show(v: f64) -> String {
    if !v.is_finite() {
        return v.to_string();
    }
    match v.abs() {
        a if a >= 1000.0 || v.fract() == 0.0 => format!("{v:.0}"),
        a if a >= 10.0 => format!("{v:.1}"),
        a if a >= 1.0 => format!("{v:.2}"),
        _ => format!("{v:.3}"),
    }
}

/// The distinct items in the order they first appear (planners and worlds keep the sweep's
/// order in the tables and the charts).
pub(super) fn first_seen<'a>(items: impl Iterator<Item = &'a str>) -> Vec<&'a str> {
    let mut seen: Vec<&str> = Vec::new();
    for item in items {
        if !seen.contains(&item) {
            seen.push(item);
        }
    }
    seen
}

/// The planners in the sweep's order.
fn planners(rows: &[Row]) -> Vec<&str> {
    first_seen(rows.iter().map(|r| r.planner.as_str()))
}

/// summary.md's text.
pub fn summary(sweep: &Sweep, columns: &[String], rows: &[Row]) -> String {
    let complete: Vec<&Row> = rows.iter().filter(|r| r.status == "complete").collect();
    let failed: Vec<&Row> = rows.iter().filter(|r| r.status == "failed").collect();
    let mut md = String::from("# Sweep summary\n\n");
    write_protocol(&mut md, sweep, rows, complete.len(), failed.len());
    let names = planners(rows);
    write_per_planner(&mut md, columns, &names, &complete);
    write_per_world(&mut md, rows, &names, &complete);
    write_equal_times(&mut md, &names, &complete);
    for (reference, title) in [("rtguide", "RT-GuIDE"), ("survey", "the survey")] {
        write_against(&mut md, reference, title, &names, &complete);
    }
    write_failed(&mut md, &failed);
    md
}

/// The complete episodes of planner `p`.
fn of_planner<'a>(complete: &[&'a Row], p: &str) -> Vec<&'a Row> {
    complete
        .iter()
        .copied()
        .filter(|r| r.planner == p)
        .collect()
}

/// The counts, the budget, surveys cut short and the run options.
fn write_protocol(md: &mut String, sweep: &Sweep, rows: &[Row], complete: usize, failed: usize) {
    let _ = writeln!(
        md,
        "{} episodes ({} worlds x {} planners x {} seeds): {} complete, {} failed, {} not run.",
        rows.len(),
        sweep.spec.worlds.len(),
        planners(rows).len(),
        sweep.spec.seeds.len(),
        complete,
        failed,
        rows.len() - complete - failed
    );
    let budget = match sweep.spec.budget {
        Budget::Seconds(s) => format!("{s} simulated seconds each"),
        Budget::SurveyFactor {
            factor,
            survey_budget,
        } => format!(
            "{factor} x the survey's simulated time in the same world and seed (the survey at most {survey_budget} s)"
        ),
    };
    let _ = writeln!(md, "Budget: {budget}.\n");
    let cut_short = sweep.cut_short_surveys();
    if !cut_short.is_empty() {
        let names: Vec<String> = cut_short
            .iter()
            .map(|e| format!("{} (seed {})", e.world_name, e.seed))
            .collect();
        let _ = writeln!(
            md,
            "**Surveys cut short by the survey budget** (their route was not finished, so the planners there had a multiple of the cap, not of the survey's time; rerun in a new folder with a larger `--survey-budget`): {}.\n",
            names.join(", ")
        );
    }
    let protocol = if sweep.stop_when_done() {
        "each episode ended when its planner said it was done (`--stop-when-done`), so a planner that finishes early had fewer mapping steps: compare at equal times below"
    } else if sweep.factor().is_some() {
        "every episode runs to its budget (the survey to the factor times its route's time): a planner done early holds still while the mapper goes on (`done_at` in results.csv), so every planner of a world and seed has the same simulated time and mapping steps"
    } else {
        "every episode runs to its budget: a planner done early holds still while the mapper goes on (`done_at` in results.csv), so every planner has the same mapping steps"
    };
    let _ = writeln!(md, "Protocol: {protocol}.\n");
    let steps: Vec<String> = planners(rows)
        .iter()
        .filter_map(|p| {
            let values: Vec<f64> = rows
                .iter()
                .filter(|r| r.status == "complete" && r.planner == *p)
                .filter_map(|r| r.number("mapping_steps"))
                .collect();
            spread(&values)
                .map(|s| format!("{p} {} [{}, {}]", show(s.mean), show(s.min), show(s.max)))
        })
        .collect();
    if !steps.is_empty() {
        let _ = writeln!(
            md,
            "Mapping steps (mean [min, max]): {}.\n",
            steps.join("; ")
        );
    }
    let _ = writeln!(
        md,
        "Run options: `{}`\n",
        option_words(&sweep.spec.run_options).join(" ")
    );
}

/// Coverage and PSNR per planner at the same simulated times (up to the shortest episode),
/// so planners compare at equal mapping time as well as at their ends.
fn write_equal_times(md: &mut String, names: &[&str], complete: &[&Row]) {
    let Some(horizon) = complete
        .iter()
        .filter_map(|r| r.coverage_over_time.last().map(|p| p[0]))
        .min_by(f64::total_cmp)
    else {
        return;
    };
    // Four instants on the measurement grid (every 10 s), the last at the horizon's.
    let grid = (horizon / 10.0).floor();
    if grid < 1.0 {
        return;
    }
    let mut instants: Vec<f64> = (1..=4)
        .map(|k| 10.0 * (grid * f64::from(k) / 4.0).round())
        .filter(|t| *t > 0.0)
        .collect();
    instants.dedup();
    let at = |series: &[[f64; 2]], t: f64| {
        series
            .iter()
            .find(|p| (p[0] - t).abs() <= 0.5)
            .map(|p| p[1])
    };
    md.push_str("\n## At equal times\n\nMeans over the complete episodes at the same simulated seconds (coverage of the hidden surface; PSNR on a fixed subsample of the hidden views, so it differs from the final PSNR on all of them).\n\n| planner |");
    for t in &instants {
        let _ = write!(md, " coverage % at {t:.0} s | PSNR dB at {t:.0} s |");
    }
    md.push_str("\n|---|");
    md.push_str(&"---:|---:|".repeat(instants.len()));
    md.push('\n');
    for p in names {
        let group = of_planner(complete, p);
        if group.is_empty() {
            continue;
        }
        let _ = write!(md, "| {p} |");
        for &t in &instants {
            for (series, scale) in [(0, 100.0), (1, 1.0)] {
                let values: Vec<f64> = group
                    .iter()
                    .filter_map(|r| {
                        let s = if series == 0 {
                            &r.coverage_over_time
                        } else {
                            &r.psnr_over_time
                        };
                        at(s, t)
                    })
                    .collect();
                match spread(&values) {
                    Some(s) => {
                        let _ = write!(md, " {} |", show(scale * s.mean));
                    }
                    None => md.push_str(" |"),
                }
            }
        }
        md.push('\n');
    }
}

/// Each figure per planner: mean, sd, min and max.
fn write_per_planner(md: &mut String, columns: &[String], names: &[&str], complete: &[&Row]) {
    let by_planner = |p: &str| of_planner(complete, p);
    md.push_str("## Per planner\n\nMean ± sample standard deviation [min, max] over the complete episodes; timing figures (wall time, memory) are this machine's.\n\n| figure |");
    for p in names {
        let _ = write!(md, " {p} (n = {}) |", by_planner(p).len());
    }
    md.push_str("\n|---|");
    md.push_str(&"---|".repeat(names.len()));
    md.push('\n');
    let skip = ["index", "seed", "budget"];
    for column in columns.iter().filter(|c| !skip.contains(&c.as_str())) {
        let cells: Vec<Option<Spread>> = names
            .iter()
            .map(|p| {
                let values: Vec<f64> = by_planner(p)
                    .iter()
                    .filter_map(|r| r.number(column))
                    .collect();
                spread(&values)
            })
            .collect();
        if cells.iter().all(Option::is_none) {
            continue;
        }
        let _ = write!(md, "| {column} |");
        for cell in cells {
            match cell {
                Some(s) => {
                    let _ = write!(
                        md,
                        " {} ± {} [{}, {}] |",
                        show(s.mean),
                        show(s.sd),
                        show(s.min),
                        show(s.max)
                    );
                }
                None => md.push_str(" |"),
            }
        }
        md.push('\n');
    }
}

/// The headline figures' means per world and planner.
fn write_per_world(md: &mut String, rows: &[Row], names: &[&str], complete: &[&Row]) {
    md.push_str(
        "\n## Per world\n\nMeans over the complete episodes.\n\n| world | kind | planner | n |",
    );
    for (_, heading, _) in HEADLINE {
        let _ = write!(md, " {heading} |");
    }
    md.push_str("\n|---|---|---|---:|");
    md.push_str(&"---:|".repeat(HEADLINE.len()));
    md.push('\n');
    let mut worlds: Vec<(&str, &str)> = Vec::new();
    for r in rows {
        if !worlds.iter().any(|(w, _)| *w == r.world) {
            worlds.push((&r.world, &r.kind));
        }
    }
    for (world, kind) in &worlds {
        for p in names {
            let group: Vec<&Row> = complete
                .iter()
                .copied()
                .filter(|r| r.world == *world && r.planner == *p)
                .collect();
            if group.is_empty() {
                continue;
            }
            let _ = write!(md, "| {world} | {kind} | {p} | {} |", group.len());
            for (column, _, scale) in HEADLINE {
                let values: Vec<f64> = group.iter().filter_map(|r| r.number(column)).collect();
                match spread(&values) {
                    Some(s) => {
                        let _ = write!(md, " {} |", show(scale * s.mean));
                    }
                    None => md.push_str(" |"),
                }
            }
            md.push('\n');
        }
    }
}

/// Each planner minus `reference` over matched episodes.
fn write_against(md: &mut String, reference: &str, title: &str, names: &[&str], complete: &[&Row]) {
    let by_planner = |p: &str| of_planner(complete, p);
    let _ = writeln!(md, "\n## Against {title}\n");
    if !names.contains(&reference) {
        let _ = writeln!(md, "{title} is not in this sweep.");
        return;
    }
    let _ = writeln!(
        md,
        "Mean ± sd of (planner - {reference}) over matched episodes: the same world and seed, both complete.\n"
    );
    md.push_str("| planner | pairs |");
    for (_, heading, _) in HEADLINE {
        let _ = write!(md, " Δ {heading} |");
    }
    md.push_str("\n|---|---:|");
    md.push_str(&"---:|".repeat(HEADLINE.len()));
    md.push('\n');
    for p in names.iter().filter(|p| **p != reference) {
        let pairs: Vec<(&Row, &Row)> = by_planner(p)
            .into_iter()
            .filter_map(|r| {
                complete
                    .iter()
                    .find(|o| o.planner == reference && o.world == r.world && o.seed == r.seed)
                    .map(|o| (r, *o))
            })
            .collect();
        let _ = write!(md, "| {p} | {} |", pairs.len());
        for (column, _, scale) in HEADLINE {
            let deltas: Vec<f64> = pairs
                .iter()
                .filter_map(|(a, b)| Some(scale * (a.number(column)? - b.number(column)?)))
                .collect();
            match spread(&deltas) {
                Some(s) => {
                    let _ = write!(md, " {:+.2} ± {:.2} |", s.mean, s.sd);
                }
                None => md.push_str(" |"),
            }
        }
        md.push('\n');
    }
}

/// The failed episodes with the first line of their error.
fn write_failed(md: &mut String, failed: &[&Row]) {
    if !failed.is_empty() {
        md.push_str("\n## Failed episodes\n\n");
        for r in failed {
            let error = r.cells.get("error").map_or("", String::as_str);
            let _ = writeln!(
                md,
                "- {} ({} / {} / seed {}): {}",
                r.index,
                r.world,
                r.planner,
                r.seed,
                error.lines().next().unwrap_or("")
            );
        }
    }
}

/// Gathers the results and writes results.csv, summary.md, summary.png and
/// coverage_over_time.png into the sweep's folder; returns the rows.
pub fn collect(sweep: &Sweep) -> Result<Vec<Row>> {
    let (columns, rows) = gather(sweep);
    write_csv(&sweep.out.join("results.csv"), &columns, &rows)?;
    let path = sweep.out.join("summary.md");
    std::fs::write(&path, summary(sweep, &columns, &rows))
        .map_err(|e| SimError::io("cannot write", path, e))?;
    super::charts::write_summary_png(&sweep.out.join("summary.png"), &rows)?;
    super::charts::write_coverage_png(&sweep.out.join("coverage_over_time.png"), &rows)?;
    Ok(rows)
}
