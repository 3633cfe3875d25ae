// The mapping loss on the GPU: mean L1 depth error over measured pixels + 0.4 mean L1 colour
// error + 0.1 (1 - SSIM), SSIM with an 11x11 Gaussian window (sigma 1.5) zero-padded, and its
// gradient with respect to the rendered pixels; the CPU engine's loss (loss/simd.rs) in five
// kernels, one thread per pixel:
//   loss_h      horizontal blur of x, y, x^2, y^2, xy per channel        -> stats (15 / pixel)
//   loss_v      vertical blur, SSIM and dS/d(mu_x, E[x^2], E[xy]) per channel -> planes (9 / pixel);
//               the L1 and SSIM sums of each workgroup                    -> partials
//   loss_bh     horizontal blur of the planes                            -> stats (9 / pixel)
//   loss_bv     vertical blur, the chain to x, the L1 terms              -> pixel_gradients (5 / pixel)
//   loss_total  the partial sums reduced into the terms                  -> terms
// The frame fitted (the target) holds r, g, b, depth per pixel, then the number of measured pixels (as f32).

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> pixels: array<f32>;
@group(0) @binding(2) var<storage, read> frame: array<f32>;
@group(0) @binding(3) var<storage, read_write> stats: array<f32>;
@group(0) @binding(4) var<storage, read_write> planes: array<f32>;
@group(0) @binding(5) var<storage, read_write> pixel_gradients: array<f32>;
@group(0) @binding(6) var<storage, read_write> partials: array<f32>;
// depth L1, colour L1, SSIM, weighted total.
@group(0) @binding(7) var<storage, read_write> terms: array<f32>;

const RADIUS: i32 = 5;
const C1: f32 = 0.0001;
const C2: f32 = 0.0009;
const COLOUR_WEIGHT: f32 = 0.4;
const SSIM_WEIGHT: f32 = 0.1;

var<workgroup> sums: array<vec3<f32>, 256>;

// The window's taps (`WINDOW`, prepended by the host from ssim.rs, so both engines use the
// same f32 values), at offsets -5..=5.
fn tap(t: i32) -> f32 {
    return WINDOW[t + RADIUS];
}

fn pixel_count() -> u32 {
    return params.width * params.height;
}

@compute @workgroup_size(256)
fn loss_h(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let p = linear_index(gid, groups);
    if (p >= pixel_count()) {
        return;
    }
    let x = i32(p % params.width);
    var acc: array<f32, 15>;
    for (var k = 0; k < 15; k++) {
        acc[k] = 0.0;
    }
    for (var t = -RADIUS; t <= RADIUS; t++) {
        let sx = x + t;
        if (sx < 0 || sx >= i32(params.width)) {
            continue;
        }
        let q = u32(i32(p) + t);
        let w = tap(t);
        for (var c = 0u; c < 3u; c++) {
            let a = pixels[7u * q + c];
            let b = frame[4u * q + c];
            acc[5u * c] += w * a;
            acc[5u * c + 1u] += w * b;
            acc[5u * c + 2u] += w * a * a;
            acc[5u * c + 3u] += w * b * b;
            acc[5u * c + 4u] += w * a * b;
        }
    }
    for (var k = 0u; k < 15u; k++) {
        stats[15u * p + k] = acc[k];
    }
}

@compute @workgroup_size(256)
fn loss_v(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let p = linear_index(gid, groups);
    var sum = vec3<f32>(0.0);
    if (p < pixel_count()) {
        let y = i32(p / params.width);
        var acc: array<f32, 15>;
        for (var k = 0; k < 15; k++) {
            acc[k] = 0.0;
        }
        for (var t = -RADIUS; t <= RADIUS; t++) {
            let sy = y + t;
            if (sy < 0 || sy >= i32(params.height)) {
                continue;
            }
            let q = u32(i32(p) + t * i32(params.width));
            let w = tap(t);
            for (var k = 0u; k < 15u; k++) {
                acc[k] += w * stats[15u * q + k];
            }
        }
        let n = f32(pixel_count());
        let gain = -SSIM_WEIGHT / 3.0 / n;
        for (var c = 0u; c < 3u; c++) {
            let mx = acc[5u * c];
            let my = acc[5u * c + 1u];
            let var_x = acc[5u * c + 2u] - mx * mx;
            let var_y = acc[5u * c + 3u] - my * my;
            let cov = acc[5u * c + 4u] - mx * my;
            let a1 = 2.0 * mx * my + C1;
            let a2 = 2.0 * cov + C2;
            let b1 = mx * mx + my * my + C1;
            let b2 = var_x + var_y + C2;
            let inv = 1.0 / (b1 * b2);
            let s = a1 * a2 * inv;
            let ds_dmu = 2.0 * my * a2 * inv - 2.0 * mx * s / b1;
            let ds_dvar = -s / b2;
            let ds_dcov = 2.0 * a1 * inv;
            planes[9u * p + 3u * c] = gain * (ds_dmu - 2.0 * mx * ds_dvar - my * ds_dcov);
            planes[9u * p + 3u * c + 1u] = gain * ds_dvar;
            planes[9u * p + 3u * c + 2u] = gain * ds_dcov;
            sum.z += s;
            sum.y += abs(pixels[7u * p + c] - frame[4u * p + c]);
        }
        let depth = frame[4u * p + 3u];
        if (depth > 0.0) {
            sum.x = abs(pixels[7u * p + 3u] - depth);
        }
    }
    sums[lid] = sum;
    workgroupBarrier();
    for (var stride = 128u; stride > 0u; stride /= 2u) {
        if (lid < stride) {
            sums[lid] += sums[lid + stride];
        }
        workgroupBarrier();
    }
    if (lid == 0u) {
        let g = linear_group(wid, groups);
        partials[4u * g] = sums[0].x;
        partials[4u * g + 1u] = sums[0].y;
        partials[4u * g + 2u] = sums[0].z;
    }
}

@compute @workgroup_size(256)
fn loss_bh(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let p = linear_index(gid, groups);
    if (p >= pixel_count()) {
        return;
    }
    let x = i32(p % params.width);
    var acc: array<f32, 9>;
    for (var k = 0; k < 9; k++) {
        acc[k] = 0.0;
    }
    for (var t = -RADIUS; t <= RADIUS; t++) {
        let sx = x + t;
        if (sx < 0 || sx >= i32(params.width)) {
            continue;
        }
        let q = u32(i32(p) + t);
        let w = tap(t);
        for (var k = 0u; k < 9u; k++) {
            acc[k] += w * planes[9u * q + k];
        }
    }
    for (var k = 0u; k < 9u; k++) {
        stats[9u * p + k] = acc[k];
    }
}

fn sign_of(d: f32) -> f32 {
    return select(0.0, 1.0, d > 0.0) - select(0.0, 1.0, d < 0.0);
}

@compute @workgroup_size(256)
fn loss_bv(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let p = linear_index(gid, groups);
    let n = pixel_count();
    if (p >= n) {
        return;
    }
    let y = i32(p / params.width);
    var acc: array<f32, 9>;
    for (var k = 0; k < 9; k++) {
        acc[k] = 0.0;
    }
    for (var t = -RADIUS; t <= RADIUS; t++) {
        let sy = y + t;
        if (sy < 0 || sy >= i32(params.height)) {
            continue;
        }
        let q = u32(i32(p) + t * i32(params.width));
        let w = tap(t);
        for (var k = 0u; k < 9u; k++) {
            acc[k] += w * stats[9u * q + k];
        }
    }
    let inv3 = 1.0 / f32(3u * n);
    for (var c = 0u; c < 3u; c++) {
        let x = pixels[7u * p + c];
        let want = frame[4u * p + c];
        pixel_gradients[5u * p + c] = COLOUR_WEIGHT * sign_of(x - want) * inv3
            + acc[3u * c] + 2.0 * x * acc[3u * c + 1u] + want * acc[3u * c + 2u];
    }
    let measured = frame[4u * n];
    let depth = frame[4u * p + 3u];
    var depth_gradient = 0.0;
    if (depth > 0.0 && measured > 0.0) {
        depth_gradient = sign_of(pixels[7u * p + 3u] - depth) / measured;
    }
    pixel_gradients[5u * p + 3u] = depth_gradient;
    pixel_gradients[5u * p + 4u] = 0.0;
}

@compute @workgroup_size(256)
fn loss_total(@builtin(local_invocation_index) lid: u32) {
    let n = pixel_count();
    let blocks = (n + GROUP - 1u) / GROUP;
    var sum = vec3<f32>(0.0);
    for (var b = lid; b < blocks; b += GROUP) {
        sum += vec3<f32>(partials[4u * b], partials[4u * b + 1u], partials[4u * b + 2u]);
    }
    sums[lid] = sum;
    workgroupBarrier();
    for (var stride = 128u; stride > 0u; stride /= 2u) {
        if (lid < stride) {
            sums[lid] += sums[lid + stride];
        }
        workgroupBarrier();
    }
    if (lid == 0u) {
        let measured = frame[4u * n];
        var depth_l1 = 0.0;
        if (measured > 0.0) {
            depth_l1 = sums[0].x / measured;
        }
        let colour_l1 = sums[0].y / f32(3u * n);
        let ssim = sums[0].z / f32(3u * n);
        terms[0] = depth_l1;
        terms[1] = colour_l1;
        terms[2] = ssim;
        terms[3] = depth_l1 + COLOUR_WEIGHT * colour_l1 + SSIM_WEIGHT * (1.0 - ssim);
    }
}
