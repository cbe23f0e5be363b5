//! One page frame as the binary message the page draws (docs/FORMATS.md#preview-frames): its
//! particles' positions, damage, speed and fragment, and the frame's fragment figures.

use shatter_post::components::size_histogram;

/// The first four bytes of a frame message.
pub const FRAME_MAGIC: &[u8; 4] = b"SHPV";
/// The frame message's layout version.
pub const FRAME_VERSION: u32 = 2;

/// A frame's fragments: each particle's, and each fragment's elements and mass.
#[derive(Debug, Clone, PartialEq)]
pub struct Fragments {
    /// The fragment of each particle (ids stable from frame to frame, as post's).
    pub fragment_of: Vec<u32>,
    /// Elements in each fragment.
    pub elements: Vec<u32>,
    /// Mass of each fragment, kg.
    pub mass_kg: Vec<f64>,
}

impl Fragments {
    /// The fragments given by `fragment_of` (ids 0 .. `count`) of particles of mass `mass_kg`.
    pub fn of(fragment_of: Vec<u32>, count: usize, mass_kg: &[f64]) -> Fragments {
        let (mut elements, mut masses) = (vec![0u32; count], vec![0.0f64; count]);
        for (&f, &m) in fragment_of.iter().zip(mass_kg) {
            elements[f as usize] += 1;
            masses[f as usize] += m;
        }
        Fragments { fragment_of, elements, mass_kg: masses }
    }

    /// The largest fragment's share of the mass (0 for a massless frame).
    pub fn largest_share(&self) -> f64 {
        let total: f64 = self.mass_kg.iter().sum();
        if total > 0.0 { self.mass_kg.iter().copied().fold(0.0, f64::max) / total } else { 0.0 }
    }
}

/// One page frame.
#[derive(Debug, Clone, PartialEq)]
pub struct PageFrame {
    /// Its number on the page (the shot's frame).
    pub frame: u32,
    /// Its stage ([`super::page_frames::FrameSource::code`]).
    pub source: u32,
    /// Seconds from the simulation's start (negative in the lead-in).
    pub time_s: f64,
    /// Each particle's position, metres.
    pub position_m: Vec<[f32; 3]>,
    /// Each particle's damage (the fraction of its bonds broken).
    pub damage: Vec<f32>,
    /// Each particle's speed, m/s.
    pub speed_m_s: Vec<f32>,
    /// The frame's fragments.
    pub fragments: Fragments,
    /// Where particles lost bonds during the frame (post's debris points; none before post has
    /// run, or outside the simulation), metres.
    pub debris_m: Vec<[f32; 3]>,
}

impl PageFrame {
    /// The message, little-endian: [`FRAME_MAGIC`]; the version, the frame, the particle count
    /// n (u32 each); the time (f32 seconds from the simulation's start); the source, the
    /// fragment count (u32 each); the largest fragment's mass share (f32); the fragment-size
    /// histogram's bin count b and b counts (u32 each; bin k holds fragments of 2^k to
    /// 2^(k+1) - 1 elements); then n positions (x, y, z f32, metres), n damages (f32), n speeds
    /// (f32, m/s) and n fragment ids (u32); then the debris point count m (u32) and m positions
    /// (x, y, z f32, metres).
    pub fn message(&self) -> Vec<u8> {
        let n = self.position_m.len();
        let histogram = size_histogram(&self.fragments.elements);
        let mut bytes = Vec::with_capacity(40 + 4 * histogram.len() + 24 * n);
        bytes.extend_from_slice(FRAME_MAGIC);
        let mut words = |words: &[u32]| words.iter().for_each(|word| bytes.extend_from_slice(&word.to_le_bytes()));
        words(&[FRAME_VERSION, self.frame, n as u32, (self.time_s as f32).to_bits(), self.source]);
        words(&[self.fragments.elements.len() as u32, (self.fragments.largest_share() as f32).to_bits()]);
        words(&[histogram.len() as u32]);
        words(&histogram.iter().map(|&(_, count)| count).collect::<Vec<u32>>());
        words(&self.position_m.iter().flatten().map(|v| v.to_bits()).collect::<Vec<u32>>());
        words(&self.damage.iter().chain(&self.speed_m_s).map(|v| v.to_bits()).collect::<Vec<u32>>());
        words(&self.fragments.fragment_of);
        words(&[self.debris_m.len() as u32]);
        words(&self.debris_m.iter().flatten().map(|v| v.to_bits()).collect::<Vec<u32>>());
        bytes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_message_carries_the_particles_and_the_fragment_figures() {
        let fragments = Fragments::of(vec![0, 1, 0], 2, &[1.0, 2.0, 1.0]);
        assert_eq!((fragments.elements.clone(), fragments.largest_share()), (vec![2, 1], 0.5));
        let frame = PageFrame {
            frame: 3,
            source: 1,
            time_s: 0.5,
            position_m: vec![[1.0, 3.0, 5.0], [2.0, 4.0, 6.0], [0.0; 3]],
            damage: vec![0.25, 0.0, 0.0],
            speed_m_s: vec![5.0, 1.0, 0.0],
            fragments,
            debris_m: vec![[7.0, 8.0, 9.0]],
        };
        let bytes = frame.message();
        let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
        let float = |at: usize| f32::from_bits(word(at));
        assert_eq!(&bytes[..4], FRAME_MAGIC);
        assert_eq!((word(4), word(8), word(12), float(16), word(20)), (FRAME_VERSION, 3, 3, 0.5, 1));
        // two fragments, the largest half the mass; sizes 2 and 1: one in bin 1, one in bin 2-3
        assert_eq!((word(24), float(28), word(32), word(36), word(40)), (2, 0.5, 2, 1, 1));
        let floats: Vec<f32> = (44..44 + 4 * 15).step_by(4).map(float).collect();
        assert_eq!(floats[..6], [1.0, 3.0, 5.0, 2.0, 4.0, 6.0]);
        assert_eq!(floats[9..15], [0.25, 0.0, 0.0, 5.0, 1.0, 0.0]);
        let ids: Vec<u32> = (104..116).step_by(4).map(word).collect();
        assert_eq!(ids, [0, 1, 0]);
        assert_eq!((word(116), float(120), float(128), bytes.len()), (1, 7.0, 9.0, 132));
    }
}
