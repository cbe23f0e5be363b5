//! The lead-in's result, `rigid/lead_in.shp`: when and where the intact body's rigid flight
//! hands over to the simulation, and how it moves then. The lead-in's frames themselves are
//! fragments files of one fragment (`rigid/lead_in.####.shp`). A stage file of kind
//! [`StageKind::LeadIn`]; format: docs/FORMATS.md.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::OutputLayout;
use crate::stage_file::{StageFileError, StageKind, StageReader, StageWriter};

/// The body at the handoff to the simulation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LeadIn {
    /// Frames of the shot before the simulation's first (frames 1 ..= this are the lead-in's).
    pub frames: u32,
    /// Time of the handoff since the shot's start, seconds.
    pub handoff_time_s: f64,
    /// Rotation from the rest frame, unit quaternion [x, y, z, w].
    pub rotation: [f64; 4],
    /// Translation, metres: x = R X + t.
    pub translation_m: [f64; 3],
    /// Centre of mass, metres.
    pub centre_m: [f64; 3],
    /// Velocity of the centre of mass, m/s.
    pub velocity_m_s: [f64; 3],
    /// Angular velocity, rad/s.
    pub angular_velocity_rad_s: [f64; 3],
    /// Rigid steps taken.
    pub steps: u64,
    /// What it was made from ([`crate::digest::sim_inputs`], which covers `[lead_in]`).
    pub inputs: u32,
}

impl LeadIn {
    /// Writes the file atomically.
    pub fn write(&self, path: &Path) -> Result<(), StageFileError> {
        let mut out = StageWriter::create(path, StageKind::LeadIn)?;
        out.write_json("meta", self)?;
        out.finish()
    }

    /// The scene's lead-in file (`layout.lead_in()`), read; the error names what to run when it
    /// is missing.
    pub fn read_for(layout: &OutputLayout) -> Result<LeadIn, String> {
        let path = layout.lead_in();
        if !path.is_file() {
            return Err(format!("{}: missing ([lead_in] is set); run `shatter lead-in` first", path.display()));
        }
        LeadIn::read(&path).map_err(|error| error.to_string())
    }

    /// Reads and validates the file.
    pub fn read(path: &Path) -> Result<LeadIn, StageFileError> {
        let mut input = StageReader::open(path, StageKind::LeadIn)?;
        let lead_in: LeadIn = input.read_json("meta")?;
        let norm: f64 = lead_in.rotation.iter().map(|c| c * c).sum();
        let vectors = [lead_in.translation_m, lead_in.centre_m, lead_in.velocity_m_s, lead_in.angular_velocity_rad_s];
        if (norm - 1.0).abs() > 1e-9
            || !lead_in.handoff_time_s.is_finite()
            || vectors.iter().flatten().any(|c| !c.is_finite())
        {
            return Err(input.malformed("the handoff pose or motion is not finite and unit".into()));
        }
        input.finish()?;
        Ok(lead_in)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lead_ins_round_trip_and_bad_poses_are_refused() {
        let lead_in = LeadIn {
            frames: 10,
            handoff_time_s: 0.4,
            rotation: [0.0, 0.6, 0.0, 0.8],
            translation_m: [0.0, 0.01, 0.0],
            centre_m: [0.0, 0.05, 0.0],
            velocity_m_s: [0.0, -4.0, 0.0],
            angular_velocity_rad_s: [0.0; 3],
            steps: 4000,
            inputs: 7,
        };
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("lead_in.shp");
        lead_in.write(&path).expect("write");
        assert_eq!(LeadIn::read(&path).expect("read"), lead_in);
        LeadIn { rotation: [0.0, 0.0, 0.0, 2.0], ..lead_in }.write(&path).expect("write");
        assert!(LeadIn::read(&path).expect_err("pose").to_string().contains("not finite and unit"));
    }
}
