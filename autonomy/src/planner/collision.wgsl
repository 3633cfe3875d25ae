// Brute-force collision check on the GPU: one thread per obstacle, every query point against
// it; a hit sets the point's flag. Exact: no subsampling, the same test as the CPU.

struct CollisionParams {
    obstacles: u32,
    points: u32,
    robot_radius: f32,
    gaussian_scale: f32,
}

@group(0) @binding(0) var<uniform> cp: CollisionParams;
// x, y, z, radius per obstacle.
@group(0) @binding(1) var<storage, read> obstacles: array<vec4<f32>>;
// x, y, z, unused per point.
@group(0) @binding(2) var<storage, read> points: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> hits: array<atomic<u32>>;

@compute @workgroup_size(256)
fn collide(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= cp.obstacles) {
        return;
    }
    let o = obstacles[i];
    let reach = cp.robot_radius + cp.gaussian_scale * o.w;
    for (var k = 0u; k < cp.points; k++) {
        let d = points[k].xyz - o.xyz;
        if (dot(d, d) < reach * reach) {
            atomicOr(&hits[k], 1u);
        }
    }
}
