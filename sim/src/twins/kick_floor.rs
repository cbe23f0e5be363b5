//! Twin of `kick_floor.wgsl`: the velocity update v += dt/2 F/m and the floor's bounce.

use super::common::{V4, floor_bounce, half_kick};
use crate::gpu::wgsl_structs::Params;

/// The bindings of `kick_floor.wgsl`, in binding order.
pub struct KickFloorBindings<'a> {
    /// The batch's constants.
    pub params: &'a Params,
    /// Two records per particle: rest position and mass; displacement and boost.
    pub body: &'a [V4],
    /// Per particle: velocity, m/s, and 1 / m.
    pub vel: &'a mut [V4],
    /// Per particle: the force, newtons.
    pub force: &'a [V4],
}

/// Twin of `kick_floor.wgsl`.
pub fn kick_floor(b: KickFloorBindings) {
    let KickFloorBindings { params, body, vel, force } = b;
    for i in 0..params.n as usize {
        let v = half_kick(vel[i], force[i], params.half_dt);
        let rest_y = body[2 * i][1];
        let disp_y = body[2 * i + 1][1];
        vel[i] = floor_bounce(v, rest_y, disp_y, params.floor_enabled, params.floor_height, params.restitution);
    }
}
