//! The native CPU engine: project, bin into 16x16 tiles, sort each tile's list by depth,
//! composite 8 pixels at a time with a vectorised exp, rayon across tiles; the backward pass
//! walks the same lists back to front.

mod backward;
mod forward;
mod project;
mod tiles;

pub use project::Splat;

use super::{validate_camera, ImageGradients, Images, RenderError};
use crate::camera::PinholeCamera;
use crate::gaussians::{Gaussians, Gradients};
use tiles::TileLists;

/// A forward pass and everything its backward pass needs.
#[derive(Debug, Clone)]
pub struct Render {
    /// The images.
    pub images: Images,
    camera: PinholeCamera,
    gaussian_count: usize,
    splats: Vec<Splat>,
    tiles: TileLists,
    /// Per pixel: transmittance left after the last contributor.
    final_transmittance: Vec<f32>,
    /// Per pixel: 1 + position in its tile's list of the last contributor (0: none).
    contributor_count: Vec<u32>,
}

impl Render {
    /// Visible Gaussians after culling.
    pub fn visible_count(&self) -> usize {
        self.splats.len()
    }

    /// (pixel, Gaussian) pairs considered by the tile lists: the work measure of benchmarks.
    pub fn tile_pair_count(&self) -> usize {
        self.tiles.entries.len() * super::TILE * super::TILE
    }
}

/// Renders colour, depth and silhouette.
pub fn render(gaussians: &Gaussians, camera: &PinholeCamera) -> Result<Render, RenderError> {
    gaussians.validate()?;
    validate_camera(camera)?;
    let splats = project::project(gaussians, camera);
    let tiles = TileLists::build(&splats, &camera.intrinsics);
    let (images, final_transmittance, contributor_count) =
        forward::composite(&splats, &tiles, &camera.intrinsics);
    Ok(Render {
        images,
        camera: *camera,
        gaussian_count: gaussians.len(),
        splats,
        tiles,
        final_transmittance,
        contributor_count,
    })
}

/// Gradients of a loss with per-pixel gradients `image_gradients` with respect to every
/// parameter of the Gaussians that `render` drew.
pub fn backward(
    render: &Render,
    image_gradients: &ImageGradients,
) -> Result<Gradients, RenderError> {
    image_gradients.check(render.images.width * render.images.height)?;
    let screen = backward::screen_gradients(render, image_gradients);
    Ok(project::chain_to_parameters(
        &render.splats,
        &screen,
        &render.camera,
        render.gaussian_count,
    ))
}
