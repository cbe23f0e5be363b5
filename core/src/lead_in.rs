//! The lead-in's result, `rigid/lead_in.shp`: when and where the intact body's rigid flight
//! hands over to the simulation, and how it moves then. The lead-in's frames themselves are
//! fragments files of one fragment (`rigid/lead_in.####.shp`). A re-entry of pieces that met
//! hands over several bodies, each particle moving with its own. A stage file of kind
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
    /// The motions of the further bodies of a handoff with several (a re-entry of pieces that
    /// met; the fields above are body 0's); empty for one body.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub others: Vec<BodyMotion>,
    /// With `others`, each particle's body (0 for the fields above, k for `others[k - 1]`), its
    /// own section of the file; empty otherwise.
    #[serde(skip)]
    pub body_of: Vec<u32>,
    /// For a re-entry of elastoplastic pieces: their permanent shape and plastic state, in
    /// sections of their own; `None` otherwise.
    #[serde(skip)]
    pub plastic: Option<PlasticStart>,
}

/// Where a re-entry of elastoplastic pieces starts from, as their last simulation left them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PlasticStart {
    /// Each particle's position in its body's rest frame, metres: the body's pose x = R X + t
    /// takes it to where the particle is. Its rest position, but where the piece was deformed
    /// for good.
    pub shape_m: Vec<[f32; 3]>,
    /// Each bond entry's plastic extension, metres, in the particle file's entry order.
    pub extension_m: Vec<f32>,
}

/// A further body's pose and motion at the handoff, as the lead-in's own fields give body 0's.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodyMotion {
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
}

impl BodyMotion {
    /// Whether the pose is a unit rotation and every value finite.
    fn is_sound(&self) -> bool {
        let norm: f64 = self.rotation.iter().map(|c| c * c).sum();
        let vectors = [self.translation_m, self.centre_m, self.velocity_m_s, self.angular_velocity_rad_s];
        (norm - 1.0).abs() <= 1e-9 && vectors.iter().flatten().all(|c| c.is_finite())
    }
}

impl LeadIn {
    /// Body 0's pose and motion (the only body's, but in a re-entry of pieces that met).
    pub fn motion(&self) -> BodyMotion {
        BodyMotion {
            rotation: self.rotation,
            translation_m: self.translation_m,
            centre_m: self.centre_m,
            velocity_m_s: self.velocity_m_s,
            angular_velocity_rad_s: self.angular_velocity_rad_s,
        }
    }

    /// Writes the file atomically.
    pub fn write(&self, path: &Path) -> Result<(), StageFileError> {
        let mut out = StageWriter::create(path, StageKind::LeadIn)?;
        out.write_json("meta", self)?;
        if !self.others.is_empty() {
            out.write_rows("bodies", &self.body_of)?;
        }
        if let Some(plastic) = &self.plastic {
            out.write_rows("shape", plastic.shape_m.as_flattened())?;
            out.write_rows("plastic", &plastic.extension_m)?;
        }
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
        let mut lead_in: LeadIn = input.read_json("meta")?;
        if !lead_in.handoff_time_s.is_finite()
            || !lead_in.motion().is_sound()
            || !lead_in.others.iter().all(BodyMotion::is_sound)
        {
            return Err(input.malformed("the handoff pose or motion is not finite and unit".into()));
        }
        if !lead_in.others.is_empty() {
            lead_in.body_of = input.read_rows("bodies")?;
            if lead_in.body_of.iter().any(|&body| body as usize > lead_in.others.len()) {
                return Err(input.malformed("a particle's body is not one of its bodies".into()));
            }
        }
        if !input.at_end() {
            let shape: Vec<f32> = input.read_rows("shape")?;
            let extension_m: Vec<f32> = input.read_rows("plastic")?;
            if !shape.len().is_multiple_of(3) || shape.iter().chain(&extension_m).any(|v| !v.is_finite()) {
                return Err(input.malformed("the pieces' shape or plastic extensions are not finite triples".into()));
            }
            let shape_m = shape.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
            lead_in.plastic = Some(PlasticStart { shape_m, extension_m });
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
            others: Vec::new(),
            body_of: Vec::new(),
            plastic: None,
        };
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("lead_in.shp");
        lead_in.write(&path).expect("write");
        assert_eq!(LeadIn::read(&path).expect("read"), lead_in);
        LeadIn { rotation: [0.0, 0.0, 0.0, 2.0], ..lead_in.clone() }.write(&path).expect("write");
        assert!(LeadIn::read(&path).expect_err("pose").to_string().contains("not finite and unit"));
        // two bodies: the second's motion, and each particle's body in a section of its own
        let other = BodyMotion { velocity_m_s: [0.0, 3.0, 0.0], ..lead_in.motion() };
        let two = LeadIn { others: vec![other], body_of: vec![0, 1, 1, 0], ..lead_in.clone() };
        two.write(&path).expect("write");
        assert_eq!(LeadIn::read(&path).expect("read"), two);
        LeadIn { body_of: vec![0, 2], ..two.clone() }.write(&path).expect("write");
        assert!(LeadIn::read(&path).expect_err("body").to_string().contains("not one of its bodies"));
        let spun = BodyMotion { rotation: [0.0, 0.0, 1.0, 1.0], ..other };
        LeadIn { others: vec![spun], ..two.clone() }.write(&path).expect("write");
        assert!(LeadIn::read(&path).expect_err("pose").to_string().contains("not finite and unit"));
        // elastoplastic pieces: their shape and plastic extensions, after the bodies
        let shape_m = vec![[0.0, 0.001, 0.0], [0.002, 0.0, 0.0], [0.0, 0.0, 0.001], [0.001, 0.001, 0.0]];
        let plastic = PlasticStart { shape_m, extension_m: vec![1e-6, 0.0, -2e-7] };
        let bent = LeadIn { plastic: Some(plastic.clone()), ..two };
        bent.write(&path).expect("write");
        assert_eq!(LeadIn::read(&path).expect("read"), bent);
        let one = LeadIn { plastic: Some(plastic.clone()), ..lead_in };
        one.write(&path).expect("write");
        assert_eq!(LeadIn::read(&path).expect("read"), one);
        let bad = PlasticStart { extension_m: vec![f32::NAN], ..plastic };
        LeadIn { plastic: Some(bad), ..one }.write(&path).expect("write");
        assert!(LeadIn::read(&path).expect_err("nan").to_string().contains("not finite"));
    }
}
