// Back-to-front gradients: one 16x16 workgroup per tile, one thread per pixel. For each splat
// of the tile's list (from the last contributor of any pixel backwards) every pixel computes
// its share of the splat's 8 screen-space gradients (`pixel_share`); the workgroup sums the
// shares and one thread per gradient adds the sum to the splat's totals with a
// compare-and-swap float add (WGSL has no float atomics), so each (tile, splat) pair costs one
// atomic per gradient, not one per pixel. How the workgroup sums is the variant's:
// backward_shared.wgsl (workgroup memory, any adapter) or backward_subgroup.wgsl (subgroup
// sums, where the adapter has them).

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> splats: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> pair_splats: array<u32>;
@group(0) @binding(3) var<storage, read> ranges: array<u32>;
@group(0) @binding(4) var<storage, read> pixels: array<f32>;
// Per pixel: d loss / d (r, g, b, depth, silhouette).
@group(0) @binding(5) var<storage, read> pixel_gradients: array<f32>;
// Per splat: 8 gradients as f32 bits, then a touched flag. In the Fisher mode: the 8
// parameters' squared per-pixel gradients, summed.
@group(0) @binding(6) var<storage, read_write> screen: array<atomic<u32>>;
// Gaussian records (2 vec4: mean xyz, log-radius; logit-opacity, rgb), for the Fisher mode's
// per-pixel chain rule.
@group(0) @binding(7) var<storage, read> gaussians: array<vec4<f32>>;

const BATCH: u32 = 64u;

// The batch of splats being walked, loaded by the workgroup together.
var<workgroup> shape: array<vec4<f32>, BATCH>;
var<workgroup> colour: array<vec4<f32>, BATCH>;
var<workgroup> radius: array<f32, BATCH>;
var<workgroup> index: array<u32, BATCH>;
var<workgroup> point: array<vec3<f32>, BATCH>;
var<workgroup> flag: atomic<u32>;
var<workgroup> snapshot: u32;

fn atomic_add_f32(slot: u32, value: f32) {
    var old = atomicLoad(&screen[slot]);
    loop {
        let swap = atomicCompareExchangeWeak(&screen[slot], old, bitcast<u32>(bitcast<f32>(old) + value));
        if (swap.exchanged) {
            break;
        }
        old = swap.old_value;
    }
}

// One pixel's parameter gradients from its screen-space ones (the chain rule of
// project.wgsl's `chain`), squared: its share of the diagonal Fisher information.
fn squared_parameters(g: array<f32, 8>, p: vec3<f32>, radius: f32, opacity: f32) -> array<f32, 8> {
    let world_radius = radius * p.z / params.fx;
    let inv_z2 = 1.0 / (p.z * p.z);
    let d_depth = g[7] - (g[0] * params.fx * p.x + g[1] * params.fy * p.y + g[2] * params.fx * world_radius) * inv_z2;
    let d_camera = vec3<f32>(g[0] * params.fx / p.z, g[1] * params.fy / p.z, d_depth);
    let r = params.camera_from_world;
    let d_world = vec3<f32>(dot(r[0].xyz, d_camera), dot(r[1].xyz, d_camera), dot(r[2].xyz, d_camera));
    let d_radius = g[2] * radius;
    let d_opacity = g[3] * opacity * (1.0 - opacity);
    return array<f32, 8>(
        d_world.x * d_world.x, d_world.y * d_world.y, d_world.z * d_world.z,
        d_radius * d_radius, d_opacity * d_opacity,
        g[4] * g[4], g[5] * g[5], g[6] * g[6],
    );
}

// A pixel's state while it walks its splats back to front.
struct PixelWalk {
    x: u32,
    y: u32,
    inside: bool,
    // Its contributors (the forward pass's count).
    count: u32,
    // Transmittance in front of the current splat.
    transmittance: f32,
    // d loss / d (r, g, b, depth, silhouette) of the pixel.
    grad: array<f32, 5>,
    // Colour, depth and silhouette composited behind the current splat.
    behind: array<f32, 5>,
}

// The pixel's walk set up from the forward pass's record: (tile, walk).
fn start_walk(local: vec3<u32>, wid: vec3<u32>) -> PixelWalk {
    let pixel = tile_pixel(local, wid);
    var walk: PixelWalk;
    walk.x = pixel.y;
    walk.y = pixel.z;
    walk.inside = pixel.w == 1u;
    walk.count = 0u;
    walk.transmittance = 1.0;
    walk.grad = array<f32, 5>(0.0, 0.0, 0.0, 0.0, 0.0);
    walk.behind = array<f32, 5>(0.0, 0.0, 0.0, 0.0, 0.0);
    if (walk.inside) {
        let p = (walk.y - params.band_start * TILE) * params.width + walk.x;
        walk.transmittance = pixels[7u * p + 5u];
        walk.count = bitcast<u32>(pixels[7u * p + 6u]);
        for (var k = 0u; k < 5u; k++) {
            walk.grad[k] = pixel_gradients[5u * p + k];
        }
    }
    return walk;
}

// The number of list entries the tile's walk covers: the most contributors of any of its
// pixels (every thread must take part).
fn tile_walk_length(lid: u32, count: u32, list_length: u32) -> u32 {
    if (lid == 0u) {
        atomicStore(&flag, 0u);
    }
    workgroupBarrier();
    atomicMax(&flag, count);
    workgroupBarrier();
    if (lid == 0u) {
        snapshot = atomicLoad(&flag);
        atomicStore(&flag, 0u);
    }
    return min(workgroupUniformLoad(&snapshot), list_length);
}

// Loads entry `at` of the tile's list into batch slot `lid`.
fn load_splat(lid: u32, at: u32) {
    let s = pair_splats[at];
    shape[lid] = splats[3u * s];
    let s1 = splats[3u * s + 1u];
    colour[lid] = vec4<f32>(splats[3u * s + 2u].xyz, s1.x);
    radius[lid] = s1.z;
    index[lid] = s;
    point[lid] = (params.camera_from_world * vec4<f32>(gaussians[2u * s].xyz, 1.0)).xyz;
}

// The pixel's share of batch splat `j` (list position `position`): its 8 screen-space
// gradients (in the Fisher mode, its squared parameter gradients), zero where the splat does
// not touch it (`touched` says which); advances the walk past the splat.
fn pixel_share(walk: ptr<function, PixelWalk>, j: u32, position: u32, squared: bool, touched: ptr<function, bool>) -> array<f32, 8> {
    let sh = shape[j];
    let dx = f32((*walk).x) - sh.x;
    let dy = f32((*walk).y) - sh.y;
    let raw = sh.w * exp((dx * dx + dy * dy) * sh.z * -0.5);
    let a = min(raw, params.max_alpha);
    let valid = (*walk).inside && a >= params.min_alpha && position < (*walk).count;
    *touched = valid;
    var g = array<f32, 8>(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    if (!valid) {
        return g;
    }
    // Transmittance in front of this splat, undone from the one behind it.
    let t = (*walk).transmittance / (1.0 - a);
    (*walk).transmittance = t;
    let weight = a * t;
    let c = colour[j];
    let values = array<f32, 5>(c.x, c.y, c.z, c.w, 1.0);
    var d_alpha = 0.0;
    for (var k = 0u; k < 5u; k++) {
        d_alpha += (*walk).grad[k] * (values[k] - (*walk).behind[k]);
        (*walk).behind[k] = a * values[k] + (1.0 - a) * (*walk).behind[k];
    }
    d_alpha *= t;
    g[4] = (*walk).grad[0] * weight;
    g[5] = (*walk).grad[1] * weight;
    g[6] = (*walk).grad[2] * weight;
    g[7] = (*walk).grad[3] * weight;
    // The 0.99 clamp cuts the gradient to the Gaussian's shape and opacity.
    if (raw <= params.max_alpha) {
        let d_q = d_alpha * a * -0.5;
        g[0] = d_q * -2.0 * dx * sh.z;
        g[1] = d_q * -2.0 * dy * sh.z;
        g[2] = d_q * (-2.0 / radius[j]) * (dx * dx + dy * dy) * sh.z;
        g[3] = d_alpha * a * (1.0 / sh.w);
    }
    if (squared) {
        return squared_parameters(g, point[j], radius[j], sh.w);
    }
    return g;
}
