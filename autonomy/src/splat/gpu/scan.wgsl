// Exclusive prefix sum of u32 in blocks of 256: each block is scanned in workgroup memory and
// its total written to `sums`; the host scans `sums` the same way (recursively) and then adds
// each block's offset back.

struct ScanParams {
    n: u32,
    _a: u32,
    _b: u32,
    _c: u32,
}

@group(0) @binding(0) var<uniform> scan: ScanParams;
@group(0) @binding(1) var<storage, read_write> data: array<u32>;
@group(0) @binding(2) var<storage, read_write> sums: array<u32>;

var<workgroup> partial: array<u32, 256>;

@compute @workgroup_size(256)
fn scan_blocks(
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let block = linear_group(wid, groups);
    let i = block * GROUP + lid;
    var x = 0u;
    if (i < scan.n) {
        x = data[i];
    }
    partial[lid] = x;
    workgroupBarrier();
    // Hillis-Steele inclusive scan.
    for (var offset = 1u; offset < GROUP; offset *= 2u) {
        var t = partial[lid];
        if (lid >= offset) {
            t += partial[lid - offset];
        }
        workgroupBarrier();
        partial[lid] = t;
        workgroupBarrier();
    }
    if (i < scan.n) {
        data[i] = partial[lid] - x;
    }
    if (lid == GROUP - 1u) {
        sums[block] = partial[lid];
    }
}

@compute @workgroup_size(256)
fn add_block_offsets(
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let block = linear_group(wid, groups);
    let i = block * GROUP + lid;
    if (i < scan.n) {
        data[i] += sums[block];
    }
}
