//! Twin of `spring_forces.wgsl`: spring forces fused with body forces: each particle's bonds
//! (stretch, break, force), the contact force, gravity, projectiles and indenters; the next boost;
//! break events; each workgroup's external power.

use super::common::{U4, V4, add, dot3, scale, sub, xyz};
use super::force_common::{body_force, workgroup_sum};
use crate::gpu::wgsl_structs::{NO_STRETCH, Params, RULE_BREAKING_FORCE, RULE_SIGNED_BOOST, Range, SLICE, Status, WG};

/// The bindings of `spring_forces.wgsl`, in binding order.
pub struct SpringForcesBindings<'a> {
    /// The batch's constants.
    pub params: &'a Params,
    /// The bond range of this dispatch.
    pub range: &'a Range,
    /// Two records per particle: rest position and mass; displacement and boost.
    pub body: &'a [V4],
    /// Per particle: velocity, m/s, and 1 / m.
    pub vel: &'a [V4],
    /// Per particle: the force, newtons.
    pub force: &'a mut [V4],
    /// Per particle: the compression boost of the next step.
    pub boost_next: &'a mut [f32],
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
    /// Per entry: k_ij, N per unit stretch.
    pub stiffness: &'a [f32],
    /// Per entry: the critical stretch.
    pub threshold: &'a [f32],
    /// Broken bits, one per entry.
    pub bits: &'a mut [u32],
    /// Per force workgroup: the external power it delivers, watts.
    pub power: &'a mut [f32],
    /// The run's clock and counters (the break events logged).
    pub status: &'a mut Status,
    /// Projectiles then indenters: static data, then each step's centres.
    pub spheres: &'a [V4],
    /// Break events: (step, bond id).
    pub events: &'a mut [[u32; 2]],
}

/// Twin of `spring_forces.wgsl` (the workgroup power sums in the shader's tree order).
pub fn spring_forces(mut b: SpringForcesBindings) {
    let (wg, range) = (WG, b.range);
    for group in 0..range.workgroups as usize {
        let mut partial = [0.0f32; WG];
        for lid in 0..wg {
            let local = group * wg + lid;
            if local < range.count as usize {
                partial[lid] = particle(&mut b, range.first as usize + local);
            }
        }
        let total = workgroup_sum(partial);
        b.power[range.first_workgroup as usize + group] = total;
    }
}

/// `particle` of `spring_forces.wgsl`: all forces on particle i; returns F_ext . v.
fn particle(b: &mut SpringForcesBindings, i: usize) -> f32 {
    // the bindings the shader reads, copied out, then those it writes
    let SpringForcesBindings { params, body, vel, rows, contact_count, contact_force, neighbor, stiffness, .. } = *b;
    let SpringForcesBindings { threshold, spheres, .. } = *b;
    let SpringForcesBindings { force, boost_next, broken_count, bits, status, events, .. } = b;
    let own = body[2 * i];
    let record = body[2 * i + 1];
    let row = rows[i];
    let step = status.step;
    let signed = params.rules & RULE_SIGNED_BOOST != 0;
    let breaking_force = params.rules & RULE_BREAKING_FORCE != 0;
    let mut f = [0.0f32; 3];
    let mut smallest = if signed { NO_STRETCH } else { 0.0f32 };
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
            let other = body[2 * j];
            let other_record = body[2 * j + 1];
            let xi = sub(xyz(other), xyz(own));
            let eta = sub(xyz(other_record), xyz(record));
            let y = add(xi, eta);
            let length = dot3(y, y).sqrt();
            let rest = dot3(xi, xi).sqrt();
            let growth = 2.0 * dot3(xi, eta) + dot3(eta, eta);
            let denominator = rest * (length + rest) * length;
            let inverse = if denominator > 0.0 { 1.0 / denominator } else { 0.0 };
            let k_ij = stiffness[e];
            let s = if k_ij > 0.0 { growth * length * inverse } else { 0.0 };
            let boost =
                if params.break_rule != 0 { record[3].min(other_record[3]) } else { record[3].max(other_record[3]) };
            if s > threshold[e] + boost {
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
                if breaking_force {
                    f = add(f, scale(y, k_ij * growth * inverse));
                    if k_ij > 0.0 || !signed {
                        smallest = smallest.min(s);
                    }
                }
            } else {
                f = add(f, scale(y, k_ij * growth * inverse));
                if k_ij > 0.0 || !signed {
                    smallest = smallest.min(s);
                }
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
    boost_next[i] = if smallest >= NO_STRETCH { 0.0 } else { smallest * -params.alpha };
    if params.contact_enabled != 0 && contact_count[i] != 0 {
        f = add(f, xyz(contact_force[i]));
    }
    let external = body_force(params, spheres, own[3], add(xyz(own), xyz(record)), step);
    let total = add(f, external);
    force[i] = [total[0], total[1], total[2], 0.0];
    dot3(external, xyz(vel[i]))
}
