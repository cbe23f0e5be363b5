//! Preprocessing: from a scene's geometry to a particle set.
//!
//! [`preprocess`] (in [`preprocess_driver`]) runs the stage. The source (a box or a closed mesh,
//! repaired as [`mod@repair`] describes) is scaled into metres, sampled into particles in that
//! frame by one of the [`samplers`] (cubes on a lattice by [`samplers::grid`], the tets of a
//! layered shell by [`samplers::tet_shell`], clipped Voronoi cells ([`clipped_voronoi`]) of
//! blue-noise sites ([`samplers::blue_noise`]) by [`samplers::voronoi`]), ordered along a Z-curve
//! ([`order`]), bonded within the horizon by k-d tree range queries ([`bonds`]), and finally
//! rotated and translated into the world ([`samplers::particle_assembly`]).
//!
//! Shared geometry: the inside test on lattice lines ([`inside`], on a [`lattice`]), exact queries
//! on the mesh ([`mesh_query`]) and the Delaunay tetrahedralization ([`delaunay`]).

pub mod bonds;
pub mod clipped_voronoi;
pub mod delaunay;
pub mod inside;
pub mod lattice;
pub mod mesh_query;
mod order;
mod preprocess_driver;
pub mod repair;
pub mod samplers;

#[cfg(test)]
mod test_meshes;

pub use preprocess_driver::{PreprocessError, Preprocessed, preprocess};
