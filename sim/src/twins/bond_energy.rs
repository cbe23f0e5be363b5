//! Twin of `bond_energy.wgsl`: each particle's share of the bond energy (at frame boundaries).

use super::common::{U4, V4, add, dot3, sub, xyz};
use crate::gpu::wgsl_structs::{Range, SLICE};

/// The bindings of `bond_energy.wgsl`, in binding order.
pub struct BondEnergyBindings<'a> {
    /// The bond range of this dispatch.
    pub range: &'a Range,
    /// Two records per particle: rest position and mass; displacement and boost.
    pub body: &'a [V4],
    /// Per particle: first entry, first bit word, row length, first file entry.
    pub rows: &'a [U4],
    /// Per entry: the partner.
    pub neighbor: &'a [u32],
    /// Per entry: k_ij, N per unit stretch.
    pub stiffness: &'a [f32],
    /// Broken bits, one per entry.
    pub bits: &'a [u32],
    /// Per particle: its share of the bond energy, joules.
    pub energy: &'a mut [f32],
}

/// Twin of `bond_energy.wgsl`.
pub fn bond_energy(b: BondEnergyBindings) {
    let BondEnergyBindings { range, body, rows, neighbor, stiffness, bits, energy } = b;
    for local in 0..range.count as usize {
        let i = range.first as usize + local;
        let own = body[2 * i];
        let record = body[2 * i + 1];
        let row = rows[i];
        let mut sum = 0.0f32;
        for k in 0..row[2] {
            if bits[(row[1] + (k >> 5) * SLICE as u32) as usize] & (1 << (k & 31)) != 0 {
                continue;
            }
            let e = (row[0] + k * SLICE as u32) as usize;
            let j = neighbor[e] as usize;
            let xi = sub(xyz(body[2 * j]), xyz(own));
            let eta = sub(xyz(body[2 * j + 1]), xyz(record));
            let y = add(xi, eta);
            let length = dot3(y, y).sqrt();
            let rest = dot3(xi, xi).sqrt();
            let growth = 2.0 * dot3(xi, eta) + dot3(eta, eta);
            let s = growth / (rest * (length + rest));
            sum += 0.25 * stiffness[e] * s * s * rest;
        }
        energy[i] = sum;
    }
}
