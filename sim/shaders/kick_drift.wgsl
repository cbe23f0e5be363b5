// Position update (the paper's first Verlet kernel): v += dt/2 F/m, u += dt v, for one particle
// per invocation. Also packs the compression boost of the last force pass next to the
// displacement (the record the spring kernel gathers), advances the clock, and flags the
// contact lists stale when the particle has moved more than half the skin since their build.
//
// With LAND_FIRST (inside a batch of steps) the previous step's velocity update comes first,
// the same operations as kick_floor: one pass over the particles instead of two.

override LAND_FIRST: bool = false;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> body: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> vel: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> force: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> boost_next: array<f32>;
@group(0) @binding(5) var<storage, read> built_at: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> status: Status;

var<workgroup> moved: atomic<u32>;

@compute @workgroup_size(64)
fn kick_drift(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    if (lid == 0u) {
        atomicStore(&moved, 0u);
    }
    workgroupBarrier();
    let i = linear_index(wid, nwg, lid);
    if (i < params.n) {
        let f = force[i];
        let rest = body[2u * i];
        let record = body[2u * i + 1u];
        var v = vel[i];
        if (LAND_FIRST) {
            v = floor_bounce(
                half_kick(v, f, params.half_dt),
                rest.y,
                record.y,
                params.floor_enabled,
                params.floor_height,
                params.restitution,
            );
        }
        v = half_kick(v, f, params.half_dt);
        let u = record.xyz + params.dt * v.xyz;
        vel[i] = v;
        body[2u * i + 1u] = vec4<f32>(u, boost_next[i]);
        let d = rest.xyz + u - built_at[i].xyz;
        if (!(dot3(d, d) <= params.skin_limit)) {
            atomicOr(&moved, 1u);
        }
        if (i == 0u) {
            status.step = status.step + 1u;
        }
    }
    workgroupBarrier();
    if (lid == 0u && atomicLoad(&moved) != 0u) {
        atomicOr(&status.rebuild, 1u);
    }
}
