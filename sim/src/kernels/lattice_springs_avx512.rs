//! The lattice layout's brick kernel in explicit AVX-512 instructions: two blocks of a brick at a
//! time, their sixteen lanes in one register, through the same operations as the portable brick
//! kernel in `lattice_springs`. The sums then take the two blocks' lanes one block after the
//! other, as the portable kernel does, so the two give the same bits. The compiler does not get
//! there from the portable code: it keeps sixteen-lane arrays on the stack.
//!
//! Its `unsafe` is the call into this module's `#[target_feature]` function, made right after the
//! CPU has been checked for AVX-512F (see `docs/DECISIONS.md#where-unsafe-is-allowed`).

use std::arch::x86_64::{
    __m128, __m256, __m512, __m512i, _CMP_GT_OQ, _CMP_LT_OQ, _mm256_add_ps, _mm256_castpd_ps, _mm256_castps_pd,
    _mm256_min_ps, _mm256_set_m128, _mm256_set1_ps, _mm256_sub_ps, _mm512_abs_ps, _mm512_add_ps, _mm512_castpd_ps,
    _mm512_castpd256_pd512, _mm512_castps_pd, _mm512_castps256_ps512, _mm512_castps512_ps256, _mm512_cmp_ps_mask,
    _mm512_div_ps, _mm512_extractf64x4_pd, _mm512_insertf64x4, _mm512_mask_mov_ps, _mm512_maskz_mov_ps, _mm512_mul_ps,
    _mm512_permutexvar_ps, _mm512_set1_ps, _mm512_setr_epi32, _mm512_sqrt_ps, _mm512_sub_ps,
};

use std::ops::Range;

use shatter_core::config::sim::BreakRule;

use super::lanes::{LANES, Lanes, any_may_have_tiny, load};
use super::lattice_springs::{BLOCKS_AHEAD, BlockPlace, ChunkPass, break_lanes, lattice_bricks};
use super::prefetch::prefetch;
use super::springs::{ChunkForces, SQUARED_FROM_M};
use crate::bond_layouts::lattice_layout::{ChunkShape, LatticeChunk, SlotInputs};

/// [`super::lattice_spring_forces`] with the AVX-512 brick kernel, if this CPU has AVX-512F
/// (detected once, then cached by the standard library). Returns whether it ran.
pub(super) fn lattice_spring_forces(
    chunk: &mut LatticeChunk,
    inputs: &SlotInputs<'_>,
    particle_of: &[u32],
    rule: BreakRule,
    out: &mut ChunkForces,
) -> bool {
    if !std::arch::is_x86_feature_detected!("avx512f") {
        return false;
    }
    // SAFETY: a `#[target_feature]` function's one precondition is that the CPU has the
    // features it enables; AVX-512F was detected on this CPU just above.
    #[allow(unsafe_code)]
    unsafe {
        lattice_spring_forces_avx512(chunk, inputs, particle_of, rule, out);
    }
    true
}

#[target_feature(enable = "avx512f")]
fn lattice_spring_forces_avx512(
    chunk: &mut LatticeChunk,
    inputs: &SlotInputs<'_>,
    particle_of: &[u32],
    rule: BreakRule,
    out: &mut ChunkForces,
) {
    lattice_bricks(
        chunk,
        inputs,
        particle_of,
        rule,
        out,
        #[inline(always)]
        |pass, b, own, bound| brick_forces(pass, b, own, bound),
    );
}

/// Two blocks' eight lanes, the first block's low.
#[target_feature(enable = "avx512f")]
#[inline]
fn join(low: __m256, high: __m256) -> __m512 {
    _mm512_castpd_ps(_mm512_insertf64x4::<1>(_mm512_castpd256_pd512(_mm256_castps_pd(low)), _mm256_castps_pd(high)))
}

/// The two blocks' lanes of a pair.
#[target_feature(enable = "avx512f")]
#[inline]
fn halves(pair: __m512) -> [__m256; 2] {
    [_mm512_castps512_ps256(pair), _mm256_castpd_ps(_mm512_extractf64x4_pd::<1>(_mm512_castps_pd(pair)))]
}

/// Eight lanes as a register.
#[target_feature(enable = "avx512f")]
#[inline]
fn lanes(values: Lanes) -> __m256 {
    bytemuck::cast(values)
}

/// [`super::lanes::min`]: b where b < a, else a.
#[target_feature(enable = "avx512f")]
#[inline]
fn min_of(a: __m256, b: __m256) -> __m256 {
    _mm256_min_ps(b, a)
}

/// a0 b0 + a1 b1 + a2 b2, lane by lane, summed in that order.
#[target_feature(enable = "avx512f")]
#[inline]
fn sum_of_products(a: &[__m512; 3], b: &[__m512; 3]) -> __m512 {
    _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(a[0], b[0]), _mm512_mul_ps(a[1], b[1])), _mm512_mul_ps(a[2], b[2]))
}

/// `eta` with the lanes under [`SQUARED_FROM_M`] in magnitude set to zero (NaN kept), as the
/// portable kernel's eta . eta takes them.
#[target_feature(enable = "avx512f")]
#[inline]
fn squared_part(eta: __m512) -> __m512 {
    let tiny = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(_mm512_abs_ps(eta), _mm512_set1_ps(SQUARED_FROM_M));
    _mm512_mask_mov_ps(eta, tiny, _mm512_set1_ps(0.0))
}

/// `value` where `condition` is positive, else 0, lane by lane.
#[target_feature(enable = "avx512f")]
#[inline]
fn where_positive(condition: __m512, value: __m512) -> __m512 {
    _mm512_maskz_mov_ps(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(condition, _mm512_set1_ps(0.0)), value)
}

/// The portable brick kernel of `lattice_springs` in AVX-512 instructions: brick `b`'s internal
/// blocks two at a time, then its external ones (an odd one last, beside a copy of itself whose
/// lanes are dropped), each pair applied block by block.
#[target_feature(enable = "avx512f")]
#[inline]
fn brick_forces(pass: &mut ChunkPass, b: usize, own: usize, bound: Lanes) -> ([Lanes; 3], Lanes) {
    let ChunkShape { brick_start, internal_end, .. } = pass.shape;
    let disp = pass.disp;
    let own_disp = [load(disp[0], own), load(disp[1], own), load(disp[2], own)];
    let mine = [lanes(own_disp[0]), lanes(own_disp[1]), lanes(own_disp[2])];
    let bound = lanes(bound);
    let brick = Brick {
        own,
        me: [join(mine[0], mine[0]), join(mine[1], mine[1]), join(mine[2], mine[2])],
        bound: join(bound, bound),
        // Lane l of the rest pair [x0 y0 z0 L0 x1 y1 z1 L1] for the low half, l + 4 for the high.
        picks: [
            _mm512_setr_epi32(0, 0, 0, 0, 0, 0, 0, 0, 4, 4, 4, 4, 4, 4, 4, 4),
            _mm512_setr_epi32(1, 1, 1, 1, 1, 1, 1, 1, 5, 5, 5, 5, 5, 5, 5, 5),
            _mm512_setr_epi32(2, 2, 2, 2, 2, 2, 2, 2, 6, 6, 6, 6, 6, 6, 6, 6),
            _mm512_setr_epi32(3, 3, 3, 3, 3, 3, 3, 3, 7, 7, 7, 7, 7, 7, 7, 7),
        ],
    };
    let zero = _mm256_set1_ps(0.0);
    let mut sums = BrickSums { force: [zero; 3], smallest: zero };
    let (start, middle, end) = (brick_start[b] as usize, internal_end[b] as usize, brick_start[b + 1] as usize);
    if any_may_have_tiny(&own_disp) {
        range_forces::<true, true>(pass, &brick, start..middle, &mut sums);
        range_forces::<false, true>(pass, &brick, middle..end, &mut sums);
    } else {
        range_forces::<true, false>(pass, &brick, start..middle, &mut sums);
        range_forces::<false, false>(pass, &brick, middle..end, &mut sums);
    }
    let force: [Lanes; 3] =
        [bytemuck::cast(sums.force[0]), bytemuck::cast(sums.force[1]), bytemuck::cast(sums.force[2])];
    (force, bytemuck::cast(sums.smallest))
}

/// The brick's blocks `blocks`, all internal or all external (`INTERNAL`), in pairs, an odd one
/// last; with the growth's test for tiny displacement differences or without it (`TINY`, as in
/// the portable kernel).
#[target_feature(enable = "avx512f")]
#[inline]
fn range_forces<const INTERNAL: bool, const TINY: bool>(
    pass: &mut ChunkPass,
    brick: &Brick,
    blocks: Range<usize>,
    sums: &mut BrickSums,
) {
    let mut block = blocks.start;
    while block + 1 < blocks.end {
        pair_forces::<INTERNAL, 2, TINY>(pass, brick, block, sums);
        block += 2;
    }
    if block < blocks.end {
        pair_forces::<INTERNAL, 1, TINY>(pass, brick, block, sums);
    }
}

/// What a brick's pairs share: its first slot, its displacements and break bound in both halves,
/// and the permutations that spread a pair's rest vectors and lengths over the lanes.
struct Brick {
    own: usize,
    me: [__m512; 3],
    bound: __m512,
    picks: [__m512i; 4],
}

/// A brick's running sums over its blocks: force and smallest stretch, lane by lane.
struct BrickSums {
    force: [__m256; 3],
    smallest: __m256,
}

/// Blocks `block` and `block + 1` of the brick (`COUNT` 2), or `block` beside a copy of itself
/// (`COUNT` 1), internal or external (`INTERNAL`), with the growth's test for tiny displacement
/// differences or without it (`TINY`): computed in one 16-lane pass, then applied block by block
/// to the sums and, for internal blocks, to the partners' totals.
#[target_feature(enable = "avx512f")]
#[inline]
fn pair_forces<const INTERNAL: bool, const COUNT: usize, const TINY: bool>(
    pass: &mut ChunkPass,
    brick: &Brick,
    block: usize,
    sums: &mut BrickSums,
) {
    let (disp, picks) = (pass.disp, &brick.picks);
    let pair = [block, block + COUNT - 1];
    let all_blocks = pass.blocks.as_ptr();
    prefetch(all_blocks, block + BLOCKS_AHEAD);
    prefetch(all_blocks, block + 1 + BLOCKS_AHEAD);
    let partner = [pass.shape.partner_slot[pair[0]] as usize, pass.shape.partner_slot[pair[1]] as usize];
    let theirs = |axis: usize| join(lanes(load(disp[axis], partner[0])), lanes(load(disp[axis], partner[1])));
    let me = &brick.me;
    let eta = [_mm512_sub_ps(theirs(0), me[0]), _mm512_sub_ps(theirs(1), me[1]), _mm512_sub_ps(theirs(2), me[2])];
    let rest: [__m128; 2] = [bytemuck::cast(pass.rest[pair[0]]), bytemuck::cast(pass.rest[pair[1]])];
    let packed = _mm512_castps256_ps512(_mm256_set_m128(rest[1], rest[0]));
    let xi = [
        _mm512_permutexvar_ps(picks[0], packed),
        _mm512_permutexvar_ps(picks[1], packed),
        _mm512_permutexvar_ps(picks[2], packed),
    ];
    let rest_length = _mm512_permutexvar_ps(picks[3], packed);
    let (first_bonds, next_bonds) = (&pass.blocks[pair[0]], &pass.blocks[pair[1]]);
    let stiffness = join(lanes(first_bonds.stiffness), lanes(next_bonds.stiffness));
    let threshold = join(lanes(first_bonds.threshold), lanes(next_bonds.threshold));

    let y = [_mm512_add_ps(xi[0], eta[0]), _mm512_add_ps(xi[1], eta[1]), _mm512_add_ps(xi[2], eta[2])];
    let length = _mm512_sqrt_ps(sum_of_products(&y, &y));
    let squared = if TINY { [squared_part(eta[0]), squared_part(eta[1]), squared_part(eta[2])] } else { eta };
    let growth = _mm512_add_ps(
        _mm512_mul_ps(_mm512_set1_ps(2.0), sum_of_products(&xi, &eta)),
        sum_of_products(&squared, &squared),
    );
    let denominator = _mm512_mul_ps(_mm512_mul_ps(rest_length, _mm512_add_ps(length, rest_length)), length);
    let inverse = where_positive(denominator, _mm512_div_ps(_mm512_set1_ps(1.0), denominator));
    let mut stretch = where_positive(stiffness, _mm512_mul_ps(_mm512_mul_ps(growth, length), inverse));
    let mut scale = _mm512_mul_ps(_mm512_mul_ps(stiffness, growth), inverse);

    let suspects = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(stretch, _mm512_add_ps(threshold, brick.bound));
    if suspects != 0 {
        let (stretch_halves, scale_halves) = (halves(stretch), halves(scale));
        let mut stretches: [Lanes; 2] = [bytemuck::cast(stretch_halves[0]), bytemuck::cast(stretch_halves[1])];
        let mut scales: [Lanes; 2] = [bytemuck::cast(scale_halves[0]), bytemuck::cast(scale_halves[1])];
        for half in 0..COUNT {
            if (suspects >> (LANES * half)) & 0xff != 0 {
                let k = pair[half];
                let ids = &pass.bond_id[k * LANES..(k + 1) * LANES];
                let place = BlockPlace { own: brick.own, partner: partner[half], internal: INTERNAL, ids };
                let bonds = &mut pass.blocks[k];
                break_lanes(&pass.context, bonds, &place, pass.breaks, [&mut stretches[half], &mut scales[half]]);
            }
        }
        stretch = join(lanes(stretches[0]), lanes(stretches[1]));
        scale = join(lanes(scales[0]), lanes(scales[1]));
    }

    let force = [_mm512_mul_ps(y[0], scale), _mm512_mul_ps(y[1], scale), _mm512_mul_ps(y[2], scale)];
    let force = [halves(force[0]), halves(force[1]), halves(force[2])];
    let stretch = halves(stretch);
    for half in 0..COUNT {
        for axis in 0..3 {
            sums.force[axis] = _mm256_add_ps(sums.force[axis], force[axis][half]);
        }
        sums.smallest = min_of(sums.smallest, stretch[half]);
        if INTERNAL {
            let at = partner[half] - pass.shape.first_slot;
            let totals = &mut pass.totals;
            for axis in 0..3 {
                let total = &mut totals.force[axis][at..at + LANES];
                // The reaction, x - f: the portable kernel's x + (-f), bit for bit.
                let updated: Lanes = bytemuck::cast(_mm256_sub_ps(lanes(load(total, 0)), force[axis][half]));
                total.copy_from_slice(&updated);
            }
            let total = &mut totals.min_stretch[at..at + LANES];
            let updated: Lanes = bytemuck::cast(min_of(lanes(load(total, 0)), stretch[half]));
            total.copy_from_slice(&updated);
        }
    }
}
