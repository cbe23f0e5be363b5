//! The plastic state of elastoplastic pieces (`material.model = "elastoplastic"`), which goes
//! back to the simulation with a piece (docs/DECISIONS.md#secondary-fracture): each particle's
//! place in its piece's rest frame, where the simulation left it when the piece became rigid
//! (the piece's permanent shape: its particles at that frame, taken back through the piece's
//! pose there), and each bond entry's plastic extension, from the last checkpoint of the
//! simulation the piece came from (the shot's, or a re-entry's).

use rapier3d_f64::math::{Rotation, Vector};
use shatter_core::checkpoint;
use shatter_core::config::material::MaterialModel;
use shatter_core::fragments::FragmentFrame;
use shatter_core::frames::PointFrame;
use shatter_core::lead_in::PlasticStart;
use shatter_core::{OutputLayout, ParticleSet, PipelineConfig};

use crate::hand_over::vectors;
use crate::rigid_driver::RigidError;

/// The shot's elastoplastic pieces as they are now.
pub(super) struct PlasticState {
    /// Each particle of the shot's file: its place in its piece's rest frame, metres.
    shape_m: Vec<[f32; 3]>,
    /// Each bond entry of the shot's file: its plastic extension, metres.
    extension_m: Vec<f32>,
}

/// What a re-entry's simulation left of its pieces' plastic state.
pub(super) struct PlasticReturn {
    /// The shot's bond entry of each of the re-entry's bond entries.
    entries: Vec<usize>,
    /// Each of the re-entry's bond entries' plastic extension at its last frame, metres.
    extension_m: Vec<f32>,
}

/// Where a simulation left its particles and pieces at the frame they became rigid.
pub(super) struct Handoff<'a> {
    /// The shot's index of each of the simulation's particles.
    pub(super) members: &'a [u32],
    /// Their positions, metres.
    pub(super) position_m: &'a [Vector],
    /// Their fragments and each fragment's pose, x = R X + t.
    pub(super) fragments: &'a FragmentFrame,
}

impl PlasticState {
    /// The shot's pieces as its simulation (in `layout`) left them at the handoff `handoff`;
    /// `None` but for the elastoplastic model.
    pub(super) fn of_shot(
        config: &PipelineConfig,
        layout: &OutputLayout,
        particles: &ParticleSet,
        handoff: &FragmentFrame,
    ) -> Result<Option<PlasticState>, RigidError> {
        if config.material.model != MaterialModel::Elastoplastic {
            return Ok(None);
        }
        let (position_m, _) = vectors(&PointFrame::read(&layout.frame_points(handoff.meta.frame))?);
        let position_m = &position_m;
        let extension_m = last_extensions(layout, handoff.meta.frame, particles.bonds.neighbor.len())?;
        let mut state = PlasticState { shape_m: particles.rest_position_m.clone(), extension_m };
        let members: Vec<u32> = (0..particles.len() as u32).collect();
        state.take_shape(&Handoff { members: &members, position_m, fragments: handoff });
        Ok(Some(state))
    }

    /// What the re-entry in `layout` (its particle file `subset` of the shot's `particles`,
    /// `members`) left, handed off at frame `frame`.
    pub(super) fn read_return(
        layout: &OutputLayout,
        particles: &ParticleSet,
        subset: &ParticleSet,
        members: &[u32],
        frame: u32,
    ) -> Result<PlasticReturn, RigidError> {
        let extension_m = last_extensions(layout, frame, subset.bonds.neighbor.len())?;
        Ok(PlasticReturn { entries: shot_entries(particles, subset, members), extension_m })
    }

    /// Takes a re-entry's pieces back: their shapes at its handoff, their plastic extensions at
    /// its end.
    pub(super) fn absorb(&mut self, handoff: &Handoff, back: &PlasticReturn) {
        self.take_shape(handoff);
        for (&entry, &extension) in back.entries.iter().zip(&back.extension_m) {
            self.extension_m[entry] = extension;
        }
    }

    /// The start of a re-entry whose particle file is `subset` of the shot's `particles`, its
    /// particles `members`.
    pub(super) fn start(&self, particles: &ParticleSet, subset: &ParticleSet, members: &[u32]) -> PlasticStart {
        PlasticStart {
            shape_m: members.iter().map(|&i| self.shape_m[i as usize]).collect(),
            extension_m: shot_entries(particles, subset, members).iter().map(|&e| self.extension_m[e]).collect(),
        }
    }

    /// Each particle of the shot's file in its piece's rest frame, metres.
    pub(super) fn shape_m(&self) -> &[[f32; 3]] {
        &self.shape_m
    }

    /// Each of `handoff`'s particles put back into its fragment's rest frame: R^T (x - t).
    fn take_shape(&mut self, handoff: &Handoff) {
        let fragments = handoff.fragments;
        for ((&i, x), &fragment) in handoff.members.iter().zip(handoff.position_m).zip(&fragments.fragment_of) {
            let q = fragments.rotation[fragment as usize].map(f64::from);
            let rotation = Rotation::from_xyzw(q[0], q[1], q[2], q[3]).normalize();
            let t = Vector::from_array(fragments.translation_m[fragment as usize].map(f64::from));
            self.shape_m[i as usize] = (rotation.inverse() * (*x - t)).to_array().map(|c| c as f32);
        }
    }
}

/// The plastic extensions in the last checkpoint of the simulation in `layout`, which must
/// reach frame `frame` and hold `entries` bond entries' values.
fn last_extensions(layout: &OutputLayout, frame: u32, entries: usize) -> Result<Vec<f32>, RigidError> {
    let path = layout.checkpoint();
    if !path.is_file() {
        return Err(RigidError::Input(format!(
            "{}: missing; the elastoplastic pieces' plastic state is in it: run `shatter sim` again",
            path.display()
        )));
    }
    let (meta, state) = checkpoint::read(&path)?;
    if meta.frame < frame || state.bond_state.len() != entries {
        return Err(RigidError::Input(format!(
            "{}: holds frame {} and {} plastic extensions, not frame {frame} or later and {entries}: run `shatter sim` \
             again",
            path.display(),
            meta.frame,
            state.bond_state.len()
        )));
    }
    Ok(state.bond_state)
}

/// The shot's bond entry of each bond entry of `subset`, the shot's `particles` `members`.
fn shot_entries(particles: &ParticleSet, subset: &ParticleSet, members: &[u32]) -> Vec<usize> {
    let mut entries = Vec::with_capacity(subset.bonds.neighbor.len());
    for (i, &member) in members.iter().enumerate() {
        for k in subset.bonds.row(i) {
            let neighbour = members[subset.bonds.neighbor[k] as usize];
            entries.push(particles.bonds.find(member as usize, neighbour).unwrap_or(0));
        }
    }
    entries
}
