//! Twin of `contact_rank.wgsl`: contact collection, step 4: every bucket in increasing particle
//! index.

use super::common::I4;
use crate::gpu::wgsl_structs::Params;

/// The bindings of `contact_rank.wgsl`, in binding order.
pub struct ContactRankBindings<'a> {
    /// The batch's constants.
    pub params: &'a Params,
    /// Per particle: its hash cell and bucket.
    pub cell: &'a [I4],
    /// Per bucket: where its particles start (one past the last bucket: the end).
    pub bucket_start: &'a [u32],
    /// The particles by bucket, each bucket in arrival order.
    pub unsorted: &'a [u32],
    /// The particles by bucket, each bucket in increasing index.
    pub sorted: &'a mut [u32],
}

/// Twin of `contact_rank.wgsl`.
pub fn contact_rank(b: ContactRankBindings) {
    let ContactRankBindings { params, cell, bucket_start, unsorted, sorted } = b;
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
