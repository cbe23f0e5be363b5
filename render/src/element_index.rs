//! Where the CPU tracer looks for the elements a ray may meet. The fragments move rigidly, so
//! their elements keep their places relative to one another: one k-d tree over the elements in
//! their rest positions ([`RestTree`]) is built once for a whole render, and each frame builds
//! only a small tree over its fragments' world boxes ([`ElementIndex`]). A ray that reaches a
//! fragment's box is carried into the rest frame by the inverse of the fragment's motion and
//! walks the rest tree inside the fragment's rest box, offering that fragment's own elements.
//!
//! The elements are still tested in world space, against the frame's planes, and a nearest hit
//! does not depend on which tree offered the candidates (ties go to the lower element), so the
//! images are those of one world tree per frame. What the rest tree must guarantee is only that
//! it offers every element a ray can hit: its element boxes are widened by a margin that covers
//! the f32 rounding of the frame's placement of the elements. A frame whose motions that margin
//! does not cover (pieces very far from the origin), or whose pieces deform (affine maps that are
//! not rigid), gets one world tree over its elements instead.

use std::sync::Arc;

use glam::{DQuat, DVec3, Quat, Vec3};

use crate::element_kdtree::{Aabb, KdTree};
use crate::packet_traversal::{PACKET, RayOrigins, SharedOrigin, each_ray};
use crate::shutter::SceneMotion;

/// The instance that holds every element (a world tree, or the unmoved rest state).
const EVERY: u32 = u32::MAX;

/// Scenes of fewer elements are rendered with a world tree per frame: it is then cheap to
/// build, and walking fragments through a rest tree costs more than it saves (the 3,000 cells
/// of `dragon_small`: its first 12 frames 22 to 27 s with world trees, 27 to 31 s through a
/// rest tree; the 43,000 tetrahedra of `vase_small` and the 50,000 cubes of the default shot
/// render 1.5x to 1.9x faster through one).
pub const REST_TREE_MIN_ELEMENTS: usize = 16_384;

/// The elements' k-d tree in their rest positions, for every frame of a render.
#[derive(Debug, Clone)]
pub struct RestTree {
    /// The tree over `bounds`.
    tree: Arc<KdTree>,
    /// Each element's rest box, widened by `margin_m`.
    bounds: Vec<Aabb>,
    /// How far the boxes are widened beyond the elements, metres.
    margin_m: f32,
    /// The tracers' widening of the elements ([`crate::scene_geometry::SceneGeometry::slack`]), metres.
    slack_m: f32,
    /// The largest coordinate of any rest box, metres.
    reach_m: f32,
}

impl RestTree {
    /// The tree over the elements' exact rest boxes `exact`, each widened by twice the tracers'
    /// `slack_m` (as the world tree's) and by 1/256 of the lattice spacing `lambda_m` for the
    /// rounding of the frames' motions.
    pub fn new(exact: &[Aabb], slack_m: f32, lambda_m: f32) -> RestTree {
        let margin_m = 2.0 * slack_m + lambda_m / 256.0;
        let bounds: Vec<Aabb> =
            exact.iter().map(|b| Aabb { min: b.min.map(|v| v - margin_m), max: b.max.map(|v| v + margin_m) }).collect();
        let reach_m = bounds.iter().flat_map(|b| b.min.into_iter().chain(b.max)).fold(0.0f32, |r, v| r.max(v.abs()));
        RestTree { tree: Arc::new(KdTree::build(&bounds)), bounds, margin_m, slack_m, reach_m }
    }

    /// Whether the margin covers elements placed by `motions` (rotation, translation) in f32: a
    /// few roundings of coordinates as large as the rest boxes' plus the largest translation.
    fn covers(&self, motions: &[(Quat, Vec3)]) -> bool {
        let travel = motions.iter().fold(0.0f32, |r, (_, t)| r.max(t.abs().max_element()));
        let need = 2.0 * self.slack_m + 16.0 * f32::EPSILON * 3.0 * (self.reach_m + travel);
        need <= self.margin_m && motions.iter().all(|(q, t)| q.is_finite() && t.is_finite())
    }
}

/// A packet's rays carried to the frame's centre placement of one motion group: each ray's
/// (origin, direction), world axes.
pub type CentreRays = [([f32; 3], [f32; 3]); PACKET];

/// One fragment's (or every element's) entry in an [`ElementIndex`].
#[derive(Debug, Clone, PartialEq)]
struct Instance {
    /// The fragment whose elements it offers, or [`EVERY`].
    fragment: u32,
    /// World to tree frame: x -> `rotation` (x - `translation`) `scale` (the inverse of the
    /// fragment's x = s R X + t, with s = |q|^2 as glam applies a quaternion); None for the
    /// identity.
    to_tree: Option<(DQuat, DVec3, f64)>,
    /// Its box in the tree's frame.
    tree_box: Aabb,
}

impl Instance {
    /// A point in the tree's frame.
    fn point(&self, p: [f32; 3]) -> [f32; 3] {
        match self.to_tree {
            None => p,
            Some((rotation, translation, scale)) => {
                ((rotation * (DVec3::from_array(p.map(f64::from)) - translation)) * scale).as_vec3().to_array()
            }
        }
    }

    /// A direction in the tree's frame (ray parameters are kept).
    fn vector(&self, d: [f32; 3]) -> [f32; 3] {
        match self.to_tree {
            None => d,
            Some((rotation, _, scale)) => {
                ((rotation * DVec3::from_array(d.map(f64::from))) * scale).as_vec3().to_array()
            }
        }
    }

    /// Whether element `e` is one of this instance's.
    fn holds(&self, fragment_of: &[u32], e: u32) -> bool {
        self.fragment == EVERY || fragment_of[e as usize] == self.fragment
    }
}

/// One frame's index of its elements for the CPU tracer (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct ElementIndex {
    /// The tree the instances are walked in: the render's rest tree, or this frame's world tree.
    tree: Arc<KdTree>,
    /// The instances, in the order of `top`'s items.
    instances: Vec<Instance>,
    /// A k-d tree over the instances' world boxes.
    top: KdTree,
}

impl ElementIndex {
    /// One world tree over the elements' world boxes `bounds` (walked directly: no top tree).
    pub fn world(bounds: &[Aabb]) -> ElementIndex {
        let tree = KdTree::build(bounds);
        let instance = Instance { fragment: EVERY, to_tree: None, tree_box: tree.bounds };
        ElementIndex { top: KdTree::build(&[]), tree: Arc::new(tree), instances: vec![instance] }
    }

    /// The tree, when this is one world tree ([`ElementIndex::world`]).
    pub fn world_tree(&self) -> Option<&KdTree> {
        matches!(self.instances.as_slice(), [Instance { fragment: EVERY, to_tree: None, .. }]).then_some(&*self.tree)
    }

    /// The index of elements placed rigidly by their fragments: element e belongs to fragment
    /// `fragment_of[e]`, moved by `motions[f]` (x = q X + t, as the scene places it) into world
    /// boxes `bounds[e]`. None when `rest`'s margin does not cover these motions.
    pub fn of_fragments(
        rest: &RestTree,
        fragment_of: &[u32],
        motions: &[(Quat, Vec3)],
        bounds: &[Aabb],
    ) -> Option<ElementIndex> {
        if !rest.covers(motions) || fragment_of.iter().any(|&f| f as usize >= motions.len()) {
            return None;
        }
        let (mut world_box, mut tree_box) = (vec![Aabb::EMPTY; motions.len()], vec![Aabb::EMPTY; motions.len()]);
        for (e, &f) in fragment_of.iter().enumerate() {
            world_box[f as usize] = world_box[f as usize].union(&bounds[e]);
            tree_box[f as usize] = tree_box[f as usize].union(&rest.bounds[e]);
        }
        let mut instances = Vec::new();
        let mut boxes = Vec::new();
        for (f, (q, t)) in motions.iter().enumerate() {
            if tree_box[f].min[0] > tree_box[f].max[0] {
                continue; // no elements
            }
            let q = DQuat::from_xyzw(f64::from(q.x), f64::from(q.y), f64::from(q.z), f64::from(q.w));
            let s = q.length_squared();
            let to_tree = (q.conjugate(), t.as_dvec3(), 1.0 / (s * s));
            instances.push(Instance { fragment: f as u32, to_tree: Some(to_tree), tree_box: tree_box[f] });
            boxes.push(world_box[f]);
        }
        Some(ElementIndex { tree: Arc::clone(&rest.tree), instances, top: KdTree::build(&boxes) })
    }

    /// Calls `hit(element, carried)` for every element the ray `origin + t direction`, t from
    /// `t_start` on, may meet before its nearest hit; `hit` returns the distance of the nearest hit so
    /// far (or infinity). The nearest hit is the one a single tree over the elements would find.
    /// Each fragment is walked over the interval of each leaf of the top tree that lists it, so
    /// the walks go front to back and stop at the nearest hit, however the fragments' boxes
    /// overlap. With `shutter` (the scene's motion and the ray's time), the instances are the
    /// motion's groups, and the ray is carried to the frame's centre for each before its walk;
    /// `carried` is the ray so carried for the element's group (None without `shutter`, or
    /// through a world tree).
    pub fn traverse(
        &self,
        fragment_of: &[u32],
        (origin, direction): ([f32; 3], [f32; 3]),
        t_start: f32,
        shutter: Option<(&SceneMotion, f32)>,
        mut hit: impl FnMut(u32, Option<([f32; 3], [f32; 3])>) -> f32,
    ) {
        if let Some(tree) = self.world_tree() {
            tree.traverse(origin, direction, t_start, f32::INFINITY, |e, _, _| hit(e, None));
            return;
        }
        let mut best = f32::INFINITY;
        self.top.traverse(origin, direction, t_start, f32::INFINITY, |i, t_min, t_max| {
            let instance = &self.instances[i as usize];
            let (origin, direction) =
                match shutter.and_then(|(motion, time)| motion.group_to_centre(instance.fragment, time)) {
                    Some(map) => (map.point(origin), map.vector(direction)),
                    None => (origin, direction),
                };
            let (o, d) = (instance.point(origin), instance.vector(direction));
            let carried = shutter.is_some().then_some((origin, direction));
            self.tree.traverse_within(&instance.tree_box, o, d, t_min, t_max, |e, _, _| {
                if instance.holds(fragment_of, e) {
                    best = hit(e, carried);
                }
                best
            });
            best
        });
    }

    /// [`ElementIndex::traverse`] for a packet of rays from one `origin` (at most [`PACKET`]
    /// `directions`), each fragment walked with [`KdTree::traverse_packet_within`]:
    /// `hit(element, rays, at_centre)` gets the bit mask of the rays that may meet the element
    /// and returns every ray's nearest hit so far. With `shutter` (the scene's motion and each
    /// ray's time), each ray is carried to the frame's centre for each instance (a motion group)
    /// before its walk, `at_centre` holds the rays so carried, and the packet walks the instance
    /// from the rays' own origins. False when a walk gave up (see
    /// [`KdTree::traverse_packet_within`]): trace the rays alone.
    pub fn traverse_packet(
        &self,
        fragment_of: &[u32],
        (origin, directions): ([f32; 3], &[[f32; 3]]),
        t_start: f32,
        shutter: Option<(&SceneMotion, &[f32])>,
        mut hit: impl FnMut(u32, u32, Option<&CentreRays>) -> [f32; PACKET],
    ) -> bool {
        if let Some(tree) = self.world_tree() {
            return tree.traverse_packet(origin, directions, t_start, |e, rays| hit(e, rays, None));
        }
        let mut best = [f32::INFINITY; PACKET];
        let mut whole = true;
        let mut local = [[0.0f32; 3]; PACKET];
        let span = ([t_start; PACKET], [f32::INFINITY; PACKET]);
        let world = SharedOrigin(origin);
        let top_whole =
            self.top.traverse_packet_within(&self.top.bounds, &world, directions, span, |i, rays, spans| {
                if whole {
                    let instance = &self.instances[i as usize];
                    // the rays that reach this leaf, over its interval; the others not at all
                    let mut span = ([1.0f32; PACKET], [0.0f32; PACKET]);
                    for r in each_ray(rays) {
                        (span.0[r], span.1[r]) = (spans.0[r], spans.1[r]);
                    }
                    let at_centre = shutter.map(|(motion, times)| {
                        let mut carried = [([0.0f32; 3], [0.0f32; 3]); PACKET];
                        for r in each_ray(rays) {
                            carried[r] = match motion.group_to_centre(instance.fragment, times[r]) {
                                Some(map) => (map.point(origin), map.vector(directions[r])),
                                None => (origin, directions[r]),
                            };
                        }
                        carried
                    });
                    let mut offer = |e: u32, rays: u32, _: (&[f32; PACKET], &[f32; PACKET])| {
                        if instance.holds(fragment_of, e) {
                            best = hit(e, rays, at_centre.as_ref());
                        }
                        best
                    };
                    let walk = &instance.tree_box;
                    whole = match &at_centre {
                        Some(carried) => {
                            let mut origins = RayOrigins([[0.0; PACKET]; 3]);
                            for r in each_ray(rays) {
                                let o = instance.point(carried[r].0);
                                (origins.0[0][r], origins.0[1][r], origins.0[2][r]) = (o[0], o[1], o[2]);
                                local[r] = instance.vector(carried[r].1);
                            }
                            let directions = &local[..directions.len()];
                            self.tree.traverse_packet_within(walk, &origins, directions, span, &mut offer)
                        }
                        None => {
                            for (to, &from) in local.iter_mut().zip(directions) {
                                *to = instance.vector(from);
                            }
                            let o = SharedOrigin(instance.point(origin));
                            self.tree.traverse_packet_within(walk, &o, &local[..directions.len()], span, &mut offer)
                        }
                    };
                }
                best
            });
        top_whole && whole
    }

    /// Calls `visit(element)` for elements near `point`; every element whose box holds the
    /// point is among them.
    pub fn for_each_at(&self, fragment_of: &[u32], point: [f32; 3], mut visit: impl FnMut(u32)) {
        if let Some(tree) = self.world_tree() {
            tree.for_each_at(point, visit);
            return;
        }
        self.top.for_each_at(point, |i| {
            let instance = &self.instances[i as usize];
            self.tree.for_each_at(instance.point(point), |e| {
                if instance.holds(fragment_of, e) {
                    visit(e);
                }
            });
        });
    }
}
