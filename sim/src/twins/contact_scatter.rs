//! Twin of `contact_scatter.wgsl`: contact collection, step 3: each particle into its bucket's
//! range at its arrival slot; the counts cleared.

use super::common::I4;
use crate::gpu::wgsl_structs::Params;

/// The bindings of `contact_scatter.wgsl`, in binding order.
pub struct ContactScatterBindings<'a> {
    /// The batch's constants.
    pub params: &'a Params,
    /// Per particle: its hash cell and bucket.
    pub cell: &'a [I4],
    /// Per particle: its slot among its bucket's particles.
    pub arrival: &'a [u32],
    /// Per bucket: where its particles start (one past the last bucket: the end).
    pub bucket_start: &'a [u32],
    /// The particles by bucket, each bucket in arrival order.
    pub unsorted: &'a mut [u32],
    /// Per bucket: its particles, cleared for the next build (atomic counters on the GPU).
    pub bucket_count: &'a mut [u32],
}

/// Twin of `contact_scatter.wgsl`.
pub fn contact_scatter(b: ContactScatterBindings) {
    let ContactScatterBindings { params, cell, arrival, bucket_start, unsorted, bucket_count } = b;
    for i in 0..params.n as usize {
        let b = cell[i][3] as u32 as usize;
        unsorted[(bucket_start[b] + arrival[i]) as usize] = i as u32;
        bucket_count[b] = 0;
    }
}
