//! The spring kernel (the paper's `springforces`): the particle loop shared by every instruction
//! set, the portable row kernel, and what both row kernels share (lane sums, the break test).
//! `springs_avx2` holds the same row kernel in explicit AVX2 instructions; both give the same
//! bits.

// Indexed loops, as in the WGSL kernel of the same pass.
#![allow(clippy::needless_range_loop)]

use shatter_core::config::sim::BreakRule;

use super::lanes::{BondLanes, bond_lanes};
use super::prefetch::prefetch_item;
pub(super) use crate::bond_layouts::row_layout::LANES;
use crate::bond_layouts::row_layout::{BondChunk, RestPosition};
use crate::simd_path::SimdPath;

/// How many blocks ahead of the one it computes a row kernel asks for its block (1 KiB ahead; on
/// the `irregular_bond_updates` bench 4, 14 and 16 ran about as fast,
/// docs/DECISIONS.md#block-streams-prefetched).
pub(super) const ROWS_AHEAD: usize = 8;

/// One chunk's outputs of the force pass (per particle of the row layout's chunk, per slot of
/// the lattice layout's).
pub struct ChunkForces<'a> {
    /// Force, newtons (x, y, z).
    pub force: [&'a mut [f32]; 3],
    /// Smallest stretch over each particle's intact bonds (never above 0).
    pub min_stretch: &'a mut [f32],
}

/// The smallest displacement difference (metres, per axis) whose square the growth's eta . eta
/// term keeps: 2^-63, whose square is f32's smallest normal number. Smaller components count as
/// zero there, so that the term never computes a subnormal square, which costs an Intel core a
/// microcode assist per lane (ahead of an impact's first stress wave most lanes underflow). The
/// squares dropped add up to less than 3 x 2^-126, under half a rounding step of any growth above
/// about 2^-100 (docs/DECISIONS.md#tiny-displacement-differences).
pub const SQUARED_FROM_M: f32 = f32::from_bits(0x2000_0000);

/// A particle whose displacement components are all at least 2^-39 m in magnitude (or NaN) has
/// no bond with a displacement difference component in (0, [`SQUARED_FROM_M`]): its own
/// components are multiples of 2^-62 m, so a partner's differs by zero, by a multiple of
/// 2^-63 m, or by more than 2^-40 m. The kernels leave out the test for such particles' bonds.
pub const NO_TINY_FROM_M: f32 = f32::from_bits(0x2c00_0000);

/// Whether bonds of a particle displaced by `disp` may have displacement difference components
/// under [`SQUARED_FROM_M`] (see [`NO_TINY_FROM_M`]).
#[inline(always)]
pub(super) fn may_have_tiny(disp: [f32; 3]) -> bool {
    disp.iter().any(|u| u.abs() < NO_TINY_FROM_M)
}

/// eta with the components under [`SQUARED_FROM_M`] set to zero: the factors of eta . eta.
#[inline(always)]
fn squared_part(eta: [f32; 3]) -> [f32; 3] {
    eta.map(|e| if e.abs() < SQUARED_FROM_M { 0.0 } else { e })
}

/// Bond stretch s = |xi + eta| / |xi| - 1 computed from the displacement difference eta, as
/// (2 xi . eta + eta . eta) / (L (|xi + eta| + L)): no cancellation, so strains of 1e-7 stay
/// exact in f32 wherever the body is; eta . eta leaves out components under
/// [`SQUARED_FROM_M`]. Returns (s, y = xi + eta, |y|).
#[inline(always)]
pub fn stretch(xi: [f32; 3], eta: [f32; 3], rest_length: f32) -> (f32, [f32; 3], f32) {
    let y = [xi[0] + eta[0], xi[1] + eta[1], xi[2] + eta[2]];
    let length = (y[0] * y[0] + y[1] * y[1] + y[2] * y[2]).sqrt();
    let e = squared_part(eta);
    let growth = 2.0 * (xi[0] * eta[0] + xi[1] * eta[1] + xi[2] * eta[2]) + (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
    (growth / (rest_length * (length + rest_length)), y, length)
}

/// The threshold a bond's stretch is compared with: its own plus the larger (or smaller) of its
/// particles' compression boosts.
#[inline(always)]
pub(super) fn effective_threshold(rule: BreakRule, threshold: f32, boost_i: f32, boost_j: f32) -> f32 {
    match rule {
        BreakRule::Max => threshold + boost_i.max(boost_j),
        BreakRule::Min => threshold + boost_i.min(boost_j),
    }
}

/// What the spring kernel gathers of a bond partner, packed into 16 bytes so that one load
/// serves it: displacement and compression boost.
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(16))]
pub struct ParticleRecord {
    /// Displacement u, metres.
    pub disp: [f32; 3],
    /// Compression boost of the particle's thresholds (from the previous step).
    pub boost: f32,
}

/// What the row kernels gather of each bond's partner, per particle.
#[derive(Debug, Clone, Copy)]
pub struct Gathers<'a> {
    /// This step's displacements and boosts.
    pub records: &'a [ParticleRecord],
    /// The rest positions, from which the kernels compute the rest vectors xi = X_j - X_i.
    pub rest_positions: &'a [RestPosition],
}

/// The spring pass's rules besides the break rule: all false are Levine et al.'s, all true
/// LAMMPS's (`shatter_core::config::sim::Rules`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PassRules {
    /// The smallest stretch is taken whatever its sign (else never above 0), so the compression
    /// boost -alpha s_min may weaken a particle whose every bond is stretched.
    pub signed_boost: bool,
    /// A bond that breaks pulls in the step in which it breaks, and its stretch counts towards
    /// the smallest.
    pub breaking_step_force: bool,
}

impl PassRules {
    /// The smallest stretch of a particle with no bond yet seen.
    fn no_stretch(self) -> f32 {
        if self.signed_boost { f32::INFINITY } else { 0.0 }
    }
}

/// One particle's running sums over the lanes.
#[derive(Debug, Clone, Copy)]
pub(super) struct LaneSums {
    /// Force, newtons, per axis and lane.
    pub force: [[f32; LANES]; 3],
    /// Smallest stretch per lane.
    pub min_stretch: [f32; LANES],
}

/// What a row kernel reads and writes besides its bond blocks.
pub(super) struct BlockContext<'a> {
    /// The gather records of all particles.
    pub records: &'a [ParticleRecord],
    /// The rest positions of all particles.
    pub rest_positions: &'a [RestPosition],
    /// The break rule.
    pub rule: BreakRule,
    /// The other rules.
    pub rules: PassRules,
    /// The chunk's per-particle sums (force x, y, z and smallest stretch) that internal bonds'
    /// reactions are scattered into.
    pub totals: &'a mut [[f32; 4]],
}

impl<'a> BlockContext<'a> {
    /// The gather records and the rest positions, these sliced to the records' length: where a
    /// kernel indexes both by the same partner, one bounds check then covers both loads (with the
    /// two lengths unrelated, the compiler checked each: 16 compare-and-branch pairs a block).
    #[inline(always)]
    pub fn gathered(&self) -> (&'a [ParticleRecord], &'a [RestPosition]) {
        (self.records, &self.rest_positions[..self.records.len()])
    }
}

/// Spring forces (the paper's `springforces`): for every intact bond of the chunk, the stretch,
/// the break test against the effective threshold, and the PMB force k s (xi + eta) / |xi + eta|.
/// Internal bonds are computed once and applied to both ends; external bonds to this end only.
/// Bonds that break are recorded in `chunk.breaks` (external ones by their lower particle only).
/// Each particle's bonds are summed lane by lane (entry k of its row in lane k mod 8), the lanes
/// then in order: a fixed order, whatever the thread count and the instruction set (AVX2 where
/// `simd` is AVX2 or wider and the CPU has it, else portable code; the two agree bit for bit).
/// Rules other than Levine's run on the portable kernel.
pub fn spring_forces(
    chunk: &mut BondChunk,
    gathers: Gathers,
    rule: BreakRule,
    rules: PassRules,
    simd: SimdPath,
    out: &mut ChunkForces,
) {
    #[cfg(target_arch = "x86_64")]
    if simd >= SimdPath::Avx2
        && rules == PassRules::default()
        && super::springs_avx2::spring_forces(chunk, gathers, rule, out)
    {
        return;
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _portable_only = simd; // off x86-64 every path is the portable one
    spring_rows(chunk, gathers, rule, rules, out, bond_row);
}

/// The particle loop of [`spring_forces`] around a row kernel, which computes the bonds of one
/// particle's row (`(chunk, context, local particle)`) and returns their lane sums. Inlined into
/// each caller, so that it is compiled for the caller's instruction set.
#[inline(always)]
pub(super) fn spring_rows(
    chunk: &mut BondChunk,
    gathers: Gathers,
    rule: BreakRule,
    rules: PassRules,
    out: &mut ChunkForces,
    mut row: impl FnMut(&mut BondChunk, &mut BlockContext, usize) -> LaneSums,
) {
    chunk.breaks.clear();
    let mut totals = std::mem::take(&mut chunk.totals);
    totals.clear();
    totals.resize(chunk.len, [0.0, 0.0, 0.0, rules.no_stretch()]);
    let Gathers { records, rest_positions } = gathers;
    let mut context = BlockContext { records, rest_positions, rule, rules, totals: &mut totals };
    for local in 0..chunk.len {
        let sums = row(chunk, &mut context, local);
        let total = &mut context.totals[local];
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

/// The portable row kernel: [`bond_block`] over the row's blocks, with the growth's test for tiny
/// displacement differences where the particle's displacement asks for it ([`may_have_tiny`]).
fn bond_row(chunk: &mut BondChunk, context: &mut BlockContext, local: usize) -> LaneSums {
    let mut sums = LaneSums { force: [[0.0; LANES]; 3], min_stretch: [context.rules.no_stretch(); LANES] };
    let tiny = may_have_tiny(context.records[chunk.first + local].disp);
    for (block, internal) in chunk.row(local) {
        prefetch_item(chunk.blocks.as_ptr(), block + ROWS_AHEAD);
        if tiny {
            bond_block::<true>(chunk, context, local, block, internal, &mut sums);
        } else {
            bond_block::<false>(chunk, context, local, block, internal, &mut sums);
        }
    }
    sums
}

/// The break test of a block whose stretches passed the cheap bound: breaks the bonds whose
/// stretch exceeds their effective threshold (zero stiffness, infinite threshold, counted, logged
/// once) and, unless the breaking step's force is applied, takes their lanes out of this step's
/// force and smallest stretch.
pub(super) fn break_lanes(
    chunk: &mut BondChunk,
    context: &mut BlockContext,
    local: usize,
    block: usize,
    stretch: &mut [f32; LANES],
    scale: &mut [f32; LANES],
) {
    let first = chunk.first;
    let i = first + local;
    let boost = context.records[i].boost;
    let bonds = &mut chunk.blocks[block];
    for lane in 0..LANES {
        let j = bonds.neighbor[lane] as usize;
        if stretch[lane] > effective_threshold(context.rule, bonds.threshold[lane], boost, context.records[j].boost) {
            bonds.threshold[lane] = f32::INFINITY;
            bonds.stiffness[lane] = 0.0;
            if i < j {
                chunk.breaks.push(chunk.bond_id[block * LANES + lane]);
            }
            if !context.rules.breaking_step_force {
                stretch[lane] = context.rules.no_stretch();
                scale[lane] = 0.0;
            }
        }
    }
}

/// The smallest threshold a stretch is compared with before the partner's boost is looked up:
/// the bond's own plus this particle's boost (max rule) or its own (min rule).
#[inline(always)]
pub(super) fn break_bound(rule: BreakRule, boost: f32) -> f32 {
    match rule {
        BreakRule::Max => boost,
        BreakRule::Min => 0.0,
    }
}

/// The portable block kernel: one block of particle `local`'s row (internal or external), the rest
/// vectors computed from the gathered rest positions. The arithmetic runs lane by lane over
/// fixed-size arrays, which the compiler turns into SIMD instructions where it can; gathers and the
/// rare breaks stay scalar. Padding lanes are inert (see
/// [`crate::bond_layouts::row_layout::BondBlock`]: their rest vector is zero, so their deformed
/// length, force and stretch are zero).
#[inline(always)]
fn bond_block<const TINY: bool>(
    chunk: &mut BondChunk,
    context: &mut BlockContext,
    local: usize,
    block: usize,
    internal: bool,
    sums: &mut LaneSums,
) {
    let first = chunk.first;
    let i = first + local;
    let (records, rest_positions) = context.gathered();
    let (me, here) = (records[i], rest_positions[i]);
    let bonds = &chunk.blocks[block];
    let (stiffness, threshold, rest_length) = (bonds.stiffness, bonds.threshold, bonds.rest_length_m);
    let partner = bonds.neighbor.map(|j| j as usize);
    let (mut xi, mut eta) = ([[0.0f32; LANES]; 3], [[0.0f32; LANES]; 3]);
    for lane in 0..LANES {
        let (other, rest_vector) = (records[partner[lane]], here.to(rest_positions[partner[lane]]));
        for axis in 0..3 {
            xi[axis][lane] = rest_vector[axis];
            eta[axis][lane] = other.disp[axis] - me.disp[axis];
        }
    }
    let BondLanes { y, mut stretch, mut scale } = bond_lanes::<TINY>(&xi, &eta, rest_length, stiffness);
    let mut suspects = false;
    if context.rules.signed_boost {
        // boosts may be negative: no cheap bound; a bond of no stiffness has no stretch
        suspects = true;
        for lane in 0..LANES {
            if stiffness[lane] == 0.0 {
                stretch[lane] = f32::INFINITY;
            }
        }
    } else {
        let bound = break_bound(context.rule, me.boost);
        for lane in 0..LANES {
            suspects |= stretch[lane] > threshold[lane] + bound;
        }
    }
    if suspects {
        break_lanes(chunk, context, local, block, &mut stretch, &mut scale);
    }
    for lane in 0..LANES {
        for axis in 0..3 {
            sums.force[axis][lane] += y[axis][lane] * scale[lane];
        }
        sums.min_stretch[lane] = sums.min_stretch[lane].min(stretch[lane]);
    }
    if internal {
        // Padding lanes add a zero force to this particle.
        for lane in 0..LANES {
            let total = &mut context.totals[partner[lane] - first];
            for axis in 0..3 {
                total[axis] -= y[axis][lane] * scale[lane];
            }
            total[3] = total[3].min(stretch[lane]);
        }
    }
}

#[cfg(test)]
mod tests {
    use shatter_core::random::SplitMix64;

    use super::*;
    use crate::bond_layouts::row_layout::BondEntry;

    /// Rest positions of particles along x, 1 mm apart.
    fn along_x(n: usize) -> Vec<RestPosition> {
        RestPosition::all(&(0..n).map(|i| [1e-3 * i as f32, 0.0, 0.0]).collect::<Vec<_>>())
    }

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
    fn stretch_drops_squares_of_tiny_displacement_differences_only() {
        // Across the bond, xi . eta is zero: the growth is eta . eta alone.
        let xi = [0.0, 1e-3, 0.0];
        assert_eq!(stretch(xi, [2f32.powi(-64), 0.0, 0.0], 1e-3).0, 0.0, "a subnormal square dropped");
        let (s, _, _) = stretch(xi, [SQUARED_FROM_M, 0.0, 0.0], 1e-3);
        assert_eq!(s, f32::MIN_POSITIVE / (1e-3 * 2e-3), "the smallest normal square kept");
        assert_eq!(SQUARED_FROM_M * SQUARED_FROM_M, f32::MIN_POSITIVE);
    }

    /// The claim of [`NO_TINY_FROM_M`]: beside a particle displaced by at least 2^-39 m along an
    /// axis, no partner's displacement differs from it along that axis by less than 2^-63 m but
    /// more than zero, whatever the partner's; at half that bound a neighbouring float does.
    #[test]
    fn no_tiny_differences_beside_a_particle_displaced_from_no_tiny_from_m() {
        let mut random = SplitMix64::new(3);
        let mut uniform = |low: f64, high: f64| low + (high - low) * random.next_f64();
        for _ in 0..200_000 {
            let sign = if uniform(-1.0, 1.0) < 0.0 { -1.0f32 } else { 1.0 };
            // From the bound up, half of them powers of two (whose lower neighbours are closest).
            let mantissa = if uniform(0.0, 1.0) < 0.5 { 1.0 } else { uniform(1.0, 2.0) as f32 };
            let own = sign * mantissa * NO_TINY_FROM_M * f32::exp2(uniform(0.0, 40.0).floor() as f32);
            assert!(!may_have_tiny([own, own, own]), "{own:e}");
            let partner = match (uniform(0.0, 3.0) as u32, uniform(-4.0, 5.0).floor() as i32) {
                (0, ulps) => f32::from_bits(own.to_bits().wrapping_add_signed(ulps)),
                (1, _) => -own,
                (_, _) => (uniform(-1.0, 1.0) as f32) * f32::exp2(uniform(-150.0, 0.0) as f32),
            };
            let difference = partner - own;
            assert!(difference == 0.0 || difference.abs() >= SQUARED_FROM_M, "{own:e} and {partner:e}");
        }
        assert!(!may_have_tiny([NO_TINY_FROM_M, -NO_TINY_FROM_M, f32::NAN]));
        let half = NO_TINY_FROM_M / 2.0;
        assert!(may_have_tiny([1.0, half, 1.0]) && may_have_tiny([0.0, 1.0, 1.0]));
        let below = f32::from_bits(half.to_bits() - 1);
        assert!(below - half != 0.0 && (below - half).abs() < SQUARED_FROM_M);
    }

    /// Displacement differences under [`SQUARED_FROM_M`] add no square to the growth, on every
    /// row path: with bonds along x and no x displacement, every bond's growth is its
    /// eta . eta alone, so the forces are all zero when the y and z differences are 2^-70 m or
    /// 2^-69 m (squares subnormal, dropped) and not when they are 2^-50 m or 2^-49 m (kept).
    #[test]
    fn tiny_displacement_differences_add_no_square_on_any_row_path() {
        let (n, len) = (48usize, 16usize);
        let rest = along_x(n);
        let mut chunk = BondChunk::new(0, len);
        for i in 0..len {
            let entry = |k: usize, j: usize| BondEntry {
                neighbor: j as u32,
                rest_vector: rest[i].to(rest[j]),
                rest_length_m: rest[i].to(rest[j])[0].abs(),
                stiffness: 1e4,
                threshold: f32::INFINITY,
                bond_id: (i * 64 + k) as u64,
            };
            let internal: Vec<BondEntry> = (i + 1..len).take(3).enumerate().map(|(k, j)| entry(k, j)).collect();
            let external: Vec<BondEntry> = (len + i..n).step_by(7).enumerate().map(|(k, j)| entry(32 + k, j)).collect();
            chunk.push_row(&internal, &external);
        }
        for (exponent, squares_kept) in [(-70, false), (-50, true)] {
            let mut random = SplitMix64::new(5);
            let mut component = || [0.0, 1.0, -1.0][(random.next_u64() % 3) as usize] * f32::exp2(exponent as f32);
            let records: Vec<ParticleRecord> =
                (0..n).map(|_| ParticleRecord { disp: [0.0, component(), component()], boost: 0.0 }).collect();
            let gathers = Gathers { records: &records, rest_positions: &rest };
            let portable = run(chunk.clone(), gathers, BreakRule::Max, SimdPath::Portable);
            let any_force = portable.0.iter().flatten().any(|f| *f != 0.0);
            assert_eq!(any_force, squares_kept, "differences of 2^{exponent} m");
            for simd in SimdPath::available() {
                let dispatched = run(chunk.clone(), gathers, BreakRule::Max, simd);
                let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
                for axis in 0..3 {
                    assert_eq!(bits(&portable.0[axis]), bits(&dispatched.0[axis]), "{simd}, 2^{exponent} m");
                }
            }
        }
    }

    /// A chunk of 40 particles (from index 100 of 300) with random rows of 0 to 20 bonds, inside
    /// and outside the chunk, random rest positions in a 1 mm cube, stiffnesses (some broken) and
    /// thresholds set so that about a tenth of the bonds break; and random gather records.
    fn random_chunk(seed: u64) -> (BondChunk, Vec<ParticleRecord>, Vec<RestPosition>) {
        let mut random = SplitMix64::new(seed);
        let mut uniform = |low: f64, high: f64| (low + (high - low) * random.next_f64()) as f32;
        let (n, first, len) = (300usize, 100usize, 40usize);
        let records: Vec<ParticleRecord> = (0..n)
            .map(|_| ParticleRecord {
                disp: [uniform(-1e-5, 1e-5), uniform(-1e-5, 1e-5), uniform(-1e-5, 1e-5)],
                boost: uniform(0.0, 1e-3),
            })
            .collect();
        let positions: Vec<[f32; 3]> = (0..n).map(|_| [0; 3].map(|_| uniform(0.0, 1e-3))).collect();
        let rest = RestPosition::all(&positions);
        let mut chunk = BondChunk::new(first, len);
        for local in 0..len {
            let i = first + local;
            let internal: Vec<usize> = (i + 1..first + len).filter(|_| uniform(0.0, 1.0) < 0.4).take(12).collect();
            let external: Vec<usize> =
                (0..first).chain(first + len..n).filter(|_| uniform(0.0, 1.0) < 0.03).take(9).collect();
            let mut entry = |k: usize, j: usize| {
                let xi = rest[i].to(rest[j]);
                BondEntry {
                    neighbor: j as u32,
                    rest_vector: xi,
                    rest_length_m: (xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]).sqrt(),
                    stiffness: if uniform(0.0, 1.0) < 0.1 { 0.0 } else { uniform(1e3, 1e4) },
                    threshold: uniform(0.0, 0.3),
                    bond_id: (i * 64 + k) as u64,
                }
            };
            let internal: Vec<BondEntry> = internal.iter().enumerate().map(|(k, &j)| entry(k, j)).collect();
            let external: Vec<BondEntry> = external.iter().enumerate().map(|(k, &j)| entry(32 + k, j)).collect();
            chunk.push_row(&internal, &external);
        }
        (chunk, records, rest)
    }

    /// Everything a pass writes: forces, smallest stretches, and the bond table after the pass
    /// (with the broken bonds' ids).
    type PassResult = ([Vec<f32>; 3], Vec<f32>, BondChunk);

    fn run(mut chunk: BondChunk, gathers: Gathers, rule: BreakRule, simd: SimdPath) -> PassResult {
        let len = chunk.len;
        let (mut fx, mut fy, mut fz) = (vec![0.0; len], vec![0.0; len], vec![0.0; len]);
        let mut min_stretch = vec![0.0; len];
        let mut out = ChunkForces { force: [&mut fx, &mut fy, &mut fz], min_stretch: &mut min_stretch };
        spring_forces(&mut chunk, gathers, rule, PassRules::default(), simd, &mut out);
        ([fx, fy, fz], min_stretch, chunk)
    }

    /// One particle (0) bonded to one outside its chunk (1) along x, 1 mm apart, stretched by
    /// `stretch`; the bond breaks above 1e-3. Returns particle 0's force x and smallest stretch,
    /// and how many bonds broke.
    fn one_bond(stretch: f32, rules: PassRules) -> (f32, f32, usize) {
        let records = [
            ParticleRecord { disp: [0.0; 3], boost: 0.0 },
            ParticleRecord { disp: [stretch * 1e-3, 0.0, 0.0], boost: 0.0 },
        ];
        let mut chunk = BondChunk::new(0, 1);
        let bond = BondEntry {
            neighbor: 1,
            rest_vector: [1e-3, 0.0, 0.0],
            rest_length_m: 1e-3,
            stiffness: 1e4,
            threshold: 1e-3,
            bond_id: 0,
        };
        chunk.push_row(&[], &[bond]);
        let (mut fx, mut fy, mut fz, mut least) = (vec![0.0], vec![0.0], vec![0.0], vec![0.0]);
        let mut out = ChunkForces { force: [&mut fx, &mut fy, &mut fz], min_stretch: &mut least };
        let gathers = Gathers { records: &records, rest_positions: &along_x(2) };
        spring_forces(&mut chunk, gathers, BreakRule::Min, rules, SimdPath::best(), &mut out);
        (fx[0], least[0], chunk.breaks.len())
    }

    #[test]
    fn lammps_rules_pull_in_the_breaking_step_and_boost_by_the_signed_stretch() {
        let levine = PassRules::default();
        let lammps = PassRules { signed_boost: true, breaking_step_force: true };
        // intact, stretched: the same pull; the smallest stretch is 0 clamped, the stretch signed
        let (pull, least, breaks) = one_bond(5e-4, levine);
        assert!((pull - 1e4 * 5e-4).abs() < 1e-4 && least == 0.0 && breaks == 0);
        let (pull, least, breaks) = one_bond(5e-4, lammps);
        assert!((pull - 1e4 * 5e-4).abs() < 1e-4 && (least - 5e-4).abs() < 1e-9 && breaks == 0);
        // breaking: Levine's drops the bond at once, LAMMPS's pulls once more and counts it
        assert_eq!(one_bond(2e-3, levine), (0.0, 0.0, 1));
        let (pull, least, breaks) = one_bond(2e-3, lammps);
        assert!((pull - 1e4 * 2e-3).abs() < 1e-4 && (least - 2e-3).abs() < 1e-9 && breaks == 1);
        // each rule alone
        let (pull, least, _) = one_bond(2e-3, PassRules { signed_boost: true, breaking_step_force: false });
        assert_eq!((pull, least), (0.0, f32::INFINITY), "a dropped bond leaves no stretch at all");
        let (pull, least, _) = one_bond(2e-3, PassRules { signed_boost: false, breaking_step_force: true });
        assert!((pull - 1e4 * 2e-3).abs() < 1e-4 && least == 0.0);
    }

    /// On every SIMD path this CPU runs (the AVX2 block kernel from `avx2` on), a pass gives the
    /// portable kernel's bits.
    #[test]
    fn every_simd_path_gives_the_portable_kernels_bits() {
        let mut breaks = 0;
        for seed in 0..20 {
            for rule in [BreakRule::Max, BreakRule::Min] {
                let (chunk, records, rest) = random_chunk(seed);
                let gathers = Gathers { records: &records, rest_positions: &rest };
                let portable = run(chunk.clone(), gathers, rule, SimdPath::Portable);
                for simd in SimdPath::available() {
                    let dispatched = run(chunk.clone(), gathers, rule, simd);
                    for axis in 0..3 {
                        let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
                        assert_eq!(
                            bits(&portable.0[axis]),
                            bits(&dispatched.0[axis]),
                            "{simd}, seed {seed} axis {axis}"
                        );
                    }
                    // Equal as numbers: the two may differ in the sign of a zero smallest stretch.
                    assert_eq!(portable.1, dispatched.1, "{simd}, seed {seed}");
                    assert_eq!(portable.2, dispatched.2, "{simd}, seed {seed}");
                }
                breaks += portable.2.breaks.len();
                assert!(portable.0[0].iter().any(|f| *f != 0.0), "seed {seed}: no forces");
            }
        }
        assert!(breaks > 100, "only {breaks} bonds broke: the break path is not exercised");
    }
}
