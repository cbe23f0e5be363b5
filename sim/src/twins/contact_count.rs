//! Twin of `contact_count.wgsl`: contact collection, step 1: each particle's hash cell and bucket,
//! counted into the bucket (arrival slots in invocation order).

use super::common::{I4, V4, add, bucket_of, cell_of, xyz};
use crate::gpu::wgsl_structs::Params;

/// Twin of `contact_count.wgsl` (arrival slots in invocation order).
pub fn contact_count(params: &Params, body: &[V4], cell: &mut [I4], arrival: &mut [u32], bucket_count: &mut [u32]) {
    for i in 0..params.n as usize {
        let p = add(xyz(body[2 * i]), xyz(body[2 * i + 1]));
        let c = cell_of(p, params.inverse_cell);
        let b = bucket_of(c, params.table_mask);
        cell[i] = [c[0], c[1], c[2], b as i32];
        arrival[i] = bucket_count[b as usize];
        bucket_count[b as usize] += 1;
    }
}
