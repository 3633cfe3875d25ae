// The backward pass's sums by subgroup (where the adapter has subgroup operations): each
// subgroup adds its pixels' shares of a splat with `subgroupAdd` and its first lane stores the
// 8 sums in a slot of its own, so a batch of splats is walked with no barrier at all; after the
// batch one barrier, then 8 threads per splat add the subgroups' slots and make the atomic adds.
// Per splat this replaces the shared-memory variant's three barriers and 8 KB of stores. The
// workgroup is one-dimensional (subgroup ids need it): thread `lid` is pixel (lid % 16,
// lid / 16) of its tile, as in the 16x16 variant.

// Per batch splat, per subgroup: its 8 sums. A batch holds as many splats as fit
// (`SLOTS / (8 x subgroups)`, at most BATCH).
const SLOTS: u32 = 2048u;
var<workgroup> slots: array<f32, SLOTS>;
// Per batch splat, one bit: some pixel of the tile was touched by it.
var<workgroup> touched_bits: array<atomic<u32>, 2>;
var<workgroup> subgroups_shared: u32;

@compute @workgroup_size(256)
fn backward(
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(subgroup_id) subgroup: u32,
    @builtin(subgroup_invocation_id) lane: u32,
    @builtin(num_subgroups) subgroups: u32,
) {
    walk_tile(vec3<u32>(lid % TILE, lid / TILE, 0u), lid, wid, subgroup, lane, subgroups, false);
}

// The Fisher mode: each pixel's gradient is carried to the parameters and squared before the
// workgroup sums it (AG-SLAM eqs 7-9), so it is not the square of the summed gradient.
@compute @workgroup_size(256)
fn fisher(
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(subgroup_id) subgroup: u32,
    @builtin(subgroup_invocation_id) lane: u32,
    @builtin(num_subgroups) subgroups: u32,
) {
    walk_tile(vec3<u32>(lid % TILE, lid / TILE, 0u), lid, wid, subgroup, lane, subgroups, true);
}

fn walk_tile(local: vec3<u32>, lid: u32, wid: vec3<u32>, subgroup: u32, lane: u32, subgroups_here: u32, squared: bool) {
    var walk = start_walk(local, wid);
    let tile = tile_pixel(local, wid).x;
    let start = ranges[2u * tile];
    let end = max(ranges[2u * tile + 1u], start);
    if (lid == 0u) {
        subgroups_shared = subgroups_here;
    }
    var top = tile_walk_length(lid, walk.count, end - start);
    // The same for every thread; loaded so that the batch loop is seen to be uniform.
    let subgroups = workgroupUniformLoad(&subgroups_shared);
    let per_batch = max(min(BATCH, SLOTS / (8u * subgroups)), 1u);
    while (top > 0u) {
        let first = select(0u, top - per_batch, top > per_batch);
        let batch = top - first;
        if (lid < batch) {
            load_splat(lid, start + first + lid);
        }
        if (lid < 2u) {
            atomicStore(&touched_bits[lid], 0u);
        }
        workgroupBarrier();
        for (var jj = 0u; jj < batch; jj++) {
            let j = batch - 1u - jj;
            var touched = false;
            let g = pixel_share(&walk, j, first + j, squared, &touched);
            let base = (j * subgroups + subgroup) * 8u;
            if (subgroupAny(touched)) {
                for (var k = 0u; k < 8u; k++) {
                    let sum = subgroupAdd(g[k]);
                    if (lane == 0u) {
                        slots[base + k] = sum;
                    }
                }
                if (lane == 0u) {
                    atomicOr(&touched_bits[j / 32u], 1u << (j % 32u));
                }
            } else if (lane == 0u) {
                for (var k = 0u; k < 8u; k++) {
                    slots[base + k] = 0.0;
                }
            }
        }
        workgroupBarrier();
        // Thread t adds gradient t % 8 of batch splat t / 8 over the subgroups.
        for (var t = lid; t < 8u * batch; t += 256u) {
            let j = t / 8u;
            let k = t % 8u;
            if ((atomicLoad(&touched_bits[j / 32u]) & (1u << (j % 32u))) != 0u) {
                var total = 0.0;
                for (var s = 0u; s < subgroups; s++) {
                    total += slots[(j * subgroups + s) * 8u + k];
                }
                atomic_add_f32(9u * index[j] + k, total);
                if (k == 0u) {
                    atomicOr(&screen[9u * index[j] + 8u], 1u);
                }
            }
        }
        workgroupBarrier();
        top = first;
    }
}
