//! CPU twins of the GPU kernels: one function per WGSL file in `sim/shaders/`, with the same
//! name and the same inputs (the shader's bindings, in binding order, as slices of the same
//! element types), written to read like the shader: a loop over the invocations with the
//! shader's body inside, the same operations in the same order. The GPU may fuse a multiply and
//! an add into one FMA and its `sqrt`, division and `pow` need not round correctly, so results
//! agree to a few ulps, not bit for bit; `tests` in this module's parent compare each pair on
//! random inputs.
//!
//! Workgroup atomics and barriers become plain sequential code: an atomic increment's return
//! value (which varies from run to run on the GPU) is taken in invocation order, which is one
//! of the orders the GPU may produce; everything the kernels compute from it is independent of
//! that order.

// Indexed loops mirror the shaders.
// `!(a <= b)` is the shaders' NaN-aware test.
#![allow(clippy::needless_range_loop, clippy::too_many_arguments, clippy::neg_cmp_op_on_partial_ord)]

use super::types::{Params, Range, SCAN_BLOCK, SLICE, Status};

/// A `vec4<f32>`.
pub type V4 = [f32; 4];
/// A `vec4<u32>`.
pub type U4 = [u32; 4];
/// A `vec4<i32>`.
pub type I4 = [i32; 4];

fn xyz(v: V4) -> [f32; 3] {
    [v[0], v[1], v[2]]
}

fn add(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn scale(a: [f32; 3], s: f32) -> [f32; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// `dot3`: summed left to right.
pub fn dot3(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `cell_of`: the hash cell of a position, floor(x / cell), saturating.
pub fn cell_of(p: [f32; 3], inverse_cell: f32) -> [i32; 3] {
    p.map(|x| (x * inverse_cell).floor().clamp(-2_147_483_648.0, 2_147_483_520.0) as i32)
}

/// `bucket_of`: the hash bucket of a cell.
pub fn bucket_of(c: [i32; 3], mask: u32) -> u32 {
    let h = (c[0] as u32).wrapping_mul(73_856_093)
        ^ (c[1] as u32).wrapping_mul(19_349_663)
        ^ (c[2] as u32).wrapping_mul(83_492_791);
    h & mask
}

/// `half_kick`: v += dt/2 F / m (w holds 1/m).
fn half_kick(v: V4, f: V4, half_dt: f32) -> V4 {
    [v[0] + half_dt * f[0] * v[3], v[1] + half_dt * f[1] * v[3], v[2] + half_dt * f[2] * v[3], v[3]]
}

/// `floor_bounce`.
fn floor_bounce(v: V4, rest_y: f32, disp_y: f32, enabled: u32, height: f32, restitution: f32) -> V4 {
    let mut out = v;
    if enabled != 0 && rest_y + disp_y < height && out[1] < 0.0 {
        out[1] *= -restitution;
    }
    out
}

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

/// Twin of `kick_floor.wgsl`.
pub fn kick_floor(params: &Params, body: &[V4], vel: &mut [V4], force: &[V4]) {
    for i in 0..params.n as usize {
        let v = half_kick(vel[i], force[i], params.half_dt);
        let rest_y = body[2 * i][1];
        let disp_y = body[2 * i + 1][1];
        vel[i] = floor_bounce(v, rest_y, disp_y, params.floor_enabled, params.floor_height, params.restitution);
    }
}

/// Twin of `contact_plan.wgsl`.
pub fn contact_plan(params: &Params, status: &mut Status, indirect: &mut [u32]) {
    let rebuild = status.rebuild != 0;
    let mut set_grid = |slot: usize, x: u32, y: u32| {
        indirect[3 * slot] = if rebuild { x } else { 0 };
        indirect[3 * slot + 1] = if rebuild { y } else { 0 };
        indirect[3 * slot + 2] = if rebuild { 1 } else { 0 };
    };
    set_grid(0, params.particle_grid_x, params.particle_grid_y);
    set_grid(1, params.table_grid_x, params.table_grid_y);
    set_grid(2, params.block_grid_x, params.block_grid_y);
    set_grid(3, 1, 1);
    if rebuild {
        status.builds += 1;
        status.rebuild = 0;
    }
}

/// Twin of `contact_count.wgsl` (arrival slots in invocation order).
pub fn contact_count(params: &Params, body: &[V4], cell: &mut [I4], arrival: &mut [u32], bucket_count: &mut [u32]) {
    for i in 0..params.n as usize {
        let p = add(xyz(body[2 * i]), xyz(body[2 * i + 1]));
        let c = cell_of(p, params.inverse_cell);
        let b = bucket_of(c, params.table_mask);
        cell[i] = [c[0], c[1], c[2], b as i32];
        arrival[i] = bucket_count[b as usize];
        bucket_count[b as usize] += 1;
    }
}

/// Twin of `scan_blocks.wgsl`.
pub fn scan_blocks(params: &Params, bucket_count: &[u32], bucket_start: &mut [u32], block_sums: &mut [u32]) {
    let table = params.table_mask as usize + 1;
    for block in 0..params.scan_blocks as usize {
        let mut sum = 0u32;
        for t in block * SCAN_BLOCK..((block + 1) * SCAN_BLOCK).min(table) {
            bucket_start[t] = sum;
            sum += bucket_count[t];
        }
        block_sums[block] = sum;
    }
}

/// Twin of `scan_block_sums.wgsl`.
pub fn scan_block_sums(params: &Params, bucket_start: &mut [u32], block_sums: &mut [u32]) {
    let mut carry = 0u32;
    for k in 0..params.scan_blocks as usize {
        let value = block_sums[k];
        block_sums[k] = carry;
        carry += value;
    }
    bucket_start[params.table_mask as usize + 1] = carry;
}

/// Twin of `scan_add.wgsl`.
pub fn scan_add(params: &Params, bucket_start: &mut [u32], block_sums: &[u32]) {
    for b in 0..=params.table_mask as usize {
        bucket_start[b] += block_sums[b / SCAN_BLOCK];
    }
}

/// Twin of `contact_scatter.wgsl`.
pub fn contact_scatter(
    params: &Params,
    cell: &[I4],
    arrival: &[u32],
    bucket_start: &[u32],
    unsorted: &mut [u32],
    bucket_count: &mut [u32],
) {
    for i in 0..params.n as usize {
        let b = cell[i][3] as u32 as usize;
        unsorted[(bucket_start[b] + arrival[i]) as usize] = i as u32;
        bucket_count[b] = 0;
    }
}

/// Twin of `contact_rank.wgsl`.
pub fn contact_rank(params: &Params, cell: &[I4], bucket_start: &[u32], unsorted: &[u32], sorted: &mut [u32]) {
    for i in 0..params.n as usize {
        let b = cell[i][3] as u32 as usize;
        let (start, end) = (bucket_start[b] as usize, bucket_start[b + 1] as usize);
        let mut rank = 0;
        for k in start..end {
            if (unsorted[k] as usize) < i {
                rank += 1;
            }
        }
        sorted[start + rank] = i as u32;
    }
}

/// Twin of `contact_candidates.wgsl`.
pub fn contact_candidates(
    params: &Params,
    body: &[V4],
    cell: &[I4],
    bucket_start: &[u32],
    sorted: &[u32],
    contact_count: &mut [u32],
    contact_list: &mut [u32],
    built_at: &mut [V4],
    status: &mut Status,
) {
    for i in 0..params.n as usize {
        let p = add(xyz(body[2 * i]), xyz(body[2 * i + 1]));
        let reach = params.reach;
        let lo = cell_of(sub(p, [reach; 3]), params.inverse_cell);
        let hi = cell_of(add(p, [reach; 3]), params.inverse_cell);
        let span = [0, 1, 2].map(|a| (hi[a].wrapping_sub(lo[a]) as u32).min(2));
        let cap = params.contact_cap as usize;
        let base = i * cap;
        let mut count = 0usize;
        for dz in 0..=span[2] {
            for dy in 0..=span[1] {
                for dx in 0..=span[0] {
                    let c =
                        [lo[0].wrapping_add(dx as i32), lo[1].wrapping_add(dy as i32), lo[2].wrapping_add(dz as i32)];
                    let b = bucket_of(c, params.table_mask) as usize;
                    for k in bucket_start[b] as usize..bucket_start[b + 1] as usize {
                        let j = sorted[k] as usize;
                        if j == i || cell[j][..3] != c {
                            continue;
                        }
                        let d = sub(p, add(xyz(body[2 * j]), xyz(body[2 * j + 1])));
                        if !(dot3(d, d) < reach * reach) {
                            continue;
                        }
                        if count < cap {
                            let mut m = count;
                            while m > 0 && contact_list[base + m - 1] >= j as u32 {
                                contact_list[base + m] = contact_list[base + m - 1];
                                m -= 1;
                            }
                            contact_list[base + m] = j as u32;
                        }
                        count += 1;
                    }
                }
            }
        }
        contact_count[i] = count.min(cap) as u32;
        built_at[i] = [p[0], p[1], p[2], 0.0];
        if count > cap {
            status.contact_needed = status.contact_needed.max(count as u32);
        }
    }
}

/// `bonded` of `collisions.wgsl`: an intact bond between the row's particle and j.
fn bonded(row: U4, j: u32, neighbor: &[u32], bits: &[u32]) -> bool {
    let (mut lo, mut hi) = (0u32, row[2]);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if neighbor[(row[0] + mid * SLICE as u32) as usize] < j {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    if lo >= row[2] || neighbor[(row[0] + lo * SLICE as u32) as usize] != j {
        return false;
    }
    bits[(row[1] + (lo >> 5) * SLICE as u32) as usize] & (1 << (lo & 31)) == 0
}

/// Twin of `collisions.wgsl`.
pub fn collisions(
    params: &Params,
    range: &Range,
    body: &[V4],
    rows: &[U4],
    contact_count: &[u32],
    contact_list: &[u32],
    contact_force: &mut [V4],
    neighbor: &[u32],
    bits: &[u32],
) {
    for local in 0..range.count as usize {
        let i = range.first as usize + local;
        let count = contact_count[i] as usize;
        if count == 0 {
            continue;
        }
        let row = rows[i];
        let x = xyz(body[2 * i]);
        let p = add(x, xyz(body[2 * i + 1]));
        let mut sum = [0.0f32; 3];
        for m in 0..count {
            let j = contact_list[i * params.contact_cap as usize + m];
            let d = sub(p, add(xyz(body[2 * j as usize]), xyz(body[2 * j as usize + 1])));
            let r2 = dot3(d, d);
            let xi = sub(x, xyz(body[2 * j as usize]));
            let reach = crate::contact::contact_reach(params.contact_distance, dot3(xi, xi));
            if r2 >= reach * reach || r2 == 0.0 || bonded(row, j, neighbor, bits) {
                continue;
            }
            let r = r2.sqrt();
            let gap = reach - r;
            let s = params.contact_stiffness * gap * gap / r;
            sum = add(sum, scale(d, s));
        }
        contact_force[i] = [sum[0], sum[1], sum[2], 0.0];
    }
}

/// `cube_root` of `spring_forces.wgsl`: pow, then one Newton step.
pub fn cube_root(x: f32) -> f32 {
    if x <= 0.0 {
        return 0.0;
    }
    let c = x.powf(1.0 / 3.0);
    c - (c * c * c - x) / (3.0 * c * c)
}

/// `projectile_force` of `spring_forces.wgsl`.
fn projectile_force(spheres: &[V4], s: usize, c: [f32; 3], p: [f32; 3]) -> [f32; 3] {
    let heading = spheres[2 * s];
    let radius = heading[3];
    let stiffness = spheres[2 * s + 1][0];
    let d = sub(p, c);
    let r = dot3(d, d).sqrt();
    if !(r >= 0.75 * radius && r <= 1.5 * radius) {
        return [0.0; 3];
    }
    let shape = 16.0 * (r - 0.75 * radius) * (r - 1.5 * radius) * (r - 1.5 * radius);
    let root = cube_root(shape);
    let magnitude = stiffness * root * root;
    let away = d.map(|x| x / r);
    let mut direction = add(away, xyz(heading));
    let norm = dot3(direction, direction).sqrt();
    if norm > 1e-6 {
        direction = direction.map(|x| x / norm);
    } else {
        direction = away;
    }
    scale(direction, magnitude)
}

/// `indenter_force` of `spring_forces.wgsl`.
fn indenter_force(spheres: &[V4], s: usize, c: [f32; 3], p: [f32; 3]) -> [f32; 3] {
    let radius = spheres[2 * s][3];
    let stiffness = spheres[2 * s + 1][0];
    let d = sub(p, c);
    let r = dot3(d, d).sqrt();
    if r >= radius || r == 0.0 {
        return [0.0; 3];
    }
    let gap = radius - r;
    scale(d, stiffness * gap * gap / r)
}

/// Twin of `spring_forces.wgsl` (the workgroup power sums in the shader's tree order).
pub fn spring_forces(
    params: &Params,
    range: &Range,
    body: &[V4],
    vel: &[V4],
    force: &mut [V4],
    boost_next: &mut [f32],
    rows: &[U4],
    broken_count: &mut [u32],
    contact_count: &[u32],
    contact_force: &[V4],
    neighbor: &[u32],
    stiffness: &[f32],
    threshold: &[f32],
    bits: &mut [u32],
    power: &mut [f32],
    status: &mut Status,
    spheres: &[V4],
    events: &mut [[u32; 2]],
) {
    let wg = super::types::WG;
    for group in 0..range.workgroups as usize {
        let mut partial = [0.0f32; super::types::WG];
        for lid in 0..wg {
            let local = group * wg + lid;
            if local < range.count as usize {
                partial[lid] = particle(
                    params,
                    range.first as usize + local,
                    body,
                    vel,
                    force,
                    boost_next,
                    rows,
                    broken_count,
                    contact_count,
                    contact_force,
                    neighbor,
                    stiffness,
                    threshold,
                    bits,
                    status,
                    spheres,
                    events,
                );
            }
        }
        let mut stride = wg / 2;
        while stride > 0 {
            for lid in 0..stride {
                partial[lid] += partial[lid + stride];
            }
            stride /= 2;
        }
        power[range.first_workgroup as usize + group] = partial[0];
    }
}

/// `particle` of `spring_forces.wgsl`: all forces on particle i; returns F_ext . v.
fn particle(
    params: &Params,
    i: usize,
    body: &[V4],
    vel: &[V4],
    force: &mut [V4],
    boost_next: &mut [f32],
    rows: &[U4],
    broken_count: &mut [u32],
    contact_count: &[u32],
    contact_force: &[V4],
    neighbor: &[u32],
    stiffness: &[f32],
    threshold: &[f32],
    bits: &mut [u32],
    status: &mut Status,
    spheres: &[V4],
    events: &mut [[u32; 2]],
) -> f32 {
    let own = body[2 * i];
    let record = body[2 * i + 1];
    let row = rows[i];
    let step = status.step;
    let mut f = [0.0f32; 3];
    let mut smallest = 0.0f32;
    let mut broke = 0u32;
    let mut word = 0u32;
    let mut changed = false;
    for k in 0..row[2] {
        let bit = k & 31;
        let w = (row[1] + (k >> 5) * SLICE as u32) as usize;
        if bit == 0 {
            word = bits[w];
            changed = false;
        }
        if word & (1 << bit) == 0 {
            let e = (row[0] + k * SLICE as u32) as usize;
            let j = neighbor[e] as usize;
            let other = body[2 * j];
            let other_record = body[2 * j + 1];
            let xi = sub(xyz(other), xyz(own));
            let eta = sub(xyz(other_record), xyz(record));
            let y = add(xi, eta);
            let length = dot3(y, y).sqrt();
            let rest = dot3(xi, xi).sqrt();
            let growth = 2.0 * dot3(xi, eta) + dot3(eta, eta);
            let denominator = rest * (length + rest) * length;
            let inverse = if denominator > 0.0 { 1.0 / denominator } else { 0.0 };
            let k_ij = stiffness[e];
            let s = if k_ij > 0.0 { growth * length * inverse } else { 0.0 };
            let boost =
                if params.break_rule != 0 { record[3].min(other_record[3]) } else { record[3].max(other_record[3]) };
            if s > threshold[e] + boost {
                word |= 1 << bit;
                changed = true;
                broke += 1;
                if i < j {
                    let slot = status.events;
                    status.events += 1;
                    if slot < params.event_capacity {
                        events[slot as usize] = [step, row[3] + k];
                    }
                }
            } else {
                f = add(f, scale(y, k_ij * growth * inverse));
                smallest = smallest.min(s);
            }
        }
        if changed && (bit == 31 || k + 1 == row[2]) {
            bits[w] = word;
            changed = false;
        }
    }
    if broke != 0 {
        broken_count[i] += broke;
    }
    boost_next[i] = smallest * -params.alpha;
    if params.contact_enabled != 0 && contact_count[i] != 0 {
        f = add(f, xyz(contact_force[i]));
    }
    let p = add(xyz(own), xyz(record));
    let mut external = scale([params.gravity_x, params.gravity_y, params.gravity_z], own[3]);
    let spheres_now = (params.projectiles + params.indenters) as usize;
    let centres = 2 * spheres_now + (step - params.batch_first_step) as usize * spheres_now;
    for s in 0..params.projectiles as usize {
        external = add(external, projectile_force(spheres, s, xyz(spheres[centres + s]), p));
    }
    for s in params.projectiles as usize..spheres_now {
        external = add(external, indenter_force(spheres, s, xyz(spheres[centres + s]), p));
    }
    let total = add(f, external);
    force[i] = [total[0], total[1], total[2], 0.0];
    dot3(external, xyz(vel[i]))
}

/// Twin of `power_sum.wgsl`.
pub fn power_sum(params: &Params, power: &[f32], status: &mut Status) {
    let mut partial = [0.0f32; 256];
    for lid in 0..256 {
        let mut k = lid;
        while k < params.power_count as usize {
            partial[lid] += power[k];
            k += 256;
        }
    }
    let mut stride = 128;
    while stride > 0 {
        for lid in 0..stride {
            partial[lid] += partial[lid + stride];
        }
        stride /= 2;
    }
    let add = partial[0] * params.dt;
    let hi = status.work_hi;
    let s = hi + add;
    let b = s - hi;
    let error = (hi - (s - b)) + (add - b);
    let lo = status.work_lo + error;
    let total = s + lo;
    status.work_lo = lo - (total - s);
    status.work_hi = total;
}

/// Twin of `bond_energy.wgsl`.
pub fn bond_energy(
    range: &Range,
    body: &[V4],
    rows: &[U4],
    neighbor: &[u32],
    stiffness: &[f32],
    bits: &[u32],
    energy: &mut [f32],
) {
    for local in 0..range.count as usize {
        let i = range.first as usize + local;
        let own = body[2 * i];
        let record = body[2 * i + 1];
        let row = rows[i];
        let mut sum = 0.0f32;
        for k in 0..row[2] {
            if bits[(row[1] + (k >> 5) * SLICE as u32) as usize] & (1 << (k & 31)) != 0 {
                continue;
            }
            let e = (row[0] + k * SLICE as u32) as usize;
            let j = neighbor[e] as usize;
            let xi = sub(xyz(body[2 * j]), xyz(own));
            let eta = sub(xyz(body[2 * j + 1]), xyz(record));
            let y = add(xi, eta);
            let length = dot3(y, y).sqrt();
            let rest = dot3(xi, xi).sqrt();
            let growth = 2.0 * dot3(xi, eta) + dot3(eta, eta);
            let s = growth / (rest * (length + rest));
            sum += 0.25 * stiffness[e] * s * s * rest;
        }
        energy[i] = sum;
    }
}
