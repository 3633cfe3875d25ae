// Adam on the GPU, one thread per Gaussian: the CPU's adam.rs (per-Gaussian step counts, only
// the Gaussians the iteration touched), on the resident records. Skipped entirely when the
// iteration's (tile, Gaussian) pairs overflowed their buffer: the host grows it and repeats.
//
// Gaussian record and moments: 8 floats (mean xyz, log-radius, logit-opacity, rgb); the
// gradient record from `chain`: the same 8 and a touched flag.

struct AdamParams {
    // Learning rates: means, log-radii, logit-opacities, colours.
    rates: vec4<f32>,
    count: u32,
    pair_capacity: u32,
    _a: u32,
    _b: u32,
}

@group(0) @binding(0) var<uniform> adam: AdamParams;
@group(0) @binding(1) var<storage, read> gradients: array<f32>;
@group(0) @binding(2) var<storage, read_write> gaussians: array<f32>;
@group(0) @binding(3) var<storage, read_write> first: array<f32>;
@group(0) @binding(4) var<storage, read_write> second: array<f32>;
@group(0) @binding(5) var<storage, read_write> steps: array<u32>;
// 1 once any iteration of this mapping step touched the Gaussian.
@group(0) @binding(6) var<storage, read_write> touched: array<u32>;
// The scan's total: the iteration's pair count.
@group(0) @binding(7) var<storage, read> pair_count: array<u32>;

const BETA1: f32 = 0.9;
const BETA2: f32 = 0.999;
const EPSILON: f32 = 1e-15;

fn rate(k: u32) -> f32 {
    if (k < 3u) {
        return adam.rates.x;
    }
    if (k == 3u) {
        return adam.rates.y;
    }
    if (k == 4u) {
        return adam.rates.z;
    }
    return adam.rates.w;
}

// b^t by repeated squaring, as Rust's powi.
fn power(b: f32, t: u32) -> f32 {
    var result = 1.0;
    var base = b;
    var e = t;
    loop {
        if (e == 0u) {
            break;
        }
        if ((e & 1u) == 1u) {
            result *= base;
        }
        base *= base;
        e = e >> 1u;
    }
    return result;
}

@compute @workgroup_size(256)
fn adam_step(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= adam.count || pair_count[0] > adam.pair_capacity) {
        return;
    }
    if (gradients[9u * i + 8u] == 0.0) {
        return;
    }
    touched[i] = 1u;
    let t = steps[i] + 1u;
    steps[i] = t;
    let c1 = 1.0 - power(BETA1, t);
    let c2 = 1.0 - power(BETA2, t);
    for (var k = 0u; k < 8u; k++) {
        let g = gradients[9u * i + k];
        let j = 8u * i + k;
        let m = BETA1 * first[j] + (1.0 - BETA1) * g;
        let v = BETA2 * second[j] + (1.0 - BETA2) * g * g;
        first[j] = m;
        second[j] = v;
        gaussians[j] -= rate(k) * (m / c1) / (sqrt(v / c2) + EPSILON);
    }
}
