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
//! Both passes take [`LANES`] particles at a time, one per lane: entry k of the eight is one
//! vector load ([`FamilyView::entry`]), the partners' values are gathered lane by lane, and the
//! arithmetic is lane-wise loops the compiler turns into vector instructions. A lane adds its
//! own entries in order and skips the ones without influence, exactly as one particle alone
//! would, so the lanes change no bit of any result.
//!
//! This is the linear peridynamic solid of Silling et al. (2007) with Mitchell's per-bond
//! plasticity as Chen et al. write it: the force derives from the energy [`energy_j`], so an
//! elastic run conserves energy. Every sum runs over a particle's entries in order, in f32.

// Indexed loops, as in a WGSL kernel of the same pass.
#![allow(clippy::needless_range_loop)]

use super::StateBasedConstants;
pub use crate::kernels::lanes::LANES;
use crate::kernels::lanes::{Lanes, load};
use crate::kernels::stretch;

/// The lanes of a particle's 32-byte record, all that a pass gathers of a partner (one cache
/// line): displacement x, y, z, volume V, dilatation theta, damage phi, and the constants
/// 15 mu / m and 3 K / m.
pub struct Record;

impl Record {
    /// Volume V, m^3.
    pub const VOLUME: usize = 3;
    /// Dilatation theta (written after the first pass).
    pub const THETA: usize = 4;
    /// Damage phi (written after the first pass).
    pub const DAMAGE: usize = 5;
    /// 15 mu / m.
    pub const DEVIATORIC: usize = 6;
    /// 3 K / m.
    pub const DILATATIONAL: usize = 7;
}

/// What every pass reads of the bonds and particles (none of it changes while a run lasts).
/// Per-entry arrays are indexed by [`FamilyView::entry`].
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

impl FamilyView<'_> {
    /// Entry k of particle i's family in a table of `stride` entries per particle: lane i % 8 of
    /// the group of particles i / 8, row k.
    pub fn entry_of(stride: usize, i: usize, k: usize) -> usize {
        (i / LANES * stride + k) * LANES + i % LANES
    }

    /// The particle and row of entry `e` in a table of `stride` entries per particle (the
    /// inverse of [`FamilyView::entry_of`]).
    pub fn place_of(stride: usize, e: usize) -> (usize, usize) {
        let (group, within) = (e / (LANES * stride), e % (LANES * stride));
        (group * LANES + within % LANES, within / LANES)
    }

    /// Entry k of particle i's family.
    pub fn entry(&self, i: usize, k: usize) -> usize {
        Self::entry_of(self.stride, i, k)
    }

    /// Particle i's entries in order.
    fn family(&self, i: usize) -> impl Iterator<Item = usize> + use<'_> {
        (0..self.stride).map(move |k| self.entry(i, k))
    }
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

/// What [`dilatation`] reads besides the geometry.
#[derive(Debug, Clone, Copy)]
pub struct DilatationInputs<'a> {
    /// Influences omega, every entry (a broken bond's: zero).
    pub influence: &'a [f32],
    /// Each particle's [`Record`]: its displacement and volume are read.
    pub record: &'a [[f32; 8]],
    /// Intact bonds, every particle.
    pub intact: &'a [u32],
    /// Bonds at the start (the particle file's), every particle.
    pub initial: &'a [u32],
}

/// What [`dilatation`] writes for one chunk.
pub struct DilatationOutputs<'a> {
    /// The chunk's dilatations theta.
    pub theta: &'a mut [f32],
    /// The chunk's damage phi.
    pub damage: &'a mut [f32],
    /// The chunk's run of entries' extensions, metres.
    pub extension: &'a mut [f32],
}

/// Pass 1 over particles `first..first + out.theta.len()` (`first` a multiple of [`LANES`]):
/// dilatation theta_i and damage phi_i, and each entry's extension (into `out.extension`, the
/// chunk's run of entries; the force pass reuses the intact ones'). It reads the
/// displacements and volumes of `inputs.record` ([`Record`]).
pub fn dilatation(view: &FamilyView, inputs: &DilatationInputs, first: usize, out: &mut DilatationOutputs) {
    let DilatationInputs { influence, record, intact, initial } = *inputs;
    let stride = view.stride;
    for (group, theta) in out.theta.chunks_mut(LANES).enumerate() {
        let first_i = first + group * LANES;
        let (u_i, _) = gather_motion(record, std::array::from_fn(|l| (first_i + l).min(record.len() - 1) as u32));
        let mut sum: Lanes = [0.0; LANES];
        for k in 0..stride {
            let at = view.entry(first_i, k);
            let omega: Lanes = load(influence, at);
            if omega == [0.0; LANES] {
                continue;
            }
            let (u_j, volume_j) = gather_motion(record, load(view.neighbor, at));
            let xi = [0, 1, 2].map(|axis| load(view.rest_vector[axis], at));
            let rest = load(view.rest_length_m, at);
            // every lane's extension is written (the force pass reads only intact entries')
            let mut extension: Lanes = [0.0; LANES];
            for l in 0..LANES {
                let eta = [u_j[0][l] - u_i[0][l], u_j[1][l] - u_i[1][l], u_j[2][l] - u_i[2][l]];
                let (s, _, _) = stretch([xi[0][l], xi[1][l], xi[2][l]], eta, rest[l]);
                extension[l] = s * rest[l];
                // every lane adds, an empty one +0.0 (see `bond_forces`)
                sum[l] += if omega[l] != 0.0 { omega[l] * rest[l] * extension[l] * volume_j[l] } else { 0.0 };
            }
            let local = at - first * stride;
            out.extension[local..local + LANES].copy_from_slice(&extension);
        }
        for (l, theta) in theta.iter_mut().enumerate() {
            *theta = 3.0 * sum[l] / view.weighted_volume[first_i + l];
        }
    }
    for (local, damage) in out.damage.iter_mut().enumerate() {
        let i = first + local;
        *damage = if initial[i] == 0 { 0.0 } else { 1.0 - intact[i] as f32 / initial[i] as f32 };
    }
}

/// The displacements and volumes ([`Record`]) of the particles `index`, one per lane.
#[inline(always)]
fn gather_motion(record: &[[f32; 8]], index: [u32; LANES]) -> ([Lanes; 3], Lanes) {
    let (mut u, mut volume) = ([[0.0; LANES]; 3], [0.0; LANES]);
    for l in 0..LANES {
        let r = &record[index[l] as usize];
        (u[0][l], u[1][l], u[2][l], volume[l]) = (r[0], r[1], r[2], r[Record::VOLUME]);
    }
    (u, volume)
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
    // `clamp` without its check that -cap <= cap (a panic path that keeps the lanes scalar)
    if plastic_extension < -cap {
        plastic_extension = -cap;
    }
    if plastic_extension > cap {
        plastic_extension = cap;
    }
    if plastic_extension != plastic {
        t_dev = stiffness * (deviatoric_extension - plastic_extension);
    }
    (dilatational * theta * omega * rest + t_dev, plastic_extension)
}

/// What [`bond_forces`] reads of the state besides the geometry.
#[derive(Debug, Clone, Copy)]
pub struct ForceInputs<'a> {
    /// Each particle's [`Record`], its dilatation and damage filled in.
    pub record: &'a [[f32; 8]],
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

/// Pass 2 over particles `first..first + out.intact.len()` (`first` a multiple of [`LANES`]):
/// both ends' force scalars, the plastic return map, the break test and the bond forces. A bond
/// that breaks exerts no force this step. The chunk's breaks come out in id order.
///
/// `PLASTIC` false is for a model without yield whose plastic extensions are all zero: they
/// stay zero, so the pass neither reads nor writes them (the same bits, half the gathers).
pub fn bond_forces<const PLASTIC: bool>(
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
    let last = record.len() - 1;
    for group in 0..out.intact.len().div_ceil(LANES) {
        let first_i = first + group * LANES;
        let own: [u32; LANES] = std::array::from_fn(|l| (first_i + l).min(last) as u32);
        let mine = Ends::gather::<PLASTIC>(view, inputs, own);
        let mut sum = [[0.0f32; LANES]; 3];
        for k in 0..stride {
            let at = view.entry(first_i, k);
            let slot = at - first * stride;
            let omega: Lanes = load(out.influence, slot);
            if omega == [0.0; LANES] {
                continue;
            }
            let partner = load(view.neighbor, at);
            let theirs = Ends::gather::<PLASTIC>(view, inputs, partner);
            let plastic_ji: Lanes = if PLASTIC {
                let back = load(view.reverse, at);
                std::array::from_fn(|l| inputs.plastic[back[l] as usize])
            } else {
                [0.0; LANES]
            };
            let xi = [0, 1, 2].map(|axis| load(view.rest_vector[axis], at));
            let rest = load(view.rest_length_m, at);
            let extension = load(inputs.extension, at);
            let plastic_ij = if PLASTIC { load(inputs.plastic, at) } else { [0.0; LANES] };
            let omega_ji = load(view.reverse_influence, at);
            let threshold = load(inputs.threshold, at);
            let break_scale = load(inputs.break_scale, at);
            let mut plastic_next = if PLASTIC { load(out.plastic, slot) } else { [0.0; LANES] };
            let mut broken = [false; LANES];
            // Every lane is computed and written: an empty lane (omega = 0) keeps its plastic
            // extension and does not break, and an empty or broken lane adds 0 y, a zero (its y
            // is finite: an empty entry's rest vector is 0, its partner particle 0), which leaves
            // the bits of a sum begun at +0.0 as they are. Lanes written only where they hold a
            // bond became masked stores (docs/DECISIONS.md#no-masked-stores).
            for l in 0..LANES {
                let bonded = omega[l] != 0.0;
                // the deformed bond y = xi + u_j - u_i, whose length is |xi| + e
                let y = [0, 1, 2].map(|a| xi[a][l] + (theirs.u[a][l] - mine.u[a][l]));
                let length = rest[l] + extension[l];
                let cap = cap_ratio * rest[l];
                let (t_ij, new_ij) =
                    force_scalar(mine.constants(l), mine.theta[l], omega[l], rest[l], extension[l], plastic_ij[l], cap);
                let (t_ji, new_ji) = force_scalar(
                    theirs.constants(l),
                    theirs.theta[l],
                    omega_ji[l],
                    rest[l],
                    extension[l],
                    plastic_ji[l],
                    cap,
                );
                plastic_next[l] = if bonded { new_ij } else { plastic_next[l] };
                let plastic_mean = 0.5 * (new_ij + new_ji);
                let damage_mean = 0.5 * (mine.damage[l] + theirs.damage[l]);
                let threshold = threshold[l] * (1.0 + strengthening * damage_mean);
                broken[l] = bonded & ((extension[l] - plastic_mean) * break_scale[l] > threshold);
                // the same bits at both ends, opposite signs: the pair's momentum is exact
                let magnitude = (t_ij + t_ji) * (mine.volume[l] * theirs.volume[l]) / length;
                let scale = if bonded & !broken[l] { magnitude } else { 0.0 };
                for axis in 0..3 {
                    sum[axis][l] += scale * y[axis];
                }
            }
            if PLASTIC {
                out.plastic[slot..slot + LANES].copy_from_slice(&plastic_next);
            }
            if broken != [false; LANES] {
                for l in (0..LANES).filter(|&l| broken[l]) {
                    let i = first_i + l;
                    out.influence[slot + l] = 0.0;
                    out.intact[i - first] -= 1;
                    if i < partner[l] as usize {
                        out.breaks.push(inputs.file_offset[i] + k as u64);
                    }
                }
            }
        }
        for axis in 0..3 {
            let force = &mut out.force[axis][first_i - first..];
            for (l, f) in force.iter_mut().take(LANES).enumerate() {
                *f = sum[axis][l];
            }
        }
    }
    // a lane group logs its breaks entry row by entry row; one particle at a time logs them in
    // id order
    out.breaks.sort_unstable();
}

/// One end of eight bonds, lane by lane: its particles' displacements, dilatations, damage and
/// constants.
struct Ends {
    u: [Lanes; 3],
    theta: Lanes,
    damage: Lanes,
    volume: Lanes,
    deviatoric: Lanes,
    dilatational: Lanes,
    yield_force: Lanes,
}

impl Ends {
    /// The values of particles `index`, one per lane (without yield forces unless `PLASTIC`).
    #[inline(always)]
    fn gather<const PLASTIC: bool>(view: &FamilyView, inputs: &ForceInputs, index: [u32; LANES]) -> Ends {
        let mut ends = Ends {
            u: [[0.0; LANES]; 3],
            theta: [0.0; LANES],
            damage: [0.0; LANES],
            volume: [0.0; LANES],
            deviatoric: [0.0; LANES],
            dilatational: [0.0; LANES],
            yield_force: [0.0; LANES],
        };
        for l in 0..LANES {
            let [ux, uy, uz, volume, theta, damage, deviatoric, dilatational] = inputs.record[index[l] as usize];
            (ends.u[0][l], ends.u[1][l], ends.u[2][l], ends.volume[l]) = (ux, uy, uz, volume);
            (ends.theta[l], ends.damage[l], ends.deviatoric[l], ends.dilatational[l]) =
                (theta, damage, deviatoric, dilatational);
        }
        // (of the records' length: one bounds check covers both arrays' loads)
        let particle = &view.particle[..inputs.record.len()];
        ends.yield_force =
            if PLASTIC { std::array::from_fn(|l| particle[index[l] as usize][3]) } else { [f32::INFINITY; LANES] };
        ends
    }

    /// Lane l's constants, as [`FamilyView::particle`] holds them.
    #[inline(always)]
    fn constants(&self, l: usize) -> [f32; 4] {
        [self.volume[l], self.deviatoric[l], self.dilatational[l], self.yield_force[l]]
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
    let m = f64::from(view.weighted_volume[i]);
    let u = |k: usize| [disp[0][k], disp[1][k], disp[2][k]];
    let intact = || view.family(i).filter(|&e| influence[e] > 0.0);
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
    let (bulk, shear) = (constants.bulk_modulus_pa, constants.shear_modulus_pa);
    let m_i = f64::from(view.weighted_volume[i]);
    let v_i = f64::from(view.particle[i][0]);
    let (mut springs, mut reach) = (0.0f64, 0.0f64);
    for e in view.family(i) {
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
