//! The contact kernels (the paper's `collisions`): each particle of a chunk pushed away from its
//! contact candidates, by eq. 6 ([`collisions`]) or by LAMMPS's short-range force
//! ([`short_range`]), the candidates summed in their fixed order.

use crate::contact::{BondLookup, Candidate, ContactList, contact_reach, repulsion};

/// A chunk of particles and what the contact kernels read of every particle.
#[derive(Debug, Clone, Copy)]
pub struct ContactChunk<'a> {
    /// The chunk's first particle.
    pub first: usize,
    /// Current positions x, metres, every particle.
    pub position: [&'a [f32]; 3],
    /// Rest positions X, metres, every particle.
    pub rest: [&'a [f32]; 3],
    /// Every particle's contact candidates.
    pub contacts: &'a ContactList,
}

/// Adds to each particle i of the chunk the sum, over its contact candidates j in their fixed
/// order, of the force `push(i, candidate, d, r2, rest2)` returns, given the offset
/// d = x_i - x_j, its squared length r2 and the squared rest distance rest2 (None: no force).
#[inline(always)]
fn sum_over_candidates(
    chunk: &ContactChunk,
    force: &mut [&mut [f32]; 3],
    push: impl Fn(usize, &Candidate, [f32; 3], f32, f32) -> Option<[f32; 3]>,
) {
    let ContactChunk { first, position, rest, contacts } = *chunk;
    // All six arrays one length, so that one bounds check covers a candidate's six loads.
    let n = position[0].len();
    let (position, rest) = (position.map(|axis| &axis[..n]), rest.map(|axis| &axis[..n]));
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
        for candidate in candidates {
            let j = candidate.particle as usize;
            let d = [p[0] - position[0][j], p[1] - position[1][j], p[2] - position[2][j]];
            let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            let xi = [x[0] - rest[0][j], x[1] - rest[1][j], x[2] - rest[2][j]];
            if let Some(f) = push(i, candidate, d, r2, xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]) {
                sum = [sum[0] + f[0], sum[1] + f[1], sum[2] + f[2]];
            }
        }
        for axis in 0..3 {
            force[axis][local] += sum[axis];
        }
    }
}

/// Collisions (the paper's `collisions`): each particle of the chunk is pushed away with
/// stiffness K_c = `stiffness_pa` from every particle it is not bonded to that is closer than the
/// contact distance `distance_m`, or than their rest distance where that is shorter (see
/// [`contact_reach`]).
pub fn collisions(
    chunk: &ContactChunk,
    bonds: &impl BondLookup,
    stiffness_pa: f32,
    distance_m: f32,
    force: &mut [&mut [f32]; 3],
) {
    sum_over_candidates(chunk, force, |_, candidate, d, r2, rest2| {
        let reach = contact_reach(distance_m, rest2);
        if r2 >= reach * reach || r2 == 0.0 || bonds.intact(candidate.bond) {
            return None;
        }
        Some(repulsion(stiffness_pa, reach, d, r2.sqrt()))
    });
}

/// LAMMPS's short-range force (`pair_style peri/pmb`) on each particle of the chunk: every
/// candidate j closer than d_ij = min(0.9 |X_i - X_j|, 1.35 lambda) at rest, bonded or not,
/// pushes i away with `stiffness` V_i V_j (d_ij - r), where `stiffness` is 15 c / delta (LAMMPS's
/// force density times V_i) and V the particles' `volume_m3`.
pub fn short_range(
    chunk: &ContactChunk,
    volume_m3: &[f32],
    stiffness: f32,
    lambda_m: f32,
    force: &mut [&mut [f32]; 3],
) {
    sum_over_candidates(chunk, force, |i, candidate, d, r2, rest2| {
        let j = candidate.particle as usize;
        let reach = (0.9 * rest2.sqrt()).min(1.35 * lambda_m);
        if r2 >= reach * reach || r2 == 0.0 {
            return None;
        }
        let r = r2.sqrt();
        let scale = stiffness * volume_m3[i] * volume_m3[j] * (reach - r) / r;
        Some(d.map(|c| c * scale))
    });
}
