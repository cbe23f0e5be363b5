//! The spring kernel's row kernel in explicit AVX2 instructions: the same operations in the same
//! order as the portable row kernel in `springs`, so the two give the same bits. What the
//! compiler cannot do on its own is the data movement: each partner's 16-byte record and rest
//! position are loaded whole and eight of each are transposed into lanes with shuffles, and the
//! reactions of internal bonds are transposed back and scattered as one 16-byte update per
//! partner.
//!
//! Its `unsafe` is the call into this module's `#[target_feature]` function, made right after
//! the CPU has been checked for AVX2 (see `docs/DECISIONS.md#where-unsafe-is-allowed`).

use std::arch::x86_64::{
    __m128, __m256, _CMP_GT_OQ, _CMP_LT_OQ, _mm_blend_ps, _mm_min_ps, _mm_sub_ps, _mm256_add_ps, _mm256_and_ps,
    _mm256_andnot_ps, _mm256_castpd_ps, _mm256_castps_pd, _mm256_castps256_ps128, _mm256_cmp_ps, _mm256_div_ps,
    _mm256_extractf128_ps, _mm256_min_ps, _mm256_movemask_ps, _mm256_mul_ps, _mm256_set_m128, _mm256_set1_ps,
    _mm256_sqrt_ps, _mm256_sub_ps, _mm256_unpackhi_pd, _mm256_unpackhi_ps, _mm256_unpacklo_pd, _mm256_unpacklo_ps,
};

use shatter_core::config::sim::BreakRule;

use super::prefetch::prefetch_item;
use super::springs::{
    BlockContext, ChunkForces, Gathers, LANES, LaneSums, PassRules, ROWS_AHEAD, SQUARED_FROM_M, break_bound,
    break_lanes, may_have_tiny, spring_rows,
};
use crate::bond_layouts::row_layout::BondChunk;

/// [`super::spring_forces`] with the AVX2 row kernel, if this CPU has AVX2 (detected once, then
/// cached by the standard library). Returns whether it ran.
pub(super) fn spring_forces(chunk: &mut BondChunk, gathers: Gathers, rule: BreakRule, out: &mut ChunkForces) -> bool {
    if !std::arch::is_x86_feature_detected!("avx2") {
        return false;
    }
    // SAFETY: a `#[target_feature]` function's one precondition is that the CPU has the
    // features it enables; AVX2 was detected on this CPU just above.
    #[allow(unsafe_code)]
    unsafe {
        spring_forces_avx2(chunk, gathers, rule, out);
    }
    true
}

#[target_feature(enable = "avx2")]
fn spring_forces_avx2(chunk: &mut BondChunk, gathers: Gathers, rule: BreakRule, out: &mut ChunkForces) {
    spring_rows(
        chunk,
        gathers,
        rule,
        PassRules::default(),
        out,
        #[inline(always)]
        |chunk, context, local| {
            if may_have_tiny(context.records[chunk.first + local].disp) {
                bond_row::<true>(chunk, context, local)
            } else {
                bond_row::<false>(chunk, context, local)
            }
        },
    );
}

/// The first three components (x, y, z) of the eight partners' 16-byte items `items` (gather
/// records or rest positions) as lanes: each item loaded whole as an (x, y, z, w) row, and the
/// rows transposed (w dropped). Each row goes from the items straight into its register half:
/// rows gathered into an array first were stored to the stack and read back 32 bytes at a time,
/// across two 16-byte stores, which the cores cannot forward (a stall on every block).
#[target_feature(enable = "avx2")]
#[inline]
fn gather_lanes<T: bytemuck::Pod>(items: &[T], partner: &[u32; LANES]) -> [__m256; 3] {
    let row = |lane: usize| bytemuck::cast::<T, __m128>(items[partner[lane] as usize]);
    let a0 = _mm256_set_m128(row(4), row(0));
    let a1 = _mm256_set_m128(row(5), row(1));
    let a2 = _mm256_set_m128(row(6), row(2));
    let a3 = _mm256_set_m128(row(7), row(3));
    // Per 128-bit half: [x0 x1 y0 y1], [x2 x3 y2 y3], [z0 z1 w0 w1], [z2 z3 w2 w3].
    let xy01 = _mm256_castps_pd(_mm256_unpacklo_ps(a0, a1));
    let xy23 = _mm256_castps_pd(_mm256_unpacklo_ps(a2, a3));
    let zw01 = _mm256_castps_pd(_mm256_unpackhi_ps(a0, a1));
    let zw23 = _mm256_castps_pd(_mm256_unpackhi_ps(a2, a3));
    [
        _mm256_castpd_ps(_mm256_unpacklo_pd(xy01, xy23)),
        _mm256_castpd_ps(_mm256_unpackhi_pd(xy01, xy23)),
        _mm256_castpd_ps(_mm256_unpacklo_pd(zw01, zw23)),
    ]
}

/// Transposes x, y, z and w lanes into eight (x, y, z, w) rows.
#[target_feature(enable = "avx2")]
#[inline]
fn lanes_to_rows(x: __m256, y: __m256, z: __m256, w: __m256) -> [__m128; LANES] {
    // Per 128-bit half: [x0 y0 x1 y1], [z0 w0 z1 w1], [x2 y2 x3 y3], [z2 w2 z3 w3].
    let xy01 = _mm256_castps_pd(_mm256_unpacklo_ps(x, y));
    let zw01 = _mm256_castps_pd(_mm256_unpacklo_ps(z, w));
    let xy23 = _mm256_castps_pd(_mm256_unpackhi_ps(x, y));
    let zw23 = _mm256_castps_pd(_mm256_unpackhi_ps(z, w));
    let r04 = _mm256_castpd_ps(_mm256_unpacklo_pd(xy01, zw01));
    let r15 = _mm256_castpd_ps(_mm256_unpackhi_pd(xy01, zw01));
    let r26 = _mm256_castpd_ps(_mm256_unpacklo_pd(xy23, zw23));
    let r37 = _mm256_castpd_ps(_mm256_unpackhi_pd(xy23, zw23));
    [
        _mm256_castps256_ps128(r04),
        _mm256_castps256_ps128(r15),
        _mm256_castps256_ps128(r26),
        _mm256_castps256_ps128(r37),
        _mm256_extractf128_ps::<1>(r04),
        _mm256_extractf128_ps::<1>(r15),
        _mm256_extractf128_ps::<1>(r26),
        _mm256_extractf128_ps::<1>(r37),
    ]
}

/// The portable row kernel of `springs` in AVX2 instructions: same operations, same order, with
/// the lane sums kept in registers over the row; with the growth's test for tiny displacement
/// differences (`TINY`) or without it, as there.
#[target_feature(enable = "avx2")]
fn bond_row<const TINY: bool>(chunk: &mut BondChunk, context: &mut BlockContext, local: usize) -> LaneSums {
    let first = chunk.first;
    let i = first + local;
    let (records, rest_positions) = context.gathered();
    let me_record = records[i];
    let me = me_record.disp.map(|u| _mm256_set1_ps(u));
    let here = rest_positions[i].position_m.map(|x| _mm256_set1_ps(x));
    let bound = _mm256_set1_ps(break_bound(context.rule, me_record.boost));
    let zero = _mm256_set1_ps(0.0);
    let mut force_sum = [zero; 3];
    let mut smallest = zero;
    for (block, internal) in chunk.row(local) {
        prefetch_item(chunk.blocks.as_ptr(), block + ROWS_AHEAD);
        let bonds = &chunk.blocks[block];
        let stiffness: __m256 = bytemuck::cast(bonds.stiffness);
        let threshold: __m256 = bytemuck::cast(bonds.threshold);
        let rest_length: __m256 = bytemuck::cast(bonds.rest_length_m);
        let partner = bonds.neighbor;
        // Padding lanes gather the particle itself: xi = X_i - X_i = 0, eta = u_i - u_i = 0.
        let disp = gather_lanes(records, &partner);
        let rest = gather_lanes(rest_positions, &partner);
        let xi = [_mm256_sub_ps(rest[0], here[0]), _mm256_sub_ps(rest[1], here[1]), _mm256_sub_ps(rest[2], here[2])];
        let eta = [_mm256_sub_ps(disp[0], me[0]), _mm256_sub_ps(disp[1], me[1]), _mm256_sub_ps(disp[2], me[2])];

        let y = [_mm256_add_ps(xi[0], eta[0]), _mm256_add_ps(xi[1], eta[1]), _mm256_add_ps(xi[2], eta[2])];
        let length = _mm256_sqrt_ps(sum_of_products(&y, &y));
        let squared = if TINY { [squared_part(eta[0]), squared_part(eta[1]), squared_part(eta[2])] } else { eta };
        let growth = _mm256_add_ps(
            _mm256_mul_ps(_mm256_set1_ps(2.0), sum_of_products(&xi, &eta)),
            sum_of_products(&squared, &squared),
        );
        let denominator = _mm256_mul_ps(_mm256_mul_ps(rest_length, _mm256_add_ps(length, rest_length)), length);
        let inverse = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GT_OQ>(denominator, zero),
            _mm256_div_ps(_mm256_set1_ps(1.0), denominator),
        );
        let mut stretch = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GT_OQ>(stiffness, zero),
            _mm256_mul_ps(_mm256_mul_ps(growth, length), inverse),
        );
        let mut scale = _mm256_mul_ps(_mm256_mul_ps(stiffness, growth), inverse);

        let suspects = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(stretch, _mm256_add_ps(threshold, bound)));
        if suspects != 0 {
            let mut stretch_lanes: [f32; LANES] = bytemuck::cast(stretch);
            let mut scale_lanes: [f32; LANES] = bytemuck::cast(scale);
            break_lanes(chunk, context, local, block, &mut stretch_lanes, &mut scale_lanes);
            stretch = bytemuck::cast(stretch_lanes);
            scale = bytemuck::cast(scale_lanes);
        }

        let force = [_mm256_mul_ps(y[0], scale), _mm256_mul_ps(y[1], scale), _mm256_mul_ps(y[2], scale)];
        for axis in 0..3 {
            force_sum[axis] = _mm256_add_ps(force_sum[axis], force[axis]);
        }
        smallest = _mm256_min_ps(smallest, stretch);
        if internal {
            // Each partner's total loses the force (x, y, z) and keeps the smaller stretch (w);
            // padding lanes add a zero force to this particle.
            let reactions = lanes_to_rows(force[0], force[1], force[2], stretch);
            let totals = &mut *context.totals;
            for lane in 0..LANES {
                let slot = &mut totals[partner[lane] as usize - first];
                let total: __m128 = bytemuck::cast(*slot);
                let updated =
                    _mm_blend_ps::<0b1000>(_mm_sub_ps(total, reactions[lane]), _mm_min_ps(total, reactions[lane]));
                *slot = bytemuck::cast(updated);
            }
        }
    }
    LaneSums { force: force_sum.map(bytemuck::cast), min_stretch: bytemuck::cast(smallest) }
}

/// a0 b0 + a1 b1 + a2 b2, lane by lane, summed in that order.
#[target_feature(enable = "avx2")]
#[inline]
fn sum_of_products(a: &[__m256; 3], b: &[__m256; 3]) -> __m256 {
    _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(a[0], b[0]), _mm256_mul_ps(a[1], b[1])), _mm256_mul_ps(a[2], b[2]))
}

/// `eta` with the lanes under [`SQUARED_FROM_M`] in magnitude set to zero (NaN kept), as the
/// portable kernel's eta . eta takes them.
#[target_feature(enable = "avx2")]
#[inline]
fn squared_part(eta: __m256) -> __m256 {
    let magnitude = _mm256_andnot_ps(_mm256_set1_ps(-0.0), eta);
    _mm256_andnot_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(magnitude, _mm256_set1_ps(SQUARED_FROM_M)), eta)
}
