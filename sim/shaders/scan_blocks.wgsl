// Prefix sum, step 1: each workgroup scans SCAN_BLOCK bucket counts (2 per invocation) into
// exclusive block-local starts and writes its block's total.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> bucket_count: array<u32>;
@group(0) @binding(2) var<storage, read_write> bucket_start: array<u32>;
@group(0) @binding(3) var<storage, read_write> block_sums: array<u32>;

var<workgroup> sums: array<u32, 256>;

@compute @workgroup_size(256)
fn scan_blocks(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let block = wid.x + wid.y * nwg.x;
    let table = params.table_mask + 1u;
    let first = block * SCAN_BLOCK + 2u * lid;
    var a = 0u;
    var b = 0u;
    if (block < params.scan_blocks) {
        if (first < table) {
            a = bucket_count[first];
        }
        if (first + 1u < table) {
            b = bucket_count[first + 1u];
        }
    }
    sums[lid] = a + b;
    workgroupBarrier();
    // Hillis-Steele inclusive scan of the pair sums.
    for (var offset = 1u; offset < 256u; offset = offset * 2u) {
        var add = 0u;
        if (lid >= offset) {
            add = sums[lid - offset];
        }
        workgroupBarrier();
        sums[lid] = sums[lid] + add;
        workgroupBarrier();
    }
    if (block < params.scan_blocks) {
        let before = sums[lid] - (a + b);
        if (first < table) {
            bucket_start[first] = before;
        }
        if (first + 1u < table) {
            bucket_start[first + 1u] = before + a;
        }
        if (lid == 255u) {
            block_sums[block] = sums[255];
        }
    }
}
