// Collection, step 4: each particle counts the members of its bucket with a lower index (its
// rank) and writes itself at start + rank: every bucket lists its particles in increasing
// index, whatever order the atomics gave. This is the counting sort's deterministic placement.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> cell: array<vec4<i32>>;
@group(0) @binding(2) var<storage, read> bucket_start: array<u32>;
@group(0) @binding(3) var<storage, read> unsorted: array<u32>;
@group(0) @binding(4) var<storage, read_write> sorted: array<u32>;

@compute @workgroup_size(64)
fn contact_rank(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_index(wid, nwg, lid);
    if (i >= params.n) {
        return;
    }
    let b = bitcast<u32>(cell[i].w);
    let start = bucket_start[b];
    let end = bucket_start[b + 1u];
    var rank = 0u;
    for (var k = start; k < end; k = k + 1u) {
        if (unsorted[k] < i) {
            rank = rank + 1u;
        }
    }
    sorted[start + rank] = i;
}
