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
use serde::Serialize;

/// Which planner drives the robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PlannerKind {
    /// RT-GuIDE: information-driven, on the map alone.
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

/// The planners' own settings from the command line (each planner reads its own).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PlannerOptions {
    /// RT-GuIDE's uncertainty: l2 (the paper's) or sq (its Table II ablation). The mapper
    /// applies it, so it is set for every planner but changes only rtguide's choices.
    pub rtguide_uncertainty: UncertaintyNorm,
    /// RT-GuIDE: seconds of each plan driven before the next may replace it (0, the paper's
    /// replanning every period; more is a flagged extension).
    pub rtguide_commit: f64,
    /// RT-GuIDE: reach viewpoints along the free space of an evidence grid when their straight
    /// edge is blocked (off: the paper's straight edges).
    pub rtguide_free_space_edges: bool,
    /// RT-GuIDE: a viewpoint beside each frontier of an evidence grid, so unseen space has
    /// utility (on by default; off: the paper's regions of Gaussians only).
    pub rtguide_frontier_regions: bool,
    /// RT-GuIDE: while a frontier viewpoint is offered, regions' viewpoints yield to it (on
    /// by default; off: regions compete with the frontiers by Omega / e^d).
    pub rtguide_frontiers_first: bool,
    /// RT-GuIDE with frontier regions: end the episode once no frontier is left to view and
    /// every region has settled (off by default: run to the budget).
    pub rtguide_finish: bool,
    /// RT-GuIDE: reached viewpoints are set aside until no other can be chosen, so the
    /// revisits tour the map (on by default; off: a reached viewpoint keeps a tenth of its
    /// utility, the paper's rule).
    pub rtguide_tour: bool,
    /// agslam: weight of the localisation term log det(J^T J) (0.5, the authors' code; 0 is
    /// their Table 3 ablation).
    pub pose_weight: f64,
    /// agslam: goal poses sampled around the chosen frontier cluster per plan.
    pub agslam_candidates: usize,
    /// agslam: H_train kept incrementally or recomputed over every keyframe each plan.
    pub agslam_train: TrainMode,
}

impl Default for PlannerOptions {
    fn default() -> Self {
        PlannerOptions {
            rtguide_uncertainty: UncertaintyNorm::L2,
            rtguide_commit: 0.0,
            rtguide_free_space_edges: false,
            rtguide_frontier_regions: true,
            rtguide_frontiers_first: true,
            rtguide_finish: false,
            rtguide_tour: true,
            pose_weight: AgslamConfig::default().pose_weight,
            agslam_candidates: AgslamConfig::default().candidates,
            agslam_train: TrainMode::Incremental,
        }
    }
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
    Ok(match kind {
        PlannerKind::RtGuide => {
            let mut config = PlannerConfig::default();
            config.mount.intrinsics = context.intrinsics;
            config.mount.range = context.range;
            if !(options.rtguide_commit.is_finite() && options.rtguide_commit >= 0.0) {
                return Err(crate::error::SimError::InvalidArgument {
                    what: "--rtguide-commit",
                    detail: format!("{}; give seconds, 0 or more", options.rtguide_commit),
                });
            }
            config.commit_seconds = options.rtguide_commit;
            config.free_space_edges = options.rtguide_free_space_edges;
            config.frontier_regions = options.rtguide_frontier_regions;
            config.frontiers_first = options.rtguide_frontiers_first;
            config.finish_when_explored = options.rtguide_finish;
            config.tour_viewpoints = options.rtguide_tour;
            config.settled_omega = context.settled_omega;
            Box::new(RtGuidePlanner::new(config, CollisionEngine::Grid))
        }
        PlannerKind::Fbe => Box::new(FbePlanner::new(
            FbeConfig {
                seed: context.seed,
                ..FbeConfig::default()
            },
            ExecutorConfig::default(),
            CollisionEngine::Grid,
        )),
        PlannerKind::Agslam => {
            for (what, ok) in [
                (
                    "--pose-weight",
                    options.pose_weight.is_finite() && options.pose_weight >= 0.0,
                ),
                ("--agslam-candidates", options.agslam_candidates > 0),
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
                    candidates: options.agslam_candidates,
                    pose_weight: options.pose_weight,
                    train: options.agslam_train,
                    seed: context.seed,
                    ..AgslamConfig::default()
                },
                mount,
                ExecutorConfig::default(),
                CollisionEngine::Grid,
            ))
        }
        PlannerKind::Survey => Box::new(SurveyPlanner::new(
            world,
            &SurveyConfig::default(),
            context.range,
            context.period,
        )?),
    })
}
