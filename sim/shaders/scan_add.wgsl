// Prefix sum, step 3: adds each block's offset to its buckets' starts.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> bucket_start: array<u32>;
@group(0) @binding(2) var<storage, read> block_sums: array<u32>;

@compute @workgroup_size(64)
fn scan_add(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let b = linear_index(wid, nwg, lid);
    if (b > params.table_mask) {
        return;
    }
    bucket_start[b] = bucket_start[b] + block_sums[b / SCAN_BLOCK];
}
