//! The step's kernels on the CPU, one function per kernel of the paper's GPU structure
//! (position update, spring forces, collisions, body forces, velocity update). Each works on one
//! chunk of particles and writes only that chunk's outputs.

// Indexed loops mirror the shaders these kernels are twins of.
#![allow(clippy::needless_range_loop)]

use shatter_core::config::sim::BreakRule;

use crate::bond_table::BondChunk;
use crate::contact::{ContactList, contact_reach, repulsion};
use crate::model::Floor;

/// One chunk's outputs of the force pass.
pub struct ChunkForces<'a> {
    /// Force accumulators, newtons.
    pub force: [&'a mut [f32]; 3],
    /// Smallest stretch over each particle's intact bonds (never above 0).
    pub min_stretch: &'a mut [f32],
    /// Broken bonds per particle (running count).
    pub broken: &'a mut [u32],
}

/// Bond stretch s = |xi + eta| / |xi| - 1 computed from the displacement difference eta, as
/// (2 xi . eta + eta . eta) / (L (|xi + eta| + L)): no cancellation, so strains of 1e-7 stay
/// exact in f32 wherever the body is. Returns (s, y = xi + eta, |y|).
#[inline(always)]
pub fn stretch(xi: [f32; 3], eta: [f32; 3], rest_length: f32) -> (f32, [f32; 3], f32) {
    let y = [xi[0] + eta[0], xi[1] + eta[1], xi[2] + eta[2]];
    let length = (y[0] * y[0] + y[1] * y[1] + y[2] * y[2]).sqrt();
    let growth = 2.0 * (xi[0] * eta[0] + xi[1] * eta[1] + xi[2] * eta[2])
        + (eta[0] * eta[0] + eta[1] * eta[1] + eta[2] * eta[2]);
    (growth / (rest_length * (length + rest_length)), y, length)
}

/// The threshold a bond's stretch is compared with: its own plus the larger (or smaller) of its
/// particles' compression boosts.
#[inline(always)]
fn effective_threshold(rule: BreakRule, threshold: f32, boost_i: f32, boost_j: f32) -> f32 {
    match rule {
        BreakRule::Max => threshold + boost_i.max(boost_j),
        BreakRule::Min => threshold + boost_i.min(boost_j),
    }
}

/// What the spring kernel gathers of a bond partner, packed into 16 bytes so that one load
/// serves it: displacement and compression boost.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C, align(16))]
pub struct ParticleRecord {
    /// Displacement u, metres.
    pub disp: [f32; 3],
    /// Compression boost of the particle's thresholds (from the previous step).
    pub boost: f32,
}

/// `values` in the first lanes, `fill` in the rest.
#[inline(always)]
fn lanes(values: &[f32], fill: f32) -> [f32; LANES] {
    match <[f32; LANES]>::try_from(values) {
        Ok(full) => full,
        Err(_) => {
            let mut out = [fill; LANES];
            for (lane, value) in values.iter().enumerate() {
                out[lane] = *value;
            }
            out
        }
    }
}

/// Bonds processed together: the arithmetic runs lane by lane over fixed-size arrays, which the
/// compiler turns into SIMD instructions; gathers and the rare breaks stay scalar.
const LANES: usize = 8;

/// One particle's running sums over the lanes.
#[derive(Debug, Clone, Copy)]
struct LaneSums {
    force: [[f32; LANES]; 3],
    min_stretch: [f32; LANES],
}

/// Spring forces (the paper's `springforces`): for every intact bond of the chunk, the stretch,
/// the break test against the effective threshold, and the PMB force k s (xi + eta) / |xi + eta|.
/// Internal bonds are computed once and applied to both ends; external bonds to this end only.
/// Bonds that break are recorded in `chunk.breaks` (external ones by their lower particle only).
/// Each particle's bonds are summed lane by lane (entry k of its row in lane k mod 8), the lanes
/// then in order: a fixed order, whatever the thread count.
pub fn spring_forces(chunk: &mut BondChunk, records: &[ParticleRecord], rule: BreakRule, out: &mut ChunkForces) {
    chunk.breaks.clear();
    let mut totals = std::mem::take(&mut chunk.totals);
    totals.clear();
    totals.resize(chunk.len, [0.0; 4]);
    for local in 0..chunk.len {
        let mut sums = LaneSums { force: [[0.0; LANES]; 3], min_stretch: [0.0; LANES] };
        let row = chunk.row_start[local] as usize..chunk.row_start[local + 1] as usize;
        let internal_end = chunk.internal_end[local] as usize;
        let mut start = row.start;
        while start < internal_end {
            let end = (start + LANES).min(internal_end);
            bond_block::<true>(chunk, records, rule, local, start..end, &mut sums, &mut totals, out.broken);
            start = end;
        }
        while start < row.end {
            let end = (start + LANES).min(row.end);
            bond_block::<false>(chunk, records, rule, local, start..end, &mut sums, &mut totals, out.broken);
            start = end;
        }
        let total = &mut totals[local];
        for axis in 0..3 {
            total[axis] += sums.force[axis].iter().sum::<f32>();
        }
        total[3] = sums.min_stretch.iter().fold(total[3], |a, b| a.min(*b));
    }
    for (local, total) in totals.iter().enumerate() {
        for axis in 0..3 {
            out.force[axis][local] = total[axis];
        }
        out.min_stretch[local] = total[3];
    }
    chunk.totals = totals;
}

/// Up to `LANES` consecutive entries of particle `local`'s row, all internal or all external.
/// `totals` are the chunk's per-particle sums (force x, y, z and smallest stretch) that internal
/// bonds scatter into.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn bond_block<const INTERNAL: bool>(
    chunk: &mut BondChunk,
    records: &[ParticleRecord],
    rule: BreakRule,
    local: usize,
    entries: std::ops::Range<usize>,
    sums: &mut LaneSums,
    totals: &mut [[f32; 4]],
    broken: &mut [u32],
) {
    let first = chunk.first;
    let i = first + local;
    let me = records[i];
    let count = entries.len();
    // Streams and gathers. Unused lanes hold a unit bond of no stiffness: finite and inert.
    let xi = [
        lanes(&chunk.rest_vector[0][entries.clone()], 1.0),
        lanes(&chunk.rest_vector[1][entries.clone()], 0.0),
        lanes(&chunk.rest_vector[2][entries.clone()], 0.0),
    ];
    let stiffness = lanes(&chunk.stiffness[entries.clone()], 0.0);
    let threshold = lanes(&chunk.threshold[entries.clone()], f32::INFINITY);
    let rest_length = lanes(&chunk.rest_length_m[entries.clone()], 1.0);
    let mut eta = [[0.0f32; LANES]; 3];
    let mut partner = [i; LANES];
    for (lane, &j) in chunk.neighbor[entries.clone()].iter().enumerate() {
        let other = records[j as usize];
        partner[lane] = j as usize;
        for axis in 0..3 {
            eta[axis][lane] = other.disp[axis] - me.disp[axis];
        }
    }
    // Stretch and force scale, lane by lane (see `stretch`; one division for both).
    let mut stretch = [0.0f32; LANES];
    let mut scale = [0.0f32; LANES];
    let mut y = [[0.0f32; LANES]; 3];
    for lane in 0..LANES {
        for axis in 0..3 {
            y[axis][lane] = xi[axis][lane] + eta[axis][lane];
        }
        let length = (y[0][lane] * y[0][lane] + y[1][lane] * y[1][lane] + y[2][lane] * y[2][lane]).sqrt();
        let growth = 2.0 * (xi[0][lane] * eta[0][lane] + xi[1][lane] * eta[1][lane] + xi[2][lane] * eta[2][lane])
            + (eta[0][lane] * eta[0][lane] + eta[1][lane] * eta[1][lane] + eta[2][lane] * eta[2][lane]);
        let denominator = rest_length[lane] * (length + rest_length[lane]) * length;
        let inverse = if denominator > 0.0 { 1.0 / denominator } else { 0.0 };
        // s = growth / (L (|y| + L)); the force k s y / |y| = k growth / (L (|y| + L) |y|) y
        stretch[lane] = if stiffness[lane] > 0.0 { growth * length * inverse } else { 0.0 };
        scale[lane] = stiffness[lane] * growth * inverse;
    }
    // Break test: the effective threshold is at least the bond's own plus this particle's boost
    // (max rule) or its own (min rule); only lanes past that bound need the partner's boost.
    let bound = match rule {
        BreakRule::Max => me.boost,
        BreakRule::Min => 0.0,
    };
    let mut suspects = false;
    for lane in 0..LANES {
        suspects |= stretch[lane] > threshold[lane] + bound;
    }
    if suspects {
        for lane in 0..count {
            let j = partner[lane];
            if stretch[lane] > effective_threshold(rule, threshold[lane], me.boost, records[j].boost) {
                let k = entries.start + lane;
                chunk.threshold[k] = f32::INFINITY;
                chunk.stiffness[k] = 0.0;
                broken[local] += 1;
                if INTERNAL {
                    broken[j - first] += 1;
                }
                if i < j {
                    chunk.breaks.push(chunk.bond_id[k]);
                }
                stretch[lane] = 0.0;
                scale[lane] = 0.0;
            }
        }
    }
    for lane in 0..LANES {
        for axis in 0..3 {
            sums.force[axis][lane] += y[axis][lane] * scale[lane];
        }
        sums.min_stretch[lane] = sums.min_stretch[lane].min(stretch[lane]);
    }
    if INTERNAL {
        for lane in 0..count {
            let total = &mut totals[partner[lane] - first];
            for axis in 0..3 {
                total[axis] -= y[axis][lane] * scale[lane];
            }
            total[3] = total[3].min(stretch[lane]);
        }
    }
}

/// Checks whether particles i and j are joined by an intact bond.
pub trait BondLookup: Sync {
    /// True when i and j share a bond that has not broken.
    fn intact(&self, i: usize, j: usize) -> bool;
}

/// Collisions (the paper's `collisions`): each particle of the chunk is pushed away from every
/// particle it is not bonded to that is closer than the contact distance, or than their rest
/// distance where that is shorter (see [`contact_reach`]).
#[allow(clippy::too_many_arguments)]
pub fn collisions(
    first: usize,
    position: [&[f32]; 3],
    rest: [&[f32]; 3],
    contacts: &ContactList,
    bonds: &impl BondLookup,
    stiffness: f32,
    distance: f32,
    force: &mut [&mut [f32]; 3],
) {
    let len = force[0].len();
    for local in 0..len {
        let i = first + local;
        let candidates = contacts.candidates(i);
        if candidates.is_empty() {
            continue;
        }
        let p = [position[0][i], position[1][i], position[2][i]];
        let x = [rest[0][i], rest[1][i], rest[2][i]];
        let mut sum = [0.0f32; 3];
        for &j in candidates {
            let j = j as usize;
            let d = [p[0] - position[0][j], p[1] - position[1][j], p[2] - position[2][j]];
            let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            let xi = [x[0] - rest[0][j], x[1] - rest[1][j], x[2] - rest[2][j]];
            let reach = contact_reach(distance, xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]);
            if r2 >= reach * reach || r2 == 0.0 || bonds.intact(i, j) {
                continue;
            }
            let f = repulsion(stiffness, reach, d, r2.sqrt());
            sum = [sum[0] + f[0], sum[1] + f[1], sum[2] + f[2]];
        }
        for axis in 0..3 {
            force[axis][local] += sum[axis];
        }
    }
}

/// A kinematic sphere's state during one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereNow {
    /// Centre, metres.
    pub center: [f32; 3],
    /// Unit direction of travel (zero when at rest).
    pub heading: [f32; 3],
    /// Radius, metres.
    pub radius: f32,
    /// Force constant.
    pub stiffness: f32,
}

/// The paper's eq. 7 projectile force on a particle at `p`.
pub fn projectile_force(sphere: &SphereNow, p: [f32; 3]) -> [f32; 3] {
    let d = [p[0] - sphere.center[0], p[1] - sphere.center[1], p[2] - sphere.center[2]];
    let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let radius = sphere.radius;
    if !(r >= 0.75 * radius && r <= 1.5 * radius) {
        return [0.0; 3];
    }
    let shape = 16.0 * (r - 0.75 * radius) * (r - 1.5 * radius) * (r - 1.5 * radius);
    let magnitude = sphere.stiffness * shape.cbrt() * shape.cbrt();
    let away = d.map(|c| c / r);
    let mut direction = [away[0] + sphere.heading[0], away[1] + sphere.heading[1], away[2] + sphere.heading[2]];
    let norm = (direction[0] * direction[0] + direction[1] * direction[1] + direction[2] * direction[2]).sqrt();
    if norm > 1e-6 {
        direction = direction.map(|c| c / norm);
    } else {
        direction = away;
    }
    direction.map(|c| c * magnitude)
}

/// A spherical indenter's force K (R - r)^2 on a particle at `p`, pushing it out.
pub fn indenter_force(sphere: &SphereNow, p: [f32; 3]) -> [f32; 3] {
    let d = [p[0] - sphere.center[0], p[1] - sphere.center[1], p[2] - sphere.center[2]];
    let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if r >= sphere.radius || r == 0.0 {
        return [0.0; 3];
    }
    let gap = sphere.radius - r;
    let scale = sphere.stiffness * gap * gap / r;
    d.map(|c| c * scale)
}

/// External forces acting this step.
#[derive(Debug, Clone, Copy)]
pub struct BodyForces<'a> {
    /// Gravity, m/s^2.
    pub gravity: [f32; 3],
    /// Projectiles now.
    pub projectiles: &'a [SphereNow],
    /// Indenters now.
    pub indenters: &'a [SphereNow],
}

/// Body forces (the paper's `bodyforces`): gravity, projectiles and indenters, added to the
/// chunk's forces. Returns the power they deliver, sum of F . v, watts (f64, in particle order).
pub fn body_forces(
    first: usize,
    position: [&[f32]; 3],
    velocity: [&[f32]; 3],
    mass: &[f32],
    forces: &BodyForces,
    force: &mut [&mut [f32]; 3],
) -> f64 {
    let mut power = 0.0f64;
    for local in 0..force[0].len() {
        let i = first + local;
        let p = [position[0][i], position[1][i], position[2][i]];
        let mut f = forces.gravity.map(|g| g * mass[i]);
        for sphere in forces.projectiles {
            let push = projectile_force(sphere, p);
            f = [f[0] + push[0], f[1] + push[1], f[2] + push[2]];
        }
        for sphere in forces.indenters {
            let push = indenter_force(sphere, p);
            f = [f[0] + push[0], f[1] + push[1], f[2] + push[2]];
        }
        for axis in 0..3 {
            force[axis][local] += f[axis];
            power += f64::from(f[axis]) * f64::from(velocity[axis][i]);
        }
    }
    power
}

/// Position update (first half of velocity Verlet): v += dt/2 F/m, then u += dt v.
pub fn kick_drift(dt: f32, inverse_mass: &[f32], force: [&[f32]; 3], velocity: [&mut [f32]; 3], disp: [&mut [f32]; 3]) {
    let half = 0.5 * dt;
    for (axis, (v, u)) in velocity.into_iter().zip(disp).enumerate() {
        for i in 0..v.len() {
            v[i] += half * force[axis][i] * inverse_mass[i];
            u[i] += dt * v[i];
        }
    }
}

/// Velocity update (second half of velocity Verlet): v += dt/2 F/m; a particle below the floor
/// that moves down has its vertical velocity reflected and scaled by the restitution.
pub fn kick_floor(
    dt: f32,
    inverse_mass: &[f32],
    force: [&[f32]; 3],
    height: (&[f32], &[f32]),
    floor: Option<Floor>,
    velocity: [&mut [f32]; 3],
) {
    let half = 0.5 * dt;
    for (axis, v) in velocity.into_iter().enumerate() {
        for i in 0..v.len() {
            v[i] += half * force[axis][i] * inverse_mass[i];
            if axis == 1 {
                if let Some(floor) = floor {
                    if height.0[i] + height.1[i] < floor.height_m && v[i] < 0.0 {
                        v[i] *= -floor.restitution;
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stretch_from_displacement_is_exact_where_subtraction_is_not() {
        // Far from the origin a stretch of 1e-6 is below f32 resolution of positions; from the
        // displacement difference it is still exact to f32 rounding of the stretch itself.
        let xi = [1e-3, 0.0, 0.0];
        let eta = [1e-9, 0.0, 0.0];
        let (s, _, _) = stretch(xi, eta, 1e-3);
        assert!((s - 1e-6).abs() < 1e-12, "{s}");
        let (s, _, _) = stretch(xi, [0.0; 3], 1e-3);
        assert_eq!(s, 0.0);
    }

    #[test]
    fn projectile_force_peaks_at_the_radius_with_k_r_squared() {
        let sphere = SphereNow { center: [0.0; 3], heading: [0.0; 3], radius: 0.01, stiffness: 1e6 };
        let f = projectile_force(&sphere, [0.01, 0.0, 0.0]);
        assert!((f[0] - 1e6 * 1e-4).abs() < 1e-3 * 1e2, "{f:?}");
        assert_eq!(projectile_force(&sphere, [0.007, 0.0, 0.0]), [0.0; 3]);
        assert_eq!(projectile_force(&sphere, [0.016, 0.0, 0.0]), [0.0; 3]);
        // halfway between travel and repulsion
        let moving = SphereNow { heading: [0.0, 1.0, 0.0], ..sphere };
        let f = projectile_force(&moving, [0.01, 0.0, 0.0]);
        assert!((f[0] - f[1]).abs() < 1e-3 && f[0] > 0.0, "{f:?}");
    }
}
