//! Twin of `scan_block_sums.wgsl`: prefix sum, step 2: the exclusive scan of the block totals.

use crate::gpu::wgsl_structs::Params;

/// Twin of `scan_block_sums.wgsl`.
pub fn scan_block_sums(params: &Params, bucket_start: &mut [u32], block_sums: &mut [u32]) {
    let mut carry = 0u32;
    for k in 0..params.scan_blocks as usize {
        let value = block_sums[k];
        block_sums[k] = carry;
        carry += value;
    }
    bucket_start[params.table_mask as usize + 1] = carry;
}
