//! Twin of `family_dilatation.wgsl`: the elastoplastic model's first pass: each intact bond's
//! extension, the dilatation theta and the damage phi of each particle, and the previous force
//! pass's plastic extensions moved into place.

use super::common::{U4, V4, add, dot3, sub, xyz};
use crate::gpu::wgsl_structs::{Params, SLICE};

/// Twin of `family_dilatation.wgsl`.
pub fn family_dilatation(
    params: &Params,
    body: &[V4],
    rows: &[U4],
    broken_count: &[u32],
    neighbor: &[u32],
    bits: &[u32],
    family_entry: &[V4],
    family_particle: &[V4],
    weighted_volume: &[f32],
    plastic: &mut [[f32; 2]],
    extension: &mut [f32],
    family_record: &mut [V4],
    damage: &mut [f32],
) {
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
