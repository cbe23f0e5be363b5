// Bond energy per particle (at frame boundaries only): half of 1/2 k s^2 L over each of its
// intact bonds, s from the displacement difference as in spring_forces.

@group(0) @binding(0) var<uniform> range: Range;
@group(0) @binding(1) var<storage, read> body: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> rows: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read> neighbor: array<u32>;
@group(0) @binding(4) var<storage, read> stiffness: array<f32>;
@group(0) @binding(5) var<storage, read> bits: array<u32>;
@group(0) @binding(6) var<storage, read_write> energy: array<f32>;

@compute @workgroup_size(64)
fn bond_energy(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let local = linear_index(wid, nwg, lid);
    if (local >= range.count) {
        return;
    }
    let i = range.first + local;
    let own = body[2u * i];
    let record = body[2u * i + 1u];
    let row = rows[i];
    var sum = 0.0;
    for (var k = 0u; k < row.z; k = k + 1u) {
        if ((bits[row.y + (k >> 5u) * SLICE] & (1u << (k & 31u))) != 0u) {
            continue;
        }
        let e = row.x + k * SLICE;
        let j = neighbor[e];
        let xi = body[2u * j].xyz - own.xyz;
        let eta = body[2u * j + 1u].xyz - record.xyz;
        let y = xi + eta;
        let length = sqrt(dot3(y, y));
        let rest = sqrt(dot3(xi, xi));
        let growth = 2.0 * dot3(xi, eta) + dot3(eta, eta);
        let s = growth / (rest * (length + rest));
        sum = sum + 0.25 * stiffness[e] * s * s * rest;
    }
    energy[i] = sum;
}
