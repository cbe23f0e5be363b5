//! Twin of `contact_count.wgsl`: contact collection, step 1: each particle's hash cell and bucket,
//! counted into the bucket (arrival slots in invocation order).

use super::common::{I4, V4, add, bucket_of, cell_of, xyz};
use crate::gpu::wgsl_structs::Params;

/// The bindings of `contact_count.wgsl`, in binding order.
pub struct ContactCountBindings<'a> {
    /// The batch's constants.
    pub params: &'a Params,
    /// Two records per particle: rest position and mass; displacement and boost.
    pub body: &'a [V4],
    /// Per particle: its hash cell and bucket.
    pub cell: &'a mut [I4],
    /// Per particle: its slot among its bucket's particles.
    pub arrival: &'a mut [u32],
    /// Per bucket: its particles (an atomic counter on the GPU).
    pub bucket_count: &'a mut [u32],
}

/// Twin of `contact_count.wgsl` (arrival slots in invocation order).
pub fn contact_count(b: ContactCountBindings) {
    let ContactCountBindings { params, body, cell, arrival, bucket_count } = b;
    for i in 0..params.n as usize {
        let p = add(xyz(body[2 * i]), xyz(body[2 * i + 1]));
        let c = cell_of(p, params.inverse_cell);
        let b = bucket_of(c, params.table_mask);
        cell[i] = [c[0], c[1], c[2], b as i32];
        arrival[i] = bucket_count[b as usize];
        bucket_count[b as usize] += 1;
    }
}
