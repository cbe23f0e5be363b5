// Position update (the paper's first Verlet kernel): v += dt/2 F/m, u += dt v, for one particle
// per invocation. Also packs the compression boost of the last force pass next to the
// displacement (the record the spring kernel gathers), advances the clock, and flags the
// contact lists stale when the particle has moved more than half the skin since their build.

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
        let v = half_kick(vel[i], force[i], params.half_dt);
        let rest = body[2u * i];
        let u = body[2u * i + 1u].xyz + params.dt * v.xyz;
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
