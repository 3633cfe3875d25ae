// One pass of a stable least-significant-digit radix sort of (tile, depth, splat) pairs, 8 bits
// at a time: the depth's four bytes first, then the tile's. Blocks of 256 pairs: `histogram`
// counts each block's digits (digit-major, so one exclusive scan gives every block's first
// slot per digit), `scatter` moves each pair to its slot, keeping the order of equal digits.

struct SortParams {
    // Blocks of 256 pairs the histogram is laid out for (the capacity's).
    blocks: u32,
    _pad: u32,
    shift: u32,
    // 1: the digit comes from the tile, 0: from the depth.
    from_tile: u32,
}

@group(0) @binding(0) var<uniform> sort: SortParams;
@group(0) @binding(1) var<storage, read> in_tiles: array<u32>;
@group(0) @binding(2) var<storage, read> in_depths: array<u32>;
@group(0) @binding(3) var<storage, read> in_splats: array<u32>;
@group(0) @binding(4) var<storage, read_write> histogram: array<u32>;
@group(0) @binding(5) var<storage, read_write> out_tiles: array<u32>;
@group(0) @binding(6) var<storage, read_write> out_depths: array<u32>;
@group(0) @binding(7) var<storage, read_write> out_splats: array<u32>;
// The scan's total: the pairs to sort are the first min(total, capacity).
@group(0) @binding(8) var<storage, read> pair_count: array<u32>;

fn pairs() -> u32 {
    return min(pair_count[0], arrayLength(&in_tiles));
}

var<workgroup> counts: array<atomic<u32>, 256>;
// 32-bit words of one block's thread bits.
const WORDS: u32 = 8u;
// Per digit, the block's threads holding it: one bit each (digit-major, WORDS words a digit).
var<workgroup> members: array<atomic<u32>, 2048>;

fn digit_of(i: u32) -> u32 {
    let key = select(in_depths[i], in_tiles[i], sort.from_tile == 1u);
    return (key >> sort.shift) & 255u;
}

@compute @workgroup_size(256)
fn histogram_pass(
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let block = linear_group(wid, groups);
    // Groups past the histogram's blocks (a 2-D dispatch's padding) would alias its entries.
    if (block >= sort.blocks) {
        return;
    }
    atomicStore(&counts[lid], 0u);
    workgroupBarrier();
    let i = block * GROUP + lid;
    if (i < pairs()) {
        atomicAdd(&counts[digit_of(i)], 1u);
    }
    workgroupBarrier();
    histogram[lid * sort.blocks + block] = atomicLoad(&counts[lid]);
}

@compute @workgroup_size(256)
fn scatter_pass(
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let block = linear_group(wid, groups);
    if (block >= sort.blocks) {
        return;
    }
    // One bit per thread in its digit's row: the stable rank is the number of set bits below
    // its own, 8 words at most (a loop over every earlier thread took up to 255 reads).
    for (var w = lid; w < 256u * WORDS; w += GROUP) {
        atomicStore(&members[w], 0u);
    }
    workgroupBarrier();
    let i = block * GROUP + lid;
    let valid = i < pairs();
    var digit = 0u;
    let word = lid / 32u;
    let bit = lid % 32u;
    if (valid) {
        digit = digit_of(i);
        atomicOr(&members[digit * WORDS + word], 1u << bit);
    }
    workgroupBarrier();
    if (!valid) {
        return;
    }
    var rank = countOneBits(atomicLoad(&members[digit * WORDS + word]) & ((1u << bit) - 1u));
    for (var w = 0u; w < word; w++) {
        rank += countOneBits(atomicLoad(&members[digit * WORDS + w]));
    }
    let slot = histogram[digit * sort.blocks + block] + rank;
    out_tiles[slot] = in_tiles[i];
    out_depths[slot] = in_depths[i];
    out_splats[slot] = in_splats[i];
}
