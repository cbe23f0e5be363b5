//! [`tetrahedralize`], the entry point: the input's checks, its exact duplicates, the first
//! simplex, then each point inserted by the [`Builder`].

use glam::DVec3;

use super::bowyer_watson::Builder;
use super::insertion_order::insertion_order;
use super::predicates::{collinear, orient};

/// Marks a missing neighbour in [`Tetrahedralization::neighbors`]: the face is on the convex hull.
pub const NO_NEIGHBOR: u32 = u32::MAX;

/// No tet.
pub(super) const NO_TET: u32 = u32::MAX;

/// Coordinates larger than this in magnitude could overflow the exact predicates.
const MAX_COORDINATE: f64 = 1e30;

/// A Delaunay tetrahedralization of a point set.
///
/// Every tet `[a, b, c, d]` (indices into the input points) is positively oriented in the sense
/// of [`robust::orient3d`]: `orient3d(a, b, c, d) > 0`, that is `d` lies below the plane through
/// `a`, `b`, `c` when they turn counterclockwise seen from above. Equivalently its volume
/// `(a - d) · ((b - d) × (c - d)) / 6` (see [`tet_volume`]) is positive. This is the orientation
/// [`robust::insphere`] expects, so `insphere(a, b, c, d, e) > 0` means `e` is strictly inside
/// the tet's circumsphere.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Tetrahedralization {
    /// Each tet's four point indices, positively oriented: `robust::orient3d(a, b, c, d) > 0`.
    pub tets: Vec<[u32; 4]>,
    /// For each tet, the tet across the face opposite vertex `k` ([`NO_NEIGHBOR`] on the convex
    /// hull).
    pub neighbors: Vec<[u32; 4]>,
    /// Points skipped because they repeat an earlier point exactly: `[skipped, kept]`, where
    /// `kept` is the lowest index with the same coordinates (`-0.0` equals `0.0`). Sorted by
    /// `skipped`. Skipped points appear in no tet.
    pub duplicates: Vec<[u32; 2]>,
}

/// Why a point set cannot be tetrahedralized.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DelaunayError {
    /// Fewer than four points were given.
    #[error("a tetrahedralization needs at least 4 points, got {count}")]
    TooFewPoints {
        /// How many points were given.
        count: usize,
    },
    /// The distinct points all lie in one plane (this includes collinear points and fewer than
    /// four distinct points), so no tet has volume.
    #[error("all {distinct} distinct points are coplanar: they span no volume")]
    Coplanar {
        /// How many distinct points there are.
        distinct: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("point {index} has a non-finite coordinate: {point}")]
    NonFinite {
        /// The point's index.
        index: usize,
        /// The point.
        point: DVec3,
    },
    /// A coordinate is so large that the exact predicates could overflow.
    #[error("point {index} = {point} has a coordinate beyond ±1e30, where the exact predicates could overflow")]
    OutOfRange {
        /// The point's index.
        index: usize,
        /// The point.
        point: DVec3,
    },
    /// More points than 32-bit indices can number.
    #[error("{count} points: at most {max} are supported")]
    TooManyPoints {
        /// How many points were given.
        count: usize,
        /// The most supported.
        max: usize,
    },
}

/// The volume of a tet of [`Tetrahedralization::tets`]: `(a - d) · ((b - d) × (c - d)) / 6`.
///
/// Computed by [`robust::orient3d`], whose sign is exact, so it is positive for every tet of a
/// [`Tetrahedralization`], slivers included (the naive floating-point formula can round a sliver's
/// volume to zero or below).
pub fn tet_volume(points: &[DVec3], tet: [u32; 4]) -> f64 {
    let [a, b, c, d] = tet.map(|i| points[i as usize]);
    orient(a, b, c, d) / 6.0
}

/// Tetrahedralizes `points`: the Delaunay tets tiling their convex hull, with face adjacency.
///
/// Exactly repeated points are skipped and listed in [`Tetrahedralization::duplicates`]; every
/// other point is a vertex of at least one tet. Deterministic: the same input always gives the
/// same output. See the [module documentation](crate::delaunay) for the algorithm and the tie rule.
pub fn tetrahedralize(points: &[DVec3]) -> Result<Tetrahedralization, DelaunayError> {
    validate(points)?;
    let (unique, duplicates) = split_duplicates(points);
    let order = insertion_order(points, unique);
    let ordered: Vec<DVec3> = order.iter().map(|&i| points[i as usize]).collect();
    let simplex = first_simplex(&ordered).ok_or(DelaunayError::Coplanar { distinct: ordered.len() })?;

    let mut builder = Builder::new(&ordered, simplex);
    let mut duplicates = duplicates;
    for p in 0..ordered.len() as u32 {
        if simplex.contains(&p) {
            continue;
        }
        if let Some(existing) = builder.insert(p) {
            // Unreachable after `split_duplicates`, kept as a safety net.
            duplicates.push([order[p as usize], order[existing as usize]]);
        }
    }
    duplicates.sort_unstable();
    let (tets, neighbors) = builder.finish(&order);
    Ok(Tetrahedralization { tets, neighbors, duplicates })
}

/// Checks the count and the coordinates.
fn validate(points: &[DVec3]) -> Result<(), DelaunayError> {
    if points.len() < 4 {
        return Err(DelaunayError::TooFewPoints { count: points.len() });
    }
    // u32::MAX marks "no tet" and the ghost vertex, so the last valid index is u32::MAX - 1.
    let max = u32::MAX as usize - 1;
    if points.len() > max {
        return Err(DelaunayError::TooManyPoints { count: points.len(), max });
    }
    for (index, &point) in points.iter().enumerate() {
        if !point.is_finite() {
            return Err(DelaunayError::NonFinite { index, point });
        }
        if point.abs().max_element() > MAX_COORDINATE {
            return Err(DelaunayError::OutOfRange { index, point });
        }
    }
    Ok(())
}

/// Splits the indices into the first of each group of equal points (ascending) and the
/// `[skipped, kept]` pairs for the others.
fn split_duplicates(points: &[DVec3]) -> (Vec<u32>, Vec<[u32; 2]>) {
    // `+ 0.0` turns -0.0 into 0.0, so equal coordinates compare equal under total_cmp.
    let key = |i: u32| (points[i as usize] + DVec3::ZERO).to_array();
    let mut sorted: Vec<u32> = (0..points.len() as u32).collect();
    sorted.sort_unstable_by(|&i, &j| {
        let (a, b) = (key(i), key(j));
        a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])).then(a[2].total_cmp(&b[2])).then(i.cmp(&j))
    });
    let mut unique = Vec::with_capacity(points.len());
    let mut duplicates = Vec::new();
    let mut kept = NO_TET;
    for &i in &sorted {
        if kept != NO_TET && points[i as usize] == points[kept as usize] {
            duplicates.push([i, kept]);
        } else {
            kept = i;
            unique.push(i);
        }
    }
    unique.sort_unstable();
    (unique, duplicates)
}

/// The first four affinely independent points, in order (indices into `points`), or `None` when
/// all points are coplanar.
fn first_simplex(points: &[DVec3]) -> Option<[u32; 4]> {
    let a = 0;
    let b = (1..points.len()).find(|&i| points[i] != points[a])?;
    let c = (b + 1..points.len()).find(|&i| !collinear(points[a], points[b], points[i]))?;
    let d = (c + 1..points.len()).find(|&i| orient(points[a], points[b], points[c], points[i]) != 0.0)?;
    Some([a, b, c, d].map(|i| i as u32))
}
