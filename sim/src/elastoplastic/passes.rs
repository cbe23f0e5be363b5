//! The passes of one force evaluation of the state-based model, each over one chunk of
//! particles (and the chunk's run of entries), writing only the chunk's outputs. With
//! omega = delta / |G xi| (G = I without anisotropy), m_i the weighted volume, e = |y| - |xi| a
//! bond's extension and e_p its plastic part:
//!
//! 1. [`dilatation`]: theta_i = 3 / m_i sum_j omega |xi| e V_j, and the damage phi_i.
//! 2. [`bond_forces`], for each intact bond i-j of the chunk's particles, both ends' force
//!    scalars: e_d = e - theta |xi| / 3; the deviatoric scalar t_dev = 15 mu / m omega (e_d - e_p),
//!    returned onto the yield surface |t_dev| = t_y pi delta^5 / m (the paper's yield force where
//!    the family is whole, scaled as the force is where it is cut) by moving e_p, which is then
//!    capped at gamma; t = 3 K theta omega |xi| / m + t_dev. Then the break test
//!    (e - e_p) / (omega |xi|) > (1 + alpha phi) s_c, which is (e - e_p) / delta without fibres,
//!    with e_p, phi and omega the means over both ends, and the force
//!    f_i = sum_j (t_ij + t_ji) V_i V_j (y_j - y_i) / |y_j - y_i| over the intact bonds.
//!
//! Each end computes both scalars of its bonds from the same inputs (the plastic extensions of
//! the previous evaluation, both dilatations, the bond's extension, whose bits are the same from
//! either end), so both ends agree bit for bit without a pass between them; each writes only its
//! own entry's new plastic extension (into a second buffer: the other end still reads the old).
//!
//! This is the linear peridynamic solid of Silling et al. (2007) with Mitchell's per-bond
//! plasticity as Chen et al. write it: the force derives from the energy [`energy_j`], so an
//! elastic run conserves energy. Every sum runs over a particle's entries in order, in f32.

// Indexed loops, as in a WGSL kernel of the same pass.
#![allow(clippy::needless_range_loop)]

use super::StateBasedConstants;
use crate::kernels::stretch;

/// What every pass reads of the bonds and particles (none of it changes while a run lasts).
#[derive(Debug, Clone, Copy)]
pub struct FamilyView<'a> {
    /// Entries per particle.
    pub stride: usize,
    /// Partner of each entry.
    pub neighbor: &'a [u32],
    /// Entry of the same bond in the partner's family.
    pub reverse: &'a [u32],
    /// Rest vectors, metres.
    pub rest_vector: [&'a [f32]; 3],
    /// Rest lengths, metres.
    pub rest_length_m: &'a [f32],
    /// The partner's influence omega_ji of each entry.
    pub reverse_influence: &'a [f32],
    /// Each particle's [V, 15 mu / m, 3 K / m, yield force]: volume m^3, the deviatoric and
    /// dilatational constants, and the deviatoric force scalar at which its bonds yield.
    pub particle: &'a [[f32; 4]],
    /// Weighted volumes, m^5.
    pub weighted_volume: &'a [f32],
}

/// The extension e = |y| - |xi| of entry `e` between displacements `u_i` and `u_j`, with
/// y = xi + u_j - u_i and |y|.
#[inline(always)]
fn extension(view: &FamilyView, e: usize, u_i: [f32; 3], u_j: [f32; 3]) -> (f32, [f32; 3], f32) {
    let xi = [view.rest_vector[0][e], view.rest_vector[1][e], view.rest_vector[2][e]];
    let eta = [u_j[0] - u_i[0], u_j[1] - u_i[1], u_j[2] - u_i[2]];
    let rest = view.rest_length_m[e];
    let (s, y, length) = stretch(xi, eta, rest);
    (s * rest, y, length)
}

/// Pass 1 over particles `first..first + theta.len()`: dilatation theta_i and damage phi_i, and
/// each intact entry's extension (into `extension_out`, the chunk's run of entries; the force
/// pass reuses it). `record` holds each particle's displacement in its first three lanes.
#[allow(clippy::too_many_arguments)]
pub fn dilatation(
    view: &FamilyView,
    influence: &[f32],
    record: &[[f32; 4]],
    counts: (&[u32], &[u32]),
    first: usize,
    theta: &mut [f32],
    damage: &mut [f32],
    extension_out: &mut [f32],
) {
    let (intact, initial) = counts;
    let stride = view.stride;
    for local in 0..theta.len() {
        let i = first + local;
        let u_i = [record[i][0], record[i][1], record[i][2]];
        let mut sum = 0.0f32;
        for e in i * stride..(i + 1) * stride {
            let omega = influence[e];
            if omega == 0.0 {
                continue;
            }
            let j = view.neighbor[e] as usize;
            let (extension, _, _) = extension(view, e, u_i, [record[j][0], record[j][1], record[j][2]]);
            extension_out[e - first * stride] = extension;
            sum += omega * view.rest_length_m[e] * extension * view.particle[j][0];
        }
        theta[local] = 3.0 * sum / view.weighted_volume[i];
        damage[local] = if initial[i] == 0 { 0.0 } else { 1.0 - intact[i] as f32 / initial[i] as f32 };
    }
}

/// One end's force scalar of a bond and its new plastic extension: `constants` the end's
/// particle constants, `theta` its dilatation, `omega` its influence, `plastic` its old plastic
/// extension, `cap` gamma.
#[inline(always)]
fn force_scalar(
    constants: [f32; 4],
    theta: f32,
    omega: f32,
    rest: f32,
    extension: f32,
    plastic: f32,
    cap: f32,
) -> (f32, f32) {
    let [_, deviatoric, dilatational, yield_force] = constants;
    let deviatoric_extension = extension - theta * rest / 3.0;
    let stiffness = deviatoric * omega;
    let mut plastic_extension = plastic;
    let mut t_dev = stiffness * (deviatoric_extension - plastic_extension);
    if t_dev.abs() > yield_force {
        plastic_extension = deviatoric_extension - yield_force.copysign(t_dev) / stiffness;
    }
    plastic_extension = plastic_extension.clamp(-cap, cap);
    if plastic_extension != plastic {
        t_dev = stiffness * (deviatoric_extension - plastic_extension);
    }
    (dilatational * theta * omega * rest + t_dev, plastic_extension)
}

/// What [`bond_forces`] reads of the state besides the geometry.
#[derive(Debug, Clone, Copy)]
pub struct ForceInputs<'a> {
    /// Each particle's displacement (lanes 0 to 2) and dilatation (lane 3).
    pub record: &'a [[f32; 4]],
    /// Each particle's damage phi.
    pub damage: &'a [f32],
    /// Each intact entry's extension, metres, from [`dilatation`].
    pub extension: &'a [f32],
    /// Plastic extensions of the previous evaluation, every entry.
    pub plastic: &'a [f32],
    /// Thresholds, every entry.
    pub threshold: &'a [f32],
    /// Break scales 1 / (omega_mean |xi|), every entry.
    pub break_scale: &'a [f32],
    /// The particle file's row offsets (bond ids).
    pub file_offset: &'a [u64],
}

/// What [`bond_forces`] writes for one chunk.
pub struct ChunkOutputs<'a> {
    /// The chunk's run of influences: a bond that breaks loses its own.
    pub influence: &'a mut [f32],
    /// The chunk's run of new plastic extensions.
    pub plastic: &'a mut [f32],
    /// The chunk's intact bond counts.
    pub intact: &'a mut [u32],
    /// The chunk's forces, newtons.
    pub force: [&'a mut [f32]; 3],
    /// Bonds broken, by the lower particle's entry.
    pub breaks: &'a mut Vec<u64>,
}

/// Pass 2 over particles `first..first + out.intact.len()`: both ends' force scalars, the plastic
/// return map, the break test and the bond forces. A bond that breaks exerts no force this step.
pub fn bond_forces(
    view: &FamilyView,
    constants: &StateBasedConstants,
    inputs: &ForceInputs,
    first: usize,
    out: &mut ChunkOutputs,
) {
    let stride = view.stride;
    let strengthening = constants.damage_strengthening as f32;
    let cap_ratio = constants.plastic_cap_ratio as f32;
    let record = inputs.record;
    for local in 0..out.intact.len() {
        let i = first + local;
        let (u_i, theta_i) = ([record[i][0], record[i][1], record[i][2]], record[i][3]);
        let constants_i = view.particle[i];
        let mut sum = [0.0f32; 3];
        for slot in local * stride..(local + 1) * stride {
            let omega = out.influence[slot];
            if omega == 0.0 {
                continue;
            }
            let e = i * stride + slot - local * stride;
            let back = view.reverse[e] as usize;
            let j = view.neighbor[e] as usize;
            let (u_j, theta_j) = ([record[j][0], record[j][1], record[j][2]], record[j][3]);
            let rest = view.rest_length_m[e];
            // the deformed bond y = xi + u_j - u_i, whose length is |xi| + e
            let extension = inputs.extension[e];
            let y = [0, 1, 2].map(|a| view.rest_vector[a][e] + (u_j[a] - u_i[a]));
            let length = rest + extension;
            let cap = cap_ratio * rest;
            let (t_ij, plastic_ij) = force_scalar(constants_i, theta_i, omega, rest, extension, inputs.plastic[e], cap);
            let omega_ji = view.reverse_influence[e];
            let (t_ji, plastic_ji) =
                force_scalar(view.particle[j], theta_j, omega_ji, rest, extension, inputs.plastic[back], cap);
            out.plastic[slot] = plastic_ij;
            let plastic_mean = 0.5 * (plastic_ij + plastic_ji);
            let damage_mean = 0.5 * (inputs.damage[i] + inputs.damage[j]);
            let threshold = inputs.threshold[e] * (1.0 + strengthening * damage_mean);
            if (extension - plastic_mean) * inputs.break_scale[e] > threshold {
                out.influence[slot] = 0.0;
                out.intact[local] -= 1;
                if i < j {
                    out.breaks.push(inputs.file_offset[i] + (e - i * stride) as u64);
                }
                continue;
            }
            // the same bits at both ends, opposite signs: the pair's momentum is exact
            let magnitude = (t_ij + t_ji) * (constants_i[0] * view.particle[j][0]) / length;
            for axis in 0..3 {
                sum[axis] += magnitude * y[axis];
            }
        }
        for axis in 0..3 {
            out.force[axis][local] = sum[axis];
        }
    }
}

/// The elastic energy stored at particle i, joules: V_i (K theta_i^2 / 2 + 15 mu / (2 m_i)
/// sum_j omega (e_d - e_p)^2 V_j), with theta_i recomputed from the displacements `disp`.
pub fn energy_j(
    view: &FamilyView,
    constants: &StateBasedConstants,
    influence: &[f32],
    plastic: &[f32],
    disp: [&[f32]; 3],
    i: usize,
) -> f64 {
    let stride = view.stride;
    let m = f64::from(view.weighted_volume[i]);
    let u = |k: usize| [disp[0][k], disp[1][k], disp[2][k]];
    let intact = || (i * stride..(i + 1) * stride).filter(|&e| influence[e] > 0.0);
    let terms = |e: usize| {
        let j = view.neighbor[e] as usize;
        let (extension, _, _) = extension(view, e, u(i), u(j));
        (
            f64::from(influence[e]),
            f64::from(view.rest_length_m[e]),
            f64::from(extension),
            f64::from(view.particle[j][0]),
        )
    };
    let dilatation_sum: f64 = intact().map(terms).map(|(omega, rest, extension, v)| omega * rest * extension * v).sum();
    let theta = 3.0 * dilatation_sum / m;
    let deviatoric_sum: f64 = intact()
        .map(|e| {
            let (omega, rest, extension, v) = terms(e);
            let elastic = extension - theta * rest / 3.0 - f64::from(plastic[e]);
            omega * elastic * elastic * v
        })
        .sum();
    let (bulk, shear) = (constants.bulk_modulus_pa, constants.shear_modulus_pa);
    f64::from(view.particle[i][0]) * (0.5 * bulk * theta * theta + 7.5 * shear / m * deviatoric_sum)
}

/// The stiffness of particle i's bonds for the stable time step, N/m: the deviatoric springs
/// V_i V_j 15 mu omega (1 / m_i + 1 / m_j) summed, plus the dilatational coupling
/// V_i 9 K (sum_j omega |xi| V_j)^2 / m_i^2, doubled for the neighbours' dilatations.
pub fn stiffness_n_m(view: &FamilyView, constants: &StateBasedConstants, influence: &[f32], i: usize) -> f64 {
    let stride = view.stride;
    let (bulk, shear) = (constants.bulk_modulus_pa, constants.shear_modulus_pa);
    let m_i = f64::from(view.weighted_volume[i]);
    let v_i = f64::from(view.particle[i][0]);
    let (mut springs, mut reach) = (0.0f64, 0.0f64);
    for e in i * stride..(i + 1) * stride {
        let omega = f64::from(influence[e]);
        if omega > 0.0 {
            let j = view.neighbor[e] as usize;
            let v_j = f64::from(view.particle[j][0]);
            springs += v_i * v_j * 15.0 * shear * omega * (1.0 / m_i + 1.0 / f64::from(view.weighted_volume[j]));
            reach += omega * f64::from(view.rest_length_m[e]) * v_j;
        }
    }
    springs + 2.0 * v_i * 9.0 * bulk * reach * reach / (m_i * m_i)
}
