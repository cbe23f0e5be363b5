// Prefix sum, step 2 (one workgroup): the exclusive scan of the block totals, in place, chunk by
// chunk with a carry; also writes the grand total after the last bucket's start.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> bucket_start: array<u32>;
@group(0) @binding(2) var<storage, read_write> block_sums: array<u32>;

var<workgroup> sums: array<u32, 256>;

@compute @workgroup_size(256)
fn scan_block_sums(@builtin(local_invocation_index) lid: u32) {
    var carry = 0u;
    let count = params.scan_blocks;
    for (var first = 0u; first < count; first = first + 256u) {
        let k = first + lid;
        var value = 0u;
        if (k < count) {
            value = block_sums[k];
        }
        sums[lid] = value;
        workgroupBarrier();
        for (var offset = 1u; offset < 256u; offset = offset * 2u) {
            var add = 0u;
            if (lid >= offset) {
                add = sums[lid - offset];
            }
            workgroupBarrier();
            sums[lid] = sums[lid] + add;
            workgroupBarrier();
        }
        if (k < count) {
            block_sums[k] = carry + sums[lid] - value;
        }
        carry = carry + sums[255];
        workgroupBarrier();
    }
    if (lid == 0u) {
        bucket_start[params.table_mask + 1u] = carry;
    }
}
