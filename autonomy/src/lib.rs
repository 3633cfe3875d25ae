//! The autonomy side of splatloop: everything a real robot would run, with no simulator in it.
//!
//! It knows cameras, images and poses in the conventions of DESIGN.md; the host (`sim/`)
//! feeds it frames and applies what it decides. It never depends on MuJoCo.

pub mod adam;
pub mod camera;
pub mod drive;
pub mod explore;
pub mod gaussians;
pub mod loss;
pub mod map;
pub mod mapping;
pub mod math;
pub mod metrics;
pub mod planner;
pub mod ply;
pub mod splat;
pub mod ssim;
pub mod synthetic;
