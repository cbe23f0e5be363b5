// The elastoplastic model's first pass (Chen et al. section 4.1 as the linear peridynamic solid;
// the CPU's `elastoplastic::passes::dilatation`), one particle per invocation. The bonds are in
// spring_forces's sliced layout (entry k of particle i at row.x + k * SLICE, broken bits in the
// particle's own words), all in one range. For each intact bond, in row order: the extension
// e = |y| - |xi| from the displacement difference (no cancellation), stored for the force pass,
// and omega |xi| e V_j summed; then theta_i = 3 sum / m_i and the damage
// phi_i = 1 - intact / initial. Also moves the previous force pass's plastic extensions
// (plastic[e].y) into place (plastic[e].x) for the force pass to read at both ends of a bond.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> body: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> rows: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read> broken_count: array<u32>;
@group(0) @binding(4) var<storage, read> neighbor: array<u32>;
@group(0) @binding(5) var<storage, read> bits: array<u32>;
// Per entry: omega_ij, omega_ji, |xi| (metres), 1 / (omega_mean |xi|).
@group(0) @binding(6) var<storage, read> family_entry: array<vec4<f32>>;
// Per particle: V (m^3), 15 mu / m, 3 K / m, the yield force.
@group(0) @binding(7) var<storage, read> family_particle: array<vec4<f32>>;
// Per particle: the weighted volume m_i, m^5.
@group(0) @binding(8) var<storage, read> weighted_volume: array<f32>;
// Per entry: (plastic extension the force pass reads, the one it writes), metres.
@group(0) @binding(9) var<storage, read_write> plastic: array<vec2<f32>>;
@group(0) @binding(10) var<storage, read_write> extension: array<f32>;
// Per particle: displacement and dilatation theta.
@group(0) @binding(11) var<storage, read_write> family_record: array<vec4<f32>>;
@group(0) @binding(12) var<storage, read_write> damage: array<f32>;

@compute @workgroup_size(64)
fn family_dilatation(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_index(wid, nwg, lid);
    if (i >= params.n) {
        return;
    }
    let own = body[2u * i];
    let u_i = body[2u * i + 1u].xyz;
    let row = rows[i];
    var sum = 0.0;
    var word = 0u;
    for (var k = 0u; k < row.z; k = k + 1u) {
        let bit = k & 31u;
        if (bit == 0u) {
            word = bits[row.y + (k >> 5u) * SLICE];
        }
        let e = row.x + k * SLICE;
        plastic[e].x = plastic[e].y;
        if ((word & (1u << bit)) == 0u) {
            let j = neighbor[e];
            let xi = body[2u * j].xyz - own.xyz;
            let eta = body[2u * j + 1u].xyz - u_i;
            let entry = family_entry[e];
            let rest = entry.z;
            let y = xi + eta;
            let length = sqrt(dot3(y, y));
            let growth = 2.0 * dot3(xi, eta) + dot3(eta, eta);
            let e_ij = growth / (rest * (length + rest)) * rest;
            extension[e] = e_ij;
            sum = sum + entry.x * rest * e_ij * family_particle[j].x;
        }
    }
    family_record[i] = vec4<f32>(u_i, 3.0 * sum / weighted_volume[i]);
    var phi = 0.0;
    if (row.z != 0u) {
        phi = 1.0 - f32(row.z - broken_count[i]) / f32(row.z);
    }
    damage[i] = phi;
}
