//! The hit search over unions of elements: the nearest element surface along a ray through the
//! k-d tree (single rays, and packets of camera rays from one origin), the element holding a
//! point, and where a ray inside a union of touching elements leaves it. The twin of
//! `shaders/hit_search.wgsl`. One difference of method, not of result: [`closest_hits`] finds a
//! packet's first surfaces in one traversal, each exactly what the shader's single-ray search
//! finds (the packet's rays share their origin's rooms to a cube's planes,
//! [`crate::primitives::CubeFromOrigin`]).

// Indexed loops mirror the shader this is the twin of.
#![allow(clippy::needless_range_loop)]
use shatter_core::particles::ElementType;

use crate::packet_traversal::{PACKET, each_ray};
use crate::primitives::{CubeFromOrigin, Trimtope, TrimtopeHit, along, dot, polytope_span, trimtope_hit};
use crate::scene_geometry::SceneGeometry;

/// No element.
pub const NONE: u32 = u32::MAX;

/// The nearest element surface along a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter.
    pub t: f32,
    /// The element, or [`NONE`].
    pub element: u32,
    /// Unit outward normal there.
    pub normal: [f32; 3],
    /// True on a fracture face (see [`SceneGeometry::is_fracture_face`]).
    pub fracture: bool,
}

impl Hit {
    /// No surface.
    pub(crate) const MISS: Hit = Hit { t: f32::INFINITY, element: NONE, normal: [0.0; 3], fracture: false };
}

/// Where the ray first meets element `e` from `t_min` on: a polytope's entry (or, for a
/// trimtope, the rules of Fig. 4), as the plane or triangle it meets there; [`resolve`] turns it
/// into a [`Hit`]. Nearest-hit searches compare entries and resolve only the nearest (a normal
/// and a fracture-face lookup for one element, not for every one).
fn element_entry(scene: &SceneGeometry, e: usize, origin: [f32; 3], direction: [f32; 3], t: (f32, f32)) -> TrimtopeHit {
    let t_min = t.0;
    if scene.element_type == ElementType::Trimtope {
        let cell = Trimtope {
            planes: scene.planes_of(e),
            triangles: scene.triangles_of(e),
            groups: scene.triangle_groups_of(e),
            site: scene.sites[e],
            slack: scene.slack,
            bounds: &scene.element_bounds[e],
        };
        return trimtope_hit(&cell, origin, direction, t);
    }
    let entry = match scene.cube(e) {
        Some((axes, distances)) => CubeFromOrigin::new(axes, distances, origin).entry(scene.slack, direction, t_min),
        None => polytope_span(scene.planes_of(e), scene.slack, origin, direction)
            .filter(|span| span.t_in >= t_min && span.plane_in != NONE)
            .map(|span| (span.t_in, span.plane_in)),
    };
    face_entry(entry)
}

/// A polytope's entry, (t, plane) or none, as a [`TrimtopeHit`].
fn face_entry(entry: Option<(f32, u32)>) -> TrimtopeHit {
    entry.map_or(TrimtopeHit::Miss, |(t, plane)| TrimtopeHit::Face { t, plane })
}

/// The ray parameter of an entry (infinity for a miss).
fn entry_t(entry: TrimtopeHit) -> f32 {
    match entry {
        TrimtopeHit::Miss => f32::INFINITY,
        TrimtopeHit::Face { t, .. } | TrimtopeHit::Surface { t, .. } => t,
    }
}

/// The hit of element `e`'s entry: its normal and whether it is a fracture face.
fn resolve(scene: &SceneGeometry, e: u32, entry: TrimtopeHit) -> Hit {
    match entry {
        TrimtopeHit::Miss => Hit::MISS,
        TrimtopeHit::Face { t, plane } => Hit {
            t,
            element: e,
            normal: scene.plane_normal(e as usize, plane),
            fracture: scene.is_fracture_face(e as usize, plane),
        },
        TrimtopeHit::Surface { t, triangle } => {
            let tri = scene.triangles_of(e as usize)[triangle as usize];
            let n = crate::primitives::cross(
                crate::primitives::sub(tri[1], tri[0]),
                crate::primitives::sub(tri[2], tri[0]),
            );
            let length = dot(n, n).sqrt();
            Hit { t, element: e, normal: n.map(|v| v / length), fracture: false }
        }
    }
}

/// The nearest entry offered so far along one ray (ties go to the lower element).
#[derive(Clone, Copy)]
struct Nearest {
    t: f32,
    element: u32,
    entry: TrimtopeHit,
}

impl Nearest {
    const NONE: Nearest = Nearest { t: f32::INFINITY, element: NONE, entry: TrimtopeHit::Miss };

    /// Keeps element `e`'s `entry` if it is nearer (or as near, from a lower element).
    fn offer(&mut self, e: u32, entry: TrimtopeHit) {
        let t = entry_t(entry);
        if t < self.t || (t == self.t && e < self.element) {
            *self = Nearest { t, element: e, entry };
        }
    }
}

/// A ray at its time carried to the frame's centre for each element it tests (see
/// [`crate::shutter`]): the identity for a still scene or a ray at the centre's time; the last
/// group's map is kept.
struct AtCentre<'a> {
    scene: &'a SceneGeometry,
    origin: [f32; 3],
    direction: [f32; 3],
    time: f32,
    /// The group last mapped, and the ray in its placement.
    last: Option<(u32, [f32; 3], [f32; 3])>,
}

impl<'a> AtCentre<'a> {
    fn new(scene: &'a SceneGeometry, origin: [f32; 3], direction: [f32; 3], time: f32) -> AtCentre<'a> {
        AtCentre { scene, origin, direction, time, last: None }
    }

    /// The ray as element `e` sees it at the centre: (origin, direction).
    fn ray(&mut self, e: u32) -> ([f32; 3], [f32; 3]) {
        let Some(motion) = self.scene.motion.as_ref().filter(|_| self.time != 0.0) else {
            return (self.origin, self.direction);
        };
        let group = motion.group_of[e as usize];
        if let Some((last, o, d)) = self.last
            && last == group
        {
            return (o, d);
        }
        let (o, d) = match motion.to_centre(e as usize, self.time) {
            Some(map) => (map.point(self.origin), map.vector(self.direction)),
            None => (self.origin, self.direction),
        };
        self.last = Some((group, o, d));
        (o, d)
    }

    /// `hit`, found at the centre, turned back to the ray's time.
    fn back(&self, hit: Hit) -> Hit {
        match (&self.scene.motion, hit.element) {
            (Some(motion), e) if e != NONE => match motion.to_centre(e as usize, self.time) {
                Some(map) => Hit { normal: map.vector_back(hit.normal), ..hit },
                None => hit,
            },
            _ => hit,
        }
    }
}

/// The nearest element surface along the ray from `t_min` on (ties go to the lower element), at
/// `time` (frames from the frame's centre, see [`crate::shutter`]).
pub fn closest_hit(scene: &SceneGeometry, origin: [f32; 3], direction: [f32; 3], t_min: f32, time: f32) -> Hit {
    let mut nearest = Nearest::NONE;
    let mut centre = AtCentre::new(scene, origin, direction, time);
    let shutter = scene.motion.as_ref().map(|motion| (motion, time));
    scene.index.traverse(scene.members(), (origin, direction), t_min, shutter, |e, carried| {
        // the index carried the ray to e's group already (as the AtCentre would)
        let (o, d) = carried.unwrap_or_else(|| centre.ray(e));
        nearest.offer(e, element_entry(scene, e as usize, o, d, (t_min, nearest.t)));
        nearest.t
    });
    centre.back(resolve(scene, nearest.element, nearest.entry))
}

/// The nearest element surfaces along a packet of rays from one `origin` (at most
/// [`PACKET`] `directions`, t from 0 on, each at its time in `times`, or all at the centre's
/// when None), into `hits`: each exactly what [`closest_hit`] gives its ray, found in one
/// traversal of the k-d tree for them all (see
/// [`crate::element_kdtree::KdTree::traverse_packet`]).
pub fn closest_hits(
    scene: &SceneGeometry,
    origin: [f32; 3],
    directions: &[[f32; 3]],
    times: Option<&[f32]>,
    hits: &mut [Hit],
) {
    let mut nearest = [Nearest::NONE; PACKET];
    let shutter = scene.motion.as_ref().zip(times);
    let moving = shutter.is_some();
    // (a packet may hold fewer rays than PACKET: the rest have no time)
    let time = |r: usize| times.and_then(|times| times.get(r)).copied().unwrap_or(0.0);
    let mut centres: Option<[AtCentre; PACKET]> = moving.then(|| {
        std::array::from_fn(|r| AtCentre::new(scene, origin, directions.get(r).copied().unwrap_or([0.0; 3]), time(r)))
    });
    let traversed = scene.index.traverse_packet(scene.members(), (origin, directions), 0.0, shutter, |e, rays, at| {
        match (&mut centres, scene.cube(e as usize)) {
            (Some(centres), _) => {
                for r in each_ray(rays) {
                    // the index carried the rays to e's group already (an AtCentre does the same)
                    let (o, d) = at.map_or_else(|| centres[r].ray(e), |at| at[r]);
                    nearest[r].offer(e, element_entry(scene, e as usize, o, d, (0.0, nearest[r].t)));
                }
            }
            (None, Some((axes, distances))) => {
                let cube = CubeFromOrigin::new(axes, distances, origin);
                for r in each_ray(rays) {
                    nearest[r].offer(e, face_entry(cube.entry(scene.slack, directions[r], 0.0)));
                }
            }
            (None, None) => {
                for r in each_ray(rays) {
                    nearest[r].offer(e, element_entry(scene, e as usize, origin, directions[r], (0.0, nearest[r].t)));
                }
            }
        }
        nearest.map(|n| n.t)
    });
    for (r, ((hit, &direction), n)) in hits.iter_mut().zip(directions).zip(nearest).enumerate() {
        *hit = if traversed {
            let hit = resolve(scene, n.element, n.entry);
            centres.as_ref().map_or(hit, |centres| centres[r].back(hit))
        } else {
            closest_hit(scene, origin, direction, 0.0, time(r))
        };
    }
}

/// The lowest element (other than `except`) holding `point`, if any.
pub fn element_at(scene: &SceneGeometry, point: [f32; 3], except: u32) -> u32 {
    let mut found = NONE;
    scene.index.for_each_at(scene.members(), point, |e| {
        if e < found && e != except && scene.contains(e as usize, point) {
            found = e;
        }
    });
    found
}

/// The element (other than `current`) holding `point` just past `current`'s plane `plane`: the
/// face neighbour that rested against that plane when it holds the point (one point test), else
/// the k-d tree's answer (a descent and a leaf of tests).
fn next_element(scene: &SceneGeometry, current: u32, plane: u32, point: [f32; 3]) -> u32 {
    if plane != NONE {
        let neighbour = scene.face_neighbours[(scene.plane_offsets[current as usize] + plane) as usize];
        if neighbour != NONE && scene.contains(neighbour as usize, point) {
            return neighbour;
        }
    }
    element_at(scene, point, current)
}

/// Consecutive steps of a union walk that each advance less than its probe step (4 x slack)
/// before the walk counts as stalled and ends at the current element's exit face. Where two
/// elements share the exit plane near their common edge (the outer face of a lattice of
/// touching cubes), the probe point past one's face lies inside the other's widened rim while
/// that one's span also ends at the point: without this the walk passed between the two
/// without moving until its step guard ran out (100,000 steps, a zero normal).
const STALLED_STEPS: u32 = 8;

/// Where a ray inside the union containing `element` leaves it, at `time` (frames from the
/// frame's centre: the walk goes through the centre's placement of `element`'s group): (distance,
/// unit outward normal of the last element's exit face, last element).
pub fn union_exit(
    scene: &SceneGeometry,
    element: u32,
    origin: [f32; 3],
    direction: [f32; 3],
    time: f32,
) -> (f32, [f32; 3], u32) {
    let mut centre = AtCentre::new(scene, origin, direction, time);
    let (origin, direction) = centre.ray(element);
    let (t, normal, last) = union_walk(scene, element, origin, direction);
    let back = centre.back(Hit { t, element, normal, fracture: false });
    (t, back.normal, last)
}

/// [`union_exit`] at the centre's time.
fn union_walk(scene: &SceneGeometry, element: u32, origin: [f32; 3], direction: [f32; 3]) -> (f32, [f32; 3], u32) {
    let step = 4.0 * scene.slack;
    let mut current = element;
    let mut travelled = 0.0f32;
    let mut from = origin;
    let mut stalled = 0;
    for _ in 0..100_000 {
        let Some((t_out, plane_out)) = scene.exit_of(current as usize, from, direction) else {
            break;
        };
        let t = t_out.max(0.0);
        let exit = along(from, direction, t);
        let next = next_element(scene, current, plane_out, along(exit, direction, step));
        stalled = if t < step { stalled + 1 } else { 0 };
        if next == NONE || plane_out == NONE || stalled > STALLED_STEPS {
            return (travelled + t, scene.plane_normal(current as usize, plane_out), current);
        }
        travelled += t;
        from = exit;
        current = next;
    }
    (travelled, [0.0; 3], current)
}
