//! Twin of `contact_rank.wgsl`: contact collection, step 4: every bucket in increasing particle
//! index.

use super::common::I4;
use crate::gpu::wgsl_structs::Params;

/// Twin of `contact_rank.wgsl`.
pub fn contact_rank(params: &Params, cell: &[I4], bucket_start: &[u32], unsorted: &[u32], sorted: &mut [u32]) {
    for i in 0..params.n as usize {
        let b = cell[i][3] as u32 as usize;
        let (start, end) = (bucket_start[b] as usize, bucket_start[b + 1] as usize);
        let mut rank = 0;
        for k in start..end {
            if (unsorted[k] as usize) < i {
                rank += 1;
            }
        }
        sorted[start + rank] = i as u32;
    }
}
