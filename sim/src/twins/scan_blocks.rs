//! Twin of `scan_blocks.wgsl`: prefix sum, step 1: the bucket counts scanned block by block.

use crate::gpu::wgsl_structs::{Params, SCAN_BLOCK};

/// The bindings of `scan_blocks.wgsl`, in binding order.
pub struct ScanBlocksBindings<'a> {
    /// The batch's constants.
    pub params: &'a Params,
    /// Per bucket: its particles.
    pub bucket_count: &'a [u32],
    /// Per bucket: where its particles start within its scan block.
    pub bucket_start: &'a mut [u32],
    /// Per scan block: its total.
    pub block_sums: &'a mut [u32],
}

/// Twin of `scan_blocks.wgsl`.
pub fn scan_blocks(b: ScanBlocksBindings) {
    let ScanBlocksBindings { params, bucket_count, bucket_start, block_sums } = b;
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
