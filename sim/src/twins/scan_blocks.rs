//! Twin of `scan_blocks.wgsl`: prefix sum, step 1: the bucket counts scanned block by block.

use crate::gpu::wgsl_structs::{Params, SCAN_BLOCK};

/// Twin of `scan_blocks.wgsl`.
pub fn scan_blocks(params: &Params, bucket_count: &[u32], bucket_start: &mut [u32], block_sums: &mut [u32]) {
    let table = params.table_mask as usize + 1;
    for block in 0..params.scan_blocks as usize {
        let mut sum = 0u32;
        for t in block * SCAN_BLOCK..((block + 1) * SCAN_BLOCK).min(table) {
            bucket_start[t] = sum;
            sum += bucket_count[t];
        }
        block_sums[block] = sum;
    }
}
