//! Arithmetic on eight f32 lanes ([`Lanes`]), one operation per function, each a loop the
//! compiler turns into one 256-bit instruction; and the bond force of eight bonds built from
//! them, shared by the kernels of both bond layouts.

// Indexed loops: one per operation, each a vector instruction.
#![allow(clippy::needless_range_loop)]

pub use crate::bond_layouts::row_layout::LANES;

/// Eight f32 lanes.
pub type Lanes = [f32; LANES];

/// Eight consecutive values of `values` from `at`.
#[inline(always)]
pub fn load<T: Copy + Default>(values: &[T], at: usize) -> [T; LANES] {
    let mut lanes = [T::default(); LANES];
    lanes.copy_from_slice(&values[at..at + LANES]);
    lanes
}

/// a + b, lane by lane.
#[inline(always)]
pub fn add(a: Lanes, b: Lanes) -> Lanes {
    let mut lanes = [0.0; LANES];
    for l in 0..LANES {
        lanes[l] = a[l] + b[l];
    }
    lanes
}

/// a - b, lane by lane.
#[inline(always)]
pub fn sub(a: Lanes, b: Lanes) -> Lanes {
    let mut lanes = [0.0; LANES];
    for l in 0..LANES {
        lanes[l] = a[l] - b[l];
    }
    lanes
}

/// a b, lane by lane.
#[inline(always)]
pub fn mul(a: Lanes, b: Lanes) -> Lanes {
    let mut lanes = [0.0; LANES];
    for l in 0..LANES {
        lanes[l] = a[l] * b[l];
    }
    lanes
}

/// a / b, lane by lane.
#[inline(always)]
pub fn div(a: Lanes, b: Lanes) -> Lanes {
    let mut lanes = [0.0; LANES];
    for l in 0..LANES {
        lanes[l] = a[l] / b[l];
    }
    lanes
}

/// The square root of a, lane by lane.
#[inline(always)]
pub fn sqrt(a: Lanes) -> Lanes {
    let mut lanes = [0.0; LANES];
    for l in 0..LANES {
        lanes[l] = a[l].sqrt();
    }
    lanes
}

/// Keeps in `total` (eight values) the smaller of each of its lanes and `value`'s ([`min`]), with
/// one plain vector store. A load, a select and a store of the same eight values LLVM turns into a
/// store of the changed lanes only (`vmaskmovps`): three micro-ops on Intel cores, but 42 on AMD's
/// Zen 2 and Zen 3, with one such store each 12 cycles (uops.info). The compiler fence between the
/// load and the store keeps the store whole; it emits no instruction.
#[inline(always)]
pub fn keep_min(total: &mut [f32], value: Lanes) {
    let current = load(total, 0);
    std::sync::atomic::compiler_fence(std::sync::atomic::Ordering::SeqCst);
    total[..LANES].copy_from_slice(&min(current, value));
}

/// The smaller of a and b, lane by lane: b where b < a, else a (where they are equal, and where
/// either is NaN). One instruction (`minps b, a`), where `f32::min`, which passes over a NaN a,
/// takes three; the two differ only for a NaN a.
#[inline(always)]
pub fn min(a: Lanes, b: Lanes) -> Lanes {
    let mut lanes = [0.0; LANES];
    for l in 0..LANES {
        lanes[l] = if b[l] < a[l] { b[l] } else { a[l] };
    }
    lanes
}

/// `value` where `condition` is positive, else 0, lane by lane.
#[inline(always)]
pub fn where_positive(condition: Lanes, value: Lanes) -> Lanes {
    let mut lanes = [0.0; LANES];
    for l in 0..LANES {
        lanes[l] = if condition[l] > 0.0 { value[l] } else { 0.0 };
    }
    lanes
}

/// -a, lane by lane (x - a is x + (-a), bit for bit).
#[inline(always)]
pub fn neg(a: Lanes) -> Lanes {
    mul(a, [-1.0; LANES])
}

/// |a|, lane by lane.
#[inline(always)]
pub fn abs(a: Lanes) -> Lanes {
    let mut lanes = [0.0; LANES];
    for l in 0..LANES {
        lanes[l] = a[l].abs();
    }
    lanes
}

/// |a| with the sign of `sign`, lane by lane.
#[inline(always)]
pub fn copysign(a: Lanes, sign: Lanes) -> Lanes {
    let mut lanes = [0.0; LANES];
    for l in 0..LANES {
        lanes[l] = a[l].copysign(sign[l]);
    }
    lanes
}

/// `then` where a > b, else `otherwise`, lane by lane: a blend through a bit mask, so that the
/// compiler keeps it one vector instruction rather than a branch per lane around the work that
/// `then` or `otherwise` took.
#[inline(always)]
pub fn pick_greater(a: Lanes, b: Lanes, then: Lanes, otherwise: Lanes) -> Lanes {
    let mut mask = [0u32; LANES];
    for l in 0..LANES {
        mask[l] = if a[l] > b[l] { u32::MAX } else { 0 };
    }
    blend(mask, then, otherwise)
}

/// `then` where `mask` is all ones, else `otherwise`, lane by lane.
#[inline(always)]
fn blend(mask: [u32; LANES], then: Lanes, otherwise: Lanes) -> Lanes {
    let mut lanes = [0.0; LANES];
    for l in 0..LANES {
        lanes[l] = f32::from_bits((then[l].to_bits() & mask[l]) | (otherwise[l].to_bits() & !mask[l]));
    }
    lanes
}

/// `then` where a < b, else `otherwise`, lane by lane.
#[inline(always)]
pub fn pick_less(a: Lanes, b: Lanes, then: Lanes, otherwise: Lanes) -> Lanes {
    pick_greater(b, a, then, otherwise)
}

/// `then` where a == b, else `otherwise`, lane by lane (a blend, as [`pick_greater`]).
#[inline(always)]
pub fn pick_equal(a: Lanes, b: Lanes, then: Lanes, otherwise: Lanes) -> Lanes {
    let mut mask = [0u32; LANES];
    for l in 0..LANES {
        mask[l] = if a[l] == b[l] { u32::MAX } else { 0 };
    }
    blend(mask, then, otherwise)
}

/// True where any lane of a exceeds b's.
#[inline(always)]
pub fn any_greater(a: Lanes, b: Lanes) -> bool {
    let mut any = false;
    for l in 0..LANES {
        any |= a[l] > b[l];
    }
    any
}

/// a0 b0 + a1 b1 + a2 b2, lane by lane, summed in that order.
#[inline(always)]
pub fn dot(a: &[Lanes; 3], b: &[Lanes; 3]) -> Lanes {
    add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2]))
}

/// a with the lanes under [`super::springs::SQUARED_FROM_M`] in magnitude set to zero (NaN
/// kept): the factors of the growth's eta . eta.
#[inline(always)]
fn squared_part(a: Lanes) -> Lanes {
    let mut lanes = [0.0; LANES];
    for l in 0..LANES {
        lanes[l] = if a[l].abs() < super::springs::SQUARED_FROM_M { 0.0 } else { a[l] };
    }
    lanes
}

/// [`super::springs::may_have_tiny`] for eight particles at once: whether any of them may.
#[inline(always)]
pub fn any_may_have_tiny(disp: &[Lanes; 3]) -> bool {
    let mut any = false;
    for axis in 0..3 {
        for l in 0..LANES {
            any |= disp[axis][l].abs() < super::springs::NO_TINY_FROM_M;
        }
    }
    any
}

/// Eight bonds' stretch and force.
pub struct BondLanes {
    /// The bond vector y = xi + eta, metres.
    pub y: [Lanes; 3],
    /// Stretch s (0 for a bond of no stiffness).
    pub stretch: Lanes,
    /// Force per metre of y: the force is `scale` y.
    pub scale: Lanes,
}

/// Eight bonds from their rest vectors xi and displacement differences eta: the deformed bonds
/// y = xi + eta, their lengths |y| and the growth 2 xi . eta + eta . eta, which is
/// |y|^2 - |xi|^2 without its cancellation (see [`super::stretch`]; eta . eta leaves out
/// components under [`super::springs::SQUARED_FROM_M`], as there). `TINY` false leaves out that
/// test, for bonds known to have no such component ([`super::springs::NO_TINY_FROM_M`]): the same
/// bits.
#[inline(always)]
pub fn deformed_bonds<const TINY: bool>(xi: &[Lanes; 3], eta: &[Lanes; 3]) -> ([Lanes; 3], Lanes, Lanes) {
    let y = [add(xi[0], eta[0]), add(xi[1], eta[1]), add(xi[2], eta[2])];
    let length = sqrt(dot(&y, &y));
    let squared = if TINY { [squared_part(eta[0]), squared_part(eta[1]), squared_part(eta[2])] } else { *eta };
    let growth = add(mul([2.0; LANES], dot(xi, eta)), dot(&squared, &squared));
    (y, length, growth)
}

/// Eight bonds' stretch s = (2 xi . eta + eta . eta) / (L (|y| + L)) from their rest vectors,
/// displacement differences and rest lengths: lane by lane the bits of [`super::stretch`].
#[inline(always)]
pub fn lane_stretch(xi: &[Lanes; 3], eta: &[Lanes; 3], rest_length: Lanes) -> Lanes {
    let (_, length, growth) = deformed_bonds::<true>(xi, eta);
    div(growth, mul(rest_length, add(length, rest_length)))
}

/// The PMB force of eight bonds from their rest vectors xi, displacement differences eta, rest
/// lengths and stiffnesses: s = (2 xi . eta + eta . eta) / (L (|y| + L)) (see
/// [`super::stretch`]), and the force k s y / |y| as `scale` y, with one division for both.
/// `TINY` as for [`deformed_bonds`].
#[inline(always)]
pub fn bond_lanes<const TINY: bool>(
    xi: &[Lanes; 3],
    eta: &[Lanes; 3],
    rest_length: Lanes,
    stiffness: Lanes,
) -> BondLanes {
    let (y, length, growth) = deformed_bonds::<TINY>(xi, eta);
    let denominator = mul(mul(rest_length, add(length, rest_length)), length);
    let inverse = where_positive(denominator, div([1.0; LANES], denominator));
    let stretch = where_positive(stiffness, mul(mul(growth, length), inverse));
    let scale = mul(mul(stiffness, growth), inverse);
    BondLanes { y, stretch, scale }
}
