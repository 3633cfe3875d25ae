// Binning splats into the tiles of one band of tile rows: count the (tile, splat) pairs of
// each splat, then (after an exclusive scan of the counts) emit them, then (after the sort)
// find where each tile's run of pairs starts and ends.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> splats: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> rects: array<vec4<u32>>;
// Pair count per splat, scanned in place into each splat's first pair.
@group(0) @binding(3) var<storage, read_write> offsets: array<u32>;
@group(0) @binding(4) var<storage, read_write> pair_tiles: array<u32>;
@group(0) @binding(5) var<storage, read_write> pair_depths: array<u32>;
@group(0) @binding(6) var<storage, read_write> pair_splats: array<u32>;
// Per tile of the whole image: first pair, one past the last.
@group(0) @binding(7) var<storage, read_write> ranges: array<u32>;
// The scan's total: how many pairs the splats asked for (the pair buffers may hold fewer; the
// resident iteration then grows them and repeats).
@group(0) @binding(8) var<storage, read> pair_count: array<u32>;

// Splat i's tiles inside the band as half-open (first column, end column, first row, end
// row); all zero when it has none.
fn band_tiles(i: u32) -> vec4<u32> {
    let r = rects[i];
    let rows = vec2<u32>(max(r.z, params.band_start), min(r.w + 1u, params.band_end));
    if (r.x > r.y || rows.x >= rows.y) {
        return vec4<u32>(0u);
    }
    return vec4<u32>(r.x, r.y + 1u, rows.x, rows.y);
}

// Whether splat i's footprint reaches tile (tx, ty): the tile's pixel nearest the centre lies
// within the extent (beyond it every alpha is under the minimum). A footprint is round, so
// the rectangle's corner tiles often hold none of it, and a pair costs a whole tile's threads.
fn touches(i: u32, tx: u32, ty: u32) -> bool {
    let s = splats[3u * i];
    let extent = splats[3u * i + 1u].y;
    let origin = vec2<f32>(f32(tx * TILE), f32(ty * TILE));
    let nearest = clamp(s.xy, origin, origin + vec2<f32>(f32(TILE - 1u)));
    let d = s.xy - nearest;
    return dot(d, d) <= extent * extent;
}

@compute @workgroup_size(256)
fn count_pairs(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= params.count) {
        return;
    }
    let t = band_tiles(i);
    var n = 0u;
    for (var ty = t.z; ty < t.w; ty++) {
        for (var tx = t.x; tx < t.y; tx++) {
            n += select(0u, 1u, touches(i, tx, ty));
        }
    }
    offsets[i] = n;
}

@compute @workgroup_size(256)
fn emit_pairs(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= params.count) {
        return;
    }
    let t = band_tiles(i);
    // Positive floats order like their bits; ties keep splat order (the sort is stable).
    let depth = bitcast<u32>(splats[3u * i + 1u].x);
    var o = offsets[i];
    let capacity = arrayLength(&pair_tiles);
    for (var ty = t.z; ty < t.w; ty++) {
        for (var tx = t.x; tx < t.y; tx++) {
            if (!touches(i, tx, ty)) {
                continue;
            }
            if (o >= capacity) {
                return;
            }
            pair_tiles[o] = ty * params.tiles_x + tx;
            pair_depths[o] = depth;
            pair_splats[o] = i;
            o++;
        }
    }
}

@compute @workgroup_size(256)
fn tile_ranges(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    let n = min(pair_count[0], arrayLength(&pair_tiles));
    if (i >= n) {
        return;
    }
    let t = pair_tiles[i];
    if (i == 0u || pair_tiles[i - 1u] != t) {
        ranges[2u * t] = i;
    }
    if (i == n - 1u || pair_tiles[i + 1u] != t) {
        ranges[2u * t + 1u] = i + 1u;
    }
}
