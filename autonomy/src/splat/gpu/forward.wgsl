// Front-to-back compositing: one 16x16 workgroup per tile of the band, one thread per pixel;
// the tile's sorted splats are staged through workgroup memory 256 at a time. The cut-offs
// and the order of operations are the CPU engine's, so the images agree to rounding.
//
// Per pixel of the band out: r, g, b, depth, silhouette, final transmittance, contributor count (bits).

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> splats: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> pair_splats: array<u32>;
@group(0) @binding(3) var<storage, read> ranges: array<u32>;
@group(0) @binding(4) var<storage, read_write> pixels: array<f32>;

var<workgroup> shape: array<vec4<f32>, 256>;
var<workgroup> colour: array<vec4<f32>, 256>;
var<workgroup> finished: atomic<u32>;
var<workgroup> finished_snapshot: u32;

@compute @workgroup_size(16, 16)
fn forward(
    @builtin(local_invocation_id) local: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let pixel = tile_pixel(local, wid);
    let tile = pixel.x;
    let x = pixel.y;
    let y = pixel.z;
    let inside = pixel.w == 1u;
    let start = ranges[2u * tile];
    let end = max(ranges[2u * tile + 1u], start);
    if (lid == 0u) {
        atomicStore(&finished, 0u);
    }
    workgroupBarrier();
    var transmittance = 1.0;
    var rgb = vec3<f32>(0.0);
    var depth = 0.0;
    var silhouette = 0.0;
    var count = 0u;
    var done = !inside;
    if (done) {
        atomicAdd(&finished, 1u);
    }
    let px = f32(x);
    let py = f32(y);
    for (var base = start; base < end; base += GROUP) {
        workgroupBarrier();
        if (lid == 0u) {
            finished_snapshot = atomicLoad(&finished);
        }
        if (workgroupUniformLoad(&finished_snapshot) == GROUP) {
            break;
        }
        let entry = base + lid;
        if (entry < end) {
            let s = pair_splats[entry];
            shape[lid] = splats[3u * s];
            colour[lid] = vec4<f32>(splats[3u * s + 2u].xyz, splats[3u * s + 1u].x);
        }
        workgroupBarrier();
        let batch = min(GROUP, end - base);
        for (var j = 0u; j < batch; j++) {
            if (done) {
                break;
            }
            let sh = shape[j];
            let dx = px - sh.x;
            let dy = py - sh.y;
            let q = (dx * dx + dy * dy) * sh.z;
            let a = min(sh.w * exp(q * -0.5), params.max_alpha);
            if (a < params.min_alpha) {
                continue;
            }
            let next = transmittance * (1.0 - a);
            if (next < params.min_transmittance) {
                done = true;
                atomicAdd(&finished, 1u);
                break;
            }
            let weight = a * transmittance;
            let c = colour[j];
            rgb += weight * c.xyz;
            depth += weight * c.w;
            silhouette += weight;
            transmittance = next;
            count = base - start + j + 1u;
        }
    }
    if (inside) {
        let p = 7u * ((y - params.band_start * TILE) * params.width + x);
        pixels[p] = rgb.x;
        pixels[p + 1u] = rgb.y;
        pixels[p + 2u] = rgb.z;
        pixels[p + 3u] = depth;
        pixels[p + 4u] = silhouette;
        pixels[p + 5u] = transmittance;
        pixels[p + 6u] = bitcast<f32>(count);
    }
}
