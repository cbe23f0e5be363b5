// Collection, step 5: each particle lists, in increasing index, every other particle within
// d_c + skin of it (the Verlet list of the CPU path), searching the 2 x 2 x 2 hash cells around
// it; stores where it stood (the lists stay valid until some particle moves half the skin).
// A particle with more candidates than the list holds records how many it needed; the host then
// enlarges the lists and replays the frame.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> body: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> cell: array<vec4<i32>>;
@group(0) @binding(3) var<storage, read> bucket_start: array<u32>;
@group(0) @binding(4) var<storage, read> sorted: array<u32>;
@group(0) @binding(5) var<storage, read_write> contact_count: array<u32>;
@group(0) @binding(6) var<storage, read_write> contact_list: array<u32>;
@group(0) @binding(7) var<storage, read_write> built_at: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> status: Status;

@compute @workgroup_size(64)
fn contact_candidates(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_index(wid, nwg, lid);
    if (i >= params.n) {
        return;
    }
    let p = body[2u * i].xyz + body[2u * i + 1u].xyz;
    let reach = params.reach;
    let lo = cell_of(p - vec3<f32>(reach), params.inverse_cell);
    let hi = cell_of(p + vec3<f32>(reach), params.inverse_cell);
    let span = min(bitcast<vec3<u32>>(hi - lo), vec3<u32>(2u));
    let cap = params.contact_cap;
    let base = i * cap;
    var count = 0u;
    for (var dz = 0u; dz <= span.z; dz = dz + 1u) {
        for (var dy = 0u; dy <= span.y; dy = dy + 1u) {
            for (var dx = 0u; dx <= span.x; dx = dx + 1u) {
                let c = lo + bitcast<vec3<i32>>(vec3<u32>(dx, dy, dz));
                let b = bucket_of(c, params.table_mask);
                let end = bucket_start[b + 1u];
                for (var k = bucket_start[b]; k < end; k = k + 1u) {
                    let j = sorted[k];
                    if (j == i || any(cell[j].xyz != c)) {
                        continue;
                    }
                    let d = p - (body[2u * j].xyz + body[2u * j + 1u].xyz);
                    if (!(dot3(d, d) < reach * reach)) {
                        continue;
                    }
                    if (count < cap) {
                        // Insertion in increasing index.
                        var m = count;
                        loop {
                            if (m == 0u || contact_list[base + m - 1u] < j) {
                                break;
                            }
                            contact_list[base + m] = contact_list[base + m - 1u];
                            m = m - 1u;
                        }
                        contact_list[base + m] = j;
                    }
                    count = count + 1u;
                }
            }
        }
    }
    contact_count[i] = min(count, cap);
    built_at[i] = vec4<f32>(p, 0.0);
    if (count > cap) {
        atomicMax(&status.contact_needed, count);
    }
}
