//! A static k-d tree over points for fixed-radius range queries.

use glam::DVec3;

/// Points per leaf: small enough to prune well, large enough to keep the tree shallow.
const LEAF_SIZE: usize = 12;

#[derive(Debug, Clone, Copy)]
enum Node {
    /// Points `start..end` of the permuted arrays.
    Leaf { start: u32, end: u32 },
    /// Points with `point[axis] <= split` are under `below` (the next node), the rest under `above`.
    Split { axis: u8, split: f64, above: u32 },
}

/// A balanced k-d tree, split at the median of the widest axis, stored depth first.
#[derive(Debug, Clone)]
pub struct PointKdTree {
    nodes: Vec<Node>,
    points: Vec<DVec3>,
    ids: Vec<u32>,
}

impl PointKdTree {
    /// Builds the tree over `points` (their indices are what queries return).
    pub fn new(points: &[DVec3]) -> PointKdTree {
        assert!(u32::try_from(points.len()).is_ok(), "a k-d tree holds at most u32::MAX points");
        let mut ids: Vec<u32> = (0..points.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * points.len() / LEAF_SIZE + 1);
        build(points, &mut ids, 0, &mut nodes);
        let permuted = ids.iter().map(|&id| points[id as usize]).collect();
        PointKdTree { nodes, points: permuted, ids }
    }

    /// Appends to `found` the index of every point within `radius_sq` (squared distance,
    /// inclusive) of `centre`, in no particular order.
    ///
    /// Subtrees are pruned by the exact distance from `centre` to the box the splits above them
    /// bound, kept incrementally (Arya and Mount's method): per axis, the offset to the nearest
    /// split crossed so far.
    pub fn within(&self, centre: DVec3, radius_sq: f64, found: &mut Vec<u32>) {
        if self.nodes.is_empty() {
            return;
        }
        // (node, squared distance to its box, per-axis offsets to its box)
        let mut stack = [(0u32, 0.0f64, [0.0f64; 3]); 64];
        let mut depth = 1;
        while depth > 0 {
            depth -= 1;
            let (mut node, box_distance_sq, offsets) = stack[depth];
            if box_distance_sq > radius_sq {
                continue;
            }
            loop {
                match self.nodes[node as usize] {
                    Node::Leaf { start, end } => {
                        // Branch-free: about a third of the candidates are hits, which a
                        // branch would mispredict.
                        let mut hits = [0u32; LEAF_SIZE];
                        let mut count = 0;
                        for k in start as usize..end as usize {
                            hits[count] = self.ids[k];
                            count += usize::from(self.points[k].distance_squared(centre) <= radius_sq);
                        }
                        found.extend_from_slice(&hits[..count]);
                        break;
                    }
                    Node::Split { axis, split, above } => {
                        let axis = axis as usize;
                        let offset = centre[axis] - split;
                        let (near, far) = if offset <= 0.0 { (node + 1, above) } else { (above, node + 1) };
                        let far_distance_sq = box_distance_sq - offsets[axis] * offsets[axis] + offset * offset;
                        if far_distance_sq <= radius_sq {
                            let mut far_offsets = offsets;
                            far_offsets[axis] = offset;
                            stack[depth] = (far, far_distance_sq, far_offsets);
                            depth += 1;
                        }
                        // the near child's box is as far as its parent's
                        node = near;
                    }
                }
            }
        }
    }
}

/// Builds the subtree over `ids` (the points' indices), appending nodes depth first.
fn build(points: &[DVec3], ids: &mut [u32], start: usize, nodes: &mut Vec<Node>) {
    let end = start + ids.len();
    if ids.len() <= LEAF_SIZE {
        nodes.push(Node::Leaf { start: start as u32, end: end as u32 });
        return;
    }
    let (lo, hi) = ids.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &id| {
        (lo.min(points[id as usize]), hi.max(points[id as usize]))
    });
    let axis = (hi - lo).max_position();
    let middle = ids.len() / 2;
    ids.select_nth_unstable_by(middle, |a, b| points[*a as usize][axis].total_cmp(&points[*b as usize][axis]));
    // Everything before `middle` is <= the median, everything from it on is >=.
    let split = points[ids[middle] as usize][axis];
    let here = nodes.len();
    nodes.push(Node::Leaf { start: 0, end: 0 }); // replaced once `above` is known
    let (below, above) = ids.split_at_mut(middle);
    build(points, below, start, nodes);
    let above_node = nodes.len() as u32;
    build(points, above, start + middle, nodes);
    nodes[here] = Node::Split { axis: axis as u8, split, above: above_node };
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic scatter of points with repeated coordinates (ties at the splits).
    fn scatter(n: usize) -> Vec<DVec3> {
        let mut state = 12345u64;
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 33) % 20) as f64 * 0.1
        };
        (0..n).map(|_| DVec3::new(next(), next(), next())).collect()
    }

    #[test]
    fn range_queries_match_brute_force() {
        let points = scatter(3000);
        let tree = PointKdTree::new(&points);
        for (q, centre) in points.iter().enumerate().step_by(37) {
            for radius in [0.0, 0.1, 0.25, 0.7] {
                let mut found = Vec::new();
                tree.within(*centre, radius * radius, &mut found);
                found.sort_unstable();
                let expected: Vec<u32> = (0..points.len() as u32)
                    .filter(|&j| points[j as usize].distance_squared(*centre) <= radius * radius)
                    .collect();
                assert_eq!(found, expected, "query {q} radius {radius}");
            }
        }
    }

    #[test]
    fn empty_and_tiny_trees_work() {
        let mut found = Vec::new();
        PointKdTree::new(&[]).within(DVec3::ZERO, 1.0, &mut found);
        PointKdTree::new(&[DVec3::ONE]).within(DVec3::ONE, 0.0, &mut found);
        assert_eq!(found, [0]);
    }
}
