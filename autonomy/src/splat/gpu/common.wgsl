// Shared by every splat kernel; the Rust side prepends it to each module (WGSL has no
// includes). Mirrors `GpuParams` in gpu/mod.rs field for field.
struct Params {
    camera_from_world: mat4x4<f32>,
    fx: f32,
    fy: f32,
    cx: f32,
    cy: f32,
    width: u32,
    height: u32,
    tiles_x: u32,
    tiles_y: u32,
    count: u32,
    near: f32,
    min_alpha: f32,
    max_alpha: f32,
    min_transmittance: f32,
    // First tile row of this band and one past its last (bands bound the pair buffers).
    band_start: u32,
    band_end: u32,
    _pad: u32,
}

const TILE: u32 = 16u;
// Threads per workgroup of the 1-D kernels.
const GROUP: u32 = 256u;

// Linear index of a 1-D kernel's thread; dispatches wider than 65535 groups use y.
fn linear_index(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * GROUP;
}

fn linear_group(wid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return wid.x + wid.y * groups.x;
}
