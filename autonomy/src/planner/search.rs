//! Motion-primitive A* (DESIGN.md): chains of 1 s primitives, cost lambda_t tau +
//! integral u^T u, heuristic |p_goal - p| / v_max, every sample point collision-checked;
//! the best N_traj trajectories come back as candidates.

use super::unicycle::{advance, Pose2, Primitives, UnicycleCommand};
use crate::math::TotalF64;
use std::collections::{BinaryHeap, HashSet};

/// Settings of the search.
#[derive(Debug, Clone, PartialEq)]
pub struct SearchConfig {
    /// The primitives.
    pub primitives: Primitives,
    /// lambda_t: cost per second of trajectory.
    pub time_weight: f64,
    /// Path length at which a trajectory is complete (the horizon), metres.
    pub horizon: f64,
    /// Collision sample points over one horizon (129 in the paper: 128 intervals).
    pub samples_per_horizon: usize,
    /// A trajectory ending this close to the goal is complete, metres.
    pub goal_tolerance: f64,
    /// Most segments in a trajectory.
    pub max_segments: usize,
    /// Node expansions before the search stops with what it has.
    pub max_expansions: usize,
    /// Candidates kept (N_traj).
    pub candidates: usize,
}

impl Default for SearchConfig {
    fn default() -> Self {
        SearchConfig {
            primitives: Primitives::rtguide(),
            time_weight: 1.0,
            horizon: 5.0,
            samples_per_horizon: 129,
            goal_tolerance: 0.5,
            max_segments: 10,
            max_expansions: 800,
            candidates: 5,
        }
    }
}

/// A collision-free trajectory.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    /// One control per segment.
    pub controls: Vec<UnicycleCommand>,
    /// Start state, then the state at the end of each segment.
    pub states: Vec<Pose2>,
    /// lambda_t tau + integral u^T u.
    pub cost: f64,
    /// Straight-line distance from the end to the goal, metres.
    pub distance_to_goal: f64,
}

struct Node {
    state: Pose2,
    cost: f64,
    length: f64,
    parent: Option<usize>,
    control: Option<UnicycleCommand>,
    segments: usize,
}

/// An open node: smallest f first, ties by insertion order (so equal inputs give equal
/// outputs).
type Open = std::cmp::Reverse<(TotalF64, usize)>;

/// Sample points of one segment (the end included, the start not) at the horizon's spacing.
pub fn segment_points(s: &Pose2, u: &UnicycleCommand, duration: f64, spacing: f64) -> Vec<Pose2> {
    let length = u.v.abs() * duration;
    let n = ((length / spacing).ceil() as usize).max(1);
    (1..=n)
        .map(|k| advance(s, u, duration * k as f64 / n as f64))
        .collect()
}

fn key(s: &Pose2) -> (i64, i64, i64) {
    let a = s.theta.rem_euclid(std::f64::consts::TAU);
    (
        (s.x / 0.1).round() as i64,
        (s.y / 0.1).round() as i64,
        (a / (std::f64::consts::PI / 12.0)).round() as i64 % 24,
    )
}

/// Searches from `start` toward `goal`. `free` gets the sample states of every primitive
/// of one expansion at once (so a GPU checks them in one dispatch) and says which segments
/// are collision-free. Returns up to `candidates` trajectories, complete ones first; empty
/// when no primitive from the start is collision-free.
pub fn search(
    config: &SearchConfig,
    start: Pose2,
    goal: [f64; 2],
    free: &mut dyn FnMut(&[Vec<Pose2>]) -> Vec<bool>,
) -> Vec<Trajectory> {
    let v_max = config
        .primitives
        .controls
        .iter()
        .fold(0.0f64, |m, u| m.max(u.v.abs()))
        .max(1e-6);
    let h = |s: &Pose2| ((goal[0] - s.x).powi(2) + (goal[1] - s.y).powi(2)).sqrt() / v_max;
    let spacing = config.horizon / (config.samples_per_horizon.max(2) - 1) as f64;
    let mut nodes = vec![Node {
        state: start,
        cost: 0.0,
        length: 0.0,
        parent: None,
        control: None,
        segments: 0,
    }];
    let mut open: BinaryHeap<Open> = BinaryHeap::new();
    open.push(std::cmp::Reverse((TotalF64(h(&start)), 0)));
    let mut closed = HashSet::new();
    let mut complete: Vec<usize> = Vec::new();
    let mut expansions = 0;
    while let Some(std::cmp::Reverse((_, i))) = open.pop() {
        let (state, segments, length) = (nodes[i].state, nodes[i].segments, nodes[i].length);
        let at_goal = h(&state) * v_max <= config.goal_tolerance;
        if i != 0 && (at_goal || length >= config.horizon || segments >= config.max_segments) {
            complete.push(i);
            if complete.len() >= config.candidates {
                break;
            }
            continue;
        }
        if !closed.insert(key(&state)) {
            continue;
        }
        expansions += 1;
        if expansions > config.max_expansions {
            break;
        }
        let segments_samples: Vec<Vec<Pose2>> = config
            .primitives
            .controls
            .iter()
            .map(|u| segment_points(&state, u, config.primitives.duration, spacing))
            .collect();
        let ok = free(&segments_samples);
        for ((u, samples), ok) in config
            .primitives
            .controls
            .iter()
            .zip(&segments_samples)
            .zip(ok)
        {
            if !ok {
                continue;
            }
            let end = *samples.last().unwrap_or(&state);
            let d = config.primitives.duration;
            let cost = nodes[i].cost + config.time_weight * d + (u.v * u.v + u.w * u.w) * d;
            nodes.push(Node {
                state: end,
                cost,
                length: length + u.v.abs() * d,
                parent: Some(i),
                control: Some(*u),
                segments: segments + 1,
            });
            let j = nodes.len() - 1;
            open.push(std::cmp::Reverse((TotalF64(cost + h(&end)), j)));
        }
    }
    // Too few complete ones: fill with the most promising partial trajectories.
    if complete.len() < config.candidates {
        let mut partial: Vec<usize> = (1..nodes.len()).filter(|i| !complete.contains(i)).collect();
        partial.sort_by(|a, b| {
            let fa = nodes[*a].cost + h(&nodes[*a].state);
            let fb = nodes[*b].cost + h(&nodes[*b].state);
            (h(&nodes[*a].state), fa, *a)
                .partial_cmp(&(h(&nodes[*b].state), fb, *b))
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        complete.extend(partial.into_iter().take(config.candidates - complete.len()));
    }
    complete
        .into_iter()
        .map(|end| {
            let mut controls = Vec::new();
            let mut states = Vec::new();
            let mut at = end;
            while let Some(p) = nodes[at].parent {
                controls.push(
                    nodes[at]
                        .control
                        .unwrap_or(UnicycleCommand { v: 0.0, w: 0.0 }),
                );
                states.push(nodes[at].state);
                at = p;
            }
            states.push(start);
            controls.reverse();
            states.reverse();
            Trajectory {
                controls,
                states,
                cost: nodes[end].cost,
                distance_to_goal: h(&nodes[end].state) * v_max,
            }
        })
        .collect()
}
