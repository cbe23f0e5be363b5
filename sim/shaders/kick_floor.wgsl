// Velocity update (the paper's second Verlet kernel): v += dt/2 F/m, then the floor reflects the
// vertical velocity of a particle below it that moves down, keeping the restitution.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> body: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> vel: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> force: array<vec4<f32>>;

@compute @workgroup_size(64)
fn kick_floor(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_index(wid, nwg, lid);
    if (i >= params.n) {
        return;
    }
    let v = half_kick(vel[i], force[i], params.half_dt);
    let rest_y = body[2u * i].y;
    let disp_y = body[2u * i + 1u].y;
    vel[i] = floor_bounce(v, rest_y, disp_y, params.floor_enabled, params.floor_height, params.restitution);
}
