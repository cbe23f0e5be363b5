// The velocity update of one step fused with the position update of the next (inside a batch of
// steps): the same operations as kick_floor followed by kick_drift, in one pass over the
// particles instead of two.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> body: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> vel: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> force: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> boost_next: array<f32>;
@group(0) @binding(5) var<storage, read> built_at: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> status: Status;

var<workgroup> moved: atomic<u32>;

@compute @workgroup_size(64)
fn kick_floor_drift(
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
        let landed = floor_bounce(
            half_kick(vel[i], f, params.half_dt),
            rest.y,
            record.y,
            params.floor_enabled,
            params.floor_height,
            params.restitution,
        );
        let v = half_kick(landed, f, params.half_dt);
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
