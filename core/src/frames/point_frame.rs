//! One frame of the point cache: `frames/points.####.ply`, a checksummed binary PLY of
//! positions, velocities and damage.

use std::path::Path;

use super::FrameFileError;
use super::frame_file_error::invalid;
use crate::ply::{Column, PointCache};

/// One frame of the point cache.
#[derive(Debug, Clone, PartialEq)]
pub struct PointFrame {
    /// Frame number (1 is the rest state).
    pub frame: u32,
    /// Steps simulated to reach it.
    pub step: u64,
    /// Simulated time, seconds.
    pub time_s: f64,
    /// Positions, metres (x, y, z arrays).
    pub position: [Vec<f32>; 3],
    /// Velocities, m/s.
    pub velocity: [Vec<f32>; 3],
    /// Fraction of each particle's bonds that are broken.
    pub damage: Vec<f32>,
    /// What the frame was made from ([`crate::digest::sim_inputs`]); `None` in files written
    /// before it was recorded.
    pub inputs: Option<u32>,
}

const COORDINATES: [&str; 3] = ["x", "y", "z"];
const VELOCITIES: [&str; 3] = ["vx", "vy", "vz"];

impl PointFrame {
    /// Writes the frame as a checksummed binary PLY (x, y, z, vx, vy, vz, damage), atomically.
    pub fn write(&self, path: &Path) -> Result<(), FrameFileError> {
        let mut columns = Vec::with_capacity(7);
        for (name, values) in COORDINATES.iter().zip(&self.position).chain(VELOCITIES.iter().zip(&self.velocity)) {
            columns.push((name.to_string(), Column::Float(values.clone())));
        }
        columns.push(("damage".to_string(), Column::Float(self.damage.clone())));
        let cache = PointCache {
            comments: vec![
                ("frame".into(), self.frame.to_string()),
                ("step".into(), self.step.to_string()),
                ("time_s".into(), format!("{:e}", self.time_s)),
            ]
            .into_iter()
            .chain(self.inputs.map(|inputs| ("inputs".into(), format!("{inputs:08x}"))))
            .collect(),
            columns,
        };
        Ok(cache.write(path)?)
    }

    /// Reads a frame written by [`PointFrame::write`], checking its header, size and checksum.
    pub fn read(path: &Path) -> Result<PointFrame, FrameFileError> {
        let cache = PointCache::read(path)?;
        let missing = |what: &str| invalid(path, format!("not a shatter point cache: no {what}"));
        let number = |key: &str| cache.comment(key).ok_or_else(|| missing(key));
        let frame = number("frame")?.parse().map_err(|_| missing("valid frame number"))?;
        let step = number("step")?.parse().map_err(|_| missing("valid step"))?;
        let time_s = number("time_s")?.parse().map_err(|_| missing("valid time"))?;
        let inputs = match cache.comment("inputs") {
            Some(hex) => Some(u32::from_str_radix(hex, 16).map_err(|_| missing("valid inputs digest"))?),
            None => None,
        };
        let column = |name: &str| cache.floats(name).map(<[f32]>::to_vec).ok_or_else(|| missing(name));
        Ok(PointFrame {
            frame,
            step,
            time_s,
            position: [column("x")?, column("y")?, column("z")?],
            velocity: [column("vx")?, column("vy")?, column("vz")?],
            damage: column("damage")?,
            inputs,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame() -> PointFrame {
        PointFrame {
            frame: 3,
            step: 1000,
            time_s: 1.25e-4,
            position: [vec![1.0, 2.0], vec![3.0, 4.0], vec![5.0, 6.0]],
            velocity: [vec![0.5, -0.5], vec![0.0, 1.0], vec![2.0, 3.0]],
            damage: vec![0.0, 0.25],
            inputs: Some(0xdead_beef),
        }
    }

    #[test]
    fn frames_round_trip_and_corruption_is_caught() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("points.0003.ply");
        frame().write(&path).expect("write");
        assert_eq!(PointFrame::read(&path).expect("read"), frame());
        let bytes = std::fs::read(&path).expect("bytes");
        let last = bytes.len() - 1;
        let mut flipped = bytes.clone();
        flipped[last] ^= 4;
        std::fs::write(&path, &flipped).expect("write");
        assert!(PointFrame::read(&path).expect_err("flip").to_string().contains("corrupted"));
        std::fs::write(&path, &bytes[..bytes.len() - 5]).expect("write");
        assert!(PointFrame::read(&path).expect_err("cut").to_string().contains("truncated"));
    }
}
