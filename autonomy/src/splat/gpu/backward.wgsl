// Back-to-front gradients: one 16x16 workgroup per tile, one thread per pixel. For each splat
// of the tile's list (from the last contributor of any pixel backwards) every pixel computes
// its share of the splat's 8 screen-space gradients; the workgroup sums them in shared memory
// (two levels, one barrier) and one thread per gradient adds the sum to the splat's totals
// with a compare-and-swap float add (WGSL has no float atomics), so each (tile, splat) pair
// costs one atomic per gradient, not one per pixel.

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

var<workgroup> shape: array<vec4<f32>, BATCH>;
var<workgroup> colour: array<vec4<f32>, BATCH>;
var<workgroup> radius: array<f32, BATCH>;
var<workgroup> index: array<u32, BATCH>;
var<workgroup> point: array<vec3<f32>, BATCH>;
var<workgroup> partial: array<array<f32, 8>, 256>;
// Per thread: one gradient summed over 8 of the tile's pixels (the reduction's first level).
var<workgroup> sums: array<f32, 256>;
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

@compute @workgroup_size(16, 16)
fn backward(
    @builtin(local_invocation_id) local: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    walk(local, lid, wid, false);
}

// The Fisher mode: each pixel's gradient is carried to the parameters and squared before the
// workgroup sums it (AG-SLAM eqs 7-9), so it is not the square of the summed gradient.
@compute @workgroup_size(16, 16)
fn fisher(
    @builtin(local_invocation_id) local: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    walk(local, lid, wid, true);
}

fn walk(local: vec3<u32>, lid: u32, wid: vec3<u32>, squared: bool) {
    let pixel = tile_pixel(local, wid);
    let tile = pixel.x;
    let x = pixel.y;
    let y = pixel.z;
    let inside = pixel.w == 1u;
    let start = ranges[2u * tile];
    let end = max(ranges[2u * tile + 1u], start);
    var transmittance = 1.0;
    var count = 0u;
    var grad = array<f32, 5>(0.0, 0.0, 0.0, 0.0, 0.0);
    if (inside) {
        let p = (y - params.band_start * TILE) * params.width + x;
        transmittance = pixels[7u * p + 5u];
        count = bitcast<u32>(pixels[7u * p + 6u]);
        for (var k = 0u; k < 5u; k++) {
            grad[k] = pixel_gradients[5u * p + k];
        }
    }
    // Colour, depth and silhouette composited behind the current splat.
    var behind = array<f32, 5>(0.0, 0.0, 0.0, 0.0, 0.0);
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
    let last = min(workgroupUniformLoad(&snapshot), end - start);
    var top = last;
    while (top > 0u) {
        let first = select(0u, top - BATCH, top > BATCH);
        let batch = top - first;
        if (lid < batch) {
            let s = pair_splats[start + first + lid];
            shape[lid] = splats[3u * s];
            let s1 = splats[3u * s + 1u];
            colour[lid] = vec4<f32>(splats[3u * s + 2u].xyz, s1.x);
            radius[lid] = s1.z;
            index[lid] = s;
            point[lid] = (params.camera_from_world * vec4<f32>(gaussians[2u * s].xyz, 1.0)).xyz;
        }
        workgroupBarrier();
        for (var jj = 0u; jj < batch; jj++) {
            let j = batch - 1u - jj;
            let position = first + j;
            let sh = shape[j];
            let dx = f32(x) - sh.x;
            let dy = f32(y) - sh.y;
            let raw = sh.w * exp((dx * dx + dy * dy) * sh.z * -0.5);
            let a = min(raw, params.max_alpha);
            let valid = inside && a >= params.min_alpha && position < count;
            var g = array<f32, 8>(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
            if (valid) {
                atomicOr(&flag, 1u);
                // Transmittance in front of this splat, undone from the one behind it.
                let t = transmittance / (1.0 - a);
                transmittance = t;
                let weight = a * t;
                let c = colour[j];
                let values = array<f32, 5>(c.x, c.y, c.z, c.w, 1.0);
                var d_alpha = 0.0;
                for (var k = 0u; k < 5u; k++) {
                    d_alpha += grad[k] * (values[k] - behind[k]);
                    behind[k] = a * values[k] + (1.0 - a) * behind[k];
                }
                d_alpha *= t;
                g[4] = grad[0] * weight;
                g[5] = grad[1] * weight;
                g[6] = grad[2] * weight;
                g[7] = grad[3] * weight;
                // The 0.99 clamp cuts the gradient to the Gaussian's shape and opacity.
                if (raw <= params.max_alpha) {
                    let d_q = d_alpha * a * -0.5;
                    g[0] = d_q * -2.0 * dx * sh.z;
                    g[1] = d_q * -2.0 * dy * sh.z;
                    g[2] = d_q * (-2.0 / radius[j]) * (dx * dx + dy * dy) * sh.z;
                    g[3] = d_alpha * a * (1.0 / sh.w);
                }
            }
            if (squared) {
                partial[lid] = squared_parameters(g, point[j], radius[j], sh.w);
            } else {
                partial[lid] = g;
            }
            workgroupBarrier();
            if (lid == 0u) {
                snapshot = atomicLoad(&flag);
                atomicStore(&flag, 0u);
            }
            if (workgroupUniformLoad(&snapshot) != 0u) {
                // Two levels, one barrier between them (a tree of halvings needs eight): each
                // thread adds one gradient over 8 pixels 32 apart (neighbouring threads read
                // neighbouring words, so no two threads of 32 share a memory bank), then 8
                // threads add their gradient's 32 partial sums.
                let k = lid % 8u;
                let chunk = lid / 8u;
                var sum = 0.0;
                for (var i = 0u; i < 8u; i++) {
                    sum += partial[chunk + 32u * i][k];
                }
                sums[lid] = sum;
                workgroupBarrier();
                if (lid < 8u) {
                    var total = 0.0;
                    for (var c = 0u; c < 32u; c++) {
                        total += sums[8u * c + lid];
                    }
                    atomic_add_f32(9u * index[j] + lid, total);
                } else if (lid == 8u) {
                    atomicOr(&screen[9u * index[j] + 8u], 1u);
                }
            }
            workgroupBarrier();
        }
        top = first;
    }
}
