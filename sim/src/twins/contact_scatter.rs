//! Twin of `contact_scatter.wgsl`: contact collection, step 3: each particle into its bucket's
//! range at its arrival slot; the counts cleared.

use super::common::I4;
use crate::gpu::wgsl_structs::Params;

/// Twin of `contact_scatter.wgsl`.
pub fn contact_scatter(
    params: &Params,
    cell: &[I4],
    arrival: &[u32],
    bucket_start: &[u32],
    unsorted: &mut [u32],
    bucket_count: &mut [u32],
) {
    for i in 0..params.n as usize {
        let b = cell[i][3] as u32 as usize;
        unsorted[(bucket_start[b] + arrival[i]) as usize] = i as u32;
        bucket_count[b] = 0;
    }
}
