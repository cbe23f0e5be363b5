//! Twin of `family_dilatation.wgsl`: the elastoplastic model's first pass: each intact bond's
//! extension, the dilatation theta and the damage phi of each particle, and the previous force
//! pass's plastic extensions moved into place.

use super::common::{U4, V4, add, dot3, sub, xyz};
use crate::gpu::wgsl_structs::{Params, SLICE};

/// The bindings of `family_dilatation.wgsl`, in binding order.
pub struct FamilyDilatationBindings<'a> {
    /// The batch's constants.
    pub params: &'a Params,
    /// Two records per particle: rest position and mass; displacement and boost.
    pub body: &'a [V4],
    /// Per particle: first entry, first bit word, row length, first file entry.
    pub rows: &'a [U4],
    /// Per particle: its broken bonds.
    pub broken_count: &'a [u32],
    /// Per entry: the partner.
    pub neighbor: &'a [u32],
    /// Broken bits, one per entry.
    pub bits: &'a [u32],
    /// Per entry: omega_ij, omega_ji, |xi| (metres), 1 / (omega_mean |xi|).
    pub family_entry: &'a [V4],
    /// Per particle: V (m^3), 15 mu / m, 3 K / m, the yield force.
    pub family_particle: &'a [V4],
    /// Per particle: the weighted volume m_i, m^5.
    pub weighted_volume: &'a [f32],
    /// Per entry: (plastic extension the force pass reads, the one it writes), metres.
    pub plastic: &'a mut [[f32; 2]],
    /// Per entry: the extension, metres.
    pub extension: &'a mut [f32],
    /// Per particle: displacement and dilatation theta.
    pub family_record: &'a mut [V4],
    /// Per particle: the damage phi.
    pub damage: &'a mut [f32],
}

/// Twin of `family_dilatation.wgsl`.
pub fn family_dilatation(b: FamilyDilatationBindings) {
    let FamilyDilatationBindings {
        params,
        body,
        rows,
        broken_count,
        neighbor,
        bits,
        family_entry,
        family_particle,
        weighted_volume,
        plastic,
        extension,
        family_record,
        damage,
    } = b;
    for i in 0..params.n as usize {
        let own = body[2 * i];
        let u_i = xyz(body[2 * i + 1]);
        let row = rows[i];
        let mut sum = 0.0f32;
        let mut word = 0u32;
        for k in 0..row[2] {
            let bit = k & 31;
            if bit == 0 {
                word = bits[(row[1] + (k >> 5) * SLICE as u32) as usize];
            }
            let e = (row[0] + k * SLICE as u32) as usize;
            plastic[e][0] = plastic[e][1];
            if word & (1 << bit) == 0 {
                let j = neighbor[e] as usize;
                let xi = sub(xyz(body[2 * j]), xyz(own));
                let eta = sub(xyz(body[2 * j + 1]), u_i);
                let entry = family_entry[e];
                let rest = entry[2];
                let y = add(xi, eta);
                let length = dot3(y, y).sqrt();
                let growth = 2.0 * dot3(xi, eta) + dot3(eta, eta);
                let e_ij = growth / (rest * (length + rest)) * rest;
                extension[e] = e_ij;
                sum += entry[0] * rest * e_ij * family_particle[j][0];
            }
        }
        family_record[i] = [u_i[0], u_i[1], u_i[2], 3.0 * sum / weighted_volume[i]];
        damage[i] = if row[2] != 0 { 1.0 - (row[2] - broken_count[i]) as f32 / row[2] as f32 } else { 0.0 };
    }
}
