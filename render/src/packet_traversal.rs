//! Packets of rays through the k-d tree ([`crate::element_kdtree`]): a tile's camera rays walk
//! the tree together, each meeting the same leaves in the same order as it would alone. The rays
//! share one origin ([`SharedOrigin`]: camera rays at the frame's centre), or each has its own
//! ([`RayOrigins`]: camera rays at their own shutter times, carried into a moving piece's frame,
//! their origins a little apart).

use crate::element_kdtree::{Aabb, KdTree, LEAF, clip, inverse_component};

/// Rays in a packet: a tile of camera rays ([`crate::image_loop::TILE_ROWS`] rows).
pub const PACKET: usize = 16;

/// Interval bounds of a packet's rays.
pub type Intervals = [f32; PACKET];

/// Where a packet's rays start.
pub trait Origins {
    /// Ray `r`'s origin.
    fn of(&self, r: usize) -> [f32; 3];

    /// Each lane's `split` minus its ray's origin on `axis`.
    fn offsets(&self, axis: usize, split: f32) -> Intervals;

    /// Whether the rays of the bit mask `rays` (not empty) visit the lower child of a node split
    /// at `split` on `axis` first, each as [`KdTree::traverse`] chooses alone; None when their
    /// choices differ.
    fn below_first(&self, axis: usize, split: f32, directions: &[[f32; 3]], rays: u32) -> Option<bool>;
}

/// One origin for every ray of a packet.
#[derive(Debug, Clone, Copy)]
pub struct SharedOrigin(pub [f32; 3]);

/// Each ray of a packet its own origin, axis by axis: `0[axis][r]` (lanes past the rays unused).
#[derive(Debug, Clone, Copy)]
pub struct RayOrigins(pub [Intervals; 3]);

impl Origins for SharedOrigin {
    #[inline(always)]
    fn of(&self, _: usize) -> [f32; 3] {
        self.0
    }

    #[inline(always)]
    fn offsets(&self, axis: usize, split: f32) -> Intervals {
        [split - self.0[axis]; PACKET]
    }

    #[inline(always)]
    fn below_first(&self, axis: usize, split: f32, directions: &[[f32; 3]], rays: u32) -> Option<bool> {
        if self.0[axis] != split {
            return Some(self.0[axis] < split);
        }
        let downwards = each_ray(rays).filter(|&r| directions[r][axis] <= 0.0).count();
        (downwards == 0 || downwards == rays.count_ones() as usize).then_some(downwards != 0)
    }
}

impl Origins for RayOrigins {
    #[inline(always)]
    fn of(&self, r: usize) -> [f32; 3] {
        [self.0[0][r], self.0[1][r], self.0[2][r]]
    }

    #[inline(always)]
    fn offsets(&self, axis: usize, split: f32) -> Intervals {
        let origins = &self.0[axis];
        std::array::from_fn(|r| split - origins[r])
    }

    #[inline(always)]
    fn below_first(&self, axis: usize, split: f32, directions: &[[f32; 3]], rays: u32) -> Option<bool> {
        // every lane at once; a lane on the plane goes by its direction, as alone
        let (origins, mut below, mut on_plane) = (&self.0[axis], 0u32, 0u32);
        for (r, &o) in origins.iter().enumerate() {
            below |= u32::from(o < split) << r;
            on_plane |= u32::from(o == split) << r;
        }
        for r in each_ray(on_plane & rays) {
            below |= u32::from(directions[r][axis] <= 0.0) << r;
        }
        match below & rays {
            0 => Some(false),
            all => (all == rays).then_some(true),
        }
    }
}

/// A subtree a packet still has to visit: its node, the rays that visit it, their intervals.
struct PacketEntry {
    node: u32,
    rays: u32,
    t_min: Intervals,
    t_max: Intervals,
}

impl KdTree {
    /// Traverses the tree with a packet of rays from one `origin` (at most [`PACKET`]
    /// `directions`, t from `t_start` on), calling `hit(primitive, rays)` for the primitives of
    /// each leaf, with the bit mask of the packet's rays that pass the leaf; `hit` returns every
    /// ray's nearest hit so far. Each ray meets the same leaves in the same order, and stops after
    /// the same leaf, as [`KdTree::traverse`] would take it alone, so its nearest hit is the
    /// same to the bit (a nearest hit does not depend on the order of the tests, only on which
    /// are made); the packet takes each node's choice for all its rays at once, lane by lane,
    /// which is what camera rays (one origin, close directions) share.
    /// Returns false, having done nothing useful, when the origin lies exactly on a split plane
    /// that the rays cross in different directions (their near sides differ): trace them alone.
    pub fn traverse_packet(
        &self,
        origin: [f32; 3],
        directions: &[[f32; 3]],
        t_start: f32,
        mut hit: impl FnMut(u32, u32) -> [f32; PACKET],
    ) -> bool {
        let span = ([t_start; PACKET], [f32::INFINITY; PACKET]);
        let origin = SharedOrigin(origin);
        self.traverse_packet_within(&self.bounds, &origin, directions, span, |item, rays, _| hit(item, rays))
    }

    /// [`KdTree::traverse_packet`] from `origins`, over the part of each ray r inside `within`
    /// and between `span.0[r]` and `span.1[r]` only (as [`KdTree::traverse_within`]); `hit` also
    /// gets the leaf's interval of each ray. Returns false, having done nothing useful, when the
    /// rays' near sides of a split plane differ (rays from one origin exactly on the plane that
    /// cross it both ways, or rays whose origins lie on either side of it).
    pub fn traverse_packet_within(
        &self,
        within: &Aabb,
        origins: &impl Origins,
        directions: &[[f32; 3]],
        span: (Intervals, Intervals),
        mut hit: impl FnMut(u32, u32, (&Intervals, &Intervals)) -> [f32; PACKET],
    ) -> bool {
        assert!(directions.len() <= PACKET, "a packet holds at most {PACKET} rays");
        // per axis, each ray's inverse direction component (lanes past the rays stay 1)
        let mut inverse = [[1.0f32; PACKET]; 3];
        let (mut t_min, mut t_max) = ([0.0f32; PACKET], [0.0f32; PACKET]);
        let mut rays = 0u32;
        for (r, direction) in directions.iter().enumerate() {
            let ray_inverse = direction.map(inverse_component);
            for axis in 0..3 {
                inverse[axis][r] = ray_inverse[axis];
            }
            let clipped = clip(within, origins.of(r), ray_inverse, span.0[r], span.1[r]);
            // Written whatever the outcome (a ray that misses keeps 0, 0): a store under a
            // condition becomes a masked vector store, slow on AMD cores
            // (docs/DECISIONS.md#no-masked-stores).
            (t_min[r], t_max[r]) = clipped.unwrap_or((0.0, 0.0));
            rays |= u32::from(clipped.is_some()) << r;
        }
        let mut best = [f32::INFINITY; PACKET];
        let mut done = 0u32;
        let mut stack: Vec<PacketEntry> = Vec::new();
        let mut node = 0u32;
        loop {
            rays &= !done;
            if rays != 0 {
                let [a, b] = self.nodes[node as usize];
                if a & 3 != LEAF {
                    let axis = (a & 3) as usize;
                    let split = f32::from_bits(b);
                    let Some(below_first) = origins.below_first(axis, split, directions, rays) else {
                        return false;
                    };
                    let (near, far) = if below_first { (node + 1, a >> 2) } else { (a >> 2, node + 1) };
                    // Every lane at once (the rays' own choices as in `traverse`): the near child
                    // only, the far child only, or both, the near one up to the plane.
                    let offsets = origins.offsets(axis, split);
                    let (mut near_rays, mut far_rays) = (0u32, 0u32);
                    let (mut far_min, far_max) = ([0.0f32; PACKET], t_max);
                    for r in 0..PACKET {
                        let t_split = offsets[r] * inverse[axis][r];
                        let near_only = t_split >= t_max[r] || t_split < 0.0;
                        let far_only = !near_only && t_split <= t_min[r];
                        let both = !near_only && !far_only;
                        near_rays |= u32::from(!far_only) << r;
                        far_rays |= u32::from(!near_only) << r;
                        far_min[r] = if both { t_split } else { t_min[r] };
                        t_max[r] = if both { t_split } else { t_max[r] };
                    }
                    let (near_rays, far_rays) = (near_rays & rays, far_rays & rays);
                    if near_rays == 0 {
                        // every ray goes on in the far child only, with its interval unchanged
                        (node, rays) = (far, far_rays);
                        continue;
                    }
                    if far_rays != 0 {
                        stack.push(PacketEntry { node: far, rays: far_rays, t_min: far_min, t_max: far_max });
                    }
                    (node, rays) = (near, near_rays);
                    continue;
                }
                let (first, count) = ((a >> 2) as usize, b as usize);
                for &item in &self.items[first..first + count] {
                    best = hit(item, rays, (&t_min, &t_max));
                }
                for r in each_ray(rays) {
                    if best[r] <= t_max[r] {
                        done |= 1 << r;
                    }
                }
            }
            let Some(entry) = stack.pop() else {
                return true;
            };
            (node, rays, t_min, t_max) = (entry.node, entry.rays, entry.t_min, entry.t_max);
        }
    }
}

/// The rays of a packet's bit mask, lowest first.
pub fn each_ray(mut rays: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (rays != 0).then(|| {
            let r = rays.trailing_zeros() as usize;
            rays &= rays - 1;
            r
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element_kdtree::tests::{boxes, entry};

    /// The items a ray meets alone through `tree` over boxes `bounds`, in order, up to its
    /// nearest box.
    fn leaves_alone(
        tree: &KdTree,
        bounds: &[crate::element_kdtree::Aabb],
        origin: [f32; 3],
        direction: [f32; 3],
    ) -> Vec<u32> {
        let (mut seen, mut found) = (Vec::new(), f32::INFINITY);
        tree.traverse(origin, direction, 0.0, f32::INFINITY, |item, _, _| {
            seen.push(item);
            found = found.min(entry(&bounds[item as usize], origin, direction));
            found
        });
        seen
    }

    /// A packet takes each ray through the leaves it meets alone, in the same order, and stops
    /// it after the same leaf; on a split plane that its rays cross both ways, it gives up.
    #[test]
    fn packets_visit_the_leaves_single_rays_visit() {
        let bounds = boxes(7, 6000);
        let tree = KdTree::build(&bounds);
        let mut rng = shatter_core::random::SplitMix64::new(8);
        let mut r = move || rng.next_f64() as f32;
        let mut visits = 0;
        for trial in 0..400 {
            let origin = [r() * 14.0 - 2.0, r() * 14.0 - 2.0, r() * 14.0 - 2.0];
            let base = [r() - 0.5, r() - 0.5, r() - 0.5];
            // narrow packets (as camera rays are) and wide ones
            let spread = if trial % 2 == 0 { 0.02 } else { 1.0 };
            let directions: Vec<[f32; 3]> =
                (0..1 + trial % PACKET).map(|_| base.map(|b| b + spread * (r() - 0.5))).collect();
            let alone: Vec<Vec<u32>> =
                directions.iter().map(|&direction| leaves_alone(&tree, &bounds, origin, direction)).collect();
            let mut together = vec![Vec::new(); directions.len()];
            let mut found = [f32::INFINITY; PACKET];
            let traversed = tree.traverse_packet(origin, &directions, 0.0, |item, rays| {
                for ray in each_ray(rays) {
                    together[ray].push(item);
                    found[ray] = found[ray].min(entry(&bounds[item as usize], origin, directions[ray]));
                }
                found
            });
            assert!(traversed, "trial {trial}");
            assert_eq!(together, alone, "trial {trial}");
            visits += alone.iter().map(Vec::len).sum::<usize>();
        }
        assert!(visits > 10_000, "{visits} tests");
        let [a, b] = tree.nodes[0];
        let (axis, split) = ((a & 3) as usize, f32::from_bits(b));
        let mut origin = [5.0f32; 3];
        origin[axis] = split;
        let mut up = [0.3f32, 0.2, 0.1];
        up[axis] = 1.0;
        let mut down = up;
        down[axis] = -1.0;
        assert!(!tree.traverse_packet(origin, &[up, down], 0.0, |_, _| [f32::INFINITY; PACKET]));
        assert!(tree.traverse_packet(origin, &[down, down], 0.0, |_, _| [f32::INFINITY; PACKET]));
    }

    /// Rays from origins a little apart (camera rays at their own times, in a moving piece's
    /// frame) also meet each one's own leaves in its own order; origins on either side of a
    /// split plane make the packet give up.
    #[test]
    fn packets_from_their_own_origins_visit_the_leaves_single_rays_visit() {
        let bounds = boxes(9, 6000);
        let tree = KdTree::build(&bounds);
        let mut rng = shatter_core::random::SplitMix64::new(10);
        let mut r = move || rng.next_f64() as f32;
        let (mut visits, mut whole) = (0, 0);
        for trial in 0..400 {
            let centre = [r() * 14.0 - 2.0, r() * 14.0 - 2.0, r() * 14.0 - 2.0];
            let base = [r() - 0.5, r() - 0.5, r() - 0.5];
            let count = 1 + trial % PACKET;
            let apart = if trial % 2 == 0 { 1e-3 } else { 0.05 };
            let mut origins = RayOrigins([[0.0; PACKET]; 3]);
            for k in 0..count {
                for (axis, c) in centre.iter().enumerate() {
                    origins.0[axis][k] = c + apart * (r() - 0.5);
                }
            }
            let directions: Vec<[f32; 3]> = (0..count).map(|_| base.map(|b| b + 0.02 * (r() - 0.5))).collect();
            let alone: Vec<Vec<u32>> = directions
                .iter()
                .enumerate()
                .map(|(k, &direction)| leaves_alone(&tree, &bounds, origins.of(k), direction))
                .collect();
            let mut together = vec![Vec::new(); count];
            let mut found = [f32::INFINITY; PACKET];
            let span = ([0.0; PACKET], [f32::INFINITY; PACKET]);
            let traversed = tree.traverse_packet_within(&tree.bounds, &origins, &directions, span, |item, rays, _| {
                for ray in each_ray(rays) {
                    together[ray].push(item);
                    found[ray] = found[ray].min(entry(&bounds[item as usize], origins.of(ray), directions[ray]));
                }
                found
            });
            if traversed {
                assert_eq!(together, alone, "trial {trial}");
                whole += 1;
                visits += alone.iter().map(Vec::len).sum::<usize>();
            }
        }
        assert!(whole > 300 && visits > 10_000, "{whole} whole packets, {visits} tests");
        // two origins either side of the root's plane, both rays crossing it upwards: their near
        // sides differ
        let [a, b] = tree.nodes[0];
        let (axis, split) = ((a & 3) as usize, f32::from_bits(b));
        let mut origins = RayOrigins([[5.0; PACKET]; 3]);
        (origins.0[axis][0], origins.0[axis][1]) = (split - 0.01, split + 0.01);
        let mut up = [0.3f32, 0.2, 0.1];
        up[axis] = 1.0;
        let span = ([0.0; PACKET], [f32::INFINITY; PACKET]);
        let none = |_: u32, _: u32, _: (&Intervals, &Intervals)| [f32::INFINITY; PACKET];
        assert!(!tree.traverse_packet_within(&tree.bounds, &origins, &[up, up], span, none));
        origins.0[axis][1] = split - 0.02;
        assert!(tree.traverse_packet_within(&tree.bounds, &origins, &[up, up], span, none));
    }
}
