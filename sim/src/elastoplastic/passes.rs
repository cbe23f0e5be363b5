//! The passes of one force evaluation of the state-based model, each over one chunk of
//! particles (and the chunk's run of entries), writing only the chunk's outputs. With
//! omega = delta / |G xi| (G = I without anisotropy), m_i the weighted volume, e = |y| - |xi| a bond's extension and e_p its
//! plastic part:
//!
//! 1. [`dilatation`]: theta_i = 3 / m_i sum_j omega |xi| e V_j, and the damage phi_i.
//! 2. [`force_scalars`]: e_d = e - theta_i |xi| / 3; the deviatoric scalar
//!    t_dev = 15 mu / m_i omega (e_d - e_p), returned onto the yield surface
//!    |t_dev| = t_y pi delta^5 / m_i (the paper's yield force where the family is whole, scaled as
//!    the force is where it is cut) by moving e_p, which is then capped at gamma;
//!    t_ij = 3 K theta_i omega |xi| / m_i + t_dev.
//! 3. [`bond_forces`]: the break test (e - e_p) / (omega |xi|) > (1 + alpha phi) s_c, which is
//!    (e - e_p) / delta without anisotropy, with e_p, phi and omega the means over both ends, so
//!    that both ends decide alike; the force
//!    f_i = sum_j (t_ij + t_ji) V_i V_j (y_j - y_i) / |y_j - y_i| over the intact bonds.
//!
//! This is the linear peridynamic solid of Silling et al. (2007) with Mitchell's per-bond
//! plasticity as Chen et al. write it: the force derives from the energy [`energy_j`], so an
//! elastic run conserves energy. Every sum runs over a particle's entries in order, in f32.

// Indexed loops, as in a WGSL kernel of the same pass.
#![allow(clippy::needless_range_loop)]

use super::StateBasedConstants;
use crate::kernels::stretch;

/// What every pass reads of the bonds and particles.
#[derive(Debug, Clone, Copy)]
pub struct FamilyView<'a> {
    /// Entries per particle.
    pub stride: usize,
    /// The horizon, metres.
    pub delta_m: f32,
    /// Partner of each entry.
    pub neighbor: &'a [u32],
    /// Entry of the same bond in the partner's family.
    pub reverse: &'a [u32],
    /// Rest vectors, metres.
    pub rest_vector: [&'a [f32]; 3],
    /// Rest lengths, metres.
    pub rest_length_m: &'a [f32],
    /// Particle volumes, m^3.
    pub volume: &'a [f32],
    /// Weighted volumes, m^5.
    pub weighted_volume: &'a [f32],
    /// Displacements, metres.
    pub disp: [&'a [f32]; 3],
}

impl FamilyView<'_> {
    /// The extension e = |y| - |xi| of entry `e` of particle `i`, and y = xi + eta.
    #[inline(always)]
    fn extension(&self, i: usize, e: usize) -> (f32, [f32; 3], f32) {
        let j = self.neighbor[e] as usize;
        let xi = [0, 1, 2].map(|a| self.rest_vector[a][e]);
        let eta = [0, 1, 2].map(|a| self.disp[a][j] - self.disp[a][i]);
        let rest = self.rest_length_m[e];
        let (s, y, length) = stretch(xi, eta, rest);
        (s * rest, y, length)
    }
}

/// Pass 1 over particles `first..first + theta.len()`: dilatation theta_i and damage phi_i.
pub fn dilatation(
    view: &FamilyView,
    influence: &[f32],
    intact: &[u32],
    initial: &[u32],
    first: usize,
    theta: &mut [f32],
    damage: &mut [f32],
) {
    let stride = view.stride;
    for local in 0..theta.len() {
        let i = first + local;
        let mut sum = 0.0f32;
        for e in i * stride..(i + 1) * stride {
            let omega = influence[e];
            if omega == 0.0 {
                continue;
            }
            let (extension, _, _) = view.extension(i, e);
            sum += omega * view.rest_length_m[e] * extension * view.volume[view.neighbor[e] as usize];
        }
        theta[local] = 3.0 * sum / view.weighted_volume[i];
        damage[local] = if initial[i] == 0 { 0.0 } else { 1.0 - intact[i] as f32 / initial[i] as f32 };
    }
}

/// Pass 2 over particles `first..`: each entry's force scalar t_ij (into `scalar`, the chunk's
/// run of entries) and its plastic extension (`plastic`, the same run), returned to the yield
/// surface and capped.
#[allow(clippy::too_many_arguments)]
pub fn force_scalars(
    view: &FamilyView,
    constants: &StateBasedConstants,
    influence: &[f32],
    theta: &[f32],
    first: usize,
    scalar: &mut [f32],
    plastic: &mut [f32],
) {
    let stride = view.stride;
    let bulk = constants.bulk_modulus_pa as f32;
    let shear = constants.shear_modulus_pa as f32;
    let cap_ratio = constants.plastic_cap_ratio as f32;
    let sphere = std::f32::consts::PI * view.delta_m.powi(5);
    for local in 0..scalar.len() / stride {
        let i = first + local;
        let m = view.weighted_volume[i];
        let theta_i = theta[i];
        let deviatoric = 15.0 * shear / m;
        // the yield force scales as the force does, so a cut family yields at the same stress
        let yield_force = (constants.yield_force_n_m6 as f32) * (sphere / m);
        let dilatational = 3.0 * bulk * theta_i / m;
        for slot in local * stride..(local + 1) * stride {
            let e = i * stride + slot - local * stride;
            let omega = influence[e];
            if omega == 0.0 {
                scalar[slot] = 0.0;
                continue;
            }
            let rest = view.rest_length_m[e];
            let (extension, _, _) = view.extension(i, e);
            let deviatoric_extension = extension - theta_i * rest / 3.0;
            let mut plastic_extension = plastic[slot];
            let mut t_dev = deviatoric * omega * (deviatoric_extension - plastic_extension);
            if t_dev.abs() > yield_force {
                plastic_extension = deviatoric_extension - yield_force.copysign(t_dev) / (deviatoric * omega);
            }
            let cap = cap_ratio * rest;
            plastic_extension = plastic_extension.clamp(-cap, cap);
            if plastic_extension != plastic[slot] {
                plastic[slot] = plastic_extension;
                t_dev = deviatoric * omega * (deviatoric_extension - plastic_extension);
            }
            scalar[slot] = dilatational * omega * rest + t_dev;
        }
    }
}

/// Pass 3 over particles `first..first + force[0].len()`: the break test and the bond forces.
/// A bond that breaks loses its influence (`influence`: the chunk's run of entries), exerts no
/// force this step, and is logged in `breaks` by its lower particle; `intact` (the chunk's
/// counts) follows.
#[allow(clippy::too_many_arguments)]
pub fn bond_forces(
    view: &FamilyView,
    constants: &StateBasedConstants,
    scalar: &[f32],
    plastic: &[f32],
    threshold: &[f32],
    break_scale: &[f32],
    damage: &[f32],
    file_offset: &[u64],
    first: usize,
    influence: &mut [f32],
    intact: &mut [u32],
    force: [&mut [f32]; 3],
    breaks: &mut Vec<u64>,
) {
    let stride = view.stride;
    let strengthening = constants.damage_strengthening as f32;
    let [fx, fy, fz] = force;
    for local in 0..fx.len() {
        let i = first + local;
        let v_i = view.volume[i];
        let mut sum = [0.0f32; 3];
        for slot in local * stride..(local + 1) * stride {
            if influence[slot] == 0.0 {
                continue;
            }
            let e = i * stride + slot - local * stride;
            let back = view.reverse[e] as usize;
            let j = view.neighbor[e] as usize;
            let (extension, y, length) = view.extension(i, e);
            let plastic_mean = 0.5 * (plastic[e] + plastic[back]);
            let damage_mean = 0.5 * (damage[i] + damage[j]);
            if (extension - plastic_mean) * break_scale[e] > threshold[e] * (1.0 + strengthening * damage_mean) {
                influence[slot] = 0.0;
                intact[local] -= 1;
                if i < j {
                    breaks.push(file_offset[i] + (e - i * stride) as u64);
                }
                continue;
            }
            // the same bits at both ends, opposite signs: the pair's momentum is exact
            let magnitude = (scalar[e] + scalar[back]) * (v_i * view.volume[j]) / length;
            for axis in 0..3 {
                sum[axis] += magnitude * y[axis];
            }
        }
        (fx[local], fy[local], fz[local]) = (sum[0], sum[1], sum[2]);
    }
}

/// The elastic energy stored at particle i, joules: V_i (K theta_i^2 / 2 + 15 mu / (2 m_i)
/// sum_j omega (e_d - e_p)^2 V_j), with theta_i recomputed from the displacements.
pub fn energy_j(
    view: &FamilyView,
    constants: &StateBasedConstants,
    influence: &[f32],
    plastic: &[f32],
    i: usize,
) -> f64 {
    let stride = view.stride;
    let m = f64::from(view.weighted_volume[i]);
    let mut dilatation_sum = 0.0f64;
    for e in i * stride..(i + 1) * stride {
        let omega = influence[e];
        if omega > 0.0 {
            let (extension, _, _) = view.extension(i, e);
            let v = f64::from(view.volume[view.neighbor[e] as usize]);
            dilatation_sum += f64::from(omega) * f64::from(view.rest_length_m[e]) * f64::from(extension) * v;
        }
    }
    let theta = 3.0 * dilatation_sum / m;
    let mut deviatoric_sum = 0.0f64;
    for e in i * stride..(i + 1) * stride {
        let omega = influence[e];
        if omega > 0.0 {
            let (extension, _, _) = view.extension(i, e);
            let elastic = f64::from(extension) - theta * f64::from(view.rest_length_m[e]) / 3.0 - f64::from(plastic[e]);
            let v = f64::from(view.volume[view.neighbor[e] as usize]);
            deviatoric_sum += f64::from(omega) * elastic * elastic * v;
        }
    }
    let (bulk, shear) = (constants.bulk_modulus_pa, constants.shear_modulus_pa);
    f64::from(view.volume[i]) * (0.5 * bulk * theta * theta + 7.5 * shear / m * deviatoric_sum)
}

/// The stiffness of particle i's bonds for the stable time step, N/m: the deviatoric springs
/// V_i V_j 15 mu omega (1 / m_i + 1 / m_j) summed, plus the dilatational coupling
/// V_i 9 K (sum_j omega |xi| V_j)^2 / m_i^2, doubled for the neighbours' dilatations.
pub fn stiffness_n_m(view: &FamilyView, constants: &StateBasedConstants, influence: &[f32], i: usize) -> f64 {
    let stride = view.stride;
    let (bulk, shear) = (constants.bulk_modulus_pa, constants.shear_modulus_pa);
    let m_i = f64::from(view.weighted_volume[i]);
    let v_i = f64::from(view.volume[i]);
    let (mut springs, mut reach) = (0.0f64, 0.0f64);
    for e in i * stride..(i + 1) * stride {
        let omega = f64::from(influence[e]);
        if omega > 0.0 {
            let j = view.neighbor[e] as usize;
            let v_j = f64::from(view.volume[j]);
            springs += v_i * v_j * 15.0 * shear * omega * (1.0 / m_i + 1.0 / f64::from(view.weighted_volume[j]));
            reach += omega * f64::from(view.rest_length_m[e]) * v_j;
        }
    }
    springs + 2.0 * v_i * 9.0 * bulk * reach * reach / (m_i * m_i)
}
