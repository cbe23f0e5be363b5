//! A small hash table pairing up the faces of the new tets that fill a cavity.

/// Pairs up the faces of the new tets through the cavity-boundary edge each contains besides the
/// new point: open addressing on the edge, cleared in O(1) by a stamp per slot.
#[derive(Debug, Default)]
pub(super) struct EdgeTable {
    slots: Vec<EdgeSlot>,
    stamp: u32,
}

#[derive(Debug, Clone, Copy, Default)]
struct EdgeSlot {
    key: u64,
    tet: u32,
    face: u32,
    stamp: u32,
}

impl EdgeTable {
    /// Empties the table, making room for `edges` entries at load factor at most one half.
    pub(super) fn reset(&mut self, edges: usize) {
        let wanted = (2 * edges).next_power_of_two().max(64);
        if self.slots.len() < wanted {
            self.slots = vec![EdgeSlot::default(); wanted];
            self.stamp = 0;
        }
        if self.stamp == u32::MAX {
            self.slots.fill(EdgeSlot::default());
            self.stamp = 0;
        }
        self.stamp += 1;
    }

    /// Records that face `face` of `tet` holds edge `{a, b}`; if another face holds it already,
    /// returns that face instead (each edge is held by exactly two faces).
    pub(super) fn pair(&mut self, a: u32, b: u32, tet: u32, face: usize) -> Option<(u32, usize)> {
        let key = (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
        let mask = self.slots.len() - 1;
        let mut i = (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 32) as usize & mask;
        loop {
            let slot = &mut self.slots[i];
            if slot.stamp != self.stamp {
                *slot = EdgeSlot { key, tet, face: face as u32, stamp: self.stamp };
                return None;
            }
            if slot.key == key {
                return Some((slot.tet, slot.face as usize));
            }
            i = (i + 1) & mask;
        }
    }
}
