//! Twin of `kick_drift.wgsl`: the position update v += dt/2 F/m, u += dt v (with `LAND_FIRST`, the
//! previous step's velocity update first); packs the boost next to u, advances the clock and flags
//! the contact lists stale.

use super::common::{V4, add, dot3, floor_bounce, half_kick, scale, sub, xyz};
use crate::gpu::wgsl_structs::{Params, Status};

/// The bindings of `kick_drift.wgsl`, in binding order.
pub struct KickDriftBindings<'a> {
    /// The batch's constants.
    pub params: &'a Params,
    /// Two records per particle: rest position and mass; displacement and boost (written).
    pub body: &'a mut [V4],
    /// Per particle: velocity, m/s, and 1 / m.
    pub vel: &'a mut [V4],
    /// Per particle: the force, newtons.
    pub force: &'a [V4],
    /// Per particle: the compression boost of the last force pass.
    pub boost_next: &'a [f32],
    /// Per particle: where it stood at the last build of the contact lists.
    pub built_at: &'a [V4],
    /// The run's clock and counters (the step, the rebuild flag).
    pub status: &'a mut Status,
}

/// Twin of `kick_drift.wgsl`, with its `LAND_FIRST` override constant as `land_first`.
pub fn kick_drift(land_first: bool, b: KickDriftBindings) {
    let KickDriftBindings { params, body, vel, force, boost_next, built_at, status } = b;
    let mut moved = false;
    for i in 0..params.n as usize {
        let f = force[i];
        let rest = body[2 * i];
        let record = body[2 * i + 1];
        let mut v = vel[i];
        if land_first {
            v = floor_bounce(
                half_kick(v, f, params.half_dt),
                rest[1],
                record[1],
                params.floor_enabled,
                params.floor_height,
                params.restitution,
            );
        }
        v = half_kick(v, f, params.half_dt);
        let u = add(xyz(record), scale(xyz(v), params.dt));
        vel[i] = v;
        body[2 * i + 1] = [u[0], u[1], u[2], boost_next[i]];
        let d = sub(add(xyz(rest), u), xyz(built_at[i]));
        if !(dot3(d, d) <= params.skin_limit) {
            moved = true;
        }
        if i == 0 {
            status.step += 1;
        }
    }
    if moved {
        status.rebuild |= 1;
    }
}
