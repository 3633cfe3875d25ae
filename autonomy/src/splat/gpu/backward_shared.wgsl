// The backward pass's sums in workgroup memory (any adapter): after each splat every thread
// stores its 8-gradient share and the workgroup adds them in two levels with one barrier.

var<workgroup> partial: array<array<f32, 8>, 256>;
// Per thread: one gradient summed over 8 of the tile's pixels (the reduction's first level).
var<workgroup> sums: array<f32, 256>;

@compute @workgroup_size(16, 16)
fn backward(
    @builtin(local_invocation_id) local: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    walk_tile(local, lid, wid, false);
}

// The Fisher mode: each pixel's gradient is carried to the parameters and squared before the
// workgroup sums it (AG-SLAM eqs 7-9), so it is not the square of the summed gradient.
@compute @workgroup_size(16, 16)
fn fisher(
    @builtin(local_invocation_id) local: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    walk_tile(local, lid, wid, true);
}

fn walk_tile(local: vec3<u32>, lid: u32, wid: vec3<u32>, squared: bool) {
    var walk = start_walk(local, wid);
    let tile = tile_pixel(local, wid).x;
    let start = ranges[2u * tile];
    let end = max(ranges[2u * tile + 1u], start);
    var top = tile_walk_length(lid, walk.count, end - start);
    while (top > 0u) {
        let first = select(0u, top - BATCH, top > BATCH);
        let batch = top - first;
        if (lid < batch) {
            load_splat(lid, start + first + lid);
        }
        workgroupBarrier();
        for (var jj = 0u; jj < batch; jj++) {
            let j = batch - 1u - jj;
            var touched = false;
            partial[lid] = pixel_share(&walk, j, first + j, squared, &touched);
            if (touched) {
                atomicOr(&flag, 1u);
            }
            workgroupBarrier();
            if (lid == 0u) {
                snapshot = atomicLoad(&flag);
                atomicStore(&flag, 0u);
            }
            if (workgroupUniformLoad(&snapshot) != 0u) {
                // Two levels, one barrier between them (a tree of halvings needs eight): each
                // thread adds one gradient over 8 pixels 32 apart (neighbouring threads read
                // neighbouring words, so no two threads of 32 share a memory bank), then 8
                // threads add their gradient's 32 partial sums.
                let k = lid % 8u;
                let chunk = lid / 8u;
                var sum = 0.0;
                for (var i = 0u; i < 8u; i++) {
                    sum += partial[chunk + 32u * i][k];
                }
                sums[lid] = sum;
                workgroupBarrier();
                if (lid < 8u) {
                    var total = 0.0;
                    for (var c = 0u; c < 32u; c++) {
                        total += sums[8u * c + lid];
                    }
                    atomic_add_f32(9u * index[j] + lid, total);
                } else if (lid == 8u) {
                    atomicOr(&screen[9u * index[j] + 8u], 1u);
                }
            }
            workgroupBarrier();
        }
        top = first;
    }
}
