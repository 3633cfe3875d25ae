//! `--planner rtguide|fbe|agslam|survey`: which planner drives an episode, its settings from
//! the command line, and building it for a world and camera. Every planner comes back as an
//! `autonomy::explore::Planner`, so the tick has one control path.

use crate::error::Result;
use crate::survey::{SurveyConfig, SurveyPlanner};
use crate::world::World;
use autonomy::camera::Intrinsics;
use autonomy::explore::agslam::{AgslamConfig, AgslamPlanner, TrainMode};
use autonomy::explore::executor::{CollisionEngine, ExecutorConfig};
use autonomy::explore::fbe::{FbeConfig, FbePlanner};
use autonomy::explore::Planner;
use autonomy::mapping::UncertaintyNorm;
use autonomy::planner::information::CameraMount;
use autonomy::planner::{PlannerConfig, RtGuidePlanner};
use serde::{Deserialize, Serialize};

/// Which planner drives the robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum PlannerKind {
    /// RT-GuIDE: information-driven, on the map alone.
    #[value(name = "rtguide")]
    RtGuide,
    /// Frontier-based exploration (AG-SLAM's baseline).
    Fbe,
    /// AG-SLAM's Fisher-information planner.
    Agslam,
    /// The ground-truth lawn-mower survey: knows the world, the upper bound.
    Survey,
}

impl PlannerKind {
    /// Every planner, in the order of the command line's help.
    pub const ALL: [PlannerKind; 4] = [
        PlannerKind::RtGuide,
        PlannerKind::Fbe,
        PlannerKind::Agslam,
        PlannerKind::Survey,
    ];

    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            PlannerKind::RtGuide => "rtguide",
            PlannerKind::Fbe => "fbe",
            PlannerKind::Agslam => "agslam",
            PlannerKind::Survey => "survey",
        }
    }
}

impl std::str::FromStr for PlannerKind {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        PlannerKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| match s {
                "frontier" => {
                    "unknown planner \"frontier\"; frontier exploration is fbe".to_owned()
                }
                "fisher" => {
                    "unknown planner \"fisher\"; AG-SLAM's Fisher planner is agslam".to_owned()
                }
                other => format!("unknown planner {other:?}; use rtguide, fbe, agslam or survey"),
            })
    }
}

/// A planner as the command line names it: a built-in one, or `python:MODULE:CLASS`, a
/// class written in Python that the Python package runs in the same loop (MODULE is a dotted
/// module importable from the working folder, or a `.py` file).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PlannerChoice {
    /// One of splatloop's own.
    Builtin(PlannerKind),
    /// A Python class with a `plan(observation, map)` method.
    Python(PythonPlannerSpec),
}

/// Where a Python planner's class is found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PythonPlannerSpec {
    /// A dotted module name, or a path to a `.py` file.
    pub module: String,
    /// The class in it; made with no arguments.
    pub class: String,
}

impl PlannerChoice {
    /// The built-in planner, or `None` for a Python one.
    pub fn builtin(&self) -> Option<PlannerKind> {
        match self {
            PlannerChoice::Builtin(kind) => Some(*kind),
            PlannerChoice::Python(_) => None,
        }
    }

    /// A short name for folders and tables: the built-in's name, or `python-CLASS`.
    pub fn label(&self) -> String {
        match self {
            PlannerChoice::Builtin(kind) => kind.name().to_owned(),
            PlannerChoice::Python(spec) => format!("python-{}", spec.class),
        }
    }
}

impl From<PlannerKind> for PlannerChoice {
    fn from(kind: PlannerKind) -> Self {
        PlannerChoice::Builtin(kind)
    }
}

impl std::fmt::Display for PlannerChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PlannerChoice::Builtin(kind) => f.write_str(kind.name()),
            PlannerChoice::Python(spec) => write!(f, "python:{}:{}", spec.module, spec.class),
        }
    }
}

impl std::str::FromStr for PlannerChoice {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let Some(rest) = s.strip_prefix("python:") else {
            return s.parse().map(PlannerChoice::Builtin);
        };
        // The class follows the last colon, so a module path may hold one (C:\...).
        match rest.rsplit_once(':') {
            Some((module, class))
                if !module.is_empty()
                    && !class.is_empty()
                    && class.chars().all(|c| c.is_alphanumeric() || c == '_') =>
            {
                Ok(PlannerChoice::Python(PythonPlannerSpec {
                    module: module.to_owned(),
                    class: class.to_owned(),
                }))
            }
            _ => Err(format!(
                "{s:?}: a Python planner is python:MODULE:CLASS (e.g. python:my_planners:Frontier or python:examples/python/frontier.py:FrontierPlanner)"
            )),
        }
    }
}

impl Serialize for PlannerChoice {
    fn serialize<S: serde::Serializer>(
        &self,
        serializer: S,
    ) -> std::result::Result<S::Ok, S::Error> {
        serializer.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for PlannerChoice {
    fn deserialize<D: serde::Deserializer<'de>>(
        deserializer: D,
    ) -> std::result::Result<Self, D::Error> {
        let text = String::deserialize(deserializer)?;
        text.parse().map_err(serde::de::Error::custom)
    }
}

/// RT-GuIDE's settings: the paper's planner and its flagged extensions. One struct serves
/// the command line (its flags), sweeps (sweep.json, by the flags' long names) and the library.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, clap::Args)]
pub struct RtGuideOptions {
    /// RT-GuIDE's uncertainty of a Gaussian: l2 (its displacement's norm, the paper's) or sq
    /// (the squared norm: the paper's Table II ablation). The mapper applies it, so it is set
    /// for every planner but changes only rtguide's choices.
    #[arg(long = "rtguide-uncertainty", value_enum, default_value_t = UncertaintyNorm::L2)]
    #[serde(rename = "rtguide_uncertainty")]
    pub uncertainty: UncertaintyNorm,
    /// RT-GuIDE: seconds of each plan the robot drives before the next plan may replace it
    /// (0: the paper's replanning every second; more is a flagged extension).
    #[arg(long = "rtguide-commit", default_value_t = 0.0)]
    #[serde(rename = "rtguide_commit")]
    pub commit: f64,
    /// RT-GuIDE: reach a viewpoint along the free space of a 2D evidence grid (built from
    /// the depth frames) when its straight edge into the graph crosses the map (a flagged
    /// extension; off is the paper's straight edges).
    #[arg(long = "rtguide-free-space-edges", action = clap::ArgAction::Set, num_args = 0..=1,
          default_value_t = false, default_missing_value = "true", value_name = "BOOL")]
    #[serde(rename = "rtguide_free_space_edges")]
    pub free_space_edges: bool,
    /// RT-GuIDE: give unseen space utility, a viewpoint beside each frontier of a 2D evidence
    /// grid worth the uncertainty of unseen space, reached along the grid's free space, and
    /// candidates clear of unseen cells (a flagged extension, on by default: the paper's
    /// regions of Gaussians alone leave rooms unentered; `false`, with `--rtguide-frontiers-first
    /// false --rtguide-tour false`, is the paper's planner).
    // Sweeps begun before the flag existed ran the paper's planner: their settings lack it.
    #[arg(long = "rtguide-frontier-regions", action = clap::ArgAction::Set, num_args = 0..=1,
          default_value_t = true, default_missing_value = "true", value_name = "BOOL")]
    #[serde(rename = "rtguide_frontier_regions", default)]
    pub frontier_regions: bool,
    /// RT-GuIDE with frontier regions: while a frontier viewpoint is offered, regions'
    /// viewpoints yield to it, so the robot does not linger among nearby regions while a
    /// room is left unseen farther off (a flagged extension, on by default; `false`: they
    /// compete by Omega / e^d).
    // Sweeps begun before the flag existed ran without it: their settings lack it.
    #[arg(long = "rtguide-frontiers-first", action = clap::ArgAction::Set, num_args = 0..=1,
          default_value_t = true, default_missing_value = "true", value_name = "BOOL")]
    #[serde(rename = "rtguide_frontiers_first", default)]
    pub frontiers_first: bool,
    /// RT-GuIDE with frontier regions: end the episode once no frontier is left to view and
    /// every region's Gaussians have settled (they move less per mapping step than Adam
    /// moves one pulled steadily): no loops among revisits, but no refinement either, so
    /// the map's PSNR and density stop where the exploration did (a flagged extension, off
    /// by default: the paper's planner runs to the budget; BENCHMARKS.md has both).
    // Sweeps begun before the flag existed ran to the budget: their settings lack it.
    #[arg(long = "rtguide-finish", action = clap::ArgAction::Set, num_args = 0..=1,
          default_value_t = false, default_missing_value = "true", value_name = "BOOL")]
    #[serde(rename = "rtguide_finish", default)]
    pub finish: bool,
    /// RT-GuIDE: set reached viewpoints aside until no other can be chosen, then offer them
    /// all again, so the revisits once the frontiers are spent tour the map's regions instead
    /// of circling among the viewpoints of the room the robot stands in (a flagged extension,
    /// on by default; `false`: the paper's rule, a reached viewpoint keeps a tenth of its
    /// utility; BENCHMARKS.md has both).
    // Sweeps begun before the flag existed ran without it: their settings lack it.
    #[arg(long = "rtguide-tour", action = clap::ArgAction::Set, num_args = 0..=1,
          default_value_t = true, default_missing_value = "true", value_name = "BOOL")]
    #[serde(rename = "rtguide_tour", default)]
    pub tour: bool,
}

impl Default for RtGuideOptions {
    fn default() -> Self {
        RtGuideOptions {
            uncertainty: UncertaintyNorm::L2,
            commit: 0.0,
            free_space_edges: false,
            frontier_regions: true,
            frontiers_first: true,
            finish: false,
            tour: true,
        }
    }
}

/// AG-SLAM's settings that the command line exposes (the rest are the authors' values).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, clap::Args)]
pub struct AgslamOptions {
    /// agslam: weight of the localisation term log det(J^T J) in the goal score (the
    /// authors' code's 0.5; 0 is the paper's Table 3 ablation).
    #[arg(long = "pose-weight", default_value_t = AgslamConfig::default().pose_weight)]
    pub pose_weight: f64,
    /// agslam: goal poses sampled around the chosen frontier cluster per plan (the authors
    /// use 256; the default is what fits the 1 s planning period on one CPU core, see
    /// BENCHMARKS.md).
    #[arg(long = "agslam-candidates", default_value_t = AgslamConfig::default().candidates)]
    #[serde(rename = "agslam_candidates")]
    pub candidates: usize,
    /// agslam: keep H_train incrementally (each keyframe's Fisher added once) or recompute it
    /// over every keyframe at each plan (full, as the authors' code; slower, same choices on
    /// a settled map).
    #[arg(long = "agslam-train", value_enum, default_value_t = TrainMode::Incremental)]
    #[serde(rename = "agslam_train")]
    pub train: TrainMode,
}

impl Default for AgslamOptions {
    fn default() -> Self {
        AgslamOptions {
            pose_weight: AgslamConfig::default().pose_weight,
            candidates: AgslamConfig::default().candidates,
            train: TrainMode::Incremental,
        }
    }
}

/// FBE's settings that the command line exposes; AG-SLAM's frontier side is FBE's, so they
/// apply to it too.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, clap::Args)]
pub struct FbeOptions {
    /// fbe and agslam: keep the executor's candidates clear of floor not yet seen free at the
    /// robot's body height, as RT-GuIDE's are (a flagged extension of the executor, on by
    /// default: the papers' grids take free space up to 1.3 m, over table tops, and the robot
    /// drove into a table's unseen side; `false` is the papers' baselines; BENCHMARKS.md has
    /// both).
    // Sweeps begun before the flag existed ran without it: their settings lack it.
    #[arg(long = "fbe-avoid-unseen", action = clap::ArgAction::Set, num_args = 0..=1,
          default_value_t = true, default_missing_value = "true", value_name = "BOOL")]
    #[serde(rename = "fbe_avoid_unseen", default)]
    pub avoid_unseen: bool,
    /// fbe and agslam: join frontier cells into one cluster across the free cells that opening
    /// the free mask cut off the robot's part (lines of free cells seen through a door from
    /// afar split its frontier into pieces too small to count, and FBE ended with a hall left
    /// behind the door). A flagged extension of the clustering, on by default; `false` is the
    /// papers' 8-connected clusters (BENCHMARKS.md has both).
    // Sweeps begun before the flag existed ran without it: their settings lack it.
    #[arg(long = "fbe-join-clusters", action = clap::ArgAction::Set, num_args = 0..=1,
          default_value_t = true, default_missing_value = "true", value_name = "BOOL")]
    #[serde(rename = "fbe_join_clusters", default)]
    pub join_clusters: bool,
}

impl Default for FbeOptions {
    fn default() -> Self {
        FbeOptions {
            avoid_unseen: true,
            join_clusters: true,
        }
    }
}

/// Every planner's own settings (each planner reads its own; the survey has none to set).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize, clap::Args)]
pub struct PlannerOptions {
    /// RT-GuIDE's.
    #[command(flatten)]
    #[serde(flatten)]
    pub rtguide: RtGuideOptions,
    /// AG-SLAM's.
    #[command(flatten)]
    #[serde(flatten)]
    pub agslam: AgslamOptions,
    /// FBE's (and AG-SLAM's frontier side).
    #[command(flatten)]
    #[serde(flatten)]
    pub fbe: FbeOptions,
}

/// What the planner needs of the episode to be built.
#[derive(Debug, Clone, Copy)]
pub struct PlannerContext {
    /// The camera's intrinsics.
    pub intrinsics: Intrinsics,
    /// The camera's range, metres.
    pub range: f64,
    /// The episode's seed (goal sampling).
    pub seed: u64,
    /// Seconds between plans.
    pub period: f64,
    /// The most a mapping step moves a Gaussian, metres (`autonomy::planner::settled_omega`):
    /// RT-GuIDE's regions below it have settled.
    pub settled_omega: f64,
}

/// Builds the planner for an episode in `world`.
pub fn build(
    kind: PlannerKind,
    options: &PlannerOptions,
    world: &World,
    context: PlannerContext,
) -> Result<Box<dyn Planner>> {
    match kind {
        PlannerKind::Survey => Ok(Box::new(SurveyPlanner::new(
            world,
            &SurveyConfig::default(),
            context.range,
            context.period,
        )?)),
        explorer => build_explorer(explorer, options, context),
    }
}

/// Builds a planner that needs nothing of the world but what its camera shows (all but the
/// survey, which knows the floor plan), e.g. for a Python planner to wrap.
pub fn build_explorer(
    kind: PlannerKind,
    options: &PlannerOptions,
    context: PlannerContext,
) -> Result<Box<dyn Planner>> {
    // Whatever `--engine` picks for the splats: on the only GPU measured (an H200) the GPU's
    // check was 10x (1e5 Gaussians) and 5x (3e6) slower than the CPU grid (BENCHMARKS.md,
    // "Collision checks: the CPU grid"), so the planners always check on the grid.
    tracing::info!("collision checks: the CPU hash grid (faster than the GPU check at every measured map size)");
    Ok(match kind {
        PlannerKind::RtGuide => {
            let mut config = PlannerConfig::default();
            config.mount.intrinsics = context.intrinsics;
            config.mount.range = context.range;
            let options = &options.rtguide;
            if !(options.commit.is_finite() && options.commit >= 0.0) {
                return Err(crate::error::SimError::InvalidArgument {
                    what: "--rtguide-commit",
                    detail: format!("{}; give seconds, 0 or more", options.commit),
                });
            }
            config.commit_seconds = options.commit;
            config.free_space_edges = options.free_space_edges;
            config.frontier_regions = options.frontier_regions;
            config.frontiers_first = options.frontiers_first;
            config.finish_when_explored = options.finish;
            config.tour_viewpoints = options.tour;
            config.settled_omega = context.settled_omega;
            Box::new(RtGuidePlanner::new(config, CollisionEngine::Grid))
        }
        PlannerKind::Fbe => Box::new(FbePlanner::new(
            FbeConfig {
                seed: context.seed,
                sensing_range: context.range,
                avoid_unseen: options.fbe.avoid_unseen,
                join_clusters: options.fbe.join_clusters,
                ..FbeConfig::default()
            },
            ExecutorConfig::default(),
            CollisionEngine::Grid,
        )),
        PlannerKind::Agslam => {
            let fbe = options.fbe;
            let options = &options.agslam;
            for (what, ok) in [
                (
                    "--pose-weight",
                    options.pose_weight.is_finite() && options.pose_weight >= 0.0,
                ),
                ("--agslam-candidates", options.candidates > 0),
            ] {
                if !ok {
                    return Err(crate::error::SimError::InvalidArgument {
                        what,
                        detail: "give a positive number (a weight may be 0)".to_owned(),
                    });
                }
            }
            let mount = CameraMount {
                intrinsics: context.intrinsics,
                range: context.range,
                ..CameraMount::default()
            };
            Box::new(AgslamPlanner::new(
                AgslamConfig {
                    candidates: options.candidates,
                    pose_weight: options.pose_weight,
                    train: options.train,
                    seed: context.seed,
                    frontier: FbeConfig {
                        avoid_unseen: fbe.avoid_unseen,
                        join_clusters: fbe.join_clusters,
                        sensing_range: context.range,
                        ..AgslamConfig::default().frontier
                    },
                    ..AgslamConfig::default()
                },
                mount,
                ExecutorConfig::default(),
                CollisionEngine::Grid,
            ))
        }
        PlannerKind::Survey => {
            return Err(crate::error::SimError::InvalidArgument {
                what: "planner",
                detail: "the survey knows the world's floor plan, so it is built with the world (Episode::new, or Env(planner=\"survey\"))".to_owned(),
            })
        }
    })
}
