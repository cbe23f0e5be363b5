//! Matte samples: per pixel, how many of its samples saw each fragment and each kind of surface
//! first. The CPU twin of `shaders/mattes.wgsl`; [`crate::cryptomatte`] turns the counts
//! into Cryptomatte ranks.

use bytemuck::{Pod, Zeroable};

/// What a sample saw first: nothing (the background).
pub const SURFACE_NONE: u32 = 0;
/// ... an element's outer surface (the original body's surface).
pub const SURFACE_OUTER: u32 = 1;
/// ... a fracture face (a face that rested against another element).
pub const SURFACE_FRACTURE: u32 = 2;
/// ... the floor.
pub const SURFACE_FLOOR: u32 = 3;

/// The names of the surface kinds in the material matte, indexed by kind - 1.
pub const SURFACE_NAMES: [&str; 3] = ["outer", "fracture", "floor"];

/// Distinct fragments counted per pixel; samples of further fragments are not counted (their
/// coverage is left out, so the fragment matte never exceeds alpha).
pub const MATTE_SLOTS: usize = 8;

/// One pixel's matte counts (laid out as the shader's `MatteOut`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Pod, Zeroable)]
pub struct MatteCounts {
    /// (fragment id + 1, samples) in order of first appearance; (0, 0) is a free slot.
    pub fragments: [[u32; 2]; MATTE_SLOTS],
    /// Samples that saw an outer surface, a fracture face, the floor first.
    pub surfaces: [u32; 3],
    /// Samples taken.
    pub samples: u32,
}

impl MatteCounts {
    /// Counts one sample that saw `fragment` (id + 1; 0 for none) on a surface of kind `surface`.
    pub fn add(&mut self, fragment: u32, surface: u32) {
        self.samples += 1;
        if surface != SURFACE_NONE {
            self.surfaces[surface as usize - 1] += 1;
        }
        if fragment == 0 {
            return;
        }
        for slot in &mut self.fragments {
            if slot[0] == fragment || slot[0] == 0 {
                slot[0] = fragment;
                slot[1] += 1;
                return;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_fill_slots_in_order_and_drop_overflow() {
        let mut counts = MatteCounts::default();
        for f in 1..=10 {
            counts.add(f, SURFACE_OUTER);
        }
        counts.add(3, SURFACE_FRACTURE);
        counts.add(0, SURFACE_FLOOR);
        counts.add(0, SURFACE_NONE);
        assert_eq!(counts.samples, 13);
        assert_eq!(counts.surfaces, [10, 1, 1]);
        assert_eq!(counts.fragments[2], [3, 2]);
        assert_eq!(counts.fragments[7], [8, 1]);
        let counted: u32 = counts.fragments.iter().map(|s| s[1]).sum();
        assert_eq!(counted, 9, "fragments 9 and 10 found no slot");
        assert_eq!(std::mem::size_of::<MatteCounts>(), 80);
    }
}
