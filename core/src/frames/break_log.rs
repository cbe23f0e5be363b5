//! The append-only bond-break log, `frames/breaks.log`: one checksummed block of (step, bond)
//! records per frame, from which the intact bond set at any frame is exact.

use std::fs::{File, OpenOptions};
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use super::{FrameFileError, invalid, io_error};
use crate::atomic_file::write_atomically;

/// A bond that broke: the step it broke in and its id.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BreakEvent {
    /// The step (1-based: the first step is step 1).
    pub step: u64,
    /// The bond id (entry index in the particle file's CSR, lower particle's row).
    pub bond: u64,
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
