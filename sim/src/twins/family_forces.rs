//! Twin of `family_forces.wgsl`: the elastoplastic model's force pass (both ends' force scalars
//! with the plastic return map, the break test, the bond forces) fused with the contact force,
//! the body forces and the grips; break events; each workgroup's external power.

use super::common::{U4, V4, add, dot3, scale, sub, xyz};
use super::force_common::{body_force, workgroup_sum};
use crate::gpu::wgsl_structs::{FamilyParams, Params, SLICE, Status, WG};

/// `force_scalar` of `family_forces.wgsl`: one end's force scalar and new plastic extension.
fn force_scalar(c: V4, theta: f32, omega: f32, rest: f32, e: f32, e_p: f32, cap: f32) -> [f32; 2] {
    let deviatoric_extension = e - theta * rest / 3.0;
    let stiffness = c[1] * omega;
    let mut plastic_extension = e_p;
    let mut t_dev = stiffness * (deviatoric_extension - plastic_extension);
    if t_dev.abs() > c[3] {
        let yield_force = if t_dev < 0.0 { -c[3] } else { c[3] };
        plastic_extension = deviatoric_extension - yield_force / stiffness;
    }
    plastic_extension = plastic_extension.max(-cap).min(cap);
    if plastic_extension != e_p {
        t_dev = stiffness * (deviatoric_extension - plastic_extension);
    }
    [c[2] * theta * omega * rest + t_dev, plastic_extension]
}

/// Twin of `family_forces.wgsl` (the workgroup power sums in the shader's tree order).
pub fn family_forces(
    params: &Params,
    family: &FamilyParams,
    body: &[V4],
    vel: &mut [V4],
    force: &mut [V4],
    rows: &[U4],
    broken_count: &mut [u32],
    contact_count: &[u32],
    contact_force: &[V4],
    neighbor: &[u32],
    bits: &mut [u32],
    family_entry: &[V4],
    family_particle: &[V4],
    family_reverse: &[u32],
    threshold: &[f32],
    plastic: &mut [[f32; 2]],
    extension: &[f32],
    family_record: &[V4],
    damage: &[f32],
    power: &mut [f32],
    status: &mut Status,
    spheres: &[V4],
    events: &mut [[u32; 2]],
    hold: &[V4],
) {
    let n = params.n as usize;
    for group in 0..n.div_ceil(WG) {
        let mut partial = [0.0f32; WG];
        for lid in 0..WG {
            let i = group * WG + lid;
            if i >= n {
                continue;
            }
            let own = body[2 * i];
            let state_i = family_record[i];
            let u_i = xyz(state_i);
            let c_i = family_particle[i];
            let row = rows[i];
            let step = status.step;
            let mut f = [0.0f32; 3];
            let mut broke = 0u32;
            let mut word = 0u32;
            let mut changed = false;
            for k in 0..row[2] {
                let bit = k & 31;
                let w = (row[1] + (k >> 5) * SLICE as u32) as usize;
                if bit == 0 {
                    word = bits[w];
                    changed = false;
                }
                if word & (1 << bit) == 0 {
                    let e = (row[0] + k * SLICE as u32) as usize;
                    let j = neighbor[e] as usize;
                    let entry = family_entry[e];
                    let rest = entry[2];
                    let state_j = family_record[j];
                    let c_j = family_particle[j];
                    let e_ij = extension[e];
                    let y = add(sub(xyz(body[2 * j]), xyz(own)), sub(xyz(state_j), u_i));
                    let length = rest + e_ij;
                    let cap = family.plastic_cap_ratio * rest;
                    let ij = force_scalar(c_i, state_i[3], entry[0], rest, e_ij, plastic[e][0], cap);
                    let back = family_reverse[e] as usize;
                    let ji = force_scalar(c_j, state_j[3], entry[1], rest, e_ij, plastic[back][0], cap);
                    plastic[e][1] = ij[1];
                    let plastic_mean = 0.5 * (ij[1] + ji[1]);
                    let damage_mean = 0.5 * (damage[i] + damage[j]);
                    let critical = threshold[e] * (1.0 + family.damage_strengthening * damage_mean);
                    if (e_ij - plastic_mean) * entry[3] > critical {
                        word |= 1 << bit;
                        changed = true;
                        broke += 1;
                        if i < j {
                            let slot = status.events;
                            status.events += 1;
                            if slot < params.event_capacity {
                                events[slot as usize] = [step, row[3] + k];
                            }
                        }
                    } else {
                        let magnitude = (ij[0] + ji[0]) * (c_i[0] * c_j[0]) / length;
                        f = add(f, scale(y, magnitude));
                    }
                }
                if changed && (bit == 31 || k + 1 == row[2]) {
                    bits[w] = word;
                    changed = false;
                }
            }
            if broke != 0 {
                broken_count[i] += broke;
            }
            if params.contact_enabled != 0 && contact_count[i] != 0 {
                f = add(f, xyz(contact_force[i]));
            }
            let applied = body_force(params, spheres, own[3], add(xyz(own), u_i), step);
            let velocity = vel[i];
            let mut p = dot3(applied, xyz(velocity));
            let mut total = add(f, applied);
            if family.grips != 0 {
                let grip = hold[i];
                if step < grip[3].to_bits() {
                    p -= dot3(total, xyz(grip));
                    total = [0.0; 3];
                    vel[i] = [grip[0], grip[1], grip[2], velocity[3]];
                }
            }
            force[i] = [total[0], total[1], total[2], 0.0];
            partial[lid] = p;
        }
        let total = workgroup_sum(partial);
        if group < params.power_count as usize {
            power[group] = total;
        }
    }
}
