//! What a sweep is: its settings (sweep.json, written once and compared on every rerun), its
//! episodes in one fixed order (the order Slurm's array indices and results.csv's rows use),
//! where each one lives on disk, whether it is done, and the `splatloop run` that makes it.

use crate::error::{Result, SimError};
use crate::planners::{PlannerChoice, PlannerKind};
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};
use std::path::{Path, PathBuf};

/// The settings file of a sweep, in its output folder.
pub const SWEEP_FILE: &str = "sweep.json";

/// How long each episode explores.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Budget {
    /// The same simulated seconds for every episode.
    Seconds(f64),
    /// The survey first in each world and seed (at most `survey_budget` simulated seconds),
    /// then every other planner for `factor` times the survey's simulated seconds there: the
    /// comparison protocol (a planner gets the time the upper bound needed, with slack).
    SurveyFactor {
        /// Multiple of the survey's time.
        factor: f64,
        /// The survey's own budget.
        survey_budget: f64,
    },
}

/// Everything that decides a sweep's results; a rerun must match it to resume.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SweepSpec {
    /// MJCF worlds, absolute paths (a rerun from another folder is the same sweep); sweep.json
    /// holds them relative to the sweep's folder, so a committed sweep resumes in any clone.
    pub worlds: Vec<PathBuf>,
    /// Planner names (`splatloop run --planner`).
    pub planners: Vec<String>,
    /// Episode seeds (sensor noise, test set, random spawn).
    pub seeds: Vec<u64>,
    /// How long each episode runs.
    pub budget: Budget,
    /// The run options every episode gets, by long name (`latency: "none"` is `--latency none`).
    pub run_options: Map<String, Value>,
    /// Whether a complete episode keeps its images (`dataset::FRAME_FILES`). It decides no
    /// number, so it is not compared on a rerun: the last command's choice is stored, and a
    /// rerun with `false` removes them from the episodes already complete too.
    #[serde(default = "keep_frames_by_default")]
    pub keep_frames: bool,
}

/// Sweeps written before `keep_frames` existed kept every episode's images.
fn keep_frames_by_default() -> bool {
    true
}

/// One episode of a sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct Episode {
    /// Position in the sweep's order.
    pub index: usize,
    /// The MJCF world.
    pub world: PathBuf,
    /// The world's file stem: its folder name and its name in the results.
    pub world_name: String,
    /// apartment, office or warehouse from the manifest.json beside a generated world;
    /// "custom" for any other world.
    pub kind: String,
    /// The planner as `--planner` takes it.
    pub planner: String,
    /// The planner's name in folders and tables (python-CLASS for a Python one).
    pub label: String,
    /// Seed.
    pub seed: u64,
}

/// Where an episode stands on disk.
#[derive(Debug, Clone, PartialEq)]
pub enum EpisodeState {
    /// Its metrics.json is there and the episode ran to its end.
    Complete {
        /// The parsed metrics.json.
        metrics: Value,
    },
    /// It ran and failed; the recorded error.
    Failed {
        /// What went wrong (the exit status and the end of its log, or metrics.json's `ended`).
        error: String,
    },
    /// Never run, killed, or interrupted: it runs (again) on the next pass.
    NotRun,
}

/// A sweep with its output folder.
#[derive(Debug, Clone)]
pub struct Sweep {
    /// The output folder, absolute.
    pub out: PathBuf,
    /// The settings.
    pub spec: SweepSpec,
    /// The episodes in order: in survey-factor mode first the survey of every world and seed,
    /// then every other planner; otherwise world by world, planner by planner, seed by seed.
    pub episodes: Vec<Episode>,
}

impl Sweep {
    /// Opens the sweep in `out` for these settings: writes sweep.json into a new folder, or
    /// checks that the one there has the same settings (a rerun resumes the same sweep).
    pub fn open(out: &Path, spec: SweepSpec) -> Result<Sweep> {
        std::fs::create_dir_all(out).map_err(|e| SimError::io("cannot create", out, e))?;
        let out = absolute(out)?;
        let file = out.join(SWEEP_FILE);
        // Settings are checked before sweep.json is written: a refused command must not
        // leave a file that then refuses the corrected one as "other settings".
        let sweep = Sweep::new(out.clone(), spec)?;
        if file.exists() {
            let mut stored = read_stored_spec(&file)?;
            let earlier = resolve_stored_worlds(&file, stored.clone());
            if let Some(detail) = first_difference(&earlier, &sweep.spec) {
                return Err(SimError::SweepChanged { path: file, detail });
            }
            if earlier.keep_frames != sweep.spec.keep_frames {
                // Stored as it was read (worlds relative), for `sweep episode` to follow.
                stored.keep_frames = sweep.spec.keep_frames;
                crate::dataset::write_json(&file, &stored)?;
            }
        } else {
            let stored = SweepSpec {
                worlds: sweep
                    .spec
                    .worlds
                    .iter()
                    .map(|w| relative_to(&out, w))
                    .collect(),
                ..sweep.spec.clone()
            };
            crate::dataset::write_json(&file, &stored)?;
        }
        Ok(sweep)
    }

    /// The sweep already in `out` (for `sweep episode` and `sweep collect`).
    pub fn load(out: &Path) -> Result<Sweep> {
        let file = out.join(SWEEP_FILE);
        if !file.exists() {
            return Err(SimError::MissingFile {
                what: "sweep (sweep.json)",
                path: file,
            });
        }
        let spec = read_spec(&file)?;
        Sweep::new(absolute(out)?, spec)
    }

    fn new(out: PathBuf, spec: SweepSpec) -> Result<Sweep> {
        let invalid = |detail: String| SimError::InvalidArgument {
            what: "sweep",
            detail,
        };
        if spec.worlds.is_empty() || spec.planners.is_empty() || spec.seeds.is_empty() {
            return Err(invalid(
                "it needs at least one world, one planner and one seed".into(),
            ));
        }
        let mut labels: Vec<(String, &String)> = Vec::new();
        for planner in &spec.planners {
            let label = planner.parse::<PlannerChoice>().map_err(invalid)?.label();
            if let Some((_, other)) = labels.iter().find(|(l, _)| *l == label) {
                return Err(invalid(format!(
                    "{other} and {planner} would share the folder {label}; rename one class"
                )));
            }
            labels.push((label, planner));
        }
        let mut worlds: Vec<(String, PathBuf, String)> = Vec::new();
        for world in &spec.worlds {
            let name = world
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .ok_or_else(|| invalid(format!("{} has no file name", world.display())))?;
            if let Some((_, other, _)) = worlds.iter().find(|(n, _, _)| *n == name) {
                return Err(invalid(format!(
                    "two worlds are named {name} ({} and {}): episode folders are named by the file; rename one",
                    other.display(),
                    world.display()
                )));
            }
            worlds.push((name, world.clone(), kind_of(world)));
        }
        let mut episodes = Vec::new();
        let mut push = |(name, world, kind): &(String, PathBuf, String), planner: &str, seed| {
            episodes.push(Episode {
                index: episodes.len(),
                world: world.clone(),
                world_name: name.clone(),
                kind: kind.clone(),
                planner: planner.to_string(),
                label: planner
                    .parse::<PlannerChoice>()
                    .map_or_else(|_| planner.to_string(), |p| p.label()),
                seed,
            });
        };
        let survey = PlannerKind::Survey.name();
        let surveyed = matches!(spec.budget, Budget::SurveyFactor { .. });
        if surveyed {
            for world in &worlds {
                for &seed in &spec.seeds {
                    push(world, survey, seed);
                }
            }
        }
        for world in &worlds {
            for planner in spec.planners.iter().filter(|p| !surveyed || *p != survey) {
                for &seed in &spec.seeds {
                    push(world, planner, seed);
                }
            }
        }
        Ok(Sweep {
            out,
            spec,
            episodes,
        })
    }

    /// The episode's folder: OUT/WORLD/PLANNER/SEED.
    pub fn folder(&self, e: &Episode) -> PathBuf {
        self.out
            .join(&e.world_name)
            .join(&e.label)
            .join(e.seed.to_string())
    }

    /// The episode's output (stdout and stderr of its run), beside its folder.
    pub fn log(&self, e: &Episode) -> PathBuf {
        self.sibling(e, "log")
    }

    /// The error of the episode's last failed run, beside its folder.
    pub fn failure_file(&self, e: &Episode) -> PathBuf {
        self.sibling(e, "failed.txt")
    }

    fn sibling(&self, e: &Episode, extension: &str) -> PathBuf {
        self.out
            .join(&e.world_name)
            .join(&e.label)
            .join(format!("{}.{extension}", e.seed))
    }

    /// Where the episode stands on disk.
    pub fn state(&self, e: &Episode) -> EpisodeState {
        let metrics = std::fs::read(self.folder(e).join("metrics.json"))
            .ok()
            .and_then(|bytes| serde_json::from_slice::<Value>(&bytes).ok());
        if let Some(metrics) = metrics {
            let ended = metrics["ended"].as_str().unwrap_or_default();
            if ended.starts_with("error") {
                return EpisodeState::Failed {
                    error: ended.to_string(),
                };
            }
            if !ended.starts_with("interrupted") {
                return EpisodeState::Complete { metrics };
            }
        }
        match std::fs::read_to_string(self.failure_file(e)) {
            Ok(error) => EpisodeState::Failed { error },
            Err(_) => EpisodeState::NotRun,
        }
    }

    /// The survey factor (survey-factor mode).
    pub fn factor(&self) -> Option<f64> {
        match self.spec.budget {
            Budget::SurveyFactor { factor, .. } => Some(factor),
            Budget::Seconds(_) => None,
        }
    }

    /// The complete surveys (survey-factor mode) that ended before their route did, on the
    /// sweep's `survey_budget`: the budgets they set are the survey budget's multiple, not the
    /// survey's time, so a user should rerun with a larger `--survey-budget`.
    pub fn cut_short_surveys(&self) -> Vec<&Episode> {
        if self.factor().is_none() {
            return Vec::new();
        }
        let survey = PlannerKind::Survey.name();
        self.episodes
            .iter()
            .filter(|e| e.planner == survey)
            .filter(|e| match self.state(e) {
                // A survey that ran on has `done_at` (null when its route was cut short).
                EpisodeState::Complete { metrics } => match metrics.get("done_at") {
                    Some(done_at) => done_at.is_null(),
                    None => metrics["ended"].as_str() != Some(crate::survey::SURVEY_COMPLETE),
                },
                _ => false,
            })
            .collect()
    }

    /// The survey episode whose time sets this episode's budget (survey-factor mode).
    pub fn survey_of(&self, e: &Episode) -> Option<&Episode> {
        let survey = PlannerKind::Survey.name();
        match self.spec.budget {
            Budget::SurveyFactor { .. } if e.planner != survey => self
                .episodes
                .iter()
                .find(|s| s.planner == survey && s.world == e.world && s.seed == e.seed),
            _ => None,
        }
    }

    /// The episode's budget in simulated seconds; in survey-factor mode its survey must be
    /// complete.
    pub fn budget_of(&self, e: &Episode) -> Result<f64> {
        match self.spec.budget {
            Budget::Seconds(s) => Ok(s),
            Budget::SurveyFactor {
                survey_budget,
                factor,
            } if self.survey_of(e).is_none() => Ok(if self.survey_runs_on() {
                // It runs to `factor` x its route's time (`--done-factor`), within this.
                factor * survey_budget
            } else {
                survey_budget
            }),
            Budget::SurveyFactor { factor, .. } => {
                let survey = self.survey_of(e).ok_or_else(|| SimError::SweepEpisode {
                    index: e.index,
                    detail: "no survey to set its budget".into(),
                })?;
                match self.state(survey) {
                    // A survey that ran on after its route (`--done-factor` in its
                    // episode.json) already took the factor; one that stopped did not.
                    EpisodeState::Complete { metrics } => metrics["simulated_seconds"]
                        .as_f64()
                        .map(|t| if self.ran_on(survey) { t } else { factor * t })
                        .ok_or_else(|| SimError::SweepEpisode {
                            index: e.index,
                            detail: format!(
                                "the survey's metrics.json in {} has no simulated_seconds",
                                self.folder(survey).display()
                            ),
                        }),
                    _ => Err(SimError::SweepEpisode {
                        index: e.index,
                        detail: format!(
                            "its budget is {factor} x the survey's time in {} (seed {}), and that survey (episode {}) has not completed; run it first (see {})",
                            e.world_name,
                            e.seed,
                            survey.index,
                            self.log(survey).display()
                        ),
                    }),
                }
            }
        }
    }

    /// The episodes in the batches they must run in: the surveys before the planners whose
    /// budgets they set; one batch otherwise.
    pub fn batches(&self) -> Vec<Vec<usize>> {
        let (first, rest): (Vec<usize>, Vec<usize>) = self
            .episodes
            .iter()
            .map(|e| e.index)
            .partition(|&i| self.survey_of(&self.episodes[i]).is_none());
        [first, rest]
            .into_iter()
            .filter(|b| !b.is_empty())
            .collect()
    }

    /// The arguments of the `splatloop run` that makes this episode.
    pub fn command(&self, e: &Episode) -> Result<Vec<String>> {
        let budget = self.budget_of(e)?;
        let mut args: Vec<String> = vec![
            "run".into(),
            "--world".into(),
            e.world.display().to_string(),
            "--planner".into(),
            e.planner.clone(),
            "--seed".into(),
            e.seed.to_string(),
            "--budget".into(),
            budget.to_string(),
            "--out".into(),
            self.folder(e).display().to_string(),
            "--overwrite".into(),
        ];
        let mut options = self.spec.run_options.clone();
        if let (Some(factor), None) = (self.factor(), self.survey_of(e)) {
            if self.survey_runs_on() {
                args.extend(["--done-factor".into(), factor.to_string()]);
            } else {
                // A survey cannot end before its route does: with a factor under 1 (or the
                // old protocol) it stops there.
                options.insert("stop_when_done".into(), Value::Bool(true));
            }
        }
        args.extend(option_words(&options));
        Ok(args)
    }

    /// Whether the surveys of a survey-factor sweep run on to the factor times their
    /// route's time (a factor of 1 or more, and not `--stop-when-done`).
    fn survey_runs_on(&self) -> bool {
        self.factor().is_some_and(|f| f >= 1.0) && !self.stop_when_done()
    }

    /// Whether a survey episode ran on after its route (`--done-factor` in its episode.json),
    /// so its simulated time is already the planners' budget.
    fn ran_on(&self, survey: &Episode) -> bool {
        std::fs::read(self.folder(survey).join("episode.json"))
            .ok()
            .and_then(|bytes| serde_json::from_slice::<Value>(&bytes).ok())
            .is_some_and(|episode| episode["config"]["done_factor"].is_number())
    }

    /// Whether the sweep's episodes end when their planner is done (`--stop-when-done`, the
    /// old protocol) rather than at their budget.
    pub fn stop_when_done(&self) -> bool {
        self.spec.run_options.get("stop_when_done") == Some(&Value::Bool(true))
    }
}

/// Run options that add files to an episode folder and change none of its numbers: a sweep
/// may go on with them changed (an episode written before them has none of their files).
const FILES_ONLY: &[&str] = &["masks"];

/// Run options as command-line words: `{"latency": "none", "rtguide_free_space_edges": true}`
/// is `--latency none --rtguide-free-space-edges`; a false switch is written out
/// (`--rtguide-frontier-regions false`), since a switch may be on by default.
pub fn option_words(options: &Map<String, Value>) -> Vec<String> {
    let mut words = Vec::new();
    for (key, value) in options {
        let flag = format!("--{}", key.replace('_', "-"));
        match value {
            Value::Bool(true) => words.push(flag),
            Value::Bool(false) => words.extend([flag, "false".into()]),
            Value::Null => {}
            Value::String(s) => words.extend([flag, s.clone()]),
            other => words.extend([flag, other.to_string()]),
        }
    }
    words
}

/// The most seeds one sweep takes: each is an episode per world and planner, listed in
/// sweep.json and results.csv.
pub const MAX_SEEDS: usize = 10_000;

/// Seeds from `1,2,5`, `1..4` (inclusive, as in a shell's `{1..4}`) or a mix (`1..3,7`), at
/// most [`MAX_SEEDS`].
pub fn parse_seeds(text: &str) -> Result<Vec<u64>> {
    let invalid = |detail: String| SimError::InvalidArgument {
        what: "--seeds",
        detail,
    };
    let too_many = || {
        invalid(format!(
            "{text} is more than {MAX_SEEDS} seeds; split the sweep into several (each its own --out)"
        ))
    };
    let number = |s: &str| {
        s.trim().parse::<u64>().map_err(|e| {
            invalid(format!(
                "{s:?} is not a seed ({e}); use a list (1,2,5) or a range (1..4)"
            ))
        })
    };
    let mut seeds = Vec::new();
    for part in text.split(',').filter(|p| !p.trim().is_empty()) {
        if let Some((a, b)) = part.split_once("..") {
            let (a, b) = (number(a)?, number(b)?);
            if b < a {
                return Err(invalid(format!("the range {part} runs backwards")));
            }
            if b - a >= MAX_SEEDS as u64 - seeds.len() as u64 {
                return Err(too_many());
            }
            seeds.extend(a..=b);
        } else {
            seeds.push(number(part)?);
        }
        if seeds.len() > MAX_SEEDS {
            return Err(too_many());
        }
    }
    if seeds.is_empty() {
        return Err(invalid("no seeds given".into()));
    }
    let mut sorted = seeds.clone();
    sorted.sort_unstable();
    if let Some(w) = sorted.windows(2).find(|w| w[0] == w[1]) {
        return Err(invalid(format!("seed {} is given twice", w[0])));
    }
    Ok(seeds)
}

/// World files from paths and shell-style patterns (`worlds/suite/office_*.xml`, quoted so
/// the sweep expands them), in the order given, each pattern's matches sorted; absolute.
pub fn resolve_worlds(items: &[String]) -> Result<Vec<PathBuf>> {
    let mut worlds = Vec::new();
    for item in items.iter().map(|s| s.trim()).filter(|s| !s.is_empty()) {
        let matches: Vec<PathBuf> = if item.contains(['*', '?', '[']) {
            let pattern = glob::glob(item).map_err(|e| SimError::InvalidArgument {
                what: "--worlds",
                detail: format!("bad pattern {item:?}: {e}"),
            })?;
            let mut found: Vec<PathBuf> = pattern.filter_map(|p| p.ok()).collect();
            found.sort();
            if found.is_empty() {
                return Err(SimError::InvalidArgument {
                    what: "--worlds",
                    detail: format!("no file matches {item:?}"),
                });
            }
            found
        } else {
            vec![PathBuf::from(item)]
        };
        for path in matches {
            if !path.is_file() {
                return Err(SimError::MissingFile {
                    what: "world",
                    path,
                });
            }
            let path = absolute(&path)?;
            if !worlds.contains(&path) {
                worlds.push(path);
            }
        }
    }
    if worlds.is_empty() {
        return Err(SimError::InvalidArgument {
            what: "--worlds",
            detail: "no worlds given".into(),
        });
    }
    Ok(worlds)
}

/// A world's kind from the manifest.json beside it (`world suite` writes one), else "custom".
fn kind_of(world: &Path) -> String {
    let manifest = world.with_file_name("manifest.json");
    let file = world.file_name().map(|f| f.to_string_lossy().into_owned());
    std::fs::read(&manifest)
        .ok()
        .and_then(|bytes| serde_json::from_slice::<Vec<Value>>(&bytes).ok())
        .and_then(|entries| {
            entries.into_iter().find_map(|entry| {
                (entry["file"].as_str() == file.as_deref())
                    .then(|| entry["kind"].as_str().map(str::to_string))
                    .flatten()
            })
        })
        .unwrap_or_else(|| "custom".into())
}

/// sweep.json, with its worlds resolved against the sweep's folder (sweeps written before
/// they were stored relative hold absolute paths, which stay as they are).
fn read_spec(file: &Path) -> Result<SweepSpec> {
    Ok(resolve_stored_worlds(file, read_stored_spec(file)?))
}

/// sweep.json as it is stored (worlds relative to its folder).
fn read_stored_spec(file: &Path) -> Result<SweepSpec> {
    let bytes = std::fs::read(file).map_err(|e| SimError::io("cannot read", file, e))?;
    serde_json::from_slice(&bytes).map_err(|source| SimError::BadJson {
        path: file.to_path_buf(),
        source,
    })
}

/// A stored spec's relative worlds resolved against the folder of its `file`.
fn resolve_stored_worlds(file: &Path, mut spec: SweepSpec) -> SweepSpec {
    let folder = file.parent().unwrap_or(Path::new("."));
    for world in &mut spec.worlds {
        if world.is_relative() {
            let joined = folder.join(&*world);
            *world = std::fs::canonicalize(&joined).unwrap_or(joined);
        }
    }
    spec
}

/// `path` relative to the folder `base` (both absolute, without `.` or `..`): up from `base`
/// to their common ancestor, then down.
fn relative_to(base: &Path, path: &Path) -> PathBuf {
    let (b, p): (Vec<_>, Vec<_>) = (base.components().collect(), path.components().collect());
    let common = b.iter().zip(&p).take_while(|(x, y)| x == y).count();
    if common == 0 {
        return path.to_path_buf();
    }
    let mut out = PathBuf::new();
    for _ in common..b.len() {
        out.push("..");
    }
    for c in &p[common..] {
        out.push(c.as_os_str());
    }
    out
}

/// The first setting in which two sweeps differ, as a person would say it.
fn first_difference(earlier: &SweepSpec, now: &SweepSpec) -> Option<String> {
    let show = |v: &dyn std::fmt::Debug| format!("{v:?}");
    if earlier.worlds != now.worlds {
        return Some(format!(
            "worlds were {} and are now {}",
            show(&earlier.worlds),
            show(&now.worlds)
        ));
    }
    if earlier.planners != now.planners {
        return Some(format!(
            "planners were {:?} and are now {:?}",
            earlier.planners, now.planners
        ));
    }
    if earlier.seeds != now.seeds {
        return Some(format!(
            "seeds were {:?} and are now {:?}",
            earlier.seeds, now.seeds
        ));
    }
    if earlier.budget != now.budget {
        return Some(format!(
            "the budget was {:?} and is now {:?}",
            earlier.budget, now.budget
        ));
    }
    let keys = earlier.run_options.keys().chain(now.run_options.keys());
    for key in keys {
        let (a, b) = (earlier.run_options.get(key), now.run_options.get(key));
        // A switch added since the sweep began is missing from it; off, it is what ran then
        // (a new switch's missing key reads as off).
        let added_off = a.is_none() && b == Some(&Value::Bool(false));
        if a != b && !added_off && !FILES_ONLY.contains(&key.as_str()) {
            return Some(format!(
                "--{} was {} and is now {}",
                key.replace('_', "-"),
                a.map_or("unset".into(), Value::to_string),
                b.map_or("unset".into(), Value::to_string)
            ));
        }
    }
    None
}

fn absolute(path: &Path) -> Result<PathBuf> {
    std::fs::canonicalize(path).map_err(|e| SimError::io("cannot resolve", path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A clone at `root`: a world file and a sweep folder beside it.
    fn clone_at(root: &Path) -> (PathBuf, PathBuf) {
        let worlds = root.join("worlds");
        std::fs::create_dir_all(&worlds).expect("worlds folder");
        let world = worlds.join("room.xml");
        std::fs::write(&world, "<mujoco/>").expect("world file");
        (
            std::fs::canonicalize(world).expect("world"),
            root.join("runs/sweep"),
        )
    }

    fn spec(world: &Path) -> SweepSpec {
        SweepSpec {
            worlds: vec![world.to_path_buf()],
            planners: vec!["survey".into()],
            seeds: vec![3],
            budget: Budget::Seconds(10.0),
            run_options: Map::new(),
            keep_frames: true,
        }
    }

    #[test]
    fn a_sweep_stores_its_worlds_relative_and_resumes_in_another_clone() {
        let tmp = tempfile::tempdir().expect("temporary folder");
        let (world, out) = clone_at(&tmp.path().join("a"));
        Sweep::open(&out, spec(&world)).expect("a new sweep");
        let stored: Value =
            serde_json::from_slice(&std::fs::read(out.join(SWEEP_FILE)).expect("sweep.json"))
                .expect("json");
        assert_eq!(stored["worlds"][0], "../../worlds/room.xml");
        assert_eq!(Sweep::load(&out).expect("loads").spec.worlds, vec![world]);
        // The same tree elsewhere (another clone with the sweep committed) resumes it ...
        let (moved, moved_out) = clone_at(&tmp.path().join("b"));
        std::fs::create_dir_all(&moved_out).expect("sweep folder");
        std::fs::copy(out.join(SWEEP_FILE), moved_out.join(SWEEP_FILE)).expect("copy");
        Sweep::open(&moved_out, spec(&moved)).expect("the same sweep");
        // ... and still refuses another world.
        let (_, elsewhere) = clone_at(&tmp.path().join("c"));
        let other = tmp.path().join("c/worlds/room.xml");
        std::fs::remove_dir_all(&elsewhere).ok();
        assert!(matches!(
            Sweep::open(
                &moved_out,
                spec(&std::fs::canonicalize(other).expect("world"))
            ),
            Err(SimError::SweepChanged { .. })
        ));
    }

    #[test]
    fn only_surveys_that_ended_before_their_route_are_cut_short() {
        let tmp = tempfile::tempdir().expect("temporary folder");
        let (world, out) = clone_at(tmp.path());
        let mut settings = spec(&world);
        settings.planners = vec!["survey".into(), "fbe".into()];
        settings.seeds = vec![3, 4, 5];
        settings.budget = Budget::SurveyFactor {
            factor: 1.5,
            survey_budget: 100.0,
        };
        let sweep = Sweep::open(&out, settings).expect("a new sweep");
        let ended = |planner: &str, seed: u64, why: &str| {
            let e = sweep
                .episodes
                .iter()
                .find(|e| e.planner == planner && e.seed == seed)
                .expect("episode");
            let folder = sweep.folder(e);
            std::fs::create_dir_all(&folder).expect("episode folder");
            let metrics = serde_json::json!({ "ended": why, "simulated_seconds": 100.0 });
            std::fs::write(folder.join("metrics.json"), metrics.to_string()).expect("metrics");
        };
        ended("survey", 3, crate::survey::SURVEY_COMPLETE);
        ended("survey", 4, "budget");
        ended("fbe", 3, "budget");
        // Seed 5's survey has not run: not cut short, just not complete.
        let cut: Vec<u64> = sweep.cut_short_surveys().iter().map(|e| e.seed).collect();
        assert_eq!(cut, [4]);
        // With a budget in seconds no survey sets a budget, so none is cut short.
        let mut seconds = sweep;
        seconds.spec.budget = Budget::Seconds(100.0);
        assert!(seconds.cut_short_surveys().is_empty());
    }

    #[test]
    fn a_switch_added_since_a_sweep_began_resumes_it_when_off() {
        let world = Path::new("/r/worlds/room.xml");
        let earlier = spec(world);
        let mut now = spec(world);
        now.run_options
            .insert("rtguide_frontiers_first".into(), Value::Bool(false));
        assert_eq!(first_difference(&earlier, &now), None);
        now.run_options
            .insert("rtguide_frontiers_first".into(), Value::Bool(true));
        assert!(first_difference(&earlier, &now).is_some());
        // An option the sweep had and the rerun lacks is still a difference.
        assert!(first_difference(&now, &earlier).is_some());
    }

    #[test]
    fn relative_paths_go_up_to_the_common_folder_then_down() {
        let cases = [
            ("/r/a/out", "/r/worlds/w.xml", "../../worlds/w.xml"),
            ("/r/out", "/r/out/w.xml", "w.xml"),
            ("/r", "/s/w.xml", "../s/w.xml"),
        ];
        for (base, path, want) in cases {
            let rel = relative_to(Path::new(base), Path::new(path));
            assert_eq!(rel, PathBuf::from(want), "{base} -> {path}");
            // Joined back onto the base and normalised, it is the path again.
            let mut back = PathBuf::from(base);
            for c in rel.components() {
                match c {
                    std::path::Component::ParentDir => {
                        back.pop();
                    }
                    other => back.push(other),
                }
            }
            assert_eq!(back, PathBuf::from(path));
        }
    }
}
