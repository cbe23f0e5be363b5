//! What the page is shown of an output folder, read as its writer leaves it (never locked): the
//! simulation's frames as they land, each as the binary message the page draws, and the bonds
//! broken by each frame.

use shatter_core::OutputLayout;
use shatter_core::frames::{BreakLog, PointFrame};

/// The first four bytes of a frame message.
pub const FRAME_MAGIC: &[u8; 4] = b"SHPV";
/// The frame message's layout version.
pub const FRAME_VERSION: u32 = 1;

/// An output folder being written or written.
#[derive(Debug, Clone)]
pub struct RunFolder {
    layout: OutputLayout,
}

impl RunFolder {
    /// The folder of `layout`.
    pub fn new(layout: OutputLayout) -> RunFolder {
        RunFolder { layout }
    }

    /// How many of the simulation's frames are there, from frame 1 on without a gap (each is
    /// written whole or not at all).
    pub fn frames(&self) -> u32 {
        (1..).take_while(|&frame| self.layout.frame_points(frame).is_file()).last().unwrap_or(0)
    }

    /// Frame `frame` as the page's message, little-endian: [`FRAME_MAGIC`], the version, the
    /// frame number and particle count n (u32 each), the simulated time (f32, seconds), then n
    /// positions (x, y, z f32, metres), n damages (f32, the fraction of a particle's bonds
    /// broken) and n speeds (f32, m/s).
    pub fn frame_message(&self, frame: u32) -> Result<Vec<u8>, String> {
        let path = self.layout.frame_points(frame);
        let points = PointFrame::read(&path).map_err(|error| error.to_string())?;
        Ok(encode(&points))
    }

    /// When frame `frame` was written, if it is there.
    pub fn frame_written(&self, frame: u32) -> Option<std::time::SystemTime> {
        std::fs::metadata(self.layout.frame_points(frame)).and_then(|meta| meta.modified()).ok()
    }

    /// The bonds broken by each frame, in frame order from frame 2 (the break log's blocks, as
    /// far as they are written whole); empty before the log exists.
    pub fn broken_bonds(&self) -> Vec<u64> {
        let blocks = BreakLog::read(&self.layout.break_log()).unwrap_or_default();
        let mut total = 0u64;
        blocks
            .iter()
            .map(|block| {
                total += block.events.len() as u64;
                total
            })
            .collect()
    }
}

/// [`RunFolder::frame_message`]'s bytes of `points`.
fn encode(points: &PointFrame) -> Vec<u8> {
    let n = points.damage.len();
    let mut bytes = Vec::with_capacity(20 + 20 * n);
    bytes.extend_from_slice(FRAME_MAGIC);
    for word in [FRAME_VERSION, points.frame, n as u32] {
        bytes.extend_from_slice(&word.to_le_bytes());
    }
    bytes.extend_from_slice(&(points.time_s as f32).to_le_bytes());
    for i in 0..n {
        for axis in &points.position {
            bytes.extend_from_slice(&axis[i].to_le_bytes());
        }
    }
    for damage in &points.damage {
        bytes.extend_from_slice(&damage.to_le_bytes());
    }
    for i in 0..n {
        let [x, y, z] = [0, 1, 2].map(|axis| points.velocity[axis][i]);
        bytes.extend_from_slice(&(x * x + y * y + z * z).sqrt().to_le_bytes());
    }
    bytes
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_message_carries_positions_damage_and_speed() {
        let points = PointFrame {
            frame: 3,
            step: 10,
            time_s: 0.5,
            position: [vec![1.0, 2.0], vec![3.0, 4.0], vec![5.0, 6.0]],
            velocity: [vec![3.0, 0.0], vec![4.0, 0.0], vec![0.0, 1.0]],
            damage: vec![0.25, 0.0],
            inputs: None,
        };
        let bytes = encode(&points);
        let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
        let float = |at: usize| f32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
        assert_eq!(&bytes[..4], FRAME_MAGIC);
        assert_eq!((word(4), word(8), word(12), float(16)), (FRAME_VERSION, 3, 2, 0.5));
        let floats: Vec<f32> = (20..bytes.len()).step_by(4).map(float).collect();
        assert_eq!(floats, [1.0, 3.0, 5.0, 2.0, 4.0, 6.0, 0.25, 0.0, 5.0, 1.0]);
    }
}
