//! Disjoint sets (union-find) over the numbers 0..n: which groups the joins so far have linked
//! them into. When two sets join, the lower root becomes the root, so every set's root is its
//! lowest member, whatever the order of the joins.

/// A disjoint-set forest over 0..n.
#[derive(Debug, Clone)]
pub struct DisjointSets {
    parent: Vec<u32>,
}

impl DisjointSets {
    /// `n` sets of one member each.
    pub fn new(n: usize) -> DisjointSets {
        DisjointSets { parent: (0..n as u32).collect() }
    }

    /// The root (lowest member) of the set holding `x`, halving paths on the way.
    pub fn root(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let up = self.parent[self.parent[x as usize] as usize];
            self.parent[x as usize] = up;
            x = up;
        }
        x
    }

    /// Joins the sets holding `a` and `b`.
    pub fn join(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.root(a), self.root(b));
        if ra != rb {
            self.parent[ra.max(rb) as usize] = ra.min(rb);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_set_is_rooted_at_its_lowest_member_whatever_the_order_of_joins() {
        for order in [[(5, 3), (3, 7), (7, 1)], [(7, 1), (5, 3), (3, 7)]] {
            let mut sets = DisjointSets::new(9);
            for (a, b) in order {
                sets.join(a, b);
            }
            assert!([1, 3, 5, 7].iter().all(|&x| sets.root(x) == 1));
            assert!([0, 2, 4, 6, 8].iter().all(|&x| sets.root(x) == x));
        }
    }
}
