// Shared by the per-tile kernels (forward, backward); needs their `params` binding.

// The pixel of a 16x16 tile kernel's thread: (tile index, x, y, 1 if inside the image).
fn tile_pixel(local: vec3<u32>, wid: vec3<u32>) -> vec4<u32> {
    let tile_y = wid.y + params.band_start;
    let x = wid.x * TILE + local.x;
    let y = tile_y * TILE + local.y;
    return vec4<u32>(tile_y * params.tiles_x + wid.x, x, y, select(0u, 1u, x < params.width && y < params.height));
}
