//! Twin of `kick_floor.wgsl`: the velocity update v += dt/2 F/m and the floor's bounce.

use super::common::{V4, floor_bounce, half_kick};
use crate::gpu::wgsl_structs::Params;

/// Twin of `kick_floor.wgsl`.
pub fn kick_floor(params: &Params, body: &[V4], vel: &mut [V4], force: &[V4]) {
    for i in 0..params.n as usize {
        let v = half_kick(vel[i], force[i], params.half_dt);
        let rest_y = body[2 * i][1];
        let disp_y = body[2 * i + 1][1];
        vel[i] = floor_bounce(v, rest_y, disp_y, params.floor_enabled, params.floor_height, params.restitution);
    }
}
