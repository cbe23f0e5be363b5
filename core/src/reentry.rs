//! A re-entry, `rigid/reentry.###.shp`: pieces of the follow-through that hit something hard
//! and go back to the simulation. The follow-through writes it with the pieces' particles as a
//! particle set of their own (`reentry/###/particles.shp`) and their rigid motion as a lead-in
//! handoff (`reentry/###/rigid/lead_in.shp`); the simulation and post then run on
//! [`pass_config`], a scene whose output folder is `reentry/###/`, exactly as on a shot; and the
//! follow-through takes the pieces they break into back. A stage file of kind
//! [`StageKind::Reentry`]; format: docs/FORMATS.md.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::stage_file::{StageFileError, StageKind, StageReader, StageWriter};
use crate::{OutputLayout, PipelineConfig};

/// Scalars of a re-entry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReentryMeta {
    /// Its number, from 1, in the order the follow-through met them.
    pub number: u32,
    /// The follow-through frame (the simulation's numbering) whose interval it starts in.
    pub frame: u32,
    /// When its simulation starts (its time 0), seconds since the first simulation's start.
    pub start_time_s: f64,
    /// The fragment ids of the pieces that went back, ascending.
    pub pieces: Vec<u32>,
    /// What they hit: "floor", "projectile N", "indenter N" or "piece N" (1-based for the
    /// spheres, as in the config; a fragment id for a piece).
    pub hit: String,
    /// The contact's approach speed, m/s.
    pub impact_speed_m_s: f64,
    /// The approach speed that made it hard, m/s (docs/DECISIONS.md#secondary-fracture).
    pub threshold_m_s: f64,
    /// What the follow-through is made from ([`crate::digest::rigid_inputs`]).
    pub inputs: u32,
    /// With `[sim.shards]`: the shot's shard centres, metres, which the re-entry's simulation
    /// keeps (it has other particles to pick them among).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shard_centres_m: Vec<[f64; 3]>,
}

/// A re-entry: its scalars and the particles of its pieces.
#[derive(Debug, Clone, PartialEq)]
pub struct Reentry {
    /// Scalars.
    pub meta: ReentryMeta,
    /// The pieces' particles (indices into the shot's particle file), ascending: particle i of
    /// the re-entry's own particle file is `members[i]`.
    pub members: Vec<u32>,
}

impl Reentry {
    /// Writes the file atomically.
    pub fn write(&self, path: &Path) -> Result<(), StageFileError> {
        let mut out = StageWriter::create(path, StageKind::Reentry)?;
        out.write_json("meta", &self.meta)?;
        out.write_rows("members", &self.members)?;
        out.finish()
    }

    /// Reads and validates the file.
    pub fn read(path: &Path) -> Result<Reentry, StageFileError> {
        let mut input = StageReader::open(path, StageKind::Reentry)?;
        let meta: ReentryMeta = input.read_json("meta")?;
        let members: Vec<u32> = input.read_rows("members")?;
        if meta.number == 0 || !meta.start_time_s.is_finite() || meta.pieces.is_empty() {
            return Err(input.malformed("its number, start time or pieces are missing".into()));
        }
        if members.is_empty() || members.windows(2).any(|pair| pair[0] >= pair[1]) {
            return Err(input.malformed("its particles are not ascending and distinct".into()));
        }
        input.finish()?;
        Ok(Reentry { meta, members })
    }
}

/// The scene that simulates `reentry` of `config`: its output folder is
/// `reentry/###/`, where the follow-through left the pieces' particle file and their motion
/// as a lead-in handoff; it has `rigid.secondary_fracture.frames` frames of its `steps_per_frame`
/// steps, no timeline (the re-entry is over in milliseconds), no starting velocity beyond the
/// pieces' own, no grips, the shot's shard centres (`reentry`'s), and no USD; two pieces that
/// met touch through a contact at least as stiff as the material's bulk modulus. `config` must
/// have `[rigid.secondary_fracture]`.
pub fn pass_config(config: &PipelineConfig, reentry: &ReentryMeta) -> PipelineConfig {
    let mut pass = config.clone();
    pass.scene.output_dir = OutputLayout::of(config).reentry_dir(reentry.number);
    if let Some(shards) = &mut pass.sim.shards {
        shards.centres_m = reentry.shard_centres_m.clone();
    }
    pass.lead_in = Some(config.lead_in.clone().unwrap_or_default());
    pass.timeline = None;
    pass.sim.initial_velocity_m_s = [0.0; 3];
    // a grip holds the body before the fracture; a piece in flight is free
    pass.sim.grip.clear();
    pass.post.usd = false;
    if reentry.pieces.len() > 1 {
        // two pieces meet through the contact force between unbonded particles: as stiff as the
        // material, so it carries an impact's pressure within a tenth of the contact distance
        // (docs/DECISIONS.md#secondary-fracture)
        pass.sim.contact.stiffness_pa = pass.sim.contact.stiffness_pa.max(config.material.bulk_modulus_pa);
    }
    if let Some(rigid) = &mut pass.rigid
        && let Some(secondary) = rigid.secondary_fracture.take()
    {
        pass.sim.frames = secondary.frames;
        pass.sim.steps_per_frame = secondary.steps_per_frame;
    }
    pass
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reentries_round_trip_and_unordered_members_are_refused() {
        let reentry = Reentry {
            meta: ReentryMeta {
                number: 2,
                frame: 31,
                start_time_s: 0.71,
                pieces: vec![3],
                hit: "floor".into(),
                impact_speed_m_s: 2.5,
                threshold_m_s: 1.1,
                inputs: 9,
                shard_centres_m: Vec::new(),
            },
            members: vec![4, 5, 9],
        };
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("reentry.002.shp");
        reentry.write(&path).expect("write");
        assert_eq!(Reentry::read(&path).expect("read"), reentry);
        Reentry { members: vec![5, 4], ..reentry }.write(&path).expect("write");
        assert!(Reentry::read(&path).expect_err("order").to_string().contains("ascending"));
    }

    #[test]
    fn a_pass_simulates_in_its_own_folder_from_its_handoff() {
        let text = "[scene]\nname = \"t\"\noutput_dir = \"out\"\nseed = 1\n[geometry]\nsource = \"box\"\n\
                    box_size_m = [0.004, 0.004, 0.004]\nsampler = \"grid\"\nspacing_m = 0.001\nhorizon_factor = 2.0\n\
                    [material]\ndensity_kg_m3 = 2200.0\nbulk_modulus_pa = 14.9e9\n[sim]\n\
                    initial_velocity_m_s = [0.0, -1.0, 0.0]\n[rigid.secondary_fracture]\nframes = 12\n";
        let text = format!("{text}[sim.shards]\ncount = 2\n");
        let config = PipelineConfig::from_toml_str(&text, Path::new("p.toml")).expect("config");
        let meta = ReentryMeta {
            number: 3,
            frame: 5,
            start_time_s: 0.1,
            pieces: vec![0],
            hit: "floor".into(),
            impact_speed_m_s: 2.0,
            threshold_m_s: 1.0,
            inputs: 1,
            shard_centres_m: vec![[0.0; 3], [0.001, 0.0, 0.0]],
        };
        let pass = pass_config(&config, &meta);
        assert_eq!(pass.sim.shards.as_ref().map(|shards| shards.centres_m.clone()), Some(meta.shard_centres_m.clone()));
        assert_eq!(pass.output_dir(), Path::new("out/reentry/003"));
        assert!(pass.lead_in.is_some() && pass.timeline.is_none());
        assert_eq!((pass.sim.frames, pass.sim.steps_per_frame), (12, 100));
        assert_eq!(pass.sim.initial_velocity_m_s, [0.0; 3]);
        assert!(pass.rigid.as_ref().is_some_and(|rigid| rigid.secondary_fracture.is_none()));
        assert_eq!(pass.sim.contact, config.sim.contact);
        // two pieces that met: their contact as stiff as the material
        let pass = pass_config(&config, &ReentryMeta { pieces: vec![0, 1], ..meta });
        assert_eq!(pass.sim.contact.stiffness_pa, 14.9e9);
    }
}
