// Projection and culling (one thread per Gaussian), then the chain rule back to the
// parameters once the backward pass has summed the screen-space gradients.
//
// Splat record, 3 vec4 per Gaussian:
//   [0] u, v, 1 / radius^2, opacity   [1] depth, extent, radius, visible (1 or 0)
//   [2] r, g, b, 0
// Gaussian record, 2 vec4: [0] mean xyz, log-radius  [1] logit-opacity, r, g, b

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> gaussians: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> splats: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> rects: array<vec4<u32>>;
// Screen gradients from the backward pass: 8 floats (as bits) + a touched flag per Gaussian.
@group(0) @binding(4) var<storage, read> screen: array<u32>;
// Parameter gradients: mean xyz, log-radius, logit-opacity, rgb, touched (1 or 0).
@group(0) @binding(5) var<storage, read_write> gradients: array<f32>;

fn sigmoid(x: f32) -> f32 {
    return 1.0 / (1.0 + exp(-x));
}

// Tile column (or row) holding pixel coordinate v, clamped to the grid like the CPU engine.
fn tile_of(v: f32, n: u32) -> u32 {
    return min(u32(clamp(v, 0.0, f32(n * TILE))) / TILE, n - 1u);
}

@compute @workgroup_size(256)
fn project(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= params.count) {
        return;
    }
    splats[3u * i + 1u] = vec4<f32>(0.0);
    rects[i] = vec4<u32>(1u, 0u, 1u, 0u);
    let g0 = gaussians[2u * i];
    let g1 = gaussians[2u * i + 1u];
    let p = params.camera_from_world * vec4<f32>(g0.xyz, 1.0);
    if (p.z < params.near) {
        return;
    }
    let opacity = sigmoid(g1.x);
    if (min(opacity, params.max_alpha) < params.min_alpha) {
        return;
    }
    let radius = params.fx * exp(g0.w) / p.z;
    let u = params.fx * p.x / p.z + params.cx;
    let v = params.fy * p.y / p.z + params.cy;
    // alpha >= 1/255 needs q <= 2 ln(255 opacity); one pixel of margin for rounding.
    let extent = radius * sqrt(max(2.0 * log(opacity * 255.0), 0.0)) + 1.0;
    let w = f32(params.width);
    let h = f32(params.height);
    if (u + extent < 0.0 || v + extent < 0.0 || u - extent > w - 1.0 || v - extent > h - 1.0) {
        return;
    }
    splats[3u * i] = vec4<f32>(u, v, 1.0 / (radius * radius), opacity);
    splats[3u * i + 1u] = vec4<f32>(p.z, extent, radius, 1.0);
    splats[3u * i + 2u] = vec4<f32>(g1.yzw, 0.0);
    rects[i] = vec4<u32>(
        tile_of(u - extent, params.tiles_x),
        tile_of(u + extent, params.tiles_x),
        tile_of(v - extent, params.tiles_y),
        tile_of(v + extent, params.tiles_y),
    );
}

@compute @workgroup_size(256)
fn chain(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= params.count) {
        return;
    }
    for (var k = 0u; k < 9u; k++) {
        gradients[9u * i + k] = 0.0;
    }
    let s1 = splats[3u * i + 1u];
    if (s1.w == 0.0) {
        return;
    }
    var s: array<f32, 8>;
    for (var k = 0u; k < 8u; k++) {
        s[k] = bitcast<f32>(screen[9u * i + k]);
    }
    let opacity = splats[3u * i].w;
    let radius = s1.z;
    let g0 = gaussians[2u * i];
    let p = params.camera_from_world * vec4<f32>(g0.xyz, 1.0);
    let world_radius = radius * p.z / params.fx;
    let inv_z2 = 1.0 / (p.z * p.z);
    let d_depth = s[7] - (s[0] * params.fx * p.x + s[1] * params.fy * p.y + s[2] * params.fx * world_radius) * inv_z2;
    let d_camera = vec3<f32>(s[0] * params.fx / p.z, s[1] * params.fy / p.z, d_depth);
    // world_from_camera's rotation is the transpose of camera_from_world's.
    let r = params.camera_from_world;
    let d_world = vec3<f32>(
        dot(r[0].xyz, d_camera),
        dot(r[1].xyz, d_camera),
        dot(r[2].xyz, d_camera),
    );
    gradients[9u * i] = d_world.x;
    gradients[9u * i + 1u] = d_world.y;
    gradients[9u * i + 2u] = d_world.z;
    gradients[9u * i + 3u] = s[2] * radius;
    gradients[9u * i + 4u] = s[3] * opacity * (1.0 - opacity);
    gradients[9u * i + 5u] = s[4];
    gradients[9u * i + 6u] = s[5];
    gradients[9u * i + 7u] = s[6];
    gradients[9u * i + 8u] = f32(screen[9u * i + 8u]);
}
