//! The samplers, each turning the source's volume into particles of its own kind, and the dispatch
//! that runs the one the scene asks for:
//!
//! - [`grid`]: cubes of side lambda on a regular lattice (the paper's glass plate);
//! - [`tet_shell`]: the tets of a Delaunay tetrahedralization of layers under the surface (the
//!   paper's vase);
//! - [`voronoi`]: clipped Voronoi cells of blue-noise sites (the paper's dragon);
//! - [`blue_noise`]: the Poisson disk points the last two start from.
//!
//! Each sampler's file also holds the glue that makes its sample a
//! [`ParticleSet`](shatter_core::particles::ParticleSet); what they share (the placement into the
//! world, bonds, masses and the file's scalars) is in [`particle_assembly`]. A new sampler is a
//! file here and one arm of the dispatch in `sampler_dispatch.rs`.

pub mod blue_noise;
pub mod grid;
pub(crate) mod particle_assembly;
mod sampler_dispatch;
mod size_estimate;
pub mod tet_shell;
pub(crate) mod voronoi;

pub(crate) use sampler_dispatch::sample_geometry;
