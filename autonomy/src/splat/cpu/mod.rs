//! The native CPU engine: project, bin into 16x16 tiles, sort each tile's list by depth,
//! composite 8 pixels at a time with a vectorised exp, rayon across tiles; the backward pass
//! walks the same lists back to front.

mod backward;
mod forward;
mod localisation;
mod project;
mod tiles;

pub use localisation::log_det;
pub use project::Splat;

use super::{
    validate_camera, FisherDiagonal, ImageGradients, Images, RenderError, FISHER_PARAMETERS,
};
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
    let (screen, _) = backward::screen_gradients(render, image_gradients, backward::Mode::Gradient);
    Ok(project::chain_to_parameters(
        &render.splats,
        &screen,
        &render.camera,
        render.gaussian_count,
    ))
}

fn chain_of(render: &Render) -> backward::Chain {
    let rotation = render
        .camera
        .world_from_camera
        .rotation
        .to_rotation_matrix()
        .into_inner()
        .cast::<f32>();
    backward::Chain {
        focal: [
            render.camera.intrinsics.fx as f32,
            render.camera.intrinsics.fy as f32,
        ],
        rotation: [0, 1, 2].map(|r| [0, 1, 2].map(|c| rotation[(r, c)])),
    }
}

/// An upstream gradient of 1 on colour and depth: what the information passes take
/// derivatives of.
fn colour_and_depth(render: &Render) -> ImageGradients {
    let pixels = render.images.width * render.images.height;
    ImageGradients {
        colour: vec![1.0; 3 * pixels],
        depth: vec![1.0; pixels],
        silhouette: vec![0.0; pixels],
    }
}

/// The diagonal Fisher information of the view `render` drew (AG-SLAM eqs 7-9): per Gaussian
/// and parameter, the sum over pixels of the squared per-pixel gradient of colour + depth.
pub fn fisher(render: &Render) -> FisherDiagonal {
    let chain = chain_of(render);
    let (per_splat, _) = backward::screen_gradients(
        render,
        &colour_and_depth(render),
        backward::Mode::Fisher(&chain),
    );
    by_gaussian(render, &per_splat)
}

/// Per-splat sums of a Fisher pass indexed like the Gaussians (zero for the culled).
fn by_gaussian(render: &Render, per_splat: &[([f32; 8], bool)]) -> FisherDiagonal {
    let mut out = vec![[0.0f32; FISHER_PARAMETERS]; render.gaussian_count];
    for (splat, (h, _)) in render.splats.iter().zip(per_splat) {
        out[splat.index as usize] = *h;
    }
    out
}

/// J_tau^T J_tau (6 x 6; translation, then rotation of the camera frame) of the view `render`
/// drew (AG-SLAM eqs 14-16): J_tau per pixel is the derivative of the pixel's colour + depth
/// with respect to a small camera motion tau in se(3).
pub fn pose_information(render: &Render) -> [[f64; 6]; 6] {
    let chain = chain_of(render);
    backward::screen_gradients(
        render,
        &colour_and_depth(render),
        backward::Mode::Pose(&chain),
    )
    .1
}

/// The Fisher diagonal and J_tau^T J_tau of one view in a single pass (what the agslam
/// planner scores each candidate with).
pub fn fisher_and_pose(render: &Render) -> (FisherDiagonal, [[f64; 6]; 6]) {
    let chain = chain_of(render);
    let (per_splat, jtj) = backward::screen_gradients(
        render,
        &colour_and_depth(render),
        backward::Mode::FisherAndPose(&chain),
    );
    (by_gaussian(render, &per_splat), jtj)
}
