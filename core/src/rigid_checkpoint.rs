//! The follow-through's checkpoint, `rigid/rigid.checkpoint.shp`: where the shot hands over to
//! rigid bodies, how far the follow-through has got, and the whole rapier world (bodies,
//! colliders, contacts, islands) serialised, so a resumed run continues bit for bit. A stage
//! file of kind [`StageKind::RigidCheckpoint`]; format: docs/FORMATS.md.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::stage_file::{StageFileError, StageKind, StageReader, StageWriter};

/// Scalars of a rigid checkpoint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigidMeta {
    /// The last frame of the fracture: frames after it are rigid.
    pub handoff_frame: u32,
    /// Simulated time of the handoff frame, seconds.
    pub handoff_time_s: f64,
    /// The shot's last frame.
    pub last_frame: u32,
    /// The last frame written before this checkpoint (`last_frame` when the stage is done).
    pub frame: u32,
    /// Rigid steps taken since the handoff.
    pub steps: u64,
    /// Whether every piece sleeps (the frames that remain repeat the last).
    pub asleep: bool,
    /// What the follow-through is made from ([`crate::digest::rigid_inputs`]).
    pub inputs: u32,
}

/// A rigid checkpoint: its scalars and the serialised world (JSON; opaque to every stage but
/// `rigid`).
#[derive(Debug, Clone, PartialEq)]
pub struct RigidCheckpoint {
    /// Scalars.
    pub meta: RigidMeta,
    /// The rapier world and the stage's own state beside it, serialised by `shatter rigid`.
    pub world: Vec<u8>,
}

impl RigidCheckpoint {
    /// Writes the checkpoint atomically.
    pub fn write(&self, path: &Path) -> Result<(), StageFileError> {
        let mut out = StageWriter::create(path, StageKind::RigidCheckpoint)?;
        out.write_json("meta", &self.meta)?;
        out.write_rows("world", &self.world)?;
        out.finish()
    }

    /// Reads and validates a checkpoint.
    pub fn read(path: &Path) -> Result<RigidCheckpoint, StageFileError> {
        let mut input = StageReader::open(path, StageKind::RigidCheckpoint)?;
        let meta: RigidMeta = input.read_json("meta")?;
        let world = input.read_rows("world")?;
        if meta.handoff_frame == 0 || meta.frame < meta.handoff_frame || meta.frame > meta.last_frame {
            return Err(input.malformed(format!(
                "frames out of order: handoff {}, written {}, last {}",
                meta.handoff_frame, meta.frame, meta.last_frame
            )));
        }
        input.finish()?;
        Ok(RigidCheckpoint { meta, world })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checkpoints_round_trip_and_bad_frame_ranges_are_named() {
        let checkpoint = RigidCheckpoint {
            meta: RigidMeta {
                handoff_frame: 20,
                handoff_time_s: 1e-3,
                last_frame: 92,
                frame: 44,
                steps: 960,
                asleep: false,
                inputs: 0xabcd,
            },
            world: b"{\"bodies\":[]}".to_vec(),
        };
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("rigid.checkpoint.shp");
        checkpoint.write(&path).expect("write");
        assert_eq!(RigidCheckpoint::read(&path).expect("read"), checkpoint);
        let mut wrong = checkpoint.clone();
        wrong.meta.frame = 10;
        wrong.write(&path).expect("write");
        assert!(RigidCheckpoint::read(&path).expect_err("order").to_string().contains("frames out of order"));
    }
}
