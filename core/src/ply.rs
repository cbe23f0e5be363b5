//! Binary little-endian PLY point caches with a checksum: the public per-frame format that
//! Blender, Houdini and any PLY reader open, and that shatter reads back with full checks.
//!
//! A file holds one `vertex` element with scalar properties (`float` or `int`), header comments
//! `comment shatter KEY VALUE`, and `comment shatter crc32 HEX`: the CRC-32 of every byte of the
//! file but that line (header comments included, so a changed frame number or time is caught),
//! which other readers ignore and shatter's reader verifies along with the exact size.

use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

use crate::atomic_file::write_atomically;

/// Why a PLY file could not be written or read. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum PlyError {
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
    /// The file is not a shatter PLY point cache, or is damaged.
    #[error("{path}: {what}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
}

/// One column of per-vertex values.
#[derive(Debug, Clone, PartialEq)]
pub enum Column {
    /// `property float NAME`.
    Float(Vec<f32>),
    /// `property int NAME`.
    Int(Vec<i32>),
}

impl Column {
    fn len(&self) -> usize {
        match self {
            Column::Float(values) => values.len(),
            Column::Int(values) => values.len(),
        }
    }

    fn type_name(&self) -> &'static str {
        match self {
            Column::Float(_) => "float",
            Column::Int(_) => "int",
        }
    }
}

/// The comment holding the CRC-32 of every byte of the file but its own line.
const CRC_KEY: &str = "crc32";

/// A point cache: named columns of equal length and `shatter` comments.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PointCache {
    /// `(key, value)` pairs written as `comment shatter KEY VALUE`.
    pub comments: Vec<(String, String)>,
    /// The vertex properties, in file order.
    pub columns: Vec<(String, Column)>,
}

impl PointCache {
    /// Number of vertices.
    pub fn len(&self) -> usize {
        self.columns.first().map_or(0, |(_, column)| column.len())
    }

    /// True when there are no vertices.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The value of comment `key`.
    pub fn comment(&self, key: &str) -> Option<&str> {
        self.comments.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    /// The float column `name`.
    pub fn floats(&self, name: &str) -> Option<&[f32]> {
        self.columns.iter().find_map(|(n, column)| match column {
            Column::Float(values) if n == name => Some(values.as_slice()),
            _ => None,
        })
    }

    /// The int column `name`.
    pub fn ints(&self, name: &str) -> Option<&[i32]> {
        self.columns.iter().find_map(|(n, column)| match column {
            Column::Int(values) if n == name => Some(values.as_slice()),
            _ => None,
        })
    }

    fn body(&self) -> Vec<u8> {
        let n = self.len();
        let mut body = Vec::with_capacity(n * self.columns.len() * 4);
        for i in 0..n {
            for (_, column) in &self.columns {
                match column {
                    Column::Float(values) => body.extend_from_slice(&values[i].to_le_bytes()),
                    Column::Int(values) => body.extend_from_slice(&values[i].to_le_bytes()),
                }
            }
        }
        body
    }

    /// Writes the cache atomically (temporary file, fsync, rename). All columns must have the
    /// same length.
    pub fn write(&self, path: &Path) -> Result<(), PlyError> {
        assert!(self.columns.iter().all(|(_, c)| c.len() == self.len()), "PLY columns differ in length");
        let body = self.body();
        let mut head = String::from("ply\nformat binary_little_endian 1.0\ncomment written by shatter\n");
        for (key, value) in &self.comments {
            head.push_str(&format!("comment shatter {key} {value}\n"));
        }
        let mut tail = format!("element vertex {}\n", self.len());
        for (name, column) in &self.columns {
            tail.push_str(&format!("property {} {name}\n", column.type_name()));
        }
        tail.push_str("end_header\n");
        let mut crc = crc32fast::Hasher::new();
        for part in [head.as_bytes(), tail.as_bytes(), &body] {
            crc.update(part);
        }
        let line = format!("comment shatter {CRC_KEY} {:08x}\n", crc.finalize());
        write_atomically(path, &[head.as_bytes(), line.as_bytes(), tail.as_bytes(), &body])
            .map_err(|source| PlyError::Io { path: path.to_path_buf(), action: "write", source })
    }

    /// Reads a cache written by [`PointCache::write`], checking the header, size and checksum
    /// (every byte of the file but the checksum's own line).
    pub fn read(path: &Path) -> Result<PointCache, PlyError> {
        let invalid = |what: String| PlyError::Invalid { path: path.to_path_buf(), what };
        let io = |action: &'static str| move |source| PlyError::Io { path: path.to_path_buf(), action, source };
        let file = File::open(path).map_err(io("open"))?;
        let file_len = file.metadata().map_err(io("stat"))?.len();
        let mut input = BufReader::new(file);
        let mut header_len = 0u64;
        let mut lines = Vec::new();
        let mut checked = crc32fast::Hasher::new();
        let crc_prefix = format!("comment shatter {CRC_KEY} ");
        let mut stored_crc = None;
        loop {
            let mut raw = Vec::new();
            let read = input.by_ref().take(4096).read_until(b'\n', &mut raw).map_err(io("read"))?;
            if read == 0 || !raw.ends_with(b"\n") || lines.len() > 256 {
                return Err(invalid("not a shatter PLY point cache: no end to the header".into()));
            }
            header_len += read as u64;
            let line = String::from_utf8_lossy(&raw).trim_end().to_string();
            match line.strip_prefix(&crc_prefix) {
                Some(value) if stored_crc.is_none() => stored_crc = Some(value.to_owned()),
                _ => checked.update(&raw),
            }
            if line == "end_header" {
                break;
            }
            lines.push(line);
        }
        if lines.first().map(String::as_str) != Some("ply")
            || !lines.iter().any(|l| l == "format binary_little_endian 1.0")
        {
            return Err(invalid("not a binary little-endian PLY file".into()));
        }
        let mut comments = Vec::new();
        let mut properties = Vec::new();
        let mut count = None;
        for line in &lines[1..] {
            let words: Vec<&str> = line.split_whitespace().collect();
            match words.as_slice() {
                ["comment", "shatter", key, rest @ ..] => comments.push((key.to_string(), rest.join(" "))),
                ["element", "vertex", n] => {
                    count = Some(n.parse::<u64>().map_err(|_| invalid(format!("bad vertex count {n:?}")))?)
                }
                ["property", kind @ ("float" | "int"), name] => properties.push((name.to_string(), *kind == "float")),
                ["property", ..] | ["element", ..] => {
                    return Err(invalid(format!("unsupported PLY header line {line:?}")));
                }
                _ => {}
            }
        }
        let n = count.ok_or_else(|| invalid("the PLY header has no vertex element".into()))?;
        let crc = stored_crc
            .and_then(|value| u32::from_str_radix(&value, 16).ok())
            .ok_or_else(|| invalid(format!("the PLY header lacks a valid `comment shatter {CRC_KEY}`")))?;
        comments.retain(|(key, _)| key != CRC_KEY);
        let row = 4 * properties.len() as u64;
        let body_len = n.checked_mul(row).ok_or_else(|| invalid("absurd vertex count".into()))?;
        if header_len + body_len != file_len {
            return Err(invalid(format!(
                "the file is {file_len} bytes but its header promises {} ({})",
                header_len + body_len,
                if file_len < header_len + body_len { "truncated" } else { "extra bytes at the end" }
            )));
        }
        let mut body = vec![0u8; body_len as usize];
        input.read_exact(&mut body).map_err(io("read"))?;
        checked.update(&body);
        let computed = checked.finalize();
        if computed != crc {
            return Err(invalid(format!("corrupted: checksum {computed:08x}, header says {crc:08x}")));
        }
        let n = n as usize;
        let word = |i: usize, p: usize| {
            let at = i * row as usize + 4 * p;
            [body[at], body[at + 1], body[at + 2], body[at + 3]]
        };
        let columns = properties
            .iter()
            .enumerate()
            .map(|(p, (name, float))| {
                let column = if *float {
                    Column::Float((0..n).map(|i| f32::from_le_bytes(word(i, p))).collect())
                } else {
                    Column::Int((0..n).map(|i| i32::from_le_bytes(word(i, p))).collect())
                };
                (name.clone(), column)
            })
            .collect();
        Ok(PointCache { comments, columns })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> PointCache {
        PointCache {
            comments: vec![("frame".into(), "3".into()), ("time_s".into(), "1.25e-4".into())],
            columns: vec![("x".into(), Column::Float(vec![1.0, 2.0])), ("fragment".into(), Column::Int(vec![0, 7]))],
        }
    }

    #[test]
    fn caches_round_trip_and_damage_is_caught() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("p.ply");
        sample().write(&path).expect("write");
        let read = PointCache::read(&path).expect("read");
        assert_eq!(read, sample());
        assert_eq!(read.comment("frame"), Some("3"));
        assert_eq!(read.ints("fragment"), Some(&[0, 7][..]));
        let bytes = std::fs::read(&path).expect("bytes");
        let mut flipped = bytes.clone();
        let last = flipped.len() - 1;
        flipped[last] ^= 8;
        std::fs::write(&path, &flipped).expect("write");
        assert!(PointCache::read(&path).expect_err("flip").to_string().contains("corrupted"));
        let mut renamed = bytes.clone();
        let at = bytes.windows(7).position(|w| w == b"frame 3").expect("frame comment") + 6;
        renamed[at] = b'4';
        std::fs::write(&path, &renamed).expect("write");
        assert!(PointCache::read(&path).expect_err("header").to_string().contains("corrupted"));
        std::fs::write(&path, &bytes[..bytes.len() - 3]).expect("write");
        assert!(PointCache::read(&path).expect_err("cut").to_string().contains("truncated"));
        std::fs::write(&path, b"ply\nformat ascii 1.0\nend_header\n").expect("write");
        assert!(PointCache::read(&path).is_err());
    }
}
