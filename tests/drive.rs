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
