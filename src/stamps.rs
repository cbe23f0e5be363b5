//! What `shatter run` knows is up to date: for each stage (and each rendered frame) a hash of
//! everything its outputs depend on, recorded when the outputs were written. A stage whose
//! recorded hash equals the current one, and whose outputs are there, is skipped.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::Context;

/// A 64-bit FNV-1a hash, written as 16 hex digits.
#[derive(Debug, Clone, Copy)]
pub struct Hasher(u64);

impl Default for Hasher {
    fn default() -> Self {
        Hasher(0xcbf2_9ce4_8422_2325)
    }
}

impl Hasher {
    /// Feeds bytes.
    pub fn bytes(mut self, bytes: &[u8]) -> Hasher {
        for byte in bytes {
            self.0 = (self.0 ^ u64::from(*byte)).wrapping_mul(0x0100_0000_01b3);
        }
        // a separator, so that ("ab", "c") and ("a", "bc") differ
        self.0 = (self.0 ^ 0xff).wrapping_mul(0x0100_0000_01b3);
        self
    }

    /// Feeds a value's JSON form.
    pub fn json(self, value: &impl serde::Serialize) -> Hasher {
        let text = serde_json::to_string(value).unwrap_or_default();
        self.bytes(text.as_bytes())
    }

    /// Feeds a value's JSON form when there is one (absent, the hash is what it would be
    /// without this call).
    pub fn json_if(self, value: Option<&impl serde::Serialize>) -> Hasher {
        match value {
            Some(value) => self.json(value),
            None => self,
        }
    }

    /// Feeds a file's contents (or a marker when it cannot be read).
    pub fn file(self, path: &Path) -> Hasher {
        match std::fs::read(path) {
            Ok(bytes) => self.bytes(&bytes),
            Err(_) => self.bytes(b"(unreadable)"),
        }
    }

    /// The hash as hex.
    pub fn finish(self) -> String {
        format!("{:016x}", self.0)
    }
}

/// The stamps of one output folder.
#[derive(Debug, Clone, Default)]
pub struct Stamps {
    path: PathBuf,
    entries: BTreeMap<String, String>,
}

impl Stamps {
    /// The stamps at `path` (none yet if the file is missing or unreadable: everything runs).
    pub fn load(path: PathBuf) -> Stamps {
        let entries =
            std::fs::read(&path).ok().and_then(|bytes| serde_json::from_slice(&bytes).ok()).unwrap_or_default();
        Stamps { path, entries }
    }

    /// Whether `key` was recorded with `hash`.
    pub fn matches(&self, key: &str, hash: &str) -> bool {
        self.entries.get(key).is_some_and(|recorded| recorded == hash)
    }

    /// Records `key` with `hash` and saves (atomically).
    pub fn record(&mut self, key: &str, hash: &str) -> anyhow::Result<()> {
        self.entries.insert(key.to_string(), hash.to_string());
        self.save()
    }

    fn save(&self) -> anyhow::Result<()> {
        let text = serde_json::to_vec_pretty(&self.entries)?;
        shatter_core::atomic_file::write_atomically(&self.path, &[&text])
            .with_context(|| format!("{}: cannot record what is up to date", self.path.display()))
    }
}
