//! The append-only bond-break log, `frames/breaks.log`: one checksummed block of (step, bond)
//! records per frame, from which the intact bond set at any frame is exact.

use std::fs::{File, OpenOptions};
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use super::FrameFileError;
use super::frame_file_error::{invalid, io_error};
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
const LOG_VERSION: u32 = 2;
const LOG_HEADER_LEN: u64 = 16;
const BLOCK_HEADER_LEN: u64 = 16;
const RECORD_LEN: u64 = 16;
/// The frame of the first block: frame 1 is the rest state, so breaks start with frame 2.
const FIRST_BLOCK_FRAME: u32 = 2;

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
        let file = OpenOptions::new().read(true).write(true).open(path).map_err(io_error(path, "open"))?;
        Ok(BreakLog { path: path.to_path_buf(), file, len: LOG_HEADER_LEN })
    }

    /// Opens an existing log and cuts it back to `len` bytes (the length a checkpoint recorded:
    /// blocks written after the checkpoint are written again on resume), returning the blocks it
    /// keeps. The first `len` bytes must be a whole, valid log; nothing is cut from a file that
    /// is not one.
    pub fn open_at(path: &Path, len: u64) -> Result<(BreakLog, Vec<BreakBlock>), FrameFileError> {
        let file = OpenOptions::new().read(true).write(true).open(path).map_err(io_error(path, "open"))?;
        let bytes = std::fs::read(path).map_err(io_error(path, "read"))?;
        let Some(kept) = usize::try_from(len).ok().filter(|len| *len <= bytes.len()) else {
            let actual = bytes.len();
            return Err(invalid(path, format!("the log is {actual} bytes, shorter than the {len} the checkpoint saw")));
        };
        let blocks = parse(path, &bytes[..kept])?;
        file.set_len(len).map_err(io_error(path, "truncate"))?;
        Ok((BreakLog { path: path.to_path_buf(), file, len }, blocks))
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
        let mut block = Vec::with_capacity(BLOCK_HEADER_LEN as usize + events.len() * RECORD_LEN as usize);
        block.extend_from_slice(&frame.to_le_bytes());
        block.extend_from_slice(&(events.len() as u32).to_le_bytes());
        block.extend_from_slice(&[0; 8]); // checksum and a zero word, filled in below
        for event in events {
            block.extend_from_slice(&event.step.to_le_bytes());
            block.extend_from_slice(&event.bond.to_le_bytes());
        }
        let crc = block_checksum(&block);
        block[8..12].copy_from_slice(&crc.to_le_bytes());
        self.file.seek(SeekFrom::Start(self.len)).map_err(io_error(&self.path, "seek"))?;
        let written = self.file.write_all(&block).and_then(|()| self.file.sync_data());
        if let Err(source) = written {
            // A full disk (or any failed write) must not leave part of a block in the log.
            let _ = self.file.set_len(self.len);
            return Err(FrameFileError::Io { path: self.path.clone(), action: "append to", source });
        }
        self.len += block.len() as u64;
        Ok(())
    }

    /// Reads and checks the whole log at `path`: its header, and every block's size, checksum
    /// (over the block's frame and count as well as its records) and frame, which must follow
    /// the previous block's.
    pub fn read(path: &Path) -> Result<Vec<BreakBlock>, FrameFileError> {
        let bytes = std::fs::read(path).map_err(io_error(path, "read"))?;
        parse(path, &bytes)
    }

    /// [`BreakLog::read`], and checks that the log reaches `last_frame`, the last frame the
    /// simulation wrote: a log cut at a block boundary is whole in itself but misses frames.
    pub fn read_through(path: &Path, last_frame: u32) -> Result<Vec<BreakBlock>, FrameFileError> {
        let blocks = BreakLog::read(path)?;
        let reached = blocks.last().map_or(FIRST_BLOCK_FRAME - 1, |block| block.frame);
        if reached < last_frame {
            return Err(invalid(
                path,
                format!(
                    "truncated: the log ends at frame {reached}, but the simulation wrote frame {last_frame}; run \
                     `shatter sim` again"
                ),
            ));
        }
        Ok(blocks)
    }
}

/// The CRC-32 of a block with its checksum field counted as zero.
fn block_checksum(block: &[u8]) -> u32 {
    let mut hasher = crc32fast::Hasher::new();
    hasher.update(&block[..8]);
    hasher.update(&[0; 4]);
    hasher.update(&block[12..]);
    hasher.finalize()
}

fn parse(path: &Path, bytes: &[u8]) -> Result<Vec<BreakBlock>, FrameFileError> {
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
    if word(12) != 0 {
        return Err(invalid(path, format!("the header's reserved word is {:#010x}, not 0", word(12))));
    }
    let mut blocks = Vec::new();
    let mut at = LOG_HEADER_LEN as usize;
    let mut expected_frame = FIRST_BLOCK_FRAME;
    while at < bytes.len() {
        if bytes.len() - at < BLOCK_HEADER_LEN as usize {
            return Err(invalid(path, format!("truncated: a block header is cut off at byte {at}")));
        }
        let (frame, count, crc) = (word(at), word(at + 4) as usize, word(at + 8));
        let start = at + BLOCK_HEADER_LEN as usize;
        let end = count.checked_mul(RECORD_LEN as usize).and_then(|len| start.checked_add(len));
        let Some(end) = end.filter(|end| *end <= bytes.len()) else {
            return Err(invalid(
                path,
                format!("truncated or corrupted: the block at byte {at} (frame {frame}) runs past the end"),
            ));
        };
        if block_checksum(&bytes[at..end]) != crc || word(at + 12) != 0 {
            return Err(invalid(path, format!("corrupted: the block at byte {at} (frame {frame}) fails its checksum")));
        }
        if frame != expected_frame {
            return Err(invalid(
                path,
                format!("corrupted: the block at byte {at} is for frame {frame}, not {expected_frame}"),
            ));
        }
        let events =
            (0..count).map(|r| BreakEvent { step: long(start + r * 16), bond: long(start + r * 16 + 8) }).collect();
        blocks.push(BreakBlock { frame, events });
        expected_frame = expected_frame.saturating_add(1);
        at = end;
    }
    Ok(blocks)
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
        assert_eq!(BreakLog::read_through(&path, 4).expect("whole"), blocks);
        drop(log);
        let (log, kept) = BreakLog::open_at(&path, after_first).expect("reopen");
        assert_eq!(log.len(), after_first);
        assert_eq!(kept, blocks[..1]);
        assert_eq!(BreakLog::read(&path).expect("read").len(), 1);
        let mut bytes = std::fs::read(&path).expect("bytes");
        let last = bytes.len() - 1;
        bytes[last] ^= 1;
        std::fs::write(&path, &bytes).expect("write");
        assert!(BreakLog::read(&path).expect_err("flip").to_string().contains("corrupted"));
        std::fs::write(&path, &bytes[..bytes.len() - 3]).expect("write");
        assert!(BreakLog::read(&path).expect_err("cut").to_string().contains("truncated"));
    }

    /// A log of frames 2 to 4 and the byte offset of each block.
    fn three_blocks(path: &Path) -> (Vec<u8>, [usize; 3]) {
        let mut log = BreakLog::create(path).expect("create");
        let mut starts = [0; 3];
        for (i, frame) in (2..=4).enumerate() {
            starts[i] = log.len() as usize;
            log.append(frame, &[BreakEvent { step: u64::from(frame) * 10, bond: u64::from(frame) }]).expect("append");
        }
        (std::fs::read(path).expect("bytes"), starts)
    }

    #[test]
    fn every_byte_of_a_block_is_checked_and_a_cut_at_a_block_boundary_is_found() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("breaks.log");
        let (bytes, starts) = three_blocks(&path);
        // a flipped bit anywhere in a block (frame, count, checksum, zero word, records) is caught
        for offset in starts[1]..starts[2] {
            let mut flipped = bytes.clone();
            flipped[offset] ^= 0x10;
            std::fs::write(&path, &flipped).expect("write");
            let message = BreakLog::read(&path).expect_err("flipped bit").to_string();
            assert!(message.contains("corrupted") || message.contains("truncated"), "byte {offset}: {message}");
        }
        // a log cut exactly after frame 3's block is whole in itself, but misses frame 4
        std::fs::write(&path, &bytes[..starts[2]]).expect("write");
        assert_eq!(BreakLog::read(&path).expect("a shorter log").len(), 2);
        let message = BreakLog::read_through(&path, 4).expect_err("cut at a boundary").to_string();
        assert!(message.contains("ends at frame 3, but the simulation wrote frame 4"), "{message}");
        // blocks out of order (frame 2's block removed) are refused
        let mut skipped = bytes[..starts[0]].to_vec();
        skipped.extend_from_slice(&bytes[starts[1]..]);
        std::fs::write(&path, &skipped).expect("write");
        assert!(BreakLog::read(&path).expect_err("gap").to_string().contains("is for frame 3, not 2"));
    }

    #[test]
    fn resuming_never_cuts_a_file_that_is_not_a_break_log() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("breaks.log");
        let text = b"these are my notes, not a break log; keep them".repeat(4);
        std::fs::write(&path, &text).expect("write");
        assert!(BreakLog::open_at(&path, 16).expect_err("not a log").to_string().contains("not a shatter break log"));
        assert_eq!(std::fs::read(&path).expect("read"), text);
        let (bytes, starts) = three_blocks(&path);
        let inside_a_block = starts[1] as u64 + 5;
        assert!(BreakLog::open_at(&path, inside_a_block).is_err(), "a length inside a block is no checkpoint's");
        assert_eq!(std::fs::read(&path).expect("read"), bytes);
    }
}
