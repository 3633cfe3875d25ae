//! The drive controller realises unicycle commands on the simulated robot.

use crate::support::room;
use splatloop::robot::{Pose2, UnicycleCommand};

fn drive(command: UnicycleCommand, seconds: f64) -> (Pose2, Pose2) {
    let mut world = room();
    // An open spot in the room, heading +x, nothing within 2.5 m ahead.
    world.set_start(Pose2 {
        x: -2.3,
        y: -0.9,
        theta: 0.0,
    });
    let start = world.pose();
    let steps = (seconds / world.model().timestep()).round() as usize;
    for _ in 0..steps {
        world.step(command).expect("stable");
    }
    assert_eq!(world.robot_collisions().count(), 0);
    (start, world.pose())
}

#[test]
fn forward_half_metre_per_second_for_four_seconds_goes_two_metres() {
    let (start, end) = drive(UnicycleCommand { v: 0.5, w: 0.0 }, 4.0);
    let travelled = (end.x - start.x).hypot(end.y - start.y);
    assert!(
        (travelled - 2.0).abs() <= 0.05 * 2.0,
        "travelled {travelled} m"
    );
    assert!(
        (end.theta - start.theta).abs() < 0.02,
        "heading drifted to {}",
        end.theta
    );
}

#[test]
fn turning_half_radian_per_second_for_two_seconds_turns_one_radian() {
    let (start, end) = drive(UnicycleCommand { v: 0.0, w: 0.5 }, 2.0);
    let turned = end.theta - start.theta;
    assert!((turned - 1.0).abs() <= 0.05, "turned {turned} rad");
    let moved = (end.x - start.x).hypot(end.y - start.y);
    assert!(moved < 0.02, "turning in place moved {moved} m");
}

#[test]
fn commands_beyond_the_limits_are_clamped() {
    let (start, end) = drive(UnicycleCommand { v: 2.0, w: 0.0 }, 2.0);
    let travelled = (end.x - start.x).hypot(end.y - start.y);
    assert!(
        travelled <= 0.6 * 2.0 * 1.01,
        "travelled {travelled} m at a clamped 0.6 m/s"
    );
    assert!(travelled >= 0.6 * 2.0 * 0.9, "travelled {travelled} m");
}

/// The README's main job drives the default pattern: one full loop (2 pi / 0.25 rad/s = 25 s)
/// must touch nothing in either world.
#[test]
fn the_circle_pattern_loops_both_worlds_without_a_collision() {
    use splatloop::camera::SensorConfig;
    use splatloop::controls::ControlSchedule;
    use splatloop::world::World;
    for name in ["worlds/room.xml", "worlds/apartment.xml"] {
        let mut world =
            World::load(&crate::support::repo_path(name), &SensorConfig::default()).expect("loads");
        let schedule = ControlSchedule::from_arg("circle", &world.robot().limits).expect("pattern");
        let start = world.pose();
        let mut touching_steps = 0;
        for _ in 0..(26.0 / world.model().timestep()) as usize {
            let t = world.data().time();
            world.step(schedule.at(t)).expect("stable");
            touching_steps += usize::from(world.robot_collisions().next().is_some());
        }
        assert_eq!(touching_steps, 0, "{name}: the robot touched an obstacle");
        let end = world.pose();
        let back = (end.x - start.x).hypot(end.y - start.y);
        assert!(
            back < 0.5,
            "{name}: a full loop should end near the start, ended {back:.2} m away"
        );
    }
}

/// A drive straight into a wall is reported as collisions (the counter can see them).
#[test]
fn driving_into_a_wall_is_a_collision() {
    let mut world = room();
    world.set_start(Pose2 {
        x: 2.0,
        y: 0.0,
        theta: 0.0,
    });
    let mut touching_steps = 0;
    for _ in 0..2500 {
        world
            .step(UnicycleCommand { v: 0.6, w: 0.0 })
            .expect("stable");
        touching_steps += usize::from(world.robot_collisions().next().is_some());
    }
    assert!(
        touching_steps > 100,
        "only {touching_steps} steps in contact with the east wall"
    );
}
