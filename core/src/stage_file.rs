//! The binary container every stage file uses.
//!
//! Layout (all integers little-endian; documented for users in `docs/FORMATS.md`):
//!
//! ```text
//! header   magic "SHATTER\0" (8) | format version u32 | kind tag [u8; 4] | payload length u64
//! payload  sections, each: tag [u8; 16] (ASCII, NUL-padded) | dtype u8 | 3 zero bytes |
//!          components u32 | rows u64 | rows * components values | zero padding to 8 bytes
//! trailer  CRC-32 (IEEE) of the payload u32 | "SEND"
//! ```
//!
//! Files are written under a temporary name in the destination folder, fsynced, then renamed, so a
//! crash never leaves a half-written file under the real name. [`StageReader::open`] checks the
//! magic, kind, version, the exact file size and the checksum before anything is parsed; every
//! parse step is bounds-checked, so no input, however broken, makes a reader panic or allocate
//! more than the file's size.

use std::fs::File;
use std::io::{self, BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use bytemuck::Pod;
use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::atomic_file::{publish, temporary_path};

/// The first eight bytes of every stage file.
pub const MAGIC: [u8; 8] = *b"SHATTER\0";
/// The last four bytes of every stage file.
pub const TRAILER_MAGIC: [u8; 4] = *b"SEND";
/// Bytes before the payload.
pub const HEADER_LEN: u64 = 24;
/// Bytes after the payload.
pub const TRAILER_LEN: u64 = 8;
const SECTION_HEADER_LEN: u64 = 32;
const TAG_LEN: usize = 16;

/// What a stage file holds. Each kind has its own format version.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StageKind {
    /// `particles.shp`, written by `shatter preprocess`.
    Particles,
    /// `sim.checkpoint.shp`: the full simulation state, written by `shatter sim` for `--resume`.
    Checkpoint,
    /// `fragments/fragments.####.shp`: one frame's fragments, written by `shatter post`.
    Fragments,
    /// `rigid/lead_in.shp`: where the lead-in hands over to the simulation, written by
    /// `shatter lead-in`.
    LeadIn,
    /// `rigid/rigid.checkpoint.shp`: the follow-through's rigid-body world, written by
    /// `shatter rigid` for resume, and the shot's frame range.
    RigidCheckpoint,
    /// `rigid/reentry.###.shp`: pieces that hit hard and go back to the simulation, written by
    /// `shatter rigid`.
    Reentry,
}

impl StageKind {
    /// Every kind this build knows.
    pub const ALL: [StageKind; 6] = [
        StageKind::Particles,
        StageKind::Checkpoint,
        StageKind::Fragments,
        StageKind::LeadIn,
        StageKind::RigidCheckpoint,
        StageKind::Reentry,
    ];

    /// The four-byte tag in the header.
    pub fn tag(self) -> [u8; 4] {
        match self {
            StageKind::Particles => *b"PART",
            StageKind::Checkpoint => *b"CHKP",
            StageKind::Fragments => *b"FRAG",
            StageKind::LeadIn => *b"LEAD",
            StageKind::RigidCheckpoint => *b"RIGD",
            StageKind::Reentry => *b"RENT",
        }
    }

    /// The format version this build writes and reads.
    pub fn version(self) -> u32 {
        match self {
            // particles 2: trimtopes carry the parts of their faces inside the mesh
            StageKind::Particles => 2,
            _ => 1,
        }
    }

    /// A human name, as in "a particles file".
    pub fn name(self) -> &'static str {
        match self {
            StageKind::Particles => "particles",
            StageKind::Checkpoint => "checkpoint",
            StageKind::Fragments => "fragments",
            StageKind::LeadIn => "lead-in",
            StageKind::RigidCheckpoint => "rigid checkpoint",
            StageKind::Reentry => "re-entry",
        }
    }

    fn from_tag(tag: [u8; 4]) -> Option<StageKind> {
        StageKind::ALL.into_iter().find(|kind| kind.tag() == tag)
    }
}

/// Why a stage file could not be written or read. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum StageFileError {
    /// The operating system refused an operation.
    #[error("{path}: cannot {action}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What was being done ("open", "write", ...).
        action: &'static str,
        /// The I/O error.
        source: io::Error,
    },
    /// The file does not start with the stage-file magic.
    #[error("{path}: not a shatter stage file (it does not start with the bytes \"SHATTER\\0\")")]
    BadMagic {
        /// The file.
        path: PathBuf,
    },
    /// The file is shorter or longer than its header says.
    #[error(
        "{path}: the file is {actual} bytes but its header says {expected}: {}",
        if actual < expected { "it is truncated (an interrupted copy or write?)" } else { "it has extra bytes at the end" }
    )]
    SizeMismatch {
        /// The file.
        path: PathBuf,
        /// The size the header implies.
        expected: u64,
        /// The size on disk.
        actual: u64,
    },
    /// The kind tag is not one this build knows.
    #[error("{path}: unknown stage file kind {tag:?} (known: {})", StageKind::ALL.map(StageKind::name).join(", "))]
    UnknownKind {
        /// The file.
        path: PathBuf,
        /// The tag, lossily decoded.
        tag: String,
    },
    /// The file is a different kind of stage file than the caller needs.
    #[error("{path}: this is a {found} file, but a {expected} file is needed here")]
    WrongKind {
        /// The file.
        path: PathBuf,
        /// The kind the caller needs.
        expected: &'static str,
        /// The kind the file holds.
        found: &'static str,
    },
    /// The file was written by another version of the format.
    #[error(
        "{path}: {kind} format version {found} is not supported (this build reads version {supported}); \
         re-run the stage that writes it"
    )]
    UnsupportedVersion {
        /// The file.
        path: PathBuf,
        /// The file's kind.
        kind: &'static str,
        /// The version in the file.
        found: u32,
        /// The version this build reads.
        supported: u32,
    },
    /// The checksum or trailer does not match: the file is corrupted.
    #[error("{path}: corrupted: {what}")]
    Corrupted {
        /// The file.
        path: PathBuf,
        /// What does not match.
        what: String,
    },
    /// The checksum matches but the content breaks the format's rules.
    #[error("{path}: malformed: {what}")]
    Malformed {
        /// The file.
        path: PathBuf,
        /// What rule is broken.
        what: String,
    },
}

/// The element type of a section.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DType {
    /// Unsigned byte (also UTF-8 JSON).
    U8 = 1,
    /// Unsigned 32-bit integer.
    U32 = 2,
    /// Unsigned 64-bit integer.
    U64 = 3,
    /// IEEE single.
    F32 = 4,
    /// IEEE double.
    F64 = 5,
}

impl DType {
    fn from_code(code: u8) -> Option<DType> {
        [DType::U8, DType::U32, DType::U64, DType::F32, DType::F64].into_iter().find(|dtype| *dtype as u8 == code)
    }

    fn size(self) -> u64 {
        match self {
            DType::U8 => 1,
            DType::U32 | DType::F32 => 4,
            DType::U64 | DType::F64 => 8,
        }
    }
}

/// A row type that can be stored in a section: `COMPONENTS` values of `DTYPE`.
pub trait Row: Pod {
    /// The element type.
    const DTYPE: DType;
    /// Values per row.
    const COMPONENTS: u32;
}

macro_rules! impl_row {
    ($($ty:ty => $dtype:ident, $components:expr;)*) => {
        $(impl Row for $ty {
            const DTYPE: DType = DType::$dtype;
            const COMPONENTS: u32 = $components;
        })*
    };
}

impl_row! {
    u8 => U8, 1;
    u32 => U32, 1;
    u64 => U64, 1;
    f32 => F32, 1;
    f64 => F64, 1;
    [u32; 2] => U32, 2;
    [f32; 3] => F32, 3;
    [f32; 4] => F32, 4;
    [[f32; 3]; 3] => F32, 9;
    [[f32; 3]; 4] => F32, 12;
}

/// Writes one stage file: sections in order, then [`StageWriter::finish`] makes it appear under
/// its real name. Dropped unfinished, it removes its temporary file and the real name is untouched.
pub struct StageWriter {
    final_path: PathBuf,
    temp_path: PathBuf,
    out: Option<BufWriter<File>>,
    crc: crc32fast::Hasher,
    payload_len: u64,
}

impl StageWriter {
    /// Starts writing a `kind` file that will replace `path` when finished.
    pub fn create(path: &Path, kind: StageKind) -> Result<StageWriter, StageFileError> {
        let temp_path = temporary_path(path);
        let file = File::create(&temp_path).map_err(|source| StageFileError::Io {
            path: temp_path.clone(),
            action: "create",
            source,
        })?;
        let mut writer = StageWriter {
            final_path: path.to_path_buf(),
            temp_path,
            out: Some(BufWriter::with_capacity(1 << 20, file)),
            crc: crc32fast::Hasher::new(),
            payload_len: 0,
        };
        let mut header = Vec::with_capacity(HEADER_LEN as usize);
        header.extend_from_slice(&MAGIC);
        header.extend_from_slice(&kind.version().to_le_bytes());
        header.extend_from_slice(&kind.tag());
        header.extend_from_slice(&0u64.to_le_bytes());
        writer.raw_write(&header)?;
        Ok(writer)
    }

    /// Appends a section of rows.
    pub fn write_rows<R: Row>(&mut self, tag: &str, rows: &[R]) -> Result<(), StageFileError> {
        let mut header = Vec::with_capacity(SECTION_HEADER_LEN as usize);
        header.extend_from_slice(&encode_tag(tag));
        header.push(R::DTYPE as u8);
        header.extend_from_slice(&[0; 3]);
        header.extend_from_slice(&R::COMPONENTS.to_le_bytes());
        header.extend_from_slice(&(rows.len() as u64).to_le_bytes());
        self.payload_write(&header)?;
        let bytes: &[u8] = bytemuck::cast_slice(rows);
        for chunk in bytes.chunks(1 << 20) {
            self.payload_write(chunk)?;
        }
        let padding = padding_after(bytes.len() as u64);
        self.payload_write(&[0u8; 8][..padding as usize])
    }

    /// Appends a section holding `value` as UTF-8 JSON.
    pub fn write_json<T: Serialize>(&mut self, tag: &str, value: &T) -> Result<(), StageFileError> {
        let json = serde_json::to_vec(value).map_err(|error| StageFileError::Io {
            path: self.temp_path.clone(),
            action: "encode metadata",
            source: io::Error::other(error),
        })?;
        self.write_rows(tag, &json)
    }

    /// Writes the trailer, fsyncs, and renames the file to its real name.
    pub fn finish(mut self) -> Result<(), StageFileError> {
        let crc = std::mem::take(&mut self.crc).finalize();
        let mut trailer = crc.to_le_bytes().to_vec();
        trailer.extend_from_slice(&TRAILER_MAGIC);
        self.raw_write(&trailer)?;
        let io_error = |path: &Path, action: &'static str| {
            let path = path.to_path_buf();
            move |source| StageFileError::Io { path, action, source }
        };
        let Some(out) = self.out.take() else { unreachable!("a StageWriter holds its file until finish consumes it") };
        let mut file = out.into_inner().map_err(|error| StageFileError::Io {
            path: self.temp_path.clone(),
            action: "write",
            source: error.into_error(),
        })?;
        file.seek(SeekFrom::Start(16)).map_err(io_error(&self.temp_path, "seek"))?;
        file.write_all(&self.payload_len.to_le_bytes()).map_err(io_error(&self.temp_path, "write"))?;
        file.sync_all().map_err(io_error(&self.temp_path, "sync"))?;
        drop(file);
        publish(&self.temp_path, &self.final_path).map_err(io_error(&self.final_path, "rename into place"))?;
        self.temp_path.clear();
        Ok(())
    }

    fn payload_write(&mut self, bytes: &[u8]) -> Result<(), StageFileError> {
        self.crc.update(bytes);
        self.payload_len += bytes.len() as u64;
        self.raw_write(bytes)
    }

    fn raw_write(&mut self, bytes: &[u8]) -> Result<(), StageFileError> {
        let Some(out) = self.out.as_mut() else {
            unreachable!("a StageWriter holds its file until finish consumes it")
        };
        out.write_all(bytes).map_err(|source| StageFileError::Io {
            path: self.temp_path.clone(),
            action: "write",
            source,
        })
    }
}

impl Drop for StageWriter {
    fn drop(&mut self) {
        if !self.temp_path.as_os_str().is_empty() {
            drop(self.out.take());
            let _ = std::fs::remove_file(&self.temp_path);
        }
    }
}

/// The header of a stage file, read without checking the payload.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StageHeader {
    /// What the file holds.
    pub kind: StageKind,
    /// The format version of the file.
    pub version: u32,
    /// Payload bytes.
    pub payload_len: u64,
}

/// Reads and checks a stage file's header: magic, known kind, supported version, exact size.
pub fn read_header(path: &Path) -> Result<StageHeader, StageFileError> {
    let mut file = open(path)?;
    read_header_from(path, &mut file)
}

fn open(path: &Path) -> Result<File, StageFileError> {
    File::open(path).map_err(|source| StageFileError::Io { path: path.to_path_buf(), action: "open", source })
}

fn read_header_from(path: &Path, file: &mut File) -> Result<StageHeader, StageFileError> {
    let actual = file
        .metadata()
        .map_err(|source| StageFileError::Io { path: path.to_path_buf(), action: "stat", source })?
        .len();
    let mut header = [0u8; HEADER_LEN as usize];
    let available = read_up_to(file, &mut header).map_err(|source| StageFileError::Io {
        path: path.to_path_buf(),
        action: "read",
        source,
    })?;
    if available < MAGIC.len() || header[..8] != MAGIC {
        return Err(StageFileError::BadMagic { path: path.to_path_buf() });
    }
    if available < HEADER_LEN as usize {
        return Err(StageFileError::SizeMismatch {
            path: path.to_path_buf(),
            expected: HEADER_LEN + TRAILER_LEN,
            actual,
        });
    }
    let version = u32::from_le_bytes(fixed(&header[8..12]));
    let tag: [u8; 4] = fixed(&header[12..16]);
    let payload_len = u64::from_le_bytes(fixed(&header[16..24]));
    let kind = StageKind::from_tag(tag).ok_or_else(|| StageFileError::UnknownKind {
        path: path.to_path_buf(),
        tag: String::from_utf8_lossy(&tag).into_owned(),
    })?;
    if version != kind.version() {
        return Err(StageFileError::UnsupportedVersion {
            path: path.to_path_buf(),
            kind: kind.name(),
            found: version,
            supported: kind.version(),
        });
    }
    let expected = HEADER_LEN.saturating_add(payload_len).saturating_add(TRAILER_LEN);
    if expected != actual {
        return Err(StageFileError::SizeMismatch { path: path.to_path_buf(), expected, actual });
    }
    Ok(StageHeader { kind, version, payload_len })
}

/// Reads one stage file: [`StageReader::open`] verifies it whole, then sections are read in the
/// order they were written and [`StageReader::finish`] checks nothing is left over.
pub struct StageReader {
    path: PathBuf,
    input: BufReader<File>,
    remaining: u64,
    checksum: u32,
}

impl StageReader {
    /// Opens `path`, which must be a `kind` file, and verifies its size and checksum.
    pub fn open(path: &Path, kind: StageKind) -> Result<StageReader, StageFileError> {
        let mut file = open(path)?;
        let header = read_header_from(path, &mut file)?;
        if header.kind != kind {
            return Err(StageFileError::WrongKind {
                path: path.to_path_buf(),
                expected: kind.name(),
                found: header.kind.name(),
            });
        }
        let io_error = |source| StageFileError::Io { path: path.to_path_buf(), action: "read", source };
        let mut input = BufReader::with_capacity(1 << 20, file);
        let mut crc = crc32fast::Hasher::new();
        let mut left = header.payload_len;
        let mut buffer = vec![0u8; 1 << 20];
        while left > 0 {
            let take = left.min(buffer.len() as u64) as usize;
            input.read_exact(&mut buffer[..take]).map_err(io_error)?;
            crc.update(&buffer[..take]);
            left -= take as u64;
        }
        let mut trailer = [0u8; TRAILER_LEN as usize];
        input.read_exact(&mut trailer).map_err(io_error)?;
        let computed = crc.finalize();
        let stored = u32::from_le_bytes(fixed(&trailer[..4]));
        if trailer[4..] != TRAILER_MAGIC {
            return Err(StageFileError::Corrupted {
                path: path.to_path_buf(),
                what: "the trailer does not end with \"SEND\"".to_string(),
            });
        }
        if stored != computed {
            return Err(StageFileError::Corrupted {
                path: path.to_path_buf(),
                what: format!("checksum mismatch (stored {stored:#010x}, computed {computed:#010x})"),
            });
        }
        input.seek(SeekFrom::Start(HEADER_LEN)).map_err(io_error)?;
        Ok(StageReader { path: path.to_path_buf(), input, remaining: header.payload_len, checksum: computed })
    }

    /// The payload's CRC-32: identifies the file's content.
    pub fn checksum(&self) -> u32 {
        self.checksum
    }

    /// The file being read.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Reads the next section, which must be called `tag` and hold rows of type `R`.
    pub fn read_rows<R: Row>(&mut self, tag: &str) -> Result<Vec<R>, StageFileError> {
        let mut header = [0u8; SECTION_HEADER_LEN as usize];
        self.take(&mut header, tag)?;
        let found_tag = decode_tag(&header[..TAG_LEN]);
        if found_tag != tag {
            return Err(self.malformed(format!("expected section {tag:?}, found {found_tag:?}")));
        }
        let dtype = DType::from_code(header[16]);
        let components = u32::from_le_bytes(fixed(&header[20..24]));
        let rows = u64::from_le_bytes(fixed(&header[24..32]));
        if dtype != Some(R::DTYPE) || components != R::COMPONENTS || header[17..20] != [0; 3] {
            return Err(self.malformed(format!(
                "section {tag:?} holds dtype code {} x {components}, expected {:?} x {}",
                header[16],
                R::DTYPE,
                R::COMPONENTS
            )));
        }
        let row_bytes = R::DTYPE.size() * u64::from(R::COMPONENTS);
        let bytes = rows.checked_mul(row_bytes).filter(|bytes| *bytes <= self.remaining);
        let Some(bytes) = bytes else {
            return Err(self.malformed(format!("section {tag:?} claims {rows} rows, more than the file holds")));
        };
        let count = usize::try_from(rows).map_err(|_| self.malformed(format!("section {tag:?} is too large")))?;
        let mut values = vec![R::zeroed(); count];
        self.take(bytemuck::cast_slice_mut(&mut values), tag)?;
        let mut padding = [0u8; 8];
        let padding = &mut padding[..padding_after(bytes) as usize];
        self.take(padding, tag)?;
        if padding.iter().any(|byte| *byte != 0) {
            return Err(self.malformed(format!("section {tag:?} has non-zero padding")));
        }
        Ok(values)
    }

    /// Reads the next section as UTF-8 JSON into `T`.
    pub fn read_json<T: DeserializeOwned>(&mut self, tag: &str) -> Result<T, StageFileError> {
        let bytes: Vec<u8> = self.read_rows(tag)?;
        serde_json::from_slice(&bytes).map_err(|error| self.malformed(format!("section {tag:?}: {error}")))
    }

    /// True when every section has been read (a format's optional last section is absent).
    pub fn at_end(&self) -> bool {
        self.remaining == 0
    }

    /// Checks that every section has been read.
    pub fn finish(self) -> Result<(), StageFileError> {
        if self.remaining != 0 {
            return Err(self.malformed(format!("{} bytes of unexpected sections at the end", self.remaining)));
        }
        Ok(())
    }

    /// An error saying the content breaks the format's rules.
    pub fn malformed(&self, what: String) -> StageFileError {
        StageFileError::Malformed { path: self.path.clone(), what }
    }

    fn take(&mut self, buffer: &mut [u8], tag: &str) -> Result<(), StageFileError> {
        if buffer.len() as u64 > self.remaining {
            return Err(self.malformed(format!("the payload ends inside section {tag:?}")));
        }
        self.input.read_exact(buffer).map_err(|source| StageFileError::Io {
            path: self.path.clone(),
            action: "read",
            source,
        })?;
        self.remaining -= buffer.len() as u64;
        Ok(())
    }
}

fn encode_tag(tag: &str) -> [u8; TAG_LEN] {
    assert!(tag.is_ascii() && tag.len() <= TAG_LEN, "section tags are short ASCII names: {tag:?}");
    let mut encoded = [0u8; TAG_LEN];
    encoded[..tag.len()].copy_from_slice(tag.as_bytes());
    encoded
}

fn decode_tag(bytes: &[u8]) -> String {
    let end = bytes.iter().position(|byte| *byte == 0).unwrap_or(bytes.len());
    String::from_utf8_lossy(&bytes[..end]).into_owned()
}

fn padding_after(bytes: u64) -> u64 {
    (8 - bytes % 8) % 8
}

fn fixed<const N: usize>(bytes: &[u8]) -> [u8; N] {
    let mut out = [0u8; N];
    out.copy_from_slice(bytes);
    out
}

fn read_up_to(file: &mut File, buffer: &mut [u8]) -> io::Result<usize> {
    let mut filled = 0;
    while filled < buffer.len() {
        match file.read(&mut buffer[filled..]) {
            Ok(0) => break,
            Ok(n) => filled += n,
            Err(error) if error.kind() == io::ErrorKind::Interrupted => {}
            Err(error) => return Err(error),
        }
    }
    Ok(filled)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write_sample(path: &Path) {
        let mut writer = StageWriter::create(path, StageKind::Particles).expect("create");
        writer.write_json("meta", &serde_json::json!({"answer": 42})).expect("json");
        writer.write_rows("positions", &[[1.0f32, 2.0, 3.0], [4.0, 5.0, 6.0]]).expect("rows");
        writer.write_rows("ids", &[7u32, 8, 9]).expect("rows");
        writer.finish().expect("finish");
    }

    type Sample = (serde_json::Value, Vec<[f32; 3]>, Vec<u32>);

    fn read_sample(path: &Path) -> Result<Sample, StageFileError> {
        let mut reader = StageReader::open(path, StageKind::Particles)?;
        let meta = reader.read_json("meta")?;
        let positions = reader.read_rows("positions")?;
        let ids = reader.read_rows("ids")?;
        reader.finish()?;
        Ok((meta, positions, ids))
    }

    #[test]
    fn sections_round_trip() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("sample.shp");
        write_sample(&path);
        let (meta, positions, ids) = read_sample(&path).expect("read back");
        assert_eq!(meta["answer"], 42);
        assert_eq!(positions, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
        assert_eq!(ids, vec![7, 8, 9]);
        assert_eq!(std::fs::read_dir(dir.path()).expect("list").count(), 1, "no temporary file left");
    }

    #[test]
    fn every_single_byte_change_and_every_truncation_is_detected() {
        let dir = tempfile::tempdir().expect("tempdir");
        let good = dir.path().join("good.shp");
        write_sample(&good);
        let bytes = std::fs::read(&good).expect("read");
        let bad = dir.path().join("bad.shp");
        for index in 0..bytes.len() {
            for flip in [0x01u8, 0x80, 0xff] {
                let mut corrupted = bytes.clone();
                corrupted[index] ^= flip;
                std::fs::write(&bad, &corrupted).expect("write");
                assert!(read_sample(&bad).is_err(), "flipping byte {index} by {flip:#x} went unnoticed");
            }
        }
        for length in 0..bytes.len() {
            std::fs::write(&bad, &bytes[..length]).expect("write");
            assert!(read_sample(&bad).is_err(), "truncation to {length} bytes went unnoticed");
        }
    }

    #[test]
    fn errors_say_what_is_wrong() {
        let dir = tempfile::tempdir().expect("tempdir");
        let good = dir.path().join("good.shp");
        write_sample(&good);
        let bytes = std::fs::read(&good).expect("read");
        let bad = dir.path().join("bad.shp");
        let message_for = |corrupt: &dyn Fn(&mut Vec<u8>)| {
            let mut copy = bytes.clone();
            corrupt(&mut copy);
            std::fs::write(&bad, &copy).expect("write");
            read_sample(&bad).expect_err("must fail").to_string()
        };
        assert!(message_for(&|b| b[0] = b'X').contains("not a shatter stage file"));
        assert!(message_for(&|b| b[8] = 9).contains("format version 9 is not supported"));
        assert!(message_for(&|b| b[12..16].copy_from_slice(b"ZZZZ")).contains("unknown stage file kind"));
        assert!(message_for(&|b| b.truncate(b.len() - 3)).contains("truncated"));
        assert!(message_for(&|b| b.push(0)).contains("extra bytes"));
        let middle = bytes.len() / 2;
        assert!(message_for(&|b| b[middle] ^= 1).contains("checksum mismatch"));
        std::fs::write(&bad, b"").expect("write");
        assert!(read_sample(&bad).expect_err("empty").to_string().contains("not a shatter stage file"));
    }

    #[test]
    fn an_unfinished_writer_leaves_the_old_file_alone() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("keep.shp");
        write_sample(&path);
        let before = std::fs::read(&path).expect("read");
        {
            let mut writer = StageWriter::create(&path, StageKind::Particles).expect("create");
            writer.write_rows("ids", &[1u32]).expect("rows");
            // dropped without finish: an error or a crash mid-way
        }
        assert_eq!(std::fs::read(&path).expect("read"), before);
        assert_eq!(std::fs::read_dir(dir.path()).expect("list").count(), 1, "temporary file removed");
    }
}
