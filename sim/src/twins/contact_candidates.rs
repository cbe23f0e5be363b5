//! Twin of `contact_candidates.wgsl`: contact collection, step 5: each particle's candidates within
//! d_c + skin, in increasing index.

use super::common::{I4, V4, add, bucket_of, cell_of, dot3, sub, xyz};
use crate::gpu::wgsl_structs::{Params, Status};

/// The bindings of `contact_candidates.wgsl`, in binding order.
pub struct ContactCandidatesBindings<'a> {
    /// The batch's constants.
    pub params: &'a Params,
    /// Two records per particle: rest position and mass; displacement and boost.
    pub body: &'a [V4],
    /// Per particle: its hash cell and bucket.
    pub cell: &'a [I4],
    /// Per bucket: where its particles start in `sorted` (one past the last bucket: the end).
    pub bucket_start: &'a [u32],
    /// The particles by bucket, each bucket in increasing index.
    pub sorted: &'a [u32],
    /// Per particle: its candidates stored.
    pub contact_count: &'a mut [u32],
    /// Per particle, `params.contact_cap` slots: its candidates in increasing index.
    pub contact_list: &'a mut [u32],
    /// Per particle: where it stood at this build.
    pub built_at: &'a mut [V4],
    /// The run's clock and counters (the most candidates a particle needed).
    pub status: &'a mut Status,
}

/// Twin of `contact_candidates.wgsl`.
pub fn contact_candidates(b: ContactCandidatesBindings) {
    let ContactCandidatesBindings {
        params,
        body,
        cell,
        bucket_start,
        sorted,
        contact_count,
        contact_list,
        built_at,
        status,
    } = b;
    for i in 0..params.n as usize {
        let p = add(xyz(body[2 * i]), xyz(body[2 * i + 1]));
        let reach = params.reach;
        let lo = cell_of(sub(p, [reach; 3]), params.inverse_cell);
        let hi = cell_of(add(p, [reach; 3]), params.inverse_cell);
        let span = [0, 1, 2].map(|a| (hi[a].wrapping_sub(lo[a]) as u32).min(2));
        let cap = params.contact_cap as usize;
        let base = i * cap;
        let mut count = 0usize;
        for dz in 0..=span[2] {
            for dy in 0..=span[1] {
                for dx in 0..=span[0] {
                    let c =
                        [lo[0].wrapping_add(dx as i32), lo[1].wrapping_add(dy as i32), lo[2].wrapping_add(dz as i32)];
                    let b = bucket_of(c, params.table_mask) as usize;
                    for k in bucket_start[b] as usize..bucket_start[b + 1] as usize {
                        let j = sorted[k] as usize;
                        if j == i || cell[j][..3] != c {
                            continue;
                        }
                        let d = sub(p, add(xyz(body[2 * j]), xyz(body[2 * j + 1])));
                        if !(dot3(d, d) < reach * reach) {
                            continue;
                        }
                        if count < cap {
                            let mut m = count;
                            while m > 0 && contact_list[base + m - 1] >= j as u32 {
                                contact_list[base + m] = contact_list[base + m - 1];
                                m -= 1;
                            }
                            contact_list[base + m] = j as u32;
                        }
                        count += 1;
                    }
                }
            }
        }
        contact_count[i] = count.min(cap) as u32;
        built_at[i] = [p[0], p[1], p[2], 0.0];
        if count > cap {
            status.contact_needed = status.contact_needed.max(count as u32);
        }
    }
}
