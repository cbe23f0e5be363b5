// Collection, step 3: each particle writes its index into its bucket's range at its arrival
// slot (an order that varies from run to run; contact_rank fixes it), and zeroes its bucket's
// count, which the prefix sum has consumed: the counts are all zero again for the next build
// (buckets without particles never stopped being zero), so no clearing pass is needed.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> cell: array<vec4<i32>>;
@group(0) @binding(2) var<storage, read> arrival: array<u32>;
@group(0) @binding(3) var<storage, read> bucket_start: array<u32>;
@group(0) @binding(4) var<storage, read_write> unsorted: array<u32>;
@group(0) @binding(5) var<storage, read_write> bucket_count: array<atomic<u32>>;

@compute @workgroup_size(64)
fn contact_scatter(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_index(wid, nwg, lid);
    if (i >= params.n) {
        return;
    }
    let b = bitcast<u32>(cell[i].w);
    unsorted[bucket_start[b] + arrival[i]] = i;
    atomicStore(&bucket_count[b], 0u);
}
