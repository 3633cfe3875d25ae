//! A loaded world: the compiled MJCF with the robot inside it, its state, and the robot's
//! start pose.

use crate::camera::{RgbdCamera, SensorConfig};
use crate::egl::EglContext;
use crate::error::Result;
use crate::labels::Labels;
use crate::mujoco::{Contact, Data, Model, ObjKind};
use crate::robot::{names, Pose2, Robot, UnicycleCommand};
use std::path::Path;
use std::sync::Arc;

/// Sensor near clipping plane, metres: closer surfaces are not measured.
pub const SENSOR_NEAR_CLIP: f64 = 0.05;

/// A world with the robot in it.
pub struct World {
    model: Arc<Model>,
    data: Data,
    robot: Robot,
    start: Pose2,
    /// Whether the MJCF has a `spawn` site (else the start is the origin).
    has_spawn_site: bool,
}

impl std::fmt::Debug for World {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("World")
            .field("path", &self.model.path())
            .field("time", &self.data.time())
            .field("pose", &self.pose())
            .finish()
    }
}

impl World {
    /// Loads an MJCF world, prepares its offscreen buffer for `sensor`, finds the robot and
    /// puts it at the world's `spawn` site (or the origin).
    pub fn load(path: &Path, sensor: &SensorConfig) -> Result<Self> {
        sensor.validate()?;
        let mut model = Model::from_xml(path)?;
        model.configure_offscreen(sensor.width, sensor.height, sensor.flags.multisample);
        model.set_near_clip(SENSOR_NEAR_CLIP);
        let robot = Robot::find(&model)?;
        let model = Arc::new(model);
        let data = Data::new(Arc::clone(&model))?;
        let site = model.id(ObjKind::Site, names::SPAWN_SITE, "");
        let has_spawn_site = site.is_ok();
        let start = match site {
            Ok(site) => {
                let p = data.site_position(site);
                let r = data.site_rotation(site);
                Pose2 {
                    x: p.x,
                    y: p.y,
                    theta: r[(1, 0)].atan2(r[(0, 0)]),
                }
            }
            Err(_) => Pose2::default(),
        };
        let mut world = World {
            model,
            data,
            robot,
            start,
            has_spawn_site,
        };
        world.reset();
        Ok(world)
    }

    /// Whether the world names its start with a `spawn` site.
    pub fn has_spawn_site(&self) -> bool {
        self.has_spawn_site
    }

    /// Overrides the start pose and resets to it.
    pub fn set_start(&mut self, start: Pose2) {
        self.start = start;
        self.reset();
    }

    /// Back to time 0 with the robot at rest at its start pose.
    pub fn reset(&mut self) {
        self.data.reset();
        self.robot.place(&mut self.data, self.start);
    }

    /// Applies `command` through the drive controller and advances one physics step.
    pub fn step(&mut self, command: UnicycleCommand) -> Result<()> {
        self.robot.drive(&mut self.data, command);
        self.data.step()
    }

    /// The robot's planar pose.
    pub fn pose(&self) -> Pose2 {
        self.robot.pose(&self.data)
    }

    /// Contacts between the robot and anything but the ground: collisions.
    pub fn robot_collisions(&self) -> impl Iterator<Item = Contact> + '_ {
        self.data.contacts().filter(|c| {
            let (a, b) = (self.robot.owns_geom(c.geom1), self.robot.owns_geom(c.geom2));
            let other = match (a, b) {
                (true, false) => c.geom2,
                (false, true) => c.geom1,
                _ => return false,
            };
            !self.model.geom_type(other).is_ground()
        })
    }

    /// The name of what the robot touches in `contact` (the geom that is not the robot's).
    pub fn touched_name(&self, contact: &Contact) -> String {
        let other = if self.robot.owns_geom(contact.geom1) {
            contact.geom2
        } else {
            contact.geom1
        };
        self.model
            .name(ObjKind::Geom, other)
            .unwrap_or_else(|| format!("geom {other}"))
    }

    /// An error unless `rate` frames per second (`what`: "camera rate", "frame rate") is at
    /// most the physics rate, which frames are taken at.
    pub fn check_frame_rate(&self, rate: f64, what: &'static str) -> Result<()> {
        let physics_rate = 1.0 / self.model.timestep();
        if rate > physics_rate {
            return Err(crate::error::SimError::InvalidArgument {
                what,
                detail: format!(
                    "{rate} frames/s is faster than the physics ({physics_rate:.0} steps/s), which a frame is taken at; give at most {physics_rate:.0}"
                ),
            });
        }
        Ok(())
    }

    /// Makes the robot's RGB-D camera (with the world's labels when `config.masks`); needs a
    /// current EGL context.
    pub fn make_camera(
        &self,
        config: &SensorConfig,
        seed: u64,
        gl: &EglContext,
    ) -> Result<RgbdCamera> {
        let camera = RgbdCamera::new(Arc::clone(&self.model), self.robot.camera, config, seed, gl)?;
        Ok(if config.masks {
            camera.with_labels(Arc::new(self.labels()?))
        } else {
            camera
        })
    }

    /// The world's instances and classes, the robot left out.
    pub fn labels(&self) -> Result<Labels> {
        Labels::of_model(&self.model, self.robot.body)
    }

    /// The compiled model.
    pub fn model(&self) -> &Arc<Model> {
        &self.model
    }

    /// The simulation state.
    pub fn data(&self) -> &Data {
        &self.data
    }

    /// The simulation state, writable (tests move the robot directly).
    pub fn data_mut(&mut self) -> &mut Data {
        &mut self.data
    }

    /// Where the robot is in the model.
    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    /// The start pose.
    pub fn start(&self) -> Pose2 {
        self.start
    }
}
