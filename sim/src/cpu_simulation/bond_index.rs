//! The CPU simulation's bond lookups for contact: which pairs are bonded and intact.

use shatter_core::particles::Bonds;

use crate::contact::{BondLookup, NO_BOND};

/// Bond lookups for contact: "are i and j bonded and intact?", from the particle file's CSR and
/// a bitset of broken bond ids.
#[derive(Debug, Clone)]
pub(super) struct BondIndex {
    offsets: Vec<u64>,
    neighbor: Vec<u32>,
    broken: Vec<u64>,
}

impl BondIndex {
    pub(super) fn new(bonds: &Bonds) -> BondIndex {
        BondIndex {
            offsets: bonds.offsets.clone(),
            neighbor: bonds.neighbor.clone(),
            broken: vec![0; bonds.neighbor.len().div_ceil(64)],
        }
    }

    /// Marks bond `id` broken and counts it in both its particles' `broken` counts.
    pub(super) fn record_break(&mut self, id: u64, broken: &mut [u32]) {
        self.broken[(id / 64) as usize] |= 1 << (id % 64);
        let i = self.offsets.partition_point(|offset| *offset <= id) - 1;
        broken[i] += 1;
        broken[self.neighbor[id as usize] as usize] += 1;
    }
}

impl BondLookup for BondIndex {
    fn bond_between(&self, i: usize, j: usize) -> u64 {
        let (lo, hi) = (i.min(j), i.max(j) as u32);
        let row = self.offsets[lo] as usize..self.offsets[lo + 1] as usize;
        match self.neighbor[row.clone()].binary_search(&hi) {
            Ok(k) => (row.start + k) as u64,
            Err(_) => NO_BOND,
        }
    }

    fn intact(&self, bond: u64) -> bool {
        bond != NO_BOND && self.broken[(bond / 64) as usize] & (1 << (bond % 64)) == 0
    }
}
