//! What `shatter sim` writes per frame: a binary PLY point cache (position, velocity, damage;
//! readable by Blender and Houdini) and the append-only bond-break log.
//!
//! Both are checksummed: the PLY header carries a CRC-32 of its body in a comment, and each block
//! of the break log carries one of its records. Formats: docs/FORMATS.md.

use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

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

const PLY_PROPERTIES: [&str; 7] = ["x", "y", "z", "vx", "vy", "vz", "damage"];

impl PointFrame {
    fn body(&self) -> Vec<u8> {
        let n = self.damage.len();
        let mut body = Vec::with_capacity(n * PLY_PROPERTIES.len() * 4);
        for i in 0..n {
            let values = [
                self.position[0][i],
                self.position[1][i],
                self.position[2][i],
                self.velocity[0][i],
                self.velocity[1][i],
                self.velocity[2][i],
                self.damage[i],
            ];
            for value in values {
                body.extend_from_slice(&value.to_le_bytes());
            }
        }
        body
    }

    /// Writes the frame as a binary little-endian PLY, atomically (temporary file, fsync, rename).
    pub fn write(&self, path: &Path) -> Result<(), FrameFileError> {
        let body = self.body();
        let mut header = String::from("ply\nformat binary_little_endian 1.0\n");
        header.push_str("comment written by shatter sim\n");
        header.push_str(&format!("comment shatter frame {}\n", self.frame));
        header.push_str(&format!("comment shatter step {}\n", self.step));
        header.push_str(&format!("comment shatter time_s {:e}\n", self.time_s));
        header.push_str(&format!("comment shatter body_crc32 {:08x}\n", crc32fast::hash(&body)));
        header.push_str(&format!("element vertex {}\n", self.damage.len()));
        for name in PLY_PROPERTIES {
            header.push_str(&format!("property float {name}\n"));
        }
        header.push_str("end_header\n");
        write_atomically(path, &[header.as_bytes(), &body])
    }

    /// Reads a frame written by [`PointFrame::write`], checking its header, size and checksum.
    pub fn read(path: &Path) -> Result<PointFrame, FrameFileError> {
        let file = File::open(path).map_err(io_error(path, "open"))?;
        let file_len = file.metadata().map_err(io_error(path, "stat"))?.len();
        let mut input = BufReader::new(file);
        let mut header_len = 0u64;
        let mut lines = Vec::new();
        loop {
            let mut line = Vec::new();
            let read = input.by_ref().take(1024).read_until(b'\n', &mut line).map_err(io_error(path, "read"))?;
            if read == 0 || !line.ends_with(b"\n") {
                return Err(invalid(path, "not a shatter PLY point cache: the header does not end"));
            }
            header_len += read as u64;
            let line = String::from_utf8_lossy(&line).trim_end().to_string();
            if line == "end_header" {
                break;
            }
            lines.push(line);
            if lines.len() > 64 {
                return Err(invalid(path, "not a shatter PLY point cache: the header is too long"));
            }
        }
        let field = |prefix: &str| lines.iter().find_map(|line| line.strip_prefix(prefix).map(str::to_owned));
        let number = |prefix: &str| -> Result<String, FrameFileError> {
            field(prefix).ok_or_else(|| invalid(path, format!("the PLY header lacks `{}`", prefix.trim())))
        };
        if lines.first().map(String::as_str) != Some("ply")
            || !lines.iter().any(|l| l == "format binary_little_endian 1.0")
        {
            return Err(invalid(path, "not a binary little-endian PLY file"));
        }
        let properties: Vec<&str> = lines.iter().filter_map(|l| l.strip_prefix("property float ")).collect();
        if properties != PLY_PROPERTIES {
            return Err(invalid(
                path,
                format!("unexpected PLY properties {properties:?}, expected {PLY_PROPERTIES:?}"),
            ));
        }
        let parse = |text: String, what: &str| {
            text.trim().parse::<u64>().map_err(|_| invalid(path, format!("bad {what} {text:?} in the PLY header")))
        };
        let n = parse(number("element vertex ")?, "vertex count")?;
        let frame = parse(number("comment shatter frame ")?, "frame")?;
        let step = parse(number("comment shatter step ")?, "step")?;
        let time_s = number("comment shatter time_s ")?
            .trim()
            .parse::<f64>()
            .map_err(|_| invalid(path, "bad time in the PLY header"))?;
        let crc = u32::from_str_radix(number("comment shatter body_crc32 ")?.trim(), 16)
            .map_err(|_| invalid(path, "bad checksum in the PLY header"))?;
        let body_len = n.checked_mul(28).ok_or_else(|| invalid(path, "absurd vertex count"))?;
        if header_len + body_len != file_len {
            return Err(invalid(
                path,
                format!(
                    "the file is {file_len} bytes but its header promises {} ({})",
                    header_len + body_len,
                    if file_len < header_len + body_len { "truncated" } else { "extra bytes at the end" }
                ),
            ));
        }
        let mut body = vec![0u8; body_len as usize];
        input.read_exact(&mut body).map_err(io_error(path, "read"))?;
        let computed = crc32fast::hash(&body);
        if computed != crc {
            return Err(invalid(path, format!("corrupted: body checksum {computed:08x}, header says {crc:08x}")));
        }
        let n = n as usize;
        let value = |i: usize, p: usize| {
            let at = (i * 7 + p) * 4;
            f32::from_le_bytes([body[at], body[at + 1], body[at + 2], body[at + 3]])
        };
        let column = |p: usize| (0..n).map(|i| value(i, p)).collect::<Vec<f32>>();
        Ok(PointFrame {
            frame: frame as u32,
            step,
            time_s,
            position: [column(0), column(1), column(2)],
            velocity: [column(3), column(4), column(5)],
            damage: column(6),
        })
    }
}

/// Writes `parts` to `path` through a temporary file in the same folder, fsynced and renamed.
pub fn write_atomically(path: &Path, parts: &[&[u8]]) -> Result<(), FrameFileError> {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let temp = path.with_file_name(format!(".{name}.partial-{}", std::process::id()));
    let result = (|| {
        let mut file = File::create(&temp).map_err(io_error(&temp, "create"))?;
        for part in parts {
            file.write_all(part).map_err(io_error(&temp, "write"))?;
        }
        file.sync_all().map_err(io_error(&temp, "sync"))?;
        std::fs::rename(&temp, path).map_err(io_error(path, "rename into place"))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&temp);
    }
    result
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
        write_atomically(path, &[&header])?;
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
