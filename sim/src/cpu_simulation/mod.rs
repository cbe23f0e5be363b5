//! The CPU simulation: state in structure-of-arrays form, advanced by velocity Verlet; the
//! production backend and the reference for the GPU one.
//!
//! - `cpu_backend`: the simulation itself: its state, its construction, what it tells of the
//!   state, and what it does as a [`crate::Backend`].
//! - `verlet_step`: the step: velocity Verlet's kick passes around the force evaluation.
//! - `force_evaluation`: the forces of a step: the bonds' by material model; chunk by chunk the
//!   contact and body forces and the next compression boosts; the grips; the breaks.
//! - `bond_index`: which pairs are bonded and intact, for contact.

mod bond_index;
mod cpu_backend;
mod force_evaluation;
mod verlet_step;

pub use cpu_backend::CpuSimulation;
