// Spring forces fused with body forces (the paper's springforces and bodyforces), one particle
// per invocation, for the particles of one bond range. For each of its bonds, in row order:
// skip it if broken; else the stretch from the displacement difference,
// s = (2 xi.eta + eta.eta) / (L (|xi + eta| + L)); if s exceeds the bond's threshold plus the
// larger (or smaller) compression boost of its two particles the bond breaks (its bit is set in
// the particle's own bit words, so no atomics; both ends compute the same s and decide alike);
// else the force k s (xi + eta) / |xi + eta| is added and the smallest stretch kept. Then the
// contact force from `collisions`, then gravity, projectiles and indenters at the current
// positions (`params.rules` may apply a breaking bond's force too, and take the smallest stretch
// whatever its sign). Writes the force, the next compression boost -alpha min(0, s_min), the particle's
// broken-bond count, break events (by the lower particle of a bond), and the workgroup's
// applied power (a fixed-order tree sum) for power_sum.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<uniform> range: Range;
@group(0) @binding(2) var<storage, read> body: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> vel: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> force: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> boost_next: array<f32>;
@group(0) @binding(6) var<storage, read> rows: array<vec4<u32>>;
@group(0) @binding(7) var<storage, read_write> broken_count: array<u32>;
@group(0) @binding(8) var<storage, read> contact_count: array<u32>;
@group(0) @binding(9) var<storage, read> contact_force: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read> neighbor: array<u32>;
@group(0) @binding(11) var<storage, read> stiffness: array<f32>;
@group(0) @binding(12) var<storage, read> threshold: array<f32>;
@group(0) @binding(13) var<storage, read_write> bits: array<u32>;
@group(0) @binding(14) var<storage, read_write> power: array<f32>;
@group(0) @binding(15) var<storage, read_write> status: Status;
@group(0) @binding(16) var<storage, read> spheres: array<vec4<f32>>;
@group(0) @binding(17) var<storage, read_write> events: array<vec2<u32>>;

// All forces on particle i; returns the applied power F_ext . v.
fn particle(i: u32) -> f32 {
    let own = body[2u * i];
    let record = body[2u * i + 1u];
    let row = rows[i];
    let step = status.step;
    let signed = (params.rules & RULE_SIGNED_BOOST) != 0u;
    let breaking_force = (params.rules & RULE_BREAKING_FORCE) != 0u;
    var f = vec3<f32>(0.0);
    var smallest = 0.0;
    if (signed) {
        smallest = NO_STRETCH;
    }
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
            let other = body[2u * j];
            let other_record = body[2u * j + 1u];
            let xi = other.xyz - own.xyz;
            let eta = other_record.xyz - record.xyz;
            let y = xi + eta;
            let length = sqrt(dot3(y, y));
            let rest = sqrt(dot3(xi, xi));
            let growth = 2.0 * dot3(xi, eta) + dot3(eta, eta);
            let denominator = rest * (length + rest) * length;
            var inverse = 0.0;
            if (denominator > 0.0) {
                inverse = 1.0 / denominator;
            }
            let k_ij = stiffness[e];
            var s = 0.0;
            if (k_ij > 0.0) {
                s = growth * length * inverse;
            }
            var boost = max(record.w, other_record.w);
            if (params.break_rule != 0u) {
                boost = min(record.w, other_record.w);
            }
            if (s > threshold[e] + boost) {
                word = word | (1u << bit);
                changed = true;
                broke = broke + 1u;
                if (i < j) {
                    let slot = atomicAdd(&status.events, 1u);
                    if (slot < params.event_capacity) {
                        events[slot] = vec2<u32>(step, row.w + k);
                    }
                }
                if (breaking_force) {
                    f = f + y * (k_ij * growth * inverse);
                    if (k_ij > 0.0 || !signed) {
                        smallest = min(smallest, s);
                    }
                }
            } else {
                f = f + y * (k_ij * growth * inverse);
                if (k_ij > 0.0 || !signed) {
                    smallest = min(smallest, s);
                }
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
    if (smallest >= NO_STRETCH) {
        boost_next[i] = 0.0;
    } else {
        boost_next[i] = smallest * -params.alpha;
    }
    if (params.contact_enabled != 0u && contact_count[i] != 0u) {
        f = f + contact_force[i].xyz;
    }
    // Body forces at the current position.
    let applied = body_force(own.w, own.xyz + record.xyz, step);
    force[i] = vec4<f32>(f + applied, 0.0);
    return dot3(applied, vel[i].xyz);
}

@compute @workgroup_size(64)
fn spring_forces(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let group = wid.x + wid.y * nwg.x;
    let local = group * WG + lid;
    var p = 0.0;
    if (local < range.count) {
        p = particle(range.first + local);
    }
    let total = workgroup_sum(lid, p);
    if (lid == 0u && group < range.workgroups) {
        power[range.first_workgroup + group] = total;
    }
}
