//! Fragments: connected components of the element adjacency graph over intact bonds, with ids
//! that stay stable from frame to frame.

use shatter_core::particles::ParticleSet;

/// The element adjacency graph in CSR form, each edge knowing the bond it rests on.
#[derive(Debug, Clone)]
pub struct AdjacencyGraph {
    offsets: Vec<u32>,
    neighbor: Vec<u32>,
    /// Index of the edge (into the particle file's adjacency pairs) behind each CSR entry.
    edge: Vec<u32>,
    /// The bond id behind each adjacency pair.
    edge_bond: Vec<u64>,
}

impl AdjacencyGraph {
    /// The graph of `particles`' adjacency pairs (each pair is a bond: the particle file
    /// guarantees it).
    pub fn new(particles: &ParticleSet) -> AdjacencyGraph {
        let n = particles.len();
        let pairs = &particles.adjacency;
        let mut degree = vec![0u32; n + 1];
        for &[a, b] in pairs {
            degree[a as usize + 1] += 1;
            degree[b as usize + 1] += 1;
        }
        for i in 0..n {
            degree[i + 1] += degree[i];
        }
        let offsets = degree.clone();
        let mut fill = degree;
        let mut neighbor = vec![0u32; 2 * pairs.len()];
        let mut edge = vec![0u32; 2 * pairs.len()];
        for (index, &[a, b]) in pairs.iter().enumerate() {
            for (from, to) in [(a, b), (b, a)] {
                let slot = fill[from as usize] as usize;
                neighbor[slot] = to;
                edge[slot] = index as u32;
                fill[from as usize] += 1;
            }
        }
        let edge_bond = pairs
            .iter()
            .map(|&[a, b]| {
                let k = particles
                    .bonds
                    .find(a as usize, b)
                    .unwrap_or_else(|| unreachable!("validated: adjacent elements are bonded"));
                k as u64
            })
            .collect();
        AdjacencyGraph { offsets, neighbor, edge, edge_bond }
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.offsets.len() - 1
    }

    /// True for a graph without elements.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number of adjacency pairs.
    pub fn edge_count(&self) -> usize {
        self.edge_bond.len()
    }

    /// The bond behind adjacency pair `edge`.
    pub fn edge_bond(&self, edge: usize) -> u64 {
        self.edge_bond[edge]
    }

    /// Labels connected components over the edges for which `intact[edge]` holds, by breadth-first
    /// search from elements in increasing index: component k is the k-th one reached, and
    /// `labels[element]` its number. Returns the number of components.
    pub fn components(&self, intact: &[bool], labels: &mut Vec<u32>) -> usize {
        let n = self.len();
        labels.clear();
        labels.resize(n, u32::MAX);
        let mut queue = Vec::new();
        let mut count = 0u32;
        for start in 0..n {
            if labels[start] != u32::MAX {
                continue;
            }
            labels[start] = count;
            queue.clear();
            queue.push(start as u32);
            let mut head = 0;
            while head < queue.len() {
                let element = queue[head] as usize;
                head += 1;
                for slot in self.offsets[element] as usize..self.offsets[element + 1] as usize {
                    let other = self.neighbor[slot] as usize;
                    if intact[self.edge[slot] as usize] && labels[other] == u32::MAX {
                        labels[other] = count;
                        queue.push(other as u32);
                    }
                }
            }
            count += 1;
        }
        count as usize
    }
}

/// Gives components stable fragment ids: on the first frame ids are the component numbers; later,
/// a component takes the id of the fragment it came from if it is that fragment's largest part
/// (most elements, then the lowest first element), and otherwise a new id, new ids being handed
/// out in order of (old id, first element). Components only ever split (bonds never heal), so each
/// lies within one earlier fragment.
#[derive(Debug, Clone, Default)]
pub struct StableIds {
    fragment_of: Vec<u32>,
    next_id: u32,
}

impl StableIds {
    /// No frame seen yet.
    pub fn new() -> StableIds {
        StableIds::default()
    }

    /// The fragment of each element in the last frame given.
    pub fn fragment_of(&self) -> &[u32] {
        &self.fragment_of
    }

    /// Number of fragments in the last frame given.
    pub fn count(&self) -> usize {
        self.next_id as usize
    }

    /// For every new fragment id of the last update, the id it split from (its parent), in id
    /// order: ids `count() - splits.len()` .. `count()`.
    pub fn assign(&mut self, labels: &[u32], components: usize) -> Vec<u32> {
        if self.fragment_of.is_empty() {
            self.fragment_of = labels.to_vec();
            self.next_id = components as u32;
            return Vec::new();
        }
        // For each component: its parent fragment, size and first element.
        let mut parent = vec![u32::MAX; components];
        let mut size = vec![0u32; components];
        let mut first = vec![u32::MAX; components];
        for (element, &label) in labels.iter().enumerate() {
            let c = label as usize;
            if parent[c] == u32::MAX {
                parent[c] = self.fragment_of[element];
                first[c] = element as u32;
            }
            size[c] += 1;
        }
        // The largest part of each parent keeps its id.
        let mut keeper = vec![u32::MAX; self.next_id as usize];
        for c in 0..components {
            let p = parent[c] as usize;
            let better = keeper[p] == u32::MAX || {
                let k = keeper[p] as usize;
                (size[c], std::cmp::Reverse(first[c])) > (size[k], std::cmp::Reverse(first[k]))
            };
            if better {
                keeper[p] = c as u32;
            }
        }
        let mut id_of = vec![u32::MAX; components];
        let mut newcomers: Vec<usize> = Vec::new();
        for c in 0..components {
            if keeper[parent[c] as usize] == c as u32 {
                id_of[c] = parent[c];
            } else {
                newcomers.push(c);
            }
        }
        newcomers.sort_by_key(|&c| (parent[c], first[c]));
        let mut parents = Vec::with_capacity(newcomers.len());
        for c in newcomers {
            id_of[c] = self.next_id;
            parents.push(parent[c]);
            self.next_id += 1;
        }
        for (element, &label) in labels.iter().enumerate() {
            self.fragment_of[element] = id_of[label as usize];
        }
        parents
    }
}

/// The fragments of a run of frames as bonds break: the components of the intact adjacency,
/// with [`StableIds`]. What post's tracker and the preview's live figures both count.
#[derive(Debug, Clone)]
pub struct FragmentIds {
    graph: AdjacencyGraph,
    intact: Vec<bool>,
    /// (bond id, adjacency edge), sorted: which edges a broken bond cuts.
    edges_by_bond: Vec<(u64, u32)>,
    labels: Vec<u32>,
    ids: StableIds,
}

impl FragmentIds {
    /// Every adjacency of `particles` intact, no frame seen yet.
    pub fn new(particles: &ParticleSet) -> FragmentIds {
        let graph = AdjacencyGraph::new(particles);
        let mut edges_by_bond: Vec<(u64, u32)> =
            (0..graph.edge_count()).map(|edge| (graph.edge_bond(edge), edge as u32)).collect();
        edges_by_bond.sort_unstable();
        FragmentIds {
            intact: vec![true; graph.edge_count()],
            graph,
            edges_by_bond,
            labels: Vec::new(),
            ids: StableIds::new(),
        }
    }

    /// Marks the adjacency edges resting on `bond` broken.
    pub fn break_bond(&mut self, bond: u64) {
        let start = self.edges_by_bond.partition_point(|(b, _)| *b < bond);
        for &(b, edge) in &self.edges_by_bond[start..] {
            if b != bond {
                break;
            }
            self.intact[edge as usize] = false;
        }
    }

    /// Finds the fragments of the next frame (the bonds broken so far): for every new id, the
    /// id it split from ([`StableIds::assign`]).
    pub fn next_frame(&mut self) -> Vec<u32> {
        let components = self.graph.components(&self.intact, &mut self.labels);
        self.ids.assign(&self.labels, components)
    }

    /// The fragment of each element in the last frame.
    pub fn fragment_of(&self) -> &[u32] {
        self.ids.fragment_of()
    }

    /// Number of fragments in the last frame.
    pub fn count(&self) -> usize {
        self.ids.count()
    }
}

/// A histogram of fragment sizes (elements): (lower bound, count) for bins 1, 2-3, 4-7, ...
pub fn size_histogram(elements: &[u32]) -> Vec<(u32, u32)> {
    let mut bins: Vec<(u32, u32)> = Vec::new();
    for &size in elements {
        let bin = 31 - size.max(1).leading_zeros();
        if bins.len() <= bin as usize {
            bins.extend((bins.len() as u32..=bin).map(|b| (1u32 << b, 0)));
        }
        bins[bin as usize].1 += 1;
    }
    bins
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_stay_with_the_largest_part_through_splits() {
        let mut ids = StableIds::new();
        // frame 1: one piece of 6 elements
        assert!(ids.assign(&[0, 0, 0, 0, 0, 0], 1).is_empty());
        // frame 2: splits into {0, 1} and {2, 3, 4, 5}: the larger keeps id 0
        let parents = ids.assign(&[0, 0, 1, 1, 1, 1], 2);
        assert_eq!(ids.fragment_of(), &[1, 1, 0, 0, 0, 0]);
        assert_eq!(parents, vec![0]);
        // frame 3: {2, 3, 4, 5} splits into three; {0, 1} stays
        let parents = ids.assign(&[0, 0, 1, 2, 2, 3], 4);
        assert_eq!(ids.fragment_of(), &[1, 1, 2, 0, 0, 3]);
        assert_eq!(parents, vec![0, 0]);
        assert_eq!(ids.count(), 4);
    }

    #[test]
    fn histogram_bins_are_powers_of_two() {
        assert_eq!(size_histogram(&[1, 1, 2, 3, 4, 9]), vec![(1, 2), (2, 2), (4, 1), (8, 1)]);
    }
}
