//! shatter rigid: the follow-through of a shot on rigid bodies (rapier3d, on parry3d). Once the
//! fracture has quieted, every fragment becomes one rigid body with its elements' exact mass
//! properties, the pose post fitted and the velocity that keeps the particles' momentum and
//! angular momentum; the pieces then fly, collide, skid and come to rest at real speed.
//!
//! - [`mass`]: mass, centre and inertia of elements and pieces from their closed surfaces.
//! - [`velocity_fit`]: the rigid velocity that conserves momentum and angular momentum.
//! - [`shapes`]: collision shapes (hulls, or a decomposition made of the piece's elements).
//! - [`contact_rules`]: friction, restitution and the handoff's overlap allowances (a hook).
//! - [`world`]: the rapier world: pieces, floor, projectiles; stepping; snapshots.
//! - [`lead_in_driver`]: the `shatter lead-in` stage: the intact body's flight to its first
//!   contact.
//! - [`handoff`]: when the fracture has quieted; [`mod@hand_over`]: particles to bodies.
//! - [`reentries`]: pieces that hit hard go back to the simulation and return broken.
//! - [`rigid_driver`]: the `shatter rigid` stage: handoff, frames, checkpoints, resume.
//! - [`shot_usd`]: the USD of the whole shot, lead-in to rest.

mod contact_rules;
mod hand_over;
mod handoff;
mod lead_in_driver;
pub mod mass;
mod plane_contacts;
mod reentries;
mod rigid_driver;
pub mod shapes;
mod shot_usd;
mod velocity_fit;
pub mod world;

pub use hand_over::hand_over;
pub use lead_in_driver::{LeadInReport, run_lead_in};
pub use reentries::{ReentryReport, ReentryState};
pub use rigid_driver::{RigidError, RigidReport, checkpoint_world, run_rigid};
