//! Twin of `kick_drift.wgsl`: the position update v += dt/2 F/m, u += dt v (with `LAND_FIRST`, the
//! previous step's velocity update first); packs the boost next to u, advances the clock and flags
//! the contact lists stale.

use super::common::{V4, add, dot3, floor_bounce, half_kick, scale, sub, xyz};
use crate::gpu::wgsl_structs::{Params, Status};

/// Twin of `kick_drift.wgsl`, with its `LAND_FIRST` constant as `land_first`.
#[allow(clippy::too_many_arguments)]
pub fn kick_drift(
    params: &Params,
    land_first: bool,
    body: &mut [V4],
    vel: &mut [V4],
    force: &[V4],
    boost_next: &[f32],
    built_at: &[V4],
    status: &mut Status,
) {
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
