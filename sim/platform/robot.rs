//! The unicycle robot inside a world: where its parts are in the model, and the drive
//! controller that turns (v, w) into wheel speeds.

use crate::error::{Result, SimError};
use crate::mujoco::{Data, Model, ObjKind};

/// Names the robot model (`models/unicycle.xml`) must provide.
pub mod names {
    /// The robot's root body.
    pub const BODY: &str = "robot";
    /// Its free joint.
    pub const ROOT_JOINT: &str = "robot_root";
    /// The RGB-D camera.
    pub const CAMERA: &str = "rgbd";
    /// Left wheel velocity actuator.
    pub const LEFT_DRIVE: &str = "left_drive";
    /// Right wheel velocity actuator.
    pub const RIGHT_DRIVE: &str = "right_drive";
    /// Left wheel geom (its radius is the wheel radius).
    pub const LEFT_WHEEL: &str = "left_wheel";
    /// Right wheel geom.
    pub const RIGHT_WHEEL: &str = "right_wheel";
    /// Optional world site that gives the start pose.
    pub const SPAWN_SITE: &str = "spawn";
}

pub use autonomy::drive::{DriveLimits, Pose2, UnicycleCommand};

/// Where the robot's parts sit in the compiled model.
#[derive(Debug, Clone)]
pub struct Robot {
    /// Root body id.
    pub body: usize,
    /// Camera id of the RGB-D sensor.
    pub camera: usize,
    root_qpos: usize,
    root_dof: usize,
    left_actuator: usize,
    right_actuator: usize,
    wheel_radius: f64,
    half_track: f64,
    is_robot_geom: Vec<bool>,
    /// Drive limits.
    pub limits: DriveLimits,
}

impl Robot {
    /// Finds the robot in `model`; a world without it gets an error that says what to add.
    pub fn find(model: &Model) -> Result<Self> {
        const INCLUDE: &str =
            "include the robot into the world with <include file=\"../models/unicycle.xml\"/>";
        let body = model.id(ObjKind::Body, names::BODY, INCLUDE)?;
        let camera = model.id(
            ObjKind::Camera,
            names::CAMERA,
            "the robot needs a camera named 'rgbd' (see models/unicycle.xml)",
        )?;
        let joint = model.id(
            ObjKind::Joint,
            names::ROOT_JOINT,
            "the robot's root body needs <freejoint name=\"robot_root\"/>",
        )?;
        if !model.joint_is_free(joint) || model.joint_body(joint) != body {
            return Err(SimError::InvalidArgument {
                what: "robot model",
                detail: format!(
                    "joint '{}' must be a free joint of body '{}'",
                    names::ROOT_JOINT,
                    names::BODY
                ),
            });
        }
        const DRIVES: &str = "the robot needs velocity actuators 'left_drive' and 'right_drive'";
        let left_actuator = model.id(ObjKind::Actuator, names::LEFT_DRIVE, DRIVES)?;
        let right_actuator = model.id(ObjKind::Actuator, names::RIGHT_DRIVE, DRIVES)?;
        const WHEELS: &str = "the robot needs wheel geoms 'left_wheel' and 'right_wheel'";
        let left_wheel = model.id(ObjKind::Geom, names::LEFT_WHEEL, WHEELS)?;
        let right_wheel = model.id(ObjKind::Geom, names::RIGHT_WHEEL, WHEELS)?;
        let wheel_radius = model.geom_size(left_wheel)[0];
        let half_track = 0.5
            * (model.body_offset(model.geom_body(left_wheel))[1]
                - model.body_offset(model.geom_body(right_wheel))[1])
                .abs();
        if wheel_radius <= 0.0 || half_track <= 0.0 {
            return Err(SimError::InvalidArgument {
                what: "robot model",
                detail: "wheels need a positive radius and must sit left and right of the body"
                    .into(),
            });
        }
        let is_robot_geom = (0..model.geom_count())
            .map(|g| model.body_is_in_subtree(model.geom_body(g), body))
            .collect();
        Ok(Robot {
            body,
            camera,
            root_qpos: model.joint_qpos_address(joint),
            root_dof: model.joint_dof_address(joint),
            left_actuator,
            right_actuator,
            wheel_radius,
            half_track,
            is_robot_geom,
            limits: DriveLimits::default(),
        })
    }

    /// Whether a geom belongs to the robot.
    pub fn owns_geom(&self, geom: usize) -> bool {
        self.is_robot_geom.get(geom).copied().unwrap_or(false)
    }

    /// The planar pose of the root body.
    pub fn pose(&self, data: &Data) -> Pose2 {
        let q = &data.qpos()[self.root_qpos..self.root_qpos + 7];
        let (w, x, y, z) = (q[3], q[4], q[5], q[6]);
        Pose2 {
            x: q[0],
            y: q[1],
            theta: (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z)),
        }
    }

    /// Places the robot at `pose` on the floor at rest (keeps its current height).
    pub fn place(&self, data: &mut Data, pose: Pose2) {
        let (s, c) = (0.5 * pose.theta).sin_cos();
        let q = &mut data.qpos_mut()[self.root_qpos..self.root_qpos + 7];
        q[0] = pose.x;
        q[1] = pose.y;
        q[3..7].copy_from_slice(&[c, 0.0, 0.0, s]);
        data.qvel_mut()[self.root_dof..self.root_dof + 6].fill(0.0);
        data.forward();
    }

    /// Clamps a command to the drive limits.
    pub fn clamp(&self, command: UnicycleCommand) -> UnicycleCommand {
        self.limits.clamp(command)
    }

    /// Drive controller: sets the wheel velocity targets that realise `command` (clamped to
    /// the limits) for a rolling, non-slipping differential drive.
    pub fn drive(&self, data: &mut Data, command: UnicycleCommand) {
        let UnicycleCommand { v, w } = self.clamp(command);
        let ctrl = data.ctrl_mut();
        ctrl[self.left_actuator] = (v - w * self.half_track) / self.wheel_radius;
        ctrl[self.right_actuator] = (v + w * self.half_track) / self.wheel_radius;
    }
}
