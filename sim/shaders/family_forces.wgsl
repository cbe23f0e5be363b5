// The elastoplastic model's force pass (Chen et al. sections 4.1, 4.2 and 5.1; the CPU's
// `elastoplastic::passes::bond_forces`) fused with the contact and body forces, one particle per
// invocation. For each intact bond, in row order, both ends' force scalars from the same inputs
// (the dilatations of both ends from family_dilatation, the bond's extension, the plastic
// extensions of the previous pass at both ends), so both ends agree bit for bit:
// e_d = e - theta |xi| / 3, t_dev = 15 mu / m omega (e_d - e_p) returned onto the yield surface
// by moving e_p (then capped at gamma), t = 3 K theta omega |xi| / m + t_dev. The particle's own
// new plastic extension is stored (plastic[e].y). Then the break test
// (e - e_p,mean) / (omega_mean |xi|) > (1 + alpha phi_mean) s_c: a breaking bond's bit is set in
// the particle's own word (no atomics) and it exerts no force; else
// (t_ij + t_ji) V_i V_j y / |y| is added. Then the contact force from `collisions`, the body
// forces, and the grips: a held particle's force is taken up by its grip (whose work -F . v
// counts as external) and its velocity set to the grip's. Writes the force, the broken-bond
// count, break events (by the lower particle) and the workgroup's external power.

// The model's constants besides the per-entry and per-particle arrays.
struct FamilyParams {
    // alpha of eq. 18: thresholds grow by (1 + alpha phi).
    damage_strengthening: f32,
    // gamma / |xi|: the cap on the plastic extension.
    plastic_cap_ratio: f32,
    // 1 when some particle is held by a grip (see `hold`).
    grips: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<uniform> family: FamilyParams;
@group(0) @binding(2) var<storage, read> body: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> vel: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> force: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> rows: array<vec4<u32>>;
@group(0) @binding(6) var<storage, read_write> broken_count: array<u32>;
@group(0) @binding(7) var<storage, read> contact_count: array<u32>;
@group(0) @binding(8) var<storage, read> contact_force: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read> neighbor: array<u32>;
@group(0) @binding(10) var<storage, read_write> bits: array<u32>;
// Per entry: omega_ij, omega_ji, |xi| (metres), 1 / (omega_mean |xi|).
@group(0) @binding(11) var<storage, read> family_entry: array<vec4<f32>>;
// Per particle: V (m^3), 15 mu / m, 3 K / m, the yield force.
@group(0) @binding(12) var<storage, read> family_particle: array<vec4<f32>>;
// Per entry: the entry of the same bond in the partner's row.
@group(0) @binding(13) var<storage, read> family_reverse: array<u32>;
// Per entry: the critical weighted elastic stretch s_c.
@group(0) @binding(14) var<storage, read> threshold: array<f32>;
@group(0) @binding(15) var<storage, read_write> plastic: array<vec2<f32>>;
@group(0) @binding(16) var<storage, read> extension: array<f32>;
@group(0) @binding(17) var<storage, read> family_record: array<vec4<f32>>;
@group(0) @binding(18) var<storage, read> damage: array<f32>;
@group(0) @binding(19) var<storage, read_write> power: array<f32>;
@group(0) @binding(20) var<storage, read_write> status: Status;
@group(0) @binding(21) var<storage, read> spheres: array<vec4<f32>>;
@group(0) @binding(22) var<storage, read_write> events: array<vec2<u32>>;
// Per particle (when family.grips): the grip's velocity (m/s) and, as the bits of w, the step
// at which it lets go (0: not held).
@group(0) @binding(23) var<storage, read> hold: array<vec4<f32>>;

// One end's force scalar of a bond and its new plastic extension: `c` the end's particle
// constants, `theta` its dilatation, `omega` its influence, `e_p` its old plastic extension.
fn force_scalar(c: vec4<f32>, theta: f32, omega: f32, rest: f32, e: f32, e_p: f32, cap: f32) -> vec2<f32> {
    let deviatoric_extension = e - theta * rest / 3.0;
    let stiffness = c.y * omega;
    var plastic_extension = e_p;
    var t_dev = stiffness * (deviatoric_extension - plastic_extension);
    if (abs(t_dev) > c.w) {
        var yield_force = c.w;
        if (t_dev < 0.0) {
            yield_force = -c.w;
        }
        plastic_extension = deviatoric_extension - yield_force / stiffness;
    }
    plastic_extension = min(max(plastic_extension, -cap), cap);
    if (plastic_extension != e_p) {
        t_dev = stiffness * (deviatoric_extension - plastic_extension);
    }
    return vec2<f32>(c.z * theta * omega * rest + t_dev, plastic_extension);
}

// All forces on particle i; returns the power of the external forces (body forces and grip).
fn particle(i: u32) -> f32 {
    let own = body[2u * i];
    let state_i = family_record[i];
    let u_i = state_i.xyz;
    let c_i = family_particle[i];
    let row = rows[i];
    let step = status.step;
    var f = vec3<f32>(0.0);
    var broke = 0u;
    var word = 0u;
    var changed = false;
    for (var k = 0u; k < row.z; k = k + 1u) {
        let bit = k & 31u;
        let w = row.y + (k >> 5u) * SLICE;
        if (bit == 0u) {
            word = bits[w];
            changed = false;
        }
        if ((word & (1u << bit)) == 0u) {
            let e = row.x + k * SLICE;
            let j = neighbor[e];
            let entry = family_entry[e];
            let rest = entry.z;
            let state_j = family_record[j];
            let c_j = family_particle[j];
            let e_ij = extension[e];
            // the deformed bond y = xi + u_j - u_i, whose length is |xi| + e
            let y = (body[2u * j].xyz - own.xyz) + (state_j.xyz - u_i);
            let length = rest + e_ij;
            let cap = family.plastic_cap_ratio * rest;
            let ij = force_scalar(c_i, state_i.w, entry.x, rest, e_ij, plastic[e].x, cap);
            let ji = force_scalar(c_j, state_j.w, entry.y, rest, e_ij, plastic[family_reverse[e]].x, cap);
            plastic[e].y = ij.y;
            let plastic_mean = 0.5 * (ij.y + ji.y);
            let damage_mean = 0.5 * (damage[i] + damage[j]);
            let critical = threshold[e] * (1.0 + family.damage_strengthening * damage_mean);
            if ((e_ij - plastic_mean) * entry.w > critical) {
                word = word | (1u << bit);
                changed = true;
                broke = broke + 1u;
                if (i < j) {
                    let slot = atomicAdd(&status.events, 1u);
                    if (slot < params.event_capacity) {
                        events[slot] = vec2<u32>(step, row.w + k);
                    }
                }
            } else {
                let magnitude = (ij.x + ji.x) * (c_i.x * c_j.x) / length;
                f = f + y * magnitude;
            }
        }
        if (changed && (bit == 31u || k + 1u == row.z)) {
            bits[w] = word;
            changed = false;
        }
    }
    if (broke != 0u) {
        broken_count[i] = broken_count[i] + broke;
    }
    if (params.contact_enabled != 0u && contact_count[i] != 0u) {
        f = f + contact_force[i].xyz;
    }
    let applied = body_force(own.w, own.xyz + u_i, step);
    let velocity = vel[i];
    var p = dot3(applied, velocity.xyz);
    var total = f + applied;
    if (family.grips != 0u) {
        let grip = hold[i];
        if (step < bitcast<u32>(grip.w)) {
            p = p - dot3(total, grip.xyz);
            total = vec3<f32>(0.0);
            vel[i] = vec4<f32>(grip.xyz, velocity.w);
        }
    }
    force[i] = vec4<f32>(total, 0.0);
    return p;
}

@compute @workgroup_size(64)
fn family_forces(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let group = wid.x + wid.y * nwg.x;
    let i = group * WG + lid;
    var p = 0.0;
    if (i < params.n) {
        p = particle(i);
    }
    let total = workgroup_sum(lid, p);
    if (lid == 0u && group < params.power_count) {
        power[group] = total;
    }
}
