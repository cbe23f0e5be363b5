//! Twin of `scan_add.wgsl`: prefix sum, step 3: each block's offset added to its buckets' starts.

use crate::gpu::wgsl_structs::{Params, SCAN_BLOCK};

/// Twin of `scan_add.wgsl`.
pub fn scan_add(params: &Params, bucket_start: &mut [u32], block_sums: &[u32]) {
    for b in 0..=params.table_mask as usize {
        bucket_start[b] += block_sums[b / SCAN_BLOCK];
    }
}
