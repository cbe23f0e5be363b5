//! Cryptomatte (Friedman and Jones, Psyop, specification 1.2): per pixel, the ids seen there
//! ranked by coverage, as (id, coverage) pairs in RGBA layers, with a manifest naming each id.
//!
//! - An id is the MurmurHash3 (x86, 32 bit, seed 0) of the name, with its exponent bits nudged
//!   so that the float it is stored as is neither denormal, infinite nor NaN.
//! - Layer `<name>NN` holds ranks 2 NN and 2 NN + 1 as R = id, G = coverage, B = id, A = coverage
//!   ([`RANKS`] ranks in all).
//! - The header holds `cryptomatte/<key>/{name, hash, conversion, manifest}`, the key being the
//!   first 7 hex digits of the name's hash.
//!
//! Two mattes come from the same matte counts ([`crate::mattes`]): fragments
//! ([`FRAGMENT_MATTE`], ids named as the USD pieces, `piece_00012` for fragment 12) and materials
//! ([`MATERIAL_MATTE`]: `outer`, `fracture`, `floor`).

use std::collections::BTreeMap;

use rayon::prelude::*;

use crate::mattes::{MATTE_SLOTS, MatteCounts, SURFACE_NAMES};

/// Ranks stored per pixel: two RGBA layers. (The specification's default is 6; a pixel here
/// seldom sees more than 3 fragments, and each layer is 4 more float channels per frame.)
pub const RANKS: usize = 4;
/// The fragment matte's name (Blender's ViewLayer.Pass convention; the object matte: each
/// fragment is an object of the shot).
pub const FRAGMENT_MATTE: &str = "ViewLayer.CryptoObject";
/// The material matte's name.
pub const MATERIAL_MATTE: &str = "ViewLayer.CryptoMaterial";

/// MurmurHash3_x86_32 of `bytes` with `seed`.
pub fn murmur3_32(bytes: &[u8], seed: u32) -> u32 {
    const C1: u32 = 0xcc9e_2d51;
    const C2: u32 = 0x1b87_3593;
    let mix = |k: u32| k.wrapping_mul(C1).rotate_left(15).wrapping_mul(C2);
    let mut h = seed;
    let mut blocks = bytes.chunks_exact(4);
    for block in &mut blocks {
        let k = u32::from_le_bytes([block[0], block[1], block[2], block[3]]);
        h = (h ^ mix(k)).rotate_left(13).wrapping_mul(5).wrapping_add(0xe654_6b64);
    }
    let tail = blocks.remainder();
    if !tail.is_empty() {
        let k = tail.iter().rev().fold(0u32, |k, &b| (k << 8) | u32::from(b));
        h ^= mix(k);
    }
    h ^= bytes.len() as u32;
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^ (h >> 16)
}

/// The id bits of `name`: its hash, with bit 23 flipped where the exponent would be all zeros or
/// all ones.
pub fn id_bits(name: &str) -> u32 {
    let hash = murmur3_32(name.as_bytes(), 0);
    let exponent = (hash >> 23) & 0xff;
    if exponent == 0 || exponent == 0xff { hash ^ (1 << 23) } else { hash }
}

/// The header key of a matte: the first 7 hex digits of its name's hash.
pub fn matte_key(name: &str) -> String {
    format!("{:08x}", murmur3_32(name.as_bytes(), 0))[..7].to_string()
}

/// The name of fragment `id` (as its USD prim is named).
pub fn fragment_name(id: u32) -> String {
    format!("piece_{id:05}")
}

/// One Cryptomatte of a frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Matte {
    /// Its name, the prefix of its channels.
    pub name: String,
    /// Name to id bits, for the manifest.
    pub manifest: BTreeMap<String, u32>,
    /// Per pixel, (id bits, coverage) by falling coverage; unused ranks are (0, 0).
    pub ranks: Vec<[(u32, f32); RANKS]>,
}

impl Matte {
    /// The manifest as the specification's JSON object: `{"name":"hex id",...}`.
    pub fn manifest_json(&self) -> String {
        let entries: Vec<String> = self
            .manifest
            .iter()
            .map(|(name, bits)| format!("{}:\"{bits:08x}\"", serde_json::Value::from(name.as_str())))
            .collect();
        format!("{{{}}}", entries.join(","))
    }

    /// The channels: `<name>00.R` (rank 0 id), `.G` (rank 0 coverage), `.B`, `.A` (rank 1), then
    /// `<name>01`; ids as the floats their bits make.
    pub fn channels(&self) -> Vec<(String, Vec<f32>)> {
        let mut channels = Vec::with_capacity(2 * RANKS);
        for layer in 0..RANKS / 2 {
            for (k, channel) in ["R", "G", "B", "A"].iter().enumerate() {
                let rank = 2 * layer + k / 2;
                let values = self
                    .ranks
                    .iter()
                    .map(|ranks| if k % 2 == 0 { f32::from_bits(ranks[rank].0) } else { ranks[rank].1 })
                    .collect();
                channels.push((format!("{}{layer:02}.{channel}", self.name), values));
            }
        }
        channels
    }
}

/// Ranks (id bits, samples) by falling samples, ties by id bits, as coverages of `samples`.
fn rank(entries: &mut [(u32, u32)], samples: u32) -> [(u32, f32); RANKS] {
    entries.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    let mut ranks = [(0u32, 0.0f32); RANKS];
    for (slot, &(bits, count)) in ranks.iter_mut().zip(entries.iter().filter(|e| e.1 > 0)) {
        *slot = (bits, count as f32 / samples.max(1) as f32);
    }
    ranks
}

/// The fragment matte of a frame whose elements belong to `fragments` (each id once).
pub fn fragment_matte(counts: &[MatteCounts], fragments: &[u32]) -> Matte {
    let bits: BTreeMap<u32, u32> = fragments.iter().map(|&f| (f, id_bits(&fragment_name(f)))).collect();
    let ranks = counts
        .par_iter()
        .map(|c| {
            let mut entries = [(0u32, 0u32); MATTE_SLOTS];
            let mut used = 0;
            for slot in c.fragments.iter().filter(|slot| slot[0] != 0) {
                let bits = bits.get(&(slot[0] - 1)).copied().unwrap_or_else(|| id_bits(&fragment_name(slot[0] - 1)));
                entries[used] = (bits, slot[1]);
                used += 1;
            }
            rank(&mut entries[..used], c.samples)
        })
        .collect();
    let manifest = fragments.iter().map(|&f| (fragment_name(f), bits[&f])).collect();
    Matte { name: FRAGMENT_MATTE.to_string(), manifest, ranks }
}

/// The material matte: outer surface, fracture faces, floor.
pub fn material_matte(counts: &[MatteCounts]) -> Matte {
    let bits = SURFACE_NAMES.map(id_bits);
    let ranks = counts.par_iter().map(|c| rank(&mut [0, 1, 2].map(|k| (bits[k], c.surfaces[k])), c.samples)).collect();
    let manifest = SURFACE_NAMES.iter().zip(bits).map(|(name, b)| (name.to_string(), b)).collect();
    Matte { name: MATERIAL_MATTE.to_string(), manifest, ranks }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn murmur3_matches_published_vectors() {
        // The reference implementation's test vectors (SMHasher).
        assert_eq!(murmur3_32(b"", 0), 0);
        assert_eq!(murmur3_32(b"", 1), 0x514e_28b7);
        assert_eq!(murmur3_32(b"", 0xffff_ffff), 0x81f1_6f39);
        assert_eq!(murmur3_32(&[0xff, 0xff, 0xff, 0xff], 0), 0x7629_3b50);
        assert_eq!(murmur3_32(&[0x21, 0x43, 0x65, 0x87], 0), 0xf55b_516b);
        assert_eq!(murmur3_32(&[0x21, 0x43, 0x65], 0), 0x7e4a_8634);
        assert_eq!(murmur3_32(&[0x21, 0x43], 0), 0xa0f7_b07a);
        assert_eq!(murmur3_32(&[0x21], 0), 0x7266_1cf4);
        assert_eq!(murmur3_32(b"Hello, world!", 1234), 0xfaf6_cdb3);
    }

    #[test]
    fn ids_are_normal_floats_and_keys_are_seven_hex_digits() {
        for k in 0..5000 {
            let id = f32::from_bits(id_bits(&fragment_name(k)));
            assert!(id.is_finite() && (id == 0.0 || id.is_normal()), "{k}: {id}");
        }
        assert_eq!(matte_key(FRAGMENT_MATTE).len(), 7);
        assert_ne!(matte_key(FRAGMENT_MATTE), matte_key(MATERIAL_MATTE));
    }

    #[test]
    fn ranks_fall_and_the_manifest_is_json() {
        let mut counts = MatteCounts::default();
        for (fragment, times) in [(3, 1), (1, 5), (2, 2)] {
            for _ in 0..times {
                counts.add(fragment, crate::mattes::SURFACE_OUTER);
            }
        }
        counts.add(0, crate::mattes::SURFACE_FLOOR);
        counts.add(0, crate::mattes::SURFACE_NONE);
        let matte = fragment_matte(&[counts], &[0, 1, 2]);
        let ranks = matte.ranks[0];
        assert_eq!(ranks[0], (id_bits("piece_00000"), 0.5));
        assert_eq!(ranks[1], (id_bits("piece_00001"), 0.2));
        assert_eq!(ranks[2], (id_bits("piece_00002"), 0.1));
        assert_eq!(ranks[3], (0, 0.0));
        let json: serde_json::Value = serde_json::from_str(&matte.manifest_json()).expect("json");
        assert_eq!(json["piece_00001"], format!("{:08x}", id_bits("piece_00001")));
        let material = material_matte(&[counts]);
        assert_eq!(material.ranks[0][0], (id_bits("outer"), 0.8));
        assert_eq!(material.ranks[0][1], (id_bits("floor"), 0.1));
        let channels = matte.channels();
        assert_eq!(channels.len(), 8);
        assert_eq!(channels[0].0, "ViewLayer.CryptoObject00.R");
        assert_eq!(channels[7].0, "ViewLayer.CryptoObject01.A");
    }
}
