//! A k-d tree over primitive bounds, built with the surface area heuristic on the CPU and
//! flattened for the GPU, and its traversal with the short stack of Horn et al. (2007): a stack
//! of a few entries that, when it overflows, forgets its oldest entry; when it runs dry before the
//! ray's interval is done, traversal restarts from the deepest node known to hold the rest of the
//! interval (push-down), beginning where the last leaf ended (kd-restart).
//!
//! The flattened form is two arrays the shaders read as is: nodes of two words and leaf primitive
//! lists. Interior node: `a = (far child << 2) | axis` with the near child at the next index,
//! `b` = split position (f32 bits). Leaf: `a = (first primitive << 2) | 3`, `b` = count.

/// Entries of the short stack (the same number in the shaders).
pub const SHORT_STACK: usize = 4;

/// Bins per axis for the SAH sweep.
const BINS: usize = 32;
/// Relative cost of a traversal step against one primitive test.
const TRAVERSAL_COST: f32 = 1.0;
/// Relative cost of testing one primitive: a polytope test (six to a few dozen planes, two
/// divisions each) against one traversal step. At 3 rather than 1.5 the trees are deeper and
/// rays test half as many elements (docs/DECISIONS.md#k-d-tree).
const INTERSECTION_COST: f32 = 3.0;
/// Leaves this small are not split.
const LEAF_SIZE: usize = 2;

/// An axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Minimum corner.
    pub min: [f32; 3],
    /// Maximum corner.
    pub max: [f32; 3],
}

impl Aabb {
    /// The empty box.
    pub const EMPTY: Aabb = Aabb { min: [f32::INFINITY; 3], max: [f32::NEG_INFINITY; 3] };

    /// The smallest box holding both.
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: [0, 1, 2].map(|a| self.min[a].min(other.min[a])),
            max: [0, 1, 2].map(|a| self.max[a].max(other.max[a])),
        }
    }

    /// Whether `point` is in the box (its faces included).
    pub fn holds(&self, point: [f32; 3]) -> bool {
        (0..3).all(|a| self.min[a] <= point[a] && point[a] <= self.max[a])
    }

    fn area(&self) -> f32 {
        let d = [0, 1, 2].map(|a| (self.max[a] - self.min[a]).max(0.0));
        2.0 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0])
    }
}

/// A flattened k-d tree.
#[derive(Debug, Clone, PartialEq)]
pub struct KdTree {
    /// Nodes, depth first, two words each (see the module docs).
    pub nodes: Vec<[u32; 2]>,
    /// Primitive indices of the leaves.
    pub items: Vec<u32>,
    /// Bounds of everything.
    pub bounds: Aabb,
}

/// The first word's low bits of a leaf node.
pub(crate) const LEAF: u32 = 3;

impl KdTree {
    /// Builds the tree over primitives with the given bounds.
    pub fn build(bounds: &[Aabb]) -> KdTree {
        let scene = bounds.iter().fold(Aabb::EMPTY, |acc, b| acc.union(b));
        let mut tree = KdTree { nodes: Vec::new(), items: Vec::new(), bounds: scene };
        if bounds.is_empty() {
            tree.nodes.push([LEAF, 0]);
            return tree;
        }
        let all: Vec<u32> = (0..bounds.len() as u32).collect();
        let (nodes, items) = build_subtree(bounds, all, scene, max_depth(bounds.len()));
        tree.nodes = nodes;
        tree.items = items;
        tree
    }

    /// Traverses the tree front to back along the ray `origin + t direction`, t in
    /// [`t_start`, `t_end`], calling `hit(primitive, t_min, t_max)` for the primitives of each leaf
    /// the ray passes, with the leaf's interval; `hit` returns the distance of the nearest hit it
    /// found so far (or infinity). Traversal stops once a hit lies within the current leaf.
    /// Returns the number of leaves visited. Mirrors the traversal in `shaders/hit_search.wgsl` (`closest_hit`) step for step.
    pub fn traverse(
        &self,
        origin: [f32; 3],
        direction: [f32; 3],
        t_start: f32,
        t_end: f32,
        hit: impl FnMut(u32, f32, f32) -> f32,
    ) -> u32 {
        self.traverse_within(&self.bounds, origin, direction, t_start, t_end, hit)
    }

    /// [`KdTree::traverse`] over the part of the ray inside `within` only (a box inside the
    /// tree's bounds, such as one fragment's): the leaves it visits are those the whole ray
    /// visits there, each with its interval clipped to the box.
    pub fn traverse_within(
        &self,
        within: &Aabb,
        origin: [f32; 3],
        direction: [f32; 3],
        t_start: f32,
        t_end: f32,
        mut hit: impl FnMut(u32, f32, f32) -> f32,
    ) -> u32 {
        let inverse = direction.map(inverse_component);
        let Some((scene_min, scene_max)) = clip(within, origin, inverse, t_start, t_end) else {
            return 0;
        };
        let mut stack = [(0u32, 0.0f32, 0.0f32); SHORT_STACK];
        let mut stack_len = 0usize;
        let mut root = 0u32;
        let (mut t_min, mut t_max) = (scene_min, scene_max);
        let mut node = root;
        let mut push_down = true;
        let mut best = f32::INFINITY;
        let mut leaves = 0;
        loop {
            let [a, b] = self.nodes[node as usize];
            if a & 3 != LEAF {
                let axis = (a & 3) as usize;
                let split = f32::from_bits(b);
                let t_split = (split - origin[axis]) * inverse[axis];
                let below_first = origin[axis] < split || (origin[axis] == split && direction[axis] <= 0.0);
                let (near, far) = if below_first { (node + 1, a >> 2) } else { (a >> 2, node + 1) };
                if t_split >= t_max || t_split < 0.0 {
                    node = near;
                } else if t_split <= t_min {
                    node = far;
                } else {
                    if stack_len == SHORT_STACK {
                        stack.copy_within(1.., 0);
                        stack_len -= 1;
                    }
                    stack[stack_len] = (far, t_split, t_max);
                    stack_len += 1;
                    node = near;
                    t_max = t_split;
                    push_down = false;
                }
                if push_down {
                    root = node;
                }
                continue;
            }
            leaves += 1;
            let (first, count) = ((a >> 2) as usize, b as usize);
            for &item in &self.items[first..first + count] {
                best = best.min(hit(item, t_min, t_max));
            }
            if best <= t_max {
                return leaves;
            }
            if stack_len > 0 {
                stack_len -= 1;
                (node, t_min, t_max) = stack[stack_len];
                push_down = false;
            } else if t_max >= scene_max {
                return leaves;
            } else {
                // kd-restart from the push-down root, beyond the leaf just done
                t_min = t_max;
                t_max = scene_max;
                node = root;
                push_down = true;
            }
        }
    }
}

impl KdTree {
    /// Calls `visit(primitive)` for the primitives of the leaf holding `point` (on a split plane,
    /// the upper side's). Primitives whose bounds contain the point are all among them.
    pub fn for_each_at(&self, point: [f32; 3], mut visit: impl FnMut(u32)) {
        let inside = (0..3).all(|a| point[a] >= self.bounds.min[a] && point[a] <= self.bounds.max[a]);
        if !inside {
            return;
        }
        let mut node = 0usize;
        loop {
            let [a, b] = self.nodes[node];
            if a & 3 == LEAF {
                let (first, count) = ((a >> 2) as usize, b as usize);
                for &item in &self.items[first..first + count] {
                    visit(item);
                }
                return;
            }
            let axis = (a & 3) as usize;
            node = if point[axis] < f32::from_bits(b) { node + 1 } else { (a >> 2) as usize };
        }
    }
}

/// 1 / d, with zero replaced by a tiny number of the same sign: infinities are not reliable on
/// GPUs, so both sides avoid them.
pub fn inverse_component(d: f32) -> f32 {
    let tiny = 1e-30f32;
    if d.abs() < tiny { 1.0 / tiny.copysign(d) } else { 1.0 / d }
}

/// The ray's interval inside `bounds`, intersected with [t_start, t_end].
pub(crate) fn clip(bounds: &Aabb, origin: [f32; 3], inverse: [f32; 3], t_start: f32, t_end: f32) -> Option<(f32, f32)> {
    let (mut near, mut far) = (t_start, t_end);
    for axis in 0..3 {
        let t0 = (bounds.min[axis] - origin[axis]) * inverse[axis];
        let t1 = (bounds.max[axis] - origin[axis]) * inverse[axis];
        let (lo, hi) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
        // NaN (a zero direction component exactly on a slab plane) keeps the interval
        near = if lo > near { lo } else { near };
        far = if hi < far { hi } else { far };
    }
    (near <= far).then_some((near, far))
}

/// The deepest a tree over `count` primitives goes (pbrt's rule).
fn max_depth(count: usize) -> usize {
    (8.0 + 1.3 * (count as f32).log2()) as usize
}

/// Subtrees with at least this many items are built in parallel with their sibling.
const PARALLEL_ITEMS: usize = 4096;

/// Builds the subtree over `items` within `node_box`: its nodes (depth first, child links and
/// leaf offsets relative to the subtree's own arrays) and leaf item lists. The two children of a
/// large node are built in parallel and spliced, left then right, so the result is the same as
/// a sequential depth-first build whatever the thread count.
fn build_subtree(bounds: &[Aabb], items: Vec<u32>, node_box: Aabb, depth_left: usize) -> (Vec<[u32; 2]>, Vec<u32>) {
    let (mut nodes, mut leaf_items) = (Vec::new(), Vec::new());
    if items.len() < PARALLEL_ITEMS {
        build_into(&mut nodes, &mut leaf_items, bounds, items, node_box, depth_left);
        return (nodes, leaf_items);
    }
    let ((axis, position), (left, left_box), (right, right_box)) = match split_node(bounds, items, node_box, depth_left)
    {
        Ok(split) => split,
        Err(items) => return (vec![[LEAF, items.len() as u32]], items),
    };
    let ((left_nodes, left_items), (right_nodes, right_items)) = rayon::join(
        || build_subtree(bounds, left, left_box, depth_left - 1),
        || build_subtree(bounds, right, right_box, depth_left - 1),
    );
    let far = 1 + left_nodes.len() as u32;
    nodes.reserve(1 + left_nodes.len() + right_nodes.len());
    nodes.push([(far << 2) | axis as u32, position.to_bits()]);
    nodes.extend(left_nodes.iter().map(|node| relocate(*node, 1, 0)));
    nodes.extend(right_nodes.iter().map(|node| relocate(*node, far, left_items.len() as u32)));
    leaf_items = left_items;
    leaf_items.extend(right_items);
    (nodes, leaf_items)
}

/// Appends the subtree over `items` within `node_box` to `nodes` and `leaf_items`, depth first.
fn build_into(
    nodes: &mut Vec<[u32; 2]>,
    leaf_items: &mut Vec<u32>,
    bounds: &[Aabb],
    items: Vec<u32>,
    node_box: Aabb,
    depth_left: usize,
) {
    let here = nodes.len();
    match split_node(bounds, items, node_box, depth_left) {
        Err(items) => {
            nodes.push([((leaf_items.len() as u32) << 2) | LEAF, items.len() as u32]);
            leaf_items.extend_from_slice(&items);
        }
        Ok(((axis, position), (left, left_box), (right, right_box))) => {
            nodes.push([0, position.to_bits()]);
            build_into(nodes, leaf_items, bounds, left, left_box, depth_left - 1);
            let far = nodes.len() as u32;
            build_into(nodes, leaf_items, bounds, right, right_box, depth_left - 1);
            nodes[here][0] = (far << 2) | axis as u32;
        }
    }
}

/// One side of a split: its items and box.
type Side = (Vec<u32>, Aabb);

/// The SAH split of a node, if splitting pays: (axis, position) and the two sides' items (an
/// item straddling the plane goes to both) and boxes; else the items back, for a leaf.
#[allow(clippy::type_complexity)]
fn split_node(
    bounds: &[Aabb],
    items: Vec<u32>,
    node_box: Aabb,
    depth_left: usize,
) -> Result<((usize, f32), Side, Side), Vec<u32>> {
    let split = if items.len() <= LEAF_SIZE || depth_left == 0 { None } else { best_split(bounds, &items, &node_box) };
    let Some((axis, position)) = split else {
        return Err(items);
    };
    let (mut left, mut right) = (Vec::new(), Vec::new());
    for &item in &items {
        let b = &bounds[item as usize];
        if b.min[axis] < position || (b.min[axis] == position && b.max[axis] == position) {
            left.push(item);
        }
        if b.max[axis] > position {
            right.push(item);
        }
    }
    let (mut left_box, mut right_box) = (node_box, node_box);
    left_box.max[axis] = position;
    right_box.min[axis] = position;
    Ok(((axis, position), (left, left_box), (right, right_box)))
}

/// `node` moved into a larger tree whose node array holds it `node_offset` further on and whose
/// item array holds its leaf's items `item_offset` further on.
fn relocate([a, b]: [u32; 2], node_offset: u32, item_offset: u32) -> [u32; 2] {
    if a & 3 == LEAF { [a + (item_offset << 2), b] } else { [a + (node_offset << 2), b] }
}

/// Nodes of at most this many items weigh a plane at each of their items' bounds; larger ones at
/// the [`BINS`] bin boundaries. Bin boundaries cut through items: in a grid of touching cubes
/// (their bounds widened by the tracer's slack, so neighbours overlap by a sliver) every such
/// plane copies a layer of cubes into both children, and a small node never runs out of slivers
/// to copy. Planes at the items' own bounds peel the slivers off, and the SAH then stops.
const EXACT_ITEMS: usize = 64;

/// The SAH-best split of `items` in `node_box`, if any beats making a leaf.
fn best_split(bounds: &[Aabb], items: &[u32], node_box: &Aabb) -> Option<(usize, f32)> {
    let area = node_box.area();
    if area <= 0.0 {
        return None;
    }
    let leaf_cost = INTERSECTION_COST * items.len() as f32;
    let binned = (items.len() > EXACT_ITEMS).then(|| bin_counts(bounds, items, node_box));
    let mut best: Option<(f32, usize, f32)> = None;
    for axis in 0..3 {
        let (lo, hi) = (node_box.min[axis], node_box.max[axis]);
        if hi <= lo {
            continue;
        }
        // A child of extent e along the axis has area 2 (d1 d2 + e (d1 + d2)), with d1 and d2
        // the node's other two extents: cross_area + perimeter * e.
        let [d1, d2] = [(axis + 1) % 3, (axis + 2) % 3].map(|a| (node_box.max[a] - node_box.min[a]).max(0.0));
        let (cross_area, perimeter) = (2.0 * d1 * d2, 2.0 * (d1 + d2));
        let mut weigh = |position: f32, left_count: usize, right_count: usize| {
            let (left_area, right_area) =
                (cross_area + perimeter * (position - lo), cross_area + perimeter * (hi - position));
            let cost = TRAVERSAL_COST
                + INTERSECTION_COST * (left_area * left_count as f32 + right_area * right_count as f32) / area;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, position));
            }
        };
        match &binned {
            Some((starts, ends)) => {
                // an item is on the left from the bin of its lower bound on, on the right up to
                // the bin of its upper bound
                let width = (hi - lo) / BINS as f32;
                let (mut left_count, mut right_count) = (0, items.len());
                for plane in 1..BINS {
                    left_count += starts[axis][plane - 1] as usize;
                    right_count -= ends[axis][plane - 1] as usize;
                    weigh(lo + plane as f32 * width, left_count, right_count);
                }
            }
            None => planes_at_bounds(bounds, items, axis, (lo, hi), &mut weigh),
        }
    }
    best.filter(|(cost, _, _)| *cost < leaf_cost).map(|(_, axis, position)| (axis, position))
}

/// Per axis, how many of `items` have their lower bound (`starts`) and their upper bound
/// (`ends`) in each of [`BINS`] equal bins across `node_box`; one pass over the items.
#[allow(clippy::type_complexity)]
fn bin_counts(bounds: &[Aabb], items: &[u32], node_box: &Aabb) -> ([[u32; BINS]; 3], [[u32; BINS]; 3]) {
    let lo = node_box.min;
    let scale = [0, 1, 2].map(|axis| {
        let extent = node_box.max[axis] - lo[axis];
        if extent > 0.0 { BINS as f32 / extent } else { 0.0 }
    });
    let bin = |x: f32, axis: usize| (((x - lo[axis]) * scale[axis]) as isize).clamp(0, BINS as isize - 1) as usize;
    let mut starts = [[0u32; BINS]; 3];
    let mut ends = [[0u32; BINS]; 3];
    for &item in items {
        let b = &bounds[item as usize];
        for axis in 0..3 {
            starts[axis][bin(b.min[axis], axis)] += 1;
            ends[axis][bin(b.max[axis], axis)] += 1;
        }
    }
    (starts, ends)
}

/// Calls `weigh(position, left count, right count)` for every item bound strictly inside `span`
/// along `axis`, with the exact counts of items reaching below and above the plane.
fn planes_at_bounds(
    bounds: &[Aabb],
    items: &[u32],
    axis: usize,
    (lo, hi): (f32, f32),
    weigh: &mut impl FnMut(f32, usize, usize),
) {
    // at most EXACT_ITEMS of each: on the stack (these nodes are most of a tree's nodes)
    let (mut low_store, mut high_store) = ([0.0f32; EXACT_ITEMS], [0.0f32; EXACT_ITEMS]);
    let (lows, highs) = (&mut low_store[..items.len()], &mut high_store[..items.len()]);
    for ((low, high), &item) in lows.iter_mut().zip(highs.iter_mut()).zip(items) {
        (*low, *high) = (bounds[item as usize].min[axis], bounds[item as usize].max[axis]);
    }
    lows.sort_unstable_by(f32::total_cmp);
    highs.sort_unstable_by(f32::total_cmp);
    // The lower bounds in order, then the upper ones: each run ascends, so the counts follow
    // with two pointers. A position equal to the one before weighs the same and cannot win
    // (ties keep the first), so it is skipped: in a grid most bounds are shared.
    let (lows, highs) = (&*lows, &*highs);
    for run in [lows, highs] {
        let (mut below, mut through, mut previous) = (0, 0, None);
        for &position in run {
            if previous == Some(position.to_bits()) {
                continue;
            }
            previous = Some(position.to_bits());
            if position > lo && position < hi {
                while below < lows.len() && lows[below] < position {
                    below += 1;
                }
                while through < highs.len() && highs[through] <= position {
                    through += 1;
                }
                weigh(position, below, highs.len() - through);
            }
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Random boxes and a brute-force nearest-hit against their slab intersections.
    pub(crate) fn boxes(seed: u64, count: usize) -> Vec<Aabb> {
        let mut rng = shatter_core::random::SplitMix64::new(seed);
        let mut r = move || rng.next_f64() as f32;
        (0..count)
            .map(|_| {
                let c = [r() * 10.0, r() * 10.0, r() * 10.0];
                let h = [r() * 0.6 + 0.05, r() * 0.6 + 0.05, r() * 0.6 + 0.05];
                Aabb { min: [c[0] - h[0], c[1] - h[1], c[2] - h[2]], max: [c[0] + h[0], c[1] + h[1], c[2] + h[2]] }
            })
            .collect()
    }

    /// The sweep's planes and counts: every distinct item bound inside the span, with the items
    /// reaching below and above it counted one by one, lower bounds first, each in order.
    #[test]
    fn the_plane_sweep_counts_like_brute_force() {
        for seed in 0..40 {
            // boxes on a coarse grid, so that many bounds are shared
            let items: Vec<Aabb> = boxes(seed, 1 + (seed as usize * 7) % EXACT_ITEMS)
                .iter()
                .map(|b| Aabb {
                    min: b.min.map(|x| (x * 2.0).round() / 2.0),
                    max: b.max.map(|x| (x * 2.0).round() / 2.0 + 0.5),
                })
                .collect();
            let ids: Vec<u32> = (0..items.len() as u32).collect();
            for axis in 0..3 {
                let span = (1.0, 9.0);
                let mut swept = Vec::new();
                planes_at_bounds(&items, &ids, axis, span, &mut |p, l, r| swept.push((p, l, r)));
                let mut expected = Vec::new();
                for ends in [|b: &Aabb, a: usize| b.min[a], |b: &Aabb, a: usize| b.max[a]] {
                    let mut positions: Vec<f32> = items.iter().map(|b| ends(b, axis)).collect();
                    positions.sort_by(f32::total_cmp);
                    positions.dedup();
                    for p in positions.into_iter().filter(|p| *p > span.0 && *p < span.1) {
                        let left = items.iter().filter(|b| b.min[axis] < p).count();
                        let right = items.iter().filter(|b| b.max[axis] > p).count();
                        expected.push((p, left, right));
                    }
                }
                assert_eq!(swept, expected, "seed {seed}, axis {axis}");
            }
        }
    }

    pub(crate) fn entry(b: &Aabb, origin: [f32; 3], direction: [f32; 3]) -> f32 {
        let inverse = direction.map(inverse_component);
        match clip(b, origin, inverse, 0.0, f32::INFINITY) {
            Some((near, _)) => near,
            None => f32::INFINITY,
        }
    }

    #[test]
    fn traversal_finds_the_nearest_box_like_brute_force() {
        let bounds = boxes(1, 12_000);
        let tree = KdTree::build(&bounds);
        let mut rng = shatter_core::random::SplitMix64::new(2);
        let mut r = move || rng.next_f64() as f32;
        let mut restarts_exercised = 0;
        for _ in 0..3000 {
            let origin = [r() * 14.0 - 2.0, r() * 14.0 - 2.0, r() * 14.0 - 2.0];
            let direction = [r() - 0.5, r() - 0.5, r() - 0.5];
            let expected = bounds.iter().map(|b| entry(b, origin, direction)).fold(f32::INFINITY, f32::min);
            let mut found = f32::INFINITY;
            let leaves = tree.traverse(origin, direction, 0.0, f32::INFINITY, |item, _, _| {
                found = found.min(entry(&bounds[item as usize], origin, direction));
                found
            });
            if leaves > 6 {
                restarts_exercised += 1;
            }
            assert_eq!(found, expected);
        }
        assert!(restarts_exercised > 0, "deep traversals happen");
    }

    #[test]
    fn axis_parallel_rays_and_empty_trees_work() {
        let bounds = boxes(3, 300);
        let tree = KdTree::build(&bounds);
        for axis in 0..3 {
            let mut origin = [5.0f32; 3];
            origin[axis] = -1.0;
            let mut direction = [0.0f32; 3];
            direction[axis] = 1.0;
            let expected = bounds.iter().map(|b| entry(b, origin, direction)).fold(f32::INFINITY, f32::min);
            let mut found = f32::INFINITY;
            tree.traverse(origin, direction, 0.0, f32::INFINITY, |item, _, _| {
                found = found.min(entry(&bounds[item as usize], origin, direction));
                found
            });
            assert_eq!(found, expected, "axis {axis}");
        }
        let empty = KdTree::build(&[]);
        let mut calls = 0;
        empty.traverse([0.0; 3], [1.0, 0.0, 0.0], 0.0, f32::INFINITY, |_, _, _| {
            calls += 1;
            0.0
        });
        assert_eq!(calls, 0);
    }

    /// The parallel build splices its subtrees into exactly the sequential depth-first layout.
    #[test]
    fn the_parallel_build_lays_the_tree_out_as_the_sequential_one() {
        let bounds = boxes(5, 20_000);
        let tree = KdTree::build(&bounds);
        let (mut nodes, mut items) = (Vec::new(), Vec::new());
        let all = (0..bounds.len() as u32).collect();
        build_into(&mut nodes, &mut items, &bounds, all, tree.bounds, max_depth(bounds.len()));
        assert!(nodes.len() > 1000, "a deep tree: {} nodes", nodes.len());
        assert_eq!(tree.nodes, nodes);
        assert_eq!(tree.items, items);
    }
}
