//! RT-GuIDE's planner: frontiers first, frontier viewpoints, the tour, the finish, the unseen
//! clearance and the aim along a graph path, on hand-made grids and maps.

use super::extensions::look_toward;
use super::*;
use crate::explore::evidence::CellClass;
use crate::explore::unseen::UnfreeDistance;

/// A straight drive east along y = `y` for `seconds` at 0.5 m/s, one segment per second.
fn drive_east(y: f64, seconds: usize) -> search::Trajectory {
    let u = UnicycleCommand { v: 0.5, w: 0.0 };
    let mut states = vec![Pose2 {
        x: 0.5,
        y,
        theta: 0.0,
    }];
    for _ in 0..seconds {
        let s = *states.last().expect("a state");
        states.push(crate::drive::advance(&s, &u, 1.0));
    }
    search::Trajectory {
        controls: vec![u; seconds],
        states,
        cost: 0.0,
        distance_to_goal: 0.0,
    }
}

/// Seen floor: a 7 x 4 m room round the origin and a 1.5 m wide corridor north from it to
/// y = 14 m, where it opens onto unseen space; walls two cells thick elsewhere. And a map
/// of one block of Gaussians 3 m east of the origin that still moves (Omega 1e-3).
fn room_with_a_corridor() -> (EvidenceGrid, GaussianMap) {
    use crate::gaussians::Gaussians;
    let inside = |x: f64, y: f64| {
        ((-2.0..5.0).contains(&x) && (-2.0..2.0).contains(&y))
            || ((-0.75..0.75).contains(&x) && (-2.0..14.0).contains(&y))
    };
    let grid = seen_floor(inside, [-60, -60], [120, 300], |_, y| y < 14.0);
    let mut g = Gaussians::default();
    for k in 0..400 {
        let (i, j) = ((k % 20) as f32, (k / 20) as f32);
        g.push([3.0 + 0.01 * i, 0.01 * j, 0.5], 0.02, 0.9, [0.5; 3]);
    }
    (grid, GaussianMap::new(g, vec![1e-3; 400]))
}

fn frontiers_first_planner(grid: &EvidenceGrid, frontiers_first: bool) -> RtGuidePlanner {
    let mut planner = RtGuidePlanner::new(
        PlannerConfig {
            frontier_regions: true,
            frontiers_first,
            ..PlannerConfig::default()
        },
        CollisionEngine::Grid,
    );
    planner.evidence = Some(grid.clone());
    planner
}

#[test]
fn with_frontiers_first_a_far_frontier_outranks_a_near_region() {
    let (grid, map) = room_with_a_corridor();
    let robot = Pose2 {
        x: 0.0,
        y: 0.0,
        theta: 0.0,
    };
    let target = |frontiers_first: bool| {
        let mut planner = frontiers_first_planner(&grid, frontiers_first);
        let plan = planner.plan(&map, robot).expect("a plan");
        let offers = planner.frontier_offers.clone();
        (plan.guidance.last().copied().expect("guidance"), offers)
    };
    // By Omega / e^d the block's viewpoints win (1e-3 e^-1.6 against 0.75 e^-13).
    let (paper, offers) = target(false);
    assert_eq!(
        offers.len(),
        1,
        "one frontier, the corridor's end: {offers:?}"
    );
    assert!(paper[1] < 5.0, "{paper:?}");
    // First, the frontier: its viewpoint within reach of the corridor's end.
    let (first, _) = target(true);
    assert!(
        (first[1] - 14.0).abs() <= FRONTIER_GOAL_RADIUS + 0.1 && first[0].abs() < 0.75,
        "{first:?}"
    );
}

#[test]
fn with_frontiers_first_a_frontier_that_cannot_be_chosen_gives_the_regions_back() {
    let (grid, map) = room_with_a_corridor();
    // Where the corridor's frontier viewpoint lies, seen from inside the corridor.
    let far = Pose2 {
        x: 0.0,
        y: 8.0,
        theta: 0.0,
    };
    let mut probe = frontiers_first_planner(&grid, true);
    probe.plan(&map, far).expect("a plan");
    assert_eq!(probe.frontier_offers.len(), 1);
    let offer = probe.frontier_offers[0].0;
    // The robot 1.1 m short of it, the graph's node at the robot 0.9 m on, 0.2 m short of
    // the viewpoint: the viewpoint is offered (over 1 m from the robot) but lies within
    // 1 m of the plan's source node through the graph, so it cannot be chosen. The robot
    // faces down the corridor (its walls are in the evidence grid only, which the
    // candidates keep clear of but the search does not know).
    let robot = Pose2 {
        x: offer[0],
        y: offer[1] - 1.1,
        theta: -std::f64::consts::FRAC_PI_2,
    };
    let mut planner = frontiers_first_planner(&grid, true);
    planner
        .graph
        .visit([offer[0], offer[1] - 0.2], planner.config.odometry_spacing);
    let plan = planner
        .plan(&map, robot)
        .expect("the regions' viewpoints come back");
    assert_eq!(planner.frontier_offers.len(), 1);
    assert_eq!(planner.frontier_offers[0].0, offer);
    // The target is one of the block's viewpoints, 3 m east of the origin.
    let target = plan.guidance.last().copied().expect("guidance");
    assert!(target[1] < 6.0, "{target:?}");
}

#[test]
fn a_frontier_reached_facing_away_is_cleared_after_a_turn_to_face_it() {
    let (grid, map) = room_with_a_corridor();
    let far = Pose2 {
        x: 0.0,
        y: 8.0,
        theta: 0.0,
    };
    let mut planner = frontiers_first_planner(&grid, true);
    let plan = planner.plan(&map, far).expect("a plan");
    let (offer, anchor) = planner.frontier_offers[0];
    assert_eq!(
        plan.guidance.last(),
        Some(&offer),
        "the frontier is the target"
    );
    // The robot arrives at the viewpoint with its back to the frontier.
    let away = (offer[1] - anchor[1]).atan2(offer[0] - anchor[0]);
    let arrived = Pose2 {
        x: offer[0],
        y: offer[1],
        theta: away,
    };
    let plan = planner.plan(&map, arrived).expect("a turn");
    assert!(plan.controls.iter().all(|u| u.v == 0.0 && u.w != 0.0));
    let end = plan.states[plan.states.len() - 1];
    let bearing = (anchor[1] - end.y).atan2(anchor[0] - end.x);
    assert!(crate::drive::wrap_angle(bearing - end.theta).abs() < 1e-9);
    assert_eq!(planner.cleared_frontiers, vec![anchor]);
    // A plan later, halfway round, the turn goes on; facing it, the planner moves on.
    let halfway = Pose2 {
        theta: plan.states[1].theta,
        ..arrived
    };
    let rest = planner.plan(&map, halfway).expect("the rest of the turn");
    assert!(rest.controls.iter().all(|u| u.v == 0.0));
    assert_eq!(rest.controls.len(), plan.controls.len() - 1);
    let facing = Pose2 {
        theta: end.theta,
        ..arrived
    };
    let _ = planner.plan(&map, facing);
    assert_eq!(planner.look_at, None);
}

#[test]
fn frontier_viewpoints_are_worth_their_length_and_cleared_ones_are_not_offered() {
    use crate::explore::frontier;
    // 8 x 4 m seen floor with walls round it, except two openings onto unseen space on
    // its east wall: 2 m (a whole region side's worth at 2.5 m regions: 0.8) and 0.7 m.
    let (w, h) = (160, 80);
    let mut g = ClassGrid::filled([w, h], [0.0, 0.0], 0.05, CellClass::Free);
    for c in 0..g.len() {
        let (x, y) = (c % w, c / w);
        let wall = x <= 1 || y <= 1 || y >= h - 2 || (x >= w - 4 && x < w - 2);
        if x >= w - 2 {
            g.classes[c] = CellClass::Unknown;
        } else if wall && !(10..50).contains(&y) && !(60..74).contains(&y) {
            g.classes[c] = CellClass::Occupied;
        }
    }
    let robot = Pose2 {
        x: 1.0,
        y: 2.0,
        theta: 0.0,
    };
    let view = FrontierView::new(g.clone(), robot, PATH_CLEARANCE, FOOTPRINT);
    assert_eq!(view.clusters.len(), 2, "{:?}", view.clusters.len());
    let mut planner = RtGuidePlanner::new(
        PlannerConfig {
            frontier_regions: true,
            ..PlannerConfig::default()
        },
        CollisionEngine::Grid,
    );
    let omega = UNSEEN_UNCERTAINTY * planner.config.region_size;
    planner.add_frontier_viewpoints(&view, robot, omega);
    let first = offered_viewpoints(&planner);
    assert_eq!(first.len(), 2);
    for cluster in &view.clusters {
        // Brute force: the cluster's length in cells, and its viewpoint beside it.
        let length = cluster.cells.len() as f64 * g.cell;
        let expected = omega * (length / planner.config.region_size).min(1.0);
        let (p, worth) = first
            .iter()
            .min_by(|a, b| {
                let d =
                    |q: [f64; 2]| (q[0] - cluster.centroid[0]).hypot(q[1] - cluster.centroid[1]);
                d(a.0).total_cmp(&d(b.0))
            })
            .copied()
            .expect("a viewpoint");
        assert!((worth - expected).abs() < 1e-12, "{worth} vs {expected}");
        assert!(
            (p[0] - cluster.centroid[0]).hypot(p[1] - cluster.centroid[1])
                <= FRONTIER_GOAL_RADIUS + 0.05
        );
        assert!(
            frontier::clearance(&g, &view.free)[g.cell_of(p).expect("on the grid")]
                >= FRONTIER_GOAL_CLEARANCE
        );
    }
    // Once the longer one is cleared it is no longer offered; the shorter still is.
    let longer = view
        .clusters
        .iter()
        .max_by_key(|c| c.cells.len())
        .expect("a cluster");
    planner.cleared_frontiers.push(longer.anchor(&g));
    planner.graph.clear_viewpoints();
    planner.add_frontier_viewpoints(&view, robot, omega);
    let second = offered_viewpoints(&planner);
    assert_eq!(second.len(), 1);
    assert!(second[0].1 < first.iter().map(|f| f.1).fold(0.0, f64::max));
    // A given-up frontier is set aside while another is offered, offered again when none
    // is, and cleared for good at its last attempt.
    let shorter = view
        .clusters
        .iter()
        .min_by_key(|c| c.cells.len())
        .expect("a cluster")
        .anchor(&g);
    let worth = |planner: &mut RtGuidePlanner| -> Vec<f64> {
        planner.graph.clear_viewpoints();
        planner.add_frontier_viewpoints(&view, robot, omega);
        offered_viewpoints(planner).iter().map(|o| o.1).collect()
    };
    let give_up = |planner: &mut RtGuidePlanner| {
        planner.target_frontier = Some(shorter);
        planner.give_up_target_frontier();
    };
    planner.cleared_frontiers.clear();
    let both = worth(&mut planner);
    let (high, low) = (both[0].max(both[1]), both[0].min(both[1]));
    give_up(&mut planner);
    assert_eq!(
        worth(&mut planner),
        vec![high],
        "set aside while the other is offered"
    );
    planner.cleared_frontiers.push(longer.anchor(&g));
    assert_eq!(
        worth(&mut planner),
        vec![low],
        "offered again when no other is"
    );
    give_up(&mut planner);
    assert_eq!(
        worth(&mut planner),
        vec![low],
        "the second attempt is not the last"
    );
    give_up(&mut planner);
    assert!(
        worth(&mut planner).is_empty(),
        "the third attempt clears it"
    );
}

#[test]
fn a_look_at_a_reached_frontier_turns_in_place_until_it_faces_it() {
    let search = SearchConfig::default();
    let half_width = 0.5;
    let robot = Pose2 {
        x: 1.0,
        y: 2.0,
        theta: 0.3,
    };
    // Anchors all round the robot, every 10 degrees.
    for k in 0..36 {
        let a = std::f64::consts::TAU * k as f64 / 36.0;
        let anchor = [robot.x + 2.0 * a.cos(), robot.y + 2.0 * a.sin()];
        let off_axis = crate::drive::wrap_angle(a - robot.theta).abs();
        let Some(turn) = look_toward(robot, anchor, half_width, &search) else {
            assert!(off_axis <= LOOK_FRACTION * half_width + 1e-9, "k = {k}");
            continue;
        };
        assert!(off_axis > LOOK_FRACTION * half_width, "k = {k}");
        // In place, within the drive's limits, one primitive period a segment.
        assert_eq!(turn.states.len(), turn.controls.len() + 1);
        for u in &turn.controls {
            assert_eq!(u.v, 0.0);
            assert!(u.w.abs() <= 0.9 + 1e-12, "w {}", u.w);
        }
        // Stepping the controls by the exact unicycle ends facing the anchor, where it
        // stood; the fewest segments that could.
        let mut s = robot;
        for u in &turn.controls {
            s = crate::drive::advance(&s, u, search.primitives.duration);
        }
        assert!((s.x - robot.x).abs() < 1e-12 && (s.y - robot.y).abs() < 1e-12);
        let facing = crate::drive::wrap_angle(a - s.theta).abs();
        assert!(facing < 1e-9, "k = {k}: {facing}");
        assert_eq!(
            turn.controls.len(),
            (off_axis / 0.9).ceil() as usize,
            "k = {k}"
        );
        assert_eq!(turn.states.last(), Some(&s));
    }
}

#[test]
fn a_settled_region_moves_less_than_adam_moves_a_gaussian_pulled_one_way() {
    use crate::adam::{Adam, LearningRates};
    use crate::gaussians::{Gaussians, Gradients};
    // Brute force: Adam's own steps on one Gaussian under a steady pull along (1, -2, 3)
    // (a gradient of any size: Adam normalises it), ten iterations, as one mapping step.
    let rates = LearningRates::default();
    let mut g = Gaussians::default();
    g.push([0.0; 3], 0.02, 0.5, [0.5; 3]);
    let mut adam = Adam::new(rates);
    adam.resize(1);
    let mut grads = Gradients::zeros(1);
    grads.means[0] = [1e-3, -2e-3, 3e-3];
    grads.touched = vec![0];
    for _ in 0..10 {
        adam.step(&mut g, &grads);
    }
    let moved = g.means[0]
        .iter()
        .map(|m| f64::from(*m).powi(2))
        .sum::<f64>()
        .sqrt();
    let bound = settled_omega(10, f64::from(rates.means));
    assert!((moved - bound).abs() < 1e-3 * bound, "{moved} vs {bound}");
}

/// The viewpoints the last plan offered, with their utility.
fn offered_viewpoints(planner: &RtGuidePlanner) -> Vec<([f64; 2], f64)> {
    planner
        .graph
        .nodes
        .iter()
        .filter_map(|n| match n.kind {
            graph::NodeKind::Viewpoint { omega, .. } => Some((n.position, omega)),
            graph::NodeKind::Odometry => None,
        })
        .collect()
}

#[test]
fn with_the_tour_a_reached_viewpoint_waits_until_no_other_can_be_chosen() {
    // One block of moving Gaussians (one region), no evidence grid: its eight viewpoints
    // ring it 4.3 m out. The robot stands 1.2 m west of the west one.
    let (_, map) = room_with_a_corridor();
    let robot = Pose2 {
        x: -2.4,
        y: 0.1,
        theta: 0.0,
    };
    let planner = |tour: bool| {
        RtGuidePlanner::new(
            PlannerConfig {
                tour_viewpoints: tour,
                ..PlannerConfig::default()
            },
            CollisionEngine::Grid,
        )
    };
    let target = |p: &mut RtGuidePlanner| {
        p.target = None;
        let plan = p.plan(&map, robot).expect("a plan");
        plan.guidance.last().copied().expect("guidance")
    };
    // Brute force: the graph joins each viewpoint straight to the node at the robot, so
    // the best is the largest Omega e^-d over straight distances, viewpoints within
    // `min_viewpoint_distance` of the robot or of a reached target left out.
    let best = |offered: &[([f64; 2], f64)], reached: &[[f64; 2]], factor: f64| {
        let min = PlannerConfig::default().min_viewpoint_distance;
        let near = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]) < min;
        offered
            .iter()
            .filter(|(p, _)| !near(*p, [robot.x, robot.y]))
            .map(|(p, omega)| {
                let reached = reached.iter().any(|r| near(*r, *p));
                let w = if reached { factor } else { 1.0 };
                (*p, w * omega * (-robot.distance(*p)).exp())
            })
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(p, _)| p)
            .expect("a viewpoint")
    };
    let close = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]) < 1e-6;
    let mut paper = planner(false);
    let first = target(&mut paper);
    let offered = offered_viewpoints(&paper);
    assert_eq!(offered.len(), 8, "{offered:?}");
    assert!(close(first, best(&offered, &[], 1.0)), "{first:?}");
    // Reached, it keeps a tenth of its utility, and e^-d still ranks it first.
    paper.visited.push(first);
    let again = target(&mut paper);
    assert!(close(again, best(&offered, &[first], 0.1)), "{again:?}");
    assert!(
        close(again, first),
        "the paper's planner goes back: {again:?}"
    );
    // With the tour it waits: the next is the best of the others.
    let mut tour = planner(true);
    assert!(close(target(&mut tour), first));
    tour.visited.push(first);
    let next = target(&mut tour);
    assert!(close(next, best(&offered, &[first], 0.0)), "{next:?}");
    assert!(
        robot.distance(next) > robot.distance(first) + 1.0,
        "{next:?}"
    );
    // Every viewpoint reached: a new round, all of them offered at their full utility.
    tour.visited = offered.iter().map(|(p, _)| *p).collect();
    let round = target(&mut tour);
    assert!(close(round, first), "{round:?}");
    assert!(tour.visited.is_empty());
}

#[test]
fn with_the_tour_viewpoints_behind_a_wall_past_the_edge_checks_start_a_new_round() {
    use crate::gaussians::Gaussians;
    // A settled wall at x = 2 m (Omega 0); twelve moving blocks beyond it, whose 96
    // viewpoints all have edges across it, more than a plan's edge checks; one moving
    // block on the robot's side, every viewpoint of it already reached.
    let mut g = Gaussians::default();
    let mut omega = Vec::new();
    let mut block = |g: &mut Gaussians, x: f32, y: f32| {
        for k in 0..100 {
            let (i, j) = ((k % 10) as f32, (k / 10) as f32);
            g.push([x + 0.02 * i, y + 0.02 * j, 0.5], 0.02, 0.9, [0.5; 3]);
            omega.push(1e-3);
        }
    };
    for b in 0..12 {
        block(&mut g, 10.0, -14.0 + 2.5 * b as f32);
    }
    block(&mut g, -3.0, 0.0);
    for k in 0..800 {
        g.push([2.0, -20.0 + 0.05 * k as f32, 0.5], 0.02, 0.9, [0.5; 3]);
        omega.push(0.0);
    }
    let map = GaussianMap::new(g, omega);
    let robot = Pose2::default();
    let mut planner = RtGuidePlanner::new(
        PlannerConfig {
            tour_viewpoints: true,
            ..PlannerConfig::default()
        },
        CollisionEngine::Grid,
    );
    planner.plan(&map, robot).expect("a plan");
    let offered = offered_viewpoints(&planner);
    let beyond = offered
        .iter()
        .filter(|(p, w)| p[0] > 2.0 && *w > 0.0)
        .count();
    assert!(
        beyond > MAX_EDGE_CHECKS,
        "{beyond} viewpoints beyond the wall"
    );
    let near_side: Vec<[f64; 2]> = offered
        .iter()
        .filter(|(p, w)| p[0] < 2.0 && *w > 0.0)
        .map(|(p, _)| *p)
        .collect();
    assert!(!near_side.is_empty());
    planner.target = None;
    planner.visited = near_side.clone();
    let plan = planner
        .plan(&map, robot)
        .expect("a new round, not GoalUnreachable");
    let target = plan.guidance.last().copied().expect("guidance");
    assert!(
        near_side
            .iter()
            .any(|p| (p[0] - target[0]).hypot(p[1] - target[1]) < 1e-6),
        "{target:?}"
    );
    assert!(planner.visited.is_empty());
}

#[test]
fn exploration_ends_only_with_no_frontier_to_view_and_every_region_settled() {
    let (grid, map) = room_with_a_corridor();
    let robot = Pose2 {
        x: 0.0,
        y: 0.0,
        theta: 0.0,
    };
    let settled = PlannerConfig::default().settled_omega;
    // The corridor's frontier, where a planner that reached it keeps it.
    let mut probe = frontiers_first_planner(&grid, true);
    probe.plan(&map, robot).expect("a plan");
    assert_eq!(probe.frontier_offers.len(), 1);
    let anchor = probe.frontier_offers[0].1;
    let step = |finish: bool, cleared: bool, omega: f32, at: Pose2| {
        let mut planner = frontiers_first_planner(&grid, true);
        planner.config.finish_when_explored = finish;
        if cleared {
            planner.cleared_frontiers.push(anchor);
        }
        let moving = GaussianMap::new(map.gaussians.clone(), vec![omega; map.len()]);
        let step = planner.step(&moving, at).expect("a step");
        assert!(planner.frontier_offers.is_empty() || !cleared);
        match step {
            RtGuideStep::Plan(_) => None,
            RtGuideStep::Explored(why) => Some(why),
        }
    };
    let below = (settled * 0.9) as f32;
    let above = (settled * 1.1) as f32;
    // The frontier viewed and the block's Gaussians settled: nothing is left.
    let why = step(true, true, below, robot).expect("explored");
    assert!(why.contains("no frontier left"), "{why}");
    // Any of: the switch off, the frontier still to view, the block still moving.
    assert_eq!(step(false, true, below, robot), None);
    assert_eq!(step(true, false, below, robot), None);
    assert_eq!(step(true, true, above, robot), None);
    // A frontier whose viewpoint is where the robot stands is not offered, yet not viewed.
    let offer = probe.frontier_offers[0].0;
    let there = Pose2 {
        x: offer[0],
        y: offer[1] - 0.5,
        theta: std::f64::consts::FRAC_PI_2,
    };
    let mut standing = frontiers_first_planner(&grid, true);
    standing.plan(&map, there).expect("a plan");
    assert!(standing.frontier_offers.is_empty() && standing.frontiers_at_robot == 1);
    assert_eq!(step(true, false, below, there), None);
    // Before any frontier was viewed nothing ends, frontier or none: a closed room seen
    // whole from a spawn in its middle.
    let closed = closed_room();
    let mut fresh = frontiers_first_planner(&closed, true);
    fresh.config.finish_when_explored = true;
    let still = GaussianMap::new(map.gaussians.clone(), vec![below; map.len()]);
    let step = fresh.step(&still, robot).expect("a step");
    assert!(matches!(step, RtGuideStep::Plan(_)), "{step:?}");
    assert!(fresh.frontier_offers.is_empty() && fresh.frontiers_at_robot == 0);
    fresh.cleared_frontiers.push([9.0, 9.0]);
    let step = fresh.step(&still, robot).expect("a step");
    assert!(matches!(step, RtGuideStep::Explored(_)), "{step:?}");
}

/// Seen floor: a 7 x 4 m room round the origin, walled all round (no frontier).
fn closed_room() -> EvidenceGrid {
    let inside = |x: f64, y: f64| (-2.0..5.0).contains(&x) && (-2.0..2.0).contains(&y);
    seen_floor(inside, [-60, -60], [120, 60], |_, _| true)
}

/// An evidence grid of 5 cm cells `lo..hi` (cell indices): free where `inside`, and a
/// wall two cells thick round it where `walled`; the rest unseen.
fn seen_floor(
    inside: impl Fn(f64, f64) -> bool,
    lo: [i32; 2],
    hi: [i32; 2],
    walled: impl Fn(f64, f64) -> bool,
) -> EvidenceGrid {
    use crate::math::Point3;
    let cell = 0.05;
    let mut grid = EvidenceGrid::new(EvidenceConfig::default());
    for j in lo[1]..hi[1] {
        for i in lo[0]..hi[0] {
            let (x, y) = ((f64::from(i) + 0.5) * cell, (f64::from(j) + 0.5) * cell);
            let near_inside = (-2..=2)
                .any(|a| (-2..=2).any(|b| inside(x + a as f64 * cell, y + b as f64 * cell)));
            if inside(x, y) {
                // Free: a ray down to the floor ends in the cell without a hit.
                grid.integrate_ray(Point3::new(x, y, 0.5), Point3::new(x + 1e-3, y, 0.0));
            } else if near_inside && walled(x, y) {
                // A wall: a ray that ends in the cell at wall height.
                grid.integrate_ray(Point3::new(x + 1e-3, y, 0.5), Point3::new(x, y, 0.5));
            }
        }
    }
    grid
}

#[test]
fn the_free_range_is_where_one_frame_maps_the_floor_ten_centimetres_apart() {
    // Brute force: cast the camera's pixel rows (at a hundredth of a row) onto the floor
    // and find the range beyond which rows the mapper's stride apart land more than 10 cm
    // from each other.
    let mount = PlannerConfig::default().mount;
    let k = mount.intrinsics;
    let stride = crate::mapping::DensifyConfig::default().stride as f64;
    let floor = |v: f64| mount.height / ((v - k.cy) / k.fy);
    let mut v = f64::from(k.height) - 1.0;
    let mut dense_to = 0.0;
    while v - stride > k.cy {
        if floor(v - stride) - floor(v) > 0.1 {
            break;
        }
        dense_to = floor(v);
        v -= 0.01;
    }
    assert!(
        (dense_to - FREE_RANGE).abs() < 0.02,
        "dense to {dense_to:.3} m, free range {FREE_RANGE}"
    );
}

#[test]
fn within_its_footprint_the_robot_may_not_come_nearer_to_cells_not_seen_free() {
    // Free floor with an occupied block at x in [3, 4], y in [1, 2]; the robot 0.4 m
    // west of it. Every move below stays inside the robot's footprint (0.3 m).
    let (w, h) = (100, 60);
    let mut g = ClassGrid::filled([w, h], [0.0, 0.0], 0.05, CellClass::Free);
    for c in 0..g.len() {
        let (x, y) = (c % w, c / w);
        if (60..80).contains(&x) && (20..40).contains(&y) {
            g.classes[c] = CellClass::Occupied;
        }
    }
    let distance = UnfreeDistance::new(&g);
    let start = Pose2 {
        x: 2.6,
        y: 1.5,
        theta: 0.0,
    };
    let step = |v: f64, w: f64| {
        let u = UnicycleCommand { v, w };
        search::Trajectory {
            controls: vec![u],
            states: vec![start, crate::drive::advance(&start, &u, 1.0)],
            cost: 0.0,
            distance_to_goal: 0.0,
        }
    };
    let clear = |t: &search::Trajectory| distance.clear_segments(t, 1.0, 0.33, start);
    // 0.25 m on toward the block: inside the footprint, but nearer than it stands.
    assert_eq!(clear(&step(0.25, 0.0)), 0);
    // Turning in place, or an arc that keeps its distance, stays as near as it was.
    assert_eq!(clear(&step(0.0, 0.9)), 1);
    // Away from the block.
    let mut back = step(0.25, 0.0);
    back.states = vec![
        Pose2 {
            theta: std::f64::consts::PI,
            ..start
        },
        Pose2 {
            x: start.x - 0.25,
            theta: std::f64::consts::PI,
            ..start
        },
    ];
    assert_eq!(distance.clear_segments(&back, 1.0, 0.33, back.states[0]), 1);
}

#[test]
fn candidates_keep_the_radius_from_cells_not_seen_free_as_a_brute_force_scan_says() {
    // 5 x 3 m seen free, with a 1 x 1 m block at x in [3, 4], y in [1, 2]: its west half
    // occupied (where depth rays ended; the drive east into it stops there too), its
    // east half unseen.
    let (w, h) = (100, 60);
    let mut g = ClassGrid::filled([w, h], [0.0, 0.0], 0.05, CellClass::Free);
    for c in 0..g.len() {
        let (x, y) = (c % w, c / w);
        if (60..70).contains(&x) && (20..40).contains(&y) {
            g.classes[c] = CellClass::Occupied;
        }
        if (70..80).contains(&x) && (20..40).contains(&y) {
            g.classes[c] = CellClass::Unknown;
        }
    }
    let unseen = UnfreeDistance::new(&g);
    let cells: Vec<[f64; 2]> = (0..g.len())
        .filter(|c| g.classes[*c] != CellClass::Free)
        .map(|c| g.centre(c))
        .collect();
    // Brute force: per segment, the nearest unseen cell centre to any point of it; beyond
    // the grid's edge is unseen too (the ring of cells just outside it).
    let nearest = |t: &search::Trajectory| -> Vec<f64> {
        t.controls
            .iter()
            .zip(&t.states)
            .map(|(u, s)| {
                search::segment_points(s, u, 1.0, 0.1)
                    .iter()
                    .map(|p| {
                        let edge = (p.x + 0.025)
                            .min(5.025 - p.x)
                            .min(p.y + 0.025)
                            .min(3.025 - p.y);
                        cells
                            .iter()
                            .map(|c| (c[0] - p.x).hypot(c[1] - p.y))
                            .fold(edge, f64::min)
                    })
                    .fold(f64::INFINITY, f64::min)
            })
            .collect()
    };
    let mut partial = 0;
    for y in [0.2, 0.4, 0.5, 0.6, 0.75, 1.5, 2.4, 2.6] {
        let t = drive_east(y, 8);
        let start = t.states[0];
        let d = nearest(&t);
        let expected = d.iter().take_while(|d| **d >= 0.35).count();
        // Away from the chamfer's 8% and the half cell, the two agree.
        let decided = d.iter().take(expected + 1).all(|d| (d - 0.35).abs() > 0.08);
        if decided {
            assert_eq!(
                unseen.clear_segments(&t, 1.0, 0.35, start),
                expected,
                "y = {y}: nearest cell not free per segment {d:.3?} m"
            );
            partial += usize::from(expected > 0 && expected < 8);
        }
    }
    assert!(partial > 0, "no drive is clear for only part of its way");
    // Both sides of the test: some drives pass whole, some not at all.
    let clear = |t: &search::Trajectory, start: Pose2| unseen.clear_segments(t, 1.0, 0.35, start);
    assert_eq!(clear(&drive_east(0.5, 8), Pose2::default()), 8);
    // Into the block it stops short; off the grid it stops; a start inside the footprint
    // of an unseen cell passes for its first 0.3 m only.
    assert_eq!(clear(&drive_east(1.5, 8), Pose2::default()), 4);
    assert_eq!(clear(&drive_east(0.5, 12), Pose2::default()), 8);
    let inside = Pose2 {
        x: 3.5,
        y: 1.5,
        theta: 0.0,
    };
    let mut short = drive_east(1.5, 1);
    short.states[0] = inside;
    short.states[1] = crate::drive::advance(&inside, &short.controls[0], 1.0);
    assert_eq!(clear(&short, inside), 0);
    short.controls[0].v = 0.25;
    short.states[1] = crate::drive::advance(&inside, &short.controls[0], 1.0);
    assert_eq!(clear(&short, inside), 1);
}

#[test]
fn a_graph_path_through_a_door_is_aimed_along_as_far_as_the_robot_sees() {
    use crate::gaussians::Gaussians;
    // 6 x 4 m of seen floor, a wall at y in [1.2, 1.3) with a door at x in [2.6, 3.4),
    // in the grid (occupied cells) and in the map (Gaussians up its face).
    let cell = 0.05;
    let (w, h) = (120, 80);
    let door = |x: f64| (2.6..3.4).contains(&x);
    let mut grid = ClassGrid::filled([w, h], [0.0, 0.0], cell, CellClass::Free);
    for c in 0..grid.len() {
        let [x, y] = grid.centre(c);
        if (1.2..1.3).contains(&y) && !door(x) {
            grid.classes[c] = CellClass::Occupied;
        }
    }
    let mut g = Gaussians::default();
    for i in 0..120 {
        let x = 0.025 + 0.05 * i as f64;
        if door(x) {
            continue;
        }
        for k in 0..20 {
            g.push(
                [x as f32, 1.25, 0.05 + 0.06 * k as f32],
                0.03,
                0.9,
                [0.5; 3],
            );
        }
    }
    let n = g.len();
    let mut planner = RtGuidePlanner::new(
        PlannerConfig {
            frontier_regions: true,
            ..PlannerConfig::default()
        },
        CollisionEngine::Grid,
    );
    planner.executor.sync(&GaussianMap::new(g, vec![1e-3; n]));
    let robot = Pose2 {
        x: 1.0,
        y: 0.5,
        theta: 0.0,
    };
    // East to the door, through it, west along the far side.
    let guidance = [[1.0, 0.5], [3.0, 0.5], [3.0, 2.0], [0.5, 2.0]];
    let horizon = planner.config.search.horizon;
    // Brute force: a segment crosses free cells only, looked at every centimetre.
    let clear = |to: [f64; 2]| {
        let n = ((to[0] - robot.x).hypot(to[1] - robot.y) / 0.01).ceil() as usize;
        (0..=n).all(|k| {
            let t = k as f64 / n.max(1) as f64;
            let (x, y) = (
                robot.x + t * (to[0] - robot.x),
                robot.y + t * (to[1] - robot.y),
            );
            let (i, j) = ((x / cell).floor() as usize, (y / cell).floor() as usize);
            grid.classes[j * w + i] == CellClass::Free
        })
    };
    // The paper's local goal (the path's end: all of it within the horizon) is behind the
    // wall west of the door.
    let local = local_goal(&guidance, horizon).expect("a path");
    assert_eq!(local, [0.5, 2.0]);
    assert!(!clear(local));
    // Brute force: every 0.2 m along the path, the last point before the first hidden one.
    let mut points = Vec::new();
    for s in 1..=((horizon / 0.2).round() as usize) {
        let d = 0.2 * s as f64;
        let p = if d <= 2.0 {
            [1.0 + d, 0.5]
        } else if d <= 3.5 {
            [3.0, 0.5 + (d - 2.0)]
        } else {
            [3.0 - (d - 3.5), 2.0]
        };
        points.push(p);
    }
    let first_hidden = points
        .iter()
        .position(|p| !clear(*p))
        .expect("one is hidden");
    let expected = points[first_hidden - 1];
    let goal = planner.seen_graph_goal(robot, &guidance, local, &grid);
    assert!(
        (goal[0] - expected[0]).hypot(goal[1] - expected[1]) < 1e-9,
        "{goal:?} vs {expected:?}"
    );
    // Up into the door, not short of it.
    assert!(goal[0] == 3.0 && goal[1] > 1.2, "{goal:?}");
    // A path the robot sees to its end keeps the paper's local goal.
    let straight = [[1.0, 0.5], [3.0, 0.5], [3.0, 1.0]];
    let local = local_goal(&straight, horizon).expect("a path");
    assert_eq!(
        planner.seen_graph_goal(robot, &straight, local, &grid),
        local
    );
}
