//! The platform: MuJoCo through its C API, an offscreen EGL context, the RGB-D camera and the robot's drive.

pub mod camera;
pub mod egl;
pub mod mujoco;
pub mod robot;
