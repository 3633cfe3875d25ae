// Pruning on the GPU: the host decides which Gaussians stay (from the map it read back once
// this mapping step) and uploads one bit each; `keep_flags` turns the bits into 0/1 slots, the
// exclusive scan of the slots gives each kept Gaussian its new index, and `scatter` copies
// each kept record of `source` to that index of `destination` (the host then copies the
// compacted records back). Records are `stride` words: 8 for the map and Adam's moments, 1 for
// Adam's step counts.

struct CompactParams {
    count: u32,
    stride: u32,
    _a: u32,
    _b: u32,
}

@group(0) @binding(0) var<uniform> compact: CompactParams;
// Bit i % 32 of word i / 32: Gaussian i stays.
@group(0) @binding(1) var<storage, read> keep: array<u32>;
// 1 per kept Gaussian, then (after the scan) its index in the compacted map.
@group(0) @binding(2) var<storage, read_write> slots: array<u32>;
@group(0) @binding(3) var<storage, read> source: array<u32>;
@group(0) @binding(4) var<storage, read_write> destination: array<u32>;

fn kept(i: u32) -> bool {
    return ((keep[i >> 5u] >> (i & 31u)) & 1u) == 1u;
}

@compute @workgroup_size(256)
fn keep_flags(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= compact.count) {
        return;
    }
    slots[i] = select(0u, 1u, kept(i));
}

@compute @workgroup_size(256)
fn scatter(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= compact.count || !kept(i)) {
        return;
    }
    let origin = i * compact.stride;
    let slot = slots[i] * compact.stride;
    for (var k = 0u; k < compact.stride; k++) {
        destination[slot + k] = source[origin + k];
    }
}
