//! 3D Delaunay tetrahedralization: incremental Bowyer-Watson on exact predicates.
//!
//! [`tetrahedralize`] turns a point set into tetrahedra that tile its convex hull, each with an
//! empty circumsphere (no input point strictly inside it).
//!
//! # Algorithm
//!
//! Points are inserted one at a time into a triangulation that is closed off by *ghost* tets:
//! every convex hull face carries a ghost tet whose fourth vertex is a symbolic vertex at
//! infinity, so no bounding "super" tetrahedron (and no clean-up after one) is needed. To insert a
//! point `p`:
//!
//! 1. **Locate**: walk from the last tet created towards `p`, crossing any face whose plane has
//!    `p` strictly on its far side (a stochastic visibility walk: the first face tried is picked
//!    at random, which guarantees the walk ends). The walk stops in a tet whose closed volume holds
//!    `p`, or in a ghost tet when `p` is strictly outside the hull.
//! 2. **Cavity**: starting there, gather by breadth-first search every tet *in conflict* with
//!    `p`: a real tet whose circumsphere holds `p` strictly inside, or a ghost tet whose hull face
//!    has `p` strictly on its outer side (or, with `p` exactly in the face's plane, strictly inside
//!    the face's circumcircle).
//! 3. **Fill**: delete the cavity and join `p` to each face on its boundary. New tets reuse the
//!    deleted tets' slots; their mutual neighbours are matched through a small hash table keyed by
//!    the boundary edge they share.
//!
//! All geometric decisions use Shewchuk's adaptive exact predicates ([`robust::orient3d`],
//! [`robust::insphere`]), so every decision is exact for finite inputs (coordinates are limited to
//! ±1e30 so nothing overflows; like any floating-point exact predicate they assume that products of
//! coordinate differences do not underflow, which holds unless distinct points are closer than about
//! 1e-60).
//!
//! # Degeneracies
//!
//! Ties are broken by one consistent rule: **a point exactly on a circumsphere (insphere = 0), or
//! exactly in the plane of a hull face and on or outside its circumcircle, is not in conflict.**
//! Under this rule the triangulation stays Delaunay after every insertion (no point strictly inside
//! any circumsphere), the cavity is always star-shaped from `p` and connected, and `p` is strictly
//! on the inner side of every cavity boundary face, so every new tet has non-zero volume. Where
//! five or more points are cospherical the rule picks one of the valid Delaunay triangulations;
//! which one depends on the insertion order, which is itself deterministic, so the same input
//! always gives the same output.
//!
//! Exactly repeated points are found up front (before any geometry) and skipped; see
//! [`Tetrahedralization::duplicates`].
//!
//! # Order
//!
//! Points are inserted in a biased randomized insertion order (BRIO): a deterministic shuffle
//! split into rounds of doubling size, each round sorted along a Z-order (Morton) curve. The
//! random rounds keep the cavities small in expectation; the curve keeps each walk short and the
//! memory traffic local (points are also copied into insertion order for the same reason).
//!
//! # Files
//!
//! The entry point, the checks, duplicates and first simplex are in `tetrahedralization.rs`; the
//! insertion order in `insertion_order.rs` (with its generator in `splitmix.rs`); the walk, cavity
//! and fill in `bowyer_watson.rs` (with the edge table that links new tets in `edge_table.rs`);
//! the exact predicates in `predicates.rs`; the tests in `tests.rs`.

mod bowyer_watson;
mod edge_table;
mod insertion_order;
mod predicates;
mod splitmix;
#[cfg(test)]
mod tests;
mod tetrahedralization;

pub use tetrahedralization::{DelaunayError, NO_NEIGHBOR, Tetrahedralization, tet_volume, tetrahedralize};
