//! Twin of `scan_add.wgsl`: prefix sum, step 3: each block's offset added to its buckets' starts.

use crate::gpu::wgsl_structs::{Params, SCAN_BLOCK};

/// The bindings of `scan_add.wgsl`, in binding order.
pub struct ScanAddBindings<'a> {
    /// The batch's constants.
    pub params: &'a Params,
    /// Per bucket: where its particles start, made global here.
    pub bucket_start: &'a mut [u32],
    /// Per scan block: the exclusive scan of the block totals.
    pub block_sums: &'a [u32],
}

/// Twin of `scan_add.wgsl`.
pub fn scan_add(b: ScanAddBindings) {
    let ScanAddBindings { params, bucket_start, block_sums } = b;
    for b in 0..=params.table_mask as usize {
        bucket_start[b] += block_sums[b / SCAN_BLOCK];
    }
}
