//! Twin of `scan_block_sums.wgsl`: prefix sum, step 2: the exclusive scan of the block totals.

use crate::gpu::wgsl_structs::Params;

/// The bindings of `scan_block_sums.wgsl`, in binding order.
pub struct ScanBlockSumsBindings<'a> {
    /// The batch's constants.
    pub params: &'a Params,
    /// Per bucket: where its particles start (here only the end, after the last bucket).
    pub bucket_start: &'a mut [u32],
    /// Per scan block: its total in, the exclusive scan of the totals out.
    pub block_sums: &'a mut [u32],
}

/// Twin of `scan_block_sums.wgsl`.
pub fn scan_block_sums(b: ScanBlockSumsBindings) {
    let ScanBlockSumsBindings { params, bucket_start, block_sums } = b;
    let mut carry = 0u32;
    for k in 0..params.scan_blocks as usize {
        let value = block_sums[k];
        block_sums[k] = carry;
        carry += value;
    }
    bucket_start[params.table_mask as usize + 1] = carry;
}
