//! Open-loop control schedules for `record`: a CSV of `t,v,w` rows or a built-in pattern.

use crate::error::{Result, SimError};
use crate::robot::{DriveLimits, UnicycleCommand};
use std::path::Path;

/// Built-in patterns, each safe to drive from the default worlds' spawn poses.
pub const PATTERNS: &[(&str, &str)] = &[
    (
        "circle",
        "v = 0.3 m/s, w = 0.25 rad/s: a 1.2 m radius circle",
    ),
    ("spin", "turn in place at 0.5 rad/s"),
    ("straight", "v = 0.4 m/s straight ahead"),
    (
        "arcs",
        "alternate 4 s of driving a gentle left arc with 2 s turns in place",
    ),
];

/// Piecewise-constant commands: row i holds from `t_i` until `t_{i+1}`.
#[derive(Debug, Clone, PartialEq)]
pub struct ControlSchedule {
    rows: Vec<(f64, UnicycleCommand)>,
    /// The file or pattern it came from, for episode metadata.
    pub source: String,
}

#[derive(Debug, serde::Deserialize)]
struct Row {
    t: f64,
    v: f64,
    w: f64,
}

impl ControlSchedule {
    /// A pattern name from [`PATTERNS`], or else the path of a CSV file.
    pub fn from_arg(arg: &str, limits: &DriveLimits) -> Result<Self> {
        if let Some(schedule) = Self::pattern(arg) {
            return Ok(schedule);
        }
        let path = Path::new(arg);
        if !path.is_file() {
            let names: Vec<_> = PATTERNS.iter().map(|(n, _)| *n).collect();
            return Err(SimError::BadControls {
                source_name: arg.into(),
                detail: format!(
                    "no such file, and not a built-in pattern ({})",
                    names.join(", ")
                ),
            });
        }
        Self::from_csv(path, limits)
    }

    /// A built-in pattern by name.
    pub fn pattern(name: &str) -> Option<Self> {
        let command = |v, w| UnicycleCommand { v, w };
        let rows = match name {
            "circle" => vec![(0.0, command(0.3, 0.25))],
            "spin" => vec![(0.0, command(0.0, 0.5))],
            "straight" => vec![(0.0, command(0.4, 0.0))],
            "arcs" => (0..200)
                .flat_map(|i| {
                    let t = 6.0 * f64::from(i);
                    [(t, command(0.35, 0.1)), (t + 4.0, command(0.0, 0.6))]
                })
                .collect(),
            _ => return None,
        };
        Some(ControlSchedule {
            rows,
            source: format!("pattern:{name}"),
        })
    }

    /// Reads `t,v,w` rows (header optional, `#` comments allowed); times must start at or
    /// after 0 and increase, and commands must respect the drive limits.
    pub fn from_csv(path: &Path, limits: &DriveLimits) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| SimError::io("cannot read controls file", path, e))?;
        let bad = |line: usize, detail: String| SimError::BadControls {
            source_name: path.display().to_string(),
            detail: format!("line {line}: {detail}"),
        };
        let has_header = text
            .lines()
            .map(str::trim)
            .find(|l| !l.is_empty() && !l.starts_with('#'))
            .is_some_and(|l| l.chars().next().is_some_and(|c| c.is_ascii_alphabetic()));
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .comment(Some(b'#'))
            .trim(csv::Trim::All)
            .from_reader(text.as_bytes());
        let mut rows: Vec<(f64, UnicycleCommand)> = Vec::new();
        for (index, record) in reader.records().enumerate() {
            let record = record.map_err(|e| bad(index + 1, e.to_string()))?;
            let line = record.position().map_or(index + 1, |p| p.line() as usize);
            if has_header && rows.is_empty() && record.get(0).is_some_and(|f| f == "t") {
                continue;
            }
            let row: Row = record
                .deserialize(None)
                .map_err(|e| bad(line, format!("expected three numbers t,v,w ({e})")))?;
            if ![row.t, row.v, row.w].iter().all(|x| x.is_finite()) {
                return Err(bad(line, "values must be finite numbers".into()));
            }
            if row.t < 0.0 || rows.last().is_some_and(|(t, _)| row.t <= *t) {
                return Err(bad(
                    line,
                    format!("time {} must be >= 0 and increasing", row.t),
                ));
            }
            if row.v < 0.0 || row.v > limits.max_forward || row.w.abs() > limits.max_turn {
                return Err(bad(
                    line,
                    format!(
                        "command v = {}, w = {} is outside v in [0, {}], |w| <= {}",
                        row.v, row.w, limits.max_forward, limits.max_turn
                    ),
                ));
            }
            rows.push((row.t, UnicycleCommand { v: row.v, w: row.w }));
        }
        if rows.is_empty() {
            return Err(bad(1, "no rows; expected lines of t,v,w".into()));
        }
        Ok(ControlSchedule {
            rows,
            source: path.display().to_string(),
        })
    }

    /// The command in force at time `t` (zero before the first row).
    pub fn at(&self, t: f64) -> UnicycleCommand {
        let index = self.rows.partition_point(|(start, _)| *start <= t);
        index
            .checked_sub(1)
            .map(|i| self.rows[i].1)
            .unwrap_or_default()
    }
}
