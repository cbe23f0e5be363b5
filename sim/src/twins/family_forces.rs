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

/// The bindings of `family_forces.wgsl`, in binding order.
pub struct FamilyForcesBindings<'a> {
    /// The batch's constants.
    pub params: &'a Params,
    /// The model's constants besides the per-entry and per-particle arrays.
    pub family: &'a FamilyParams,
    /// Two records per particle: rest position and mass; displacement and boost.
    pub body: &'a [V4],
    /// Per particle: velocity, m/s, and 1 / m (a gripped particle's set to its grip's).
    pub vel: &'a mut [V4],
    /// Per particle: the force, newtons.
    pub force: &'a mut [V4],
    /// Per particle: first entry, first bit word, row length, first file entry.
    pub rows: &'a [U4],
    /// Per particle: its broken bonds.
    pub broken_count: &'a mut [u32],
    /// Per particle: its contact candidates.
    pub contact_count: &'a [u32],
    /// Per particle: the contact force from `collisions`, newtons.
    pub contact_force: &'a [V4],
    /// Per entry: the partner.
    pub neighbor: &'a [u32],
    /// Broken bits, one per entry.
    pub bits: &'a mut [u32],
    /// Per entry: omega_ij, omega_ji, |xi| (metres), 1 / (omega_mean |xi|).
    pub family_entry: &'a [V4],
    /// Per particle: V (m^3), 15 mu / m, 3 K / m, the yield force.
    pub family_particle: &'a [V4],
    /// Per entry: the entry of the same bond in the partner's row.
    pub family_reverse: &'a [u32],
    /// Per entry: the critical weighted elastic stretch s_c.
    pub threshold: &'a [f32],
    /// Per entry: (plastic extension read, the one written), metres.
    pub plastic: &'a mut [[f32; 2]],
    /// Per entry: the extension from `family_dilatation`, metres.
    pub extension: &'a [f32],
    /// Per particle: displacement and dilatation theta from `family_dilatation`.
    pub family_record: &'a [V4],
    /// Per particle: the damage phi from `family_dilatation`.
    pub damage: &'a [f32],
    /// Per force workgroup: the external power it delivers, watts.
    pub power: &'a mut [f32],
    /// The run's clock and counters (the break events logged).
    pub status: &'a mut Status,
    /// Projectiles then indenters: static data, then each step's centres.
    pub spheres: &'a [V4],
    /// Break events: (step, bond id).
    pub events: &'a mut [[u32; 2]],
    /// Per particle: its grip's velocity (m/s) and, as the bits of w, the step it lets go at.
    pub hold: &'a [V4],
}

/// Twin of `family_forces.wgsl` (the workgroup power sums in the shader's tree order).
pub fn family_forces(mut b: FamilyForcesBindings) {
    let n = b.params.n as usize;
    for group in 0..n.div_ceil(WG) {
        let mut partial = [0.0f32; WG];
        for lid in 0..WG {
            let i = group * WG + lid;
            if i >= n {
                continue;
            }
            partial[lid] = particle(&mut b, i);
        }
        let total = workgroup_sum(partial);
        if group < b.params.power_count as usize {
            b.power[group] = total;
        }
    }
}

/// `particle` of `family_forces.wgsl`: all forces on particle i; returns the power of the
/// external forces (body forces and grip).
fn particle(b: &mut FamilyForcesBindings, i: usize) -> f32 {
    // the bindings the shader reads, copied out, then those it writes
    let FamilyForcesBindings { params, family, body, rows, contact_count, contact_force, neighbor, .. } = *b;
    let FamilyForcesBindings { family_entry, family_particle, family_reverse, threshold, extension, .. } = *b;
    let FamilyForcesBindings { family_record, damage, spheres, hold, .. } = *b;
    let FamilyForcesBindings { vel, force, broken_count, bits, plastic, status, events, .. } = b;
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
    p
}
