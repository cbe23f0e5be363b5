//! Twin of `collisions.wgsl`: the contact force of eq. 6 over each particle's candidates.

use super::common::{U4, V4, add, dot3, scale, sub, xyz};
use crate::gpu::wgsl_structs::{Params, RULE_LAMMPS_CONTACT, Range, SLICE};

/// The bindings of `collisions.wgsl`, in binding order.
pub struct CollisionsBindings<'a> {
    /// The batch's constants.
    pub params: &'a Params,
    /// The bond range of this dispatch.
    pub range: &'a Range,
    /// Two records per particle: rest position and mass; displacement and boost.
    pub body: &'a [V4],
    /// Per particle: first entry, first bit word, row length, first file entry.
    pub rows: &'a [U4],
    /// Per particle: its contact candidates.
    pub contact_count: &'a [u32],
    /// Per particle, `params.contact_cap` slots: its candidates in increasing index.
    pub contact_list: &'a [u32],
    /// Per particle: the contact force, newtons.
    pub contact_force: &'a mut [V4],
    /// Per entry: the partner.
    pub neighbor: &'a [u32],
    /// Broken bits, one per entry.
    pub bits: &'a [u32],
}

/// `bonded` of `collisions.wgsl`: an intact bond between the row's particle and j.
fn bonded(row: U4, j: u32, neighbor: &[u32], bits: &[u32]) -> bool {
    let (mut lo, mut hi) = (0u32, row[2]);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if neighbor[(row[0] + mid * SLICE as u32) as usize] < j {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    if lo >= row[2] || neighbor[(row[0] + lo * SLICE as u32) as usize] != j {
        return false;
    }
    bits[(row[1] + (lo >> 5) * SLICE as u32) as usize] & (1 << (lo & 31)) == 0
}

/// Twin of `collisions.wgsl`.
pub fn collisions(b: CollisionsBindings) {
    let CollisionsBindings { params, range, body, rows, contact_count, contact_list, contact_force, neighbor, bits } =
        b;
    for local in 0..range.count as usize {
        let i = range.first as usize + local;
        let count = contact_count[i] as usize;
        if count == 0 {
            continue;
        }
        let row = rows[i];
        let lammps = params.rules & RULE_LAMMPS_CONTACT != 0;
        let own_mass = body[2 * i][3];
        let x = xyz(body[2 * i]);
        let p = add(x, xyz(body[2 * i + 1]));
        let mut sum = [0.0f32; 3];
        for m in 0..count {
            let j = contact_list[i * params.contact_cap as usize + m];
            let d = sub(p, add(xyz(body[2 * j as usize]), xyz(body[2 * j as usize + 1])));
            let r2 = dot3(d, d);
            let xi = sub(x, xyz(body[2 * j as usize]));
            if lammps {
                let reach = (0.9 * dot3(xi, xi).sqrt()).min(params.contact_distance);
                if r2 >= reach * reach || r2 == 0.0 {
                    continue;
                }
                let r = r2.sqrt();
                let s = params.contact_stiffness * own_mass * body[2 * j as usize][3] * (reach - r) / r;
                sum = add(sum, scale(d, s));
                continue;
            }
            let reach = crate::contact::contact_reach(params.contact_distance, dot3(xi, xi));
            if r2 >= reach * reach || r2 == 0.0 || bonded(row, j, neighbor, bits) {
                continue;
            }
            let r = r2.sqrt();
            let gap = reach - r;
            let s = params.contact_stiffness * gap * gap / r;
            sum = add(sum, scale(d, s));
        }
        contact_force[i] = [sum[0], sum[1], sum[2], 0.0];
    }
}
