//! What `shatter sim` writes per frame: a binary PLY point cache (position, velocity, damage;
//! readable by Blender and Houdini) and the append-only bond-break log.
//!
//! Both are checksummed: the PLY header carries a CRC-32 of its body in a comment (see
//! [`shatter_core::ply`]), and each block of the break log carries one of its records. Formats:
//! docs/FORMATS.md.

use std::fs::{File, OpenOptions};
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use shatter_core::ply::{Column, PlyError, PointCache};
use shatter_core::stage_file::write_atomically;

use crate::simulation::BreakEvent;

/// Why a frame file or the break log could not be written or read. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum FrameFileError {
    /// The operating system refused an operation.
    #[error("{path}: cannot {action}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What was being done.
        action: &'static str,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A point cache could not be read or written.
    #[error(transparent)]
    Ply(#[from] PlyError),
    /// The file is not what it should be.
    #[error("{path}: {what}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
}

fn io_error<'a>(path: &'a Path, action: &'static str) -> impl FnOnce(std::io::Error) -> FrameFileError + 'a {
    move |source| FrameFileError::Io { path: path.to_path_buf(), action, source }
}

fn invalid(path: &Path, what: impl Into<String>) -> FrameFileError {
    FrameFileError::Invalid { path: path.to_path_buf(), what: what.into() }
}

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
            ],
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
        let column = |name: &str| cache.floats(name).map(<[f32]>::to_vec).ok_or_else(|| missing(name));
        Ok(PointFrame {
            frame,
            step,
            time_s,
            position: [column("x")?, column("y")?, column("z")?],
            velocity: [column("vx")?, column("vy")?, column("vz")?],
            damage: column("damage")?,
        })
    }
}

const LOG_MAGIC: &[u8; 8] = b"SHBREAKS";
const LOG_VERSION: u32 = 1;
const LOG_HEADER_LEN: u64 = 16;
const BLOCK_HEADER_LEN: u64 = 16;
const RECORD_LEN: u64 = 16;

/// One frame's block of the break log: the bonds that broke while simulating up to `frame`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BreakBlock {
    /// The frame the block ends at.
    pub frame: u32,
    /// The breaks, in order.
    pub events: Vec<BreakEvent>,
}

/// The append-only bond-break log.
#[derive(Debug)]
pub struct BreakLog {
    path: PathBuf,
    file: File,
    len: u64,
}

impl BreakLog {
    /// Creates an empty log at `path` (replacing any old one).
    pub fn create(path: &Path) -> Result<BreakLog, FrameFileError> {
        let mut header = LOG_MAGIC.to_vec();
        header.extend_from_slice(&LOG_VERSION.to_le_bytes());
        header.extend_from_slice(&0u32.to_le_bytes());
        write_atomically(path, &[&header]).map_err(io_error(path, "create"))?;
        BreakLog::open_at(path, LOG_HEADER_LEN)
    }

    /// Opens an existing log and cuts it back to `len` bytes (the length a checkpoint recorded:
    /// blocks written after the checkpoint are written again on resume).
    pub fn open_at(path: &Path, len: u64) -> Result<BreakLog, FrameFileError> {
        let file = OpenOptions::new().read(true).write(true).open(path).map_err(io_error(path, "open"))?;
        let actual = file.metadata().map_err(io_error(path, "stat"))?.len();
        if actual < len {
            return Err(invalid(path, format!("the log is {actual} bytes, shorter than the {len} the checkpoint saw")));
        }
        file.set_len(len).map_err(io_error(path, "truncate"))?;
        Ok(BreakLog { path: path.to_path_buf(), file, len })
    }

    /// Current length in bytes.
    pub fn len(&self) -> u64 {
        self.len
    }

    /// True when the log holds no block.
    pub fn is_empty(&self) -> bool {
        self.len <= LOG_HEADER_LEN
    }

    /// Appends one frame's block and makes it durable.
    pub fn append(&mut self, frame: u32, events: &[BreakEvent]) -> Result<(), FrameFileError> {
        let mut records = Vec::with_capacity(events.len() * RECORD_LEN as usize);
        for event in events {
            records.extend_from_slice(&event.step.to_le_bytes());
            records.extend_from_slice(&event.bond.to_le_bytes());
        }
        let mut block = Vec::with_capacity(BLOCK_HEADER_LEN as usize + records.len());
        block.extend_from_slice(&frame.to_le_bytes());
        block.extend_from_slice(&(events.len() as u32).to_le_bytes());
        block.extend_from_slice(&crc32fast::hash(&records).to_le_bytes());
        block.extend_from_slice(&0u32.to_le_bytes());
        block.extend_from_slice(&records);
        self.file.seek(SeekFrom::Start(self.len)).map_err(io_error(&self.path, "seek"))?;
        self.file.write_all(&block).map_err(io_error(&self.path, "write"))?;
        self.file.sync_data().map_err(io_error(&self.path, "sync"))?;
        self.len += block.len() as u64;
        Ok(())
    }

    /// Reads and checks the whole log at `path`.
    pub fn read(path: &Path) -> Result<Vec<BreakBlock>, FrameFileError> {
        let bytes = std::fs::read(path).map_err(io_error(path, "read"))?;
        if bytes.len() < LOG_HEADER_LEN as usize || &bytes[..8] != LOG_MAGIC {
            return Err(invalid(path, "not a shatter break log (it does not start with \"SHBREAKS\")"));
        }
        let word = |at: usize| u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
        let long = |at: usize| {
            let mut b = [0u8; 8];
            b.copy_from_slice(&bytes[at..at + 8]);
            u64::from_le_bytes(b)
        };
        if word(8) != LOG_VERSION {
            return Err(invalid(
                path,
                format!("break log version {} is not supported (this build reads {LOG_VERSION})", word(8)),
            ));
        }
        let mut blocks = Vec::new();
        let mut at = LOG_HEADER_LEN as usize;
        while at < bytes.len() {
            if bytes.len() - at < BLOCK_HEADER_LEN as usize {
                return Err(invalid(path, format!("truncated: a block header is cut off at byte {at}")));
            }
            let (frame, count, crc) = (word(at), word(at + 4) as usize, word(at + 8));
            let start = at + BLOCK_HEADER_LEN as usize;
            let end = count.checked_mul(RECORD_LEN as usize).and_then(|len| start.checked_add(len));
            let Some(end) = end.filter(|end| *end <= bytes.len()) else {
                return Err(invalid(path, format!("truncated: the block for frame {frame} is cut off")));
            };
            if crc32fast::hash(&bytes[start..end]) != crc || word(at + 12) != 0 {
                return Err(invalid(path, format!("corrupted: the block for frame {frame} fails its checksum")));
            }
            let events =
                (0..count).map(|r| BreakEvent { step: long(start + r * 16), bond: long(start + r * 16 + 8) }).collect();
            blocks.push(BreakBlock { frame, events });
            at = end;
        }
        Ok(blocks)
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

    #[test]
    fn the_break_log_appends_truncates_and_checks() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("breaks.log");
        let mut log = BreakLog::create(&path).expect("create");
        log.append(2, &[BreakEvent { step: 5, bond: 77 }]).expect("append");
        let after_first = log.len();
        log.append(3, &[BreakEvent { step: 9, bond: 1 }, BreakEvent { step: 9, bond: 4 }]).expect("append");
        log.append(4, &[]).expect("append");
        let blocks = BreakLog::read(&path).expect("read");
        assert_eq!(blocks.len(), 3);
        assert_eq!(blocks[1].events[1], BreakEvent { step: 9, bond: 4 });
        drop(log);
        let log = BreakLog::open_at(&path, after_first).expect("reopen");
        assert_eq!(log.len(), after_first);
        assert_eq!(BreakLog::read(&path).expect("read").len(), 1);
        let mut bytes = std::fs::read(&path).expect("bytes");
        let last = bytes.len() - 1;
        bytes[last] ^= 1;
        std::fs::write(&path, &bytes).expect("write");
        assert!(BreakLog::read(&path).expect_err("flip").to_string().contains("corrupted"));
        std::fs::write(&path, &bytes[..bytes.len() - 3]).expect("write");
        assert!(BreakLog::read(&path).expect_err("cut").to_string().contains("truncated"));
    }
}
