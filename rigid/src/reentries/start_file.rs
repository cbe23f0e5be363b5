//! The files a re-entry's simulation starts from, in `reentry/###/`: the pieces' particles with
//! the bonds between them that still hold, as a particle file of their own, and their rigid
//! motions (with an elastoplastic piece's shape and plastic state) as a lead-in handoff.

use shatter_core::lead_in::{BodyMotion, LeadIn};
use shatter_core::reentry::{ReentryMeta, pass_config};
use shatter_core::{OutputLayout, ParticleSet, PipelineConfig, digest};

use super::approach::BodyState;
use super::plastic::PlasticState;
use crate::rigid_driver::RigidError;

/// What a re-entry's start is made of.
pub(super) struct StartFiles<'a> {
    pub(super) config: &'a PipelineConfig,
    /// The shot's particles.
    pub(super) particles: &'a ParticleSet,
    /// Each bond entry of the shot's particle file, by its canonical index: broken.
    pub(super) broken: &'a [bool],
    /// The pieces' plastic state, for the elastoplastic model.
    pub(super) plastic: Option<&'a PlasticState>,
}

impl StartFiles<'_> {
    /// Writes the start of re-entry `meta`, whose pieces (their particles `members`, each
    /// ascending) start as `starts` at `handoff_time_s` (seconds since the shot's start).
    /// Returns their particles, merged in ascending order.
    pub(super) fn write(
        &self,
        meta: &ReentryMeta,
        members: &[Vec<u32>],
        starts: &[BodyState],
        handoff_time_s: f64,
    ) -> Result<Vec<u32>, RigidError> {
        let (members, mut lead_in) = handoff_of(members, starts, handoff_time_s);
        let pass = pass_config(self.config, meta);
        let pass_layout = OutputLayout::of(&pass);
        create_dir(&pass_layout.rigid_dir())?;
        let mut subset = self.particles.subset(&members, |entry| !self.broken[entry]);
        lead_in.plastic = self.plastic.map(|plastic| plastic.start(self.particles, &subset, &members));
        // the particle file names its start, so the simulation's digest of it (and every
        // file made from it) changes with the start
        let mut start = crc32fast::Hasher::new();
        start.update(&rmp_serde::to_vec(&lead_in).unwrap_or_default());
        if let Some(plastic) = &lead_in.plastic {
            let values = plastic.shape_m.as_flattened().iter().chain(&plastic.extension_m);
            values.for_each(|value| start.update(&value.to_le_bytes()));
        }
        let (number, start_digest) = (meta.number, start.finalize());
        subset.meta.scene_name = format!("{}, re-entry {number} (start {start_digest:08x})", subset.meta.scene_name);
        subset.write(&pass_layout.particles())?;
        let (_, checksum) = ParticleSet::read_with_checksum(&pass_layout.particles())?;
        lead_in.inputs = digest::sim_inputs(checksum, &pass);
        lead_in.write(&pass_layout.lead_in())?;
        Ok(members)
    }
}

/// The particles of pieces `members` (each ascending), merged in ascending order, and the start
/// that hands their bodies `starts` to the simulation at `handoff_time_s` (seconds since the
/// shot's start): the first piece's motion, and with several each particle's body.
fn handoff_of(members: &[Vec<u32>], starts: &[BodyState], handoff_time_s: f64) -> (Vec<u32>, LeadIn) {
    let mut tagged: Vec<(u32, u32)> =
        members.iter().enumerate().flat_map(|(body, m)| m.iter().map(move |&i| (i, body as u32))).collect();
    tagged.sort_unstable();
    let motion = |body: &BodyState| {
        let q = body.rotation;
        BodyMotion {
            rotation: [q.x, q.y, q.z, q.w],
            translation_m: body.translation.to_array(),
            centre_m: body.centre.to_array(),
            velocity_m_s: body.linear.to_array(),
            angular_velocity_rad_s: body.angular.to_array(),
        }
    };
    let first = motion(&starts[0]);
    let others: Vec<BodyMotion> = starts[1..].iter().map(motion).collect();
    let body_of = if others.is_empty() { Vec::new() } else { tagged.iter().map(|&(_, body)| body).collect() };
    let lead_in = LeadIn {
        frames: 0,
        handoff_time_s,
        rotation: first.rotation,
        translation_m: first.translation_m,
        centre_m: first.centre_m,
        velocity_m_s: first.velocity_m_s,
        angular_velocity_rad_s: first.angular_velocity_rad_s,
        steps: 0,
        inputs: 0,
        others,
        body_of,
        plastic: None,
    };
    (tagged.into_iter().map(|(i, _)| i).collect(), lead_in)
}

fn create_dir(path: &std::path::Path) -> Result<(), RigidError> {
    std::fs::create_dir_all(path)
        .map_err(|error| RigidError::Input(format!("{}: cannot create: {error}", path.display())))
}
