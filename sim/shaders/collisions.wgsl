// Collisions (the paper's kernel): each particle of a bond range is pushed away from every
// candidate closer than d_c that it has no intact bond with, by eq. 6, K_c (d_c - r)^2 d / r,
// d_c capped at the pair's rest distance (a broken bond's particles do not repel where they sat),
// summed over the candidates in increasing index. Bonds are looked up in the particle's own
// row (binary search; rows are sorted) and its own broken bits, as they were after the last
// force pass: a bond that breaks in this step's force pass still counts, as on the CPU. Under
// RULE_LAMMPS_CONTACT, LAMMPS's short-range force instead: every candidate closer than
// min(0.9 |xi|, contact_distance), bonded or not, pushes with contact_stiffness m_i m_j (d - r)
// d / r (contact_stiffness = 15 c / (delta rho^2), the masses standing for rho V).

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<uniform> range: Range;
@group(0) @binding(2) var<storage, read> body: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> rows: array<vec4<u32>>;
@group(0) @binding(4) var<storage, read> contact_count: array<u32>;
@group(0) @binding(5) var<storage, read> contact_list: array<u32>;
@group(0) @binding(6) var<storage, read_write> contact_force: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> neighbor: array<u32>;
@group(0) @binding(8) var<storage, read> bits: array<u32>;

// True when particle i (row `row`) has an intact bond with j.
fn bonded(row: vec4<u32>, j: u32) -> bool {
    var lo = 0u;
    var hi = row.z;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (neighbor[row.x + mid * SLICE] < j) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    if (lo >= row.z || neighbor[row.x + lo * SLICE] != j) {
        return false;
    }
    return (bits[row.y + (lo >> 5u) * SLICE] & (1u << (lo & 31u))) == 0u;
}

@compute @workgroup_size(64)
fn collisions(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let local = linear_index(wid, nwg, lid);
    if (local >= range.count) {
        return;
    }
    let i = range.first + local;
    let count = contact_count[i];
    if (count == 0u) {
        return;
    }
    let row = rows[i];
    let lammps = (params.rules & RULE_LAMMPS_CONTACT) != 0u;
    let own_mass = body[2u * i].w;
    let x = body[2u * i].xyz;
    let p = x + body[2u * i + 1u].xyz;
    var sum = vec3<f32>(0.0);
    for (var m = 0u; m < count; m = m + 1u) {
        let j = contact_list[i * params.contact_cap + m];
        let d = p - (body[2u * j].xyz + body[2u * j + 1u].xyz);
        let r2 = dot3(d, d);
        let xi = x - body[2u * j].xyz;
        if (lammps) {
            let reach = min(0.9 * sqrt(dot3(xi, xi)), params.contact_distance);
            if (r2 >= reach * reach || r2 == 0.0) {
                continue;
            }
            let r = sqrt(r2);
            sum = sum + d * (params.contact_stiffness * own_mass * body[2u * j].w * (reach - r) / r);
            continue;
        }
        let reach = min(params.contact_distance, sqrt(dot3(xi, xi)));
        if (r2 >= reach * reach || r2 == 0.0 || bonded(row, j)) {
            continue;
        }
        let r = sqrt(r2);
        let gap = reach - r;
        let scale = params.contact_stiffness * gap * gap / r;
        sum = sum + d * scale;
    }
    contact_force[i] = vec4<f32>(sum, 0.0);
}
