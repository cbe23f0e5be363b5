//! One frame's scene in world space, flattened for tracing (and for upload to the GPU as is):
//! every element as the planes of its convex polytope (and a trimtope's site and surface
//! triangles), with the index the CPU tracer searches. [`crate::placing`] builds it. What the
//! GPU tracer reads of it is in `shaders/scene_geometry.wgsl`.

use shatter_core::particles::ElementType;

use crate::element_index::ElementIndex;
use crate::element_kdtree::Aabb;
use crate::primitives::{CubeFromOrigin, Plane, paired_contains, polytope_contains, polytope_span};
use crate::shutter::SceneMotion;

/// The elements of one frame, flattened for tracing (and for upload to the GPU as is).
#[derive(Debug, Clone, PartialEq)]
pub struct SceneGeometry {
    /// What the elements are: cubes are glass, tetrahedra and trimtopes opaque.
    pub element_type: ElementType,
    /// Offsets into `planes`, one more than there are elements.
    pub plane_offsets: Vec<u32>,
    /// Element planes, unit outward normal: inside where n . x <= d.
    pub planes: Vec<Plane>,
    /// Offsets into `triangles` (trimtopes; all zero otherwise).
    pub triangle_offsets: Vec<u32>,
    /// Embedded surface triangles of trimtopes, outward winding, each element's in Z order.
    pub triangles: Vec<[[f32; 3]; 3]>,
    /// Offsets into `triangle_groups`, one more than there are elements.
    pub triangle_group_offsets: Vec<u32>,
    /// Bounds of each element's groups of [`crate::primitives::TRIANGLE_GROUP`] consecutive triangles.
    pub triangle_groups: Vec<Aabb>,
    /// A point inside each element (a trimtope's Voronoi site).
    pub sites: Vec<[f32; 3]>,
    /// The fragment of each element.
    pub fragment: Vec<u32>,
    /// Per element, bit k set when its plane k rests against an adjacent element: where such a
    /// face is seen, it is a fracture face (cubes and tetrahedra; trimtopes show fracture faces on
    /// all their planes and the outer surface on their triangles, and keep 0 here). Deformed
    /// cubes: only against an element of another fragment (within one, a seam between two
    /// cubes' affine maps).
    pub interior_faces: Vec<u32>,
    /// Parallel to `planes`: the element that rested against each plane (cubes and tetrahedra),
    /// else [`crate::hit_search::NONE`]. A ray walking through a union, leaving an element by a plane,
    /// tries that neighbour before it asks the k-d tree (see [`crate::hit_search::union_exit`]).
    pub face_neighbours: Vec<u32>,
    /// Each element's world bounds, widened by twice `slack` (what a world k-d tree is built
    /// over: the GPU tracer's).
    pub element_bounds: Vec<Aabb>,
    /// Where the CPU tracer finds the elements a ray may meet.
    pub index: ElementIndex,
    /// How far elements are widened in ray tests (so touching elements leave no cracks), metres.
    pub slack: f32,
    /// When every element has six planes [`crate::primitives::in_opposite_pairs`] (cubes placed rigidly), each
    /// one's plane distances and axes, as [`CubeFromOrigin`] reads them; else empty.
    pub cube_slabs: Vec<CubeSlabs>,
    /// The distinct axes of the cubes in `cube_slabs` (one set for each fragment's turn).
    pub cube_axes: Vec<[[f32; 3]; 3]>,
    /// How the elements move while the shutter is open (None: still); the elements are placed
    /// at the frame's centre, and `element_bounds` hold them over the whole shutter.
    pub motion: Option<SceneMotion>,
}

/// A cube's six plane distances and the index of its axes (the normals of planes 0, 2 and 4) in
/// [`SceneGeometry::cube_axes`]: what [`CubeFromOrigin`] reads of a cube whose planes are
/// [`crate::primitives::in_opposite_pairs`], in a third of the bytes of the planes themselves (two to a cache
/// line: the nearest-hit search waits on memory).
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(32))]
pub struct CubeSlabs {
    /// The planes' distances (each plane's `[3]`).
    pub distances: [f32; 6],
    /// Index into [`SceneGeometry::cube_axes`].
    pub axes: u32,
    /// The cube's interior faces, fracture faces where seen ([`SceneGeometry::interior_faces`]'s
    /// entry, copied): kept in the padding beside the distances, so that a nearest hit's lookup
    /// finds them in the line its test loaded.
    pub interior_faces: u32,
}

impl SceneGeometry {
    /// What the index's instances hold each element by: its motion group under an open
    /// shutter, else its fragment.
    pub fn members(&self) -> &[u32] {
        self.motion.as_ref().map_or(&self.fragment, |motion| &motion.group_of)
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.sites.len()
    }

    /// True for an empty scene.
    pub fn is_empty(&self) -> bool {
        self.sites.is_empty()
    }

    /// Element `e`'s planes.
    pub fn planes_of(&self, e: usize) -> &[Plane] {
        &self.planes[self.plane_offsets[e] as usize..self.plane_offsets[e + 1] as usize]
    }

    /// Whether `point` lies inside element `e`'s polytope widened by [`SceneGeometry::slack`]
    /// ([`polytope_contains`]).
    pub fn contains(&self, e: usize, point: [f32; 3]) -> bool {
        if let Some(cube) = self.cube_slabs.get(e) {
            paired_contains(&self.cube_axes[cube.axes as usize], &cube.distances, self.slack, point)
        } else {
            polytope_contains(self.planes_of(e), self.slack, point)
        }
    }

    /// Where the ray `origin + t direction` leaves element `e`'s polytope widened by
    /// [`SceneGeometry::slack`]: the t and plane of the end of its span ([`polytope_span`]), when
    /// that exists.
    pub fn exit_of(&self, e: usize, origin: [f32; 3], direction: [f32; 3]) -> Option<(f32, u32)> {
        match self.cube(e) {
            Some((axes, distances)) => CubeFromOrigin::new(axes, distances, origin).exit(self.slack, direction),
            None => {
                polytope_span(self.planes_of(e), self.slack, origin, direction).map(|span| (span.t_out, span.plane_out))
            }
        }
    }

    /// Element `e`'s axes and plane distances as [`CubeFromOrigin`] reads them, if it is a cube
    /// whose planes are in opposite pairs.
    pub fn cube(&self, e: usize) -> Option<(&[[f32; 3]; 3], &[f32; 6])> {
        self.cube_slabs.get(e).map(|cube| (&self.cube_axes[cube.axes as usize], &cube.distances))
    }

    /// The unit outward normal of element `e`'s plane `plane` (its last plane's past the end):
    /// for a cube in opposite pairs from its axes (plane 2k + 1's is plane 2k's negated, bit for
    /// bit), whose few sets stay in cache where the planes would be a miss per hit.
    pub fn plane_normal(&self, e: usize, plane: u32) -> [f32; 3] {
        match self.cube(e) {
            Some((axes, _)) => {
                let k = plane.min(5) as usize;
                let axis = axes[k / 2];
                if k.is_multiple_of(2) { axis } else { axis.map(|v| -v) }
            }
            None => {
                let planes = self.planes_of(e);
                let p = planes[(plane as usize).min(planes.len() - 1)];
                [p[0], p[1], p[2]]
            }
        }
    }

    /// True when plane `plane` of element `e` is a fracture face where it is seen.
    pub fn is_fracture_face(&self, e: usize, plane: u32) -> bool {
        if self.element_type == ElementType::Trimtope {
            return true;
        }
        let faces = match self.cube_slabs.get(e) {
            Some(cube) => cube.interior_faces,
            None => self.interior_faces[e],
        };
        (faces >> plane) & 1 == 1
    }

    /// Element `e`'s surface triangles.
    pub fn triangles_of(&self, e: usize) -> &[[[f32; 3]; 3]] {
        &self.triangles[self.triangle_offsets[e] as usize..self.triangle_offsets[e + 1] as usize]
    }

    /// Bounds of element `e`'s groups of surface triangles.
    pub fn triangle_groups_of(&self, e: usize) -> &[Aabb] {
        &self.triangle_groups[self.triangle_group_offsets[e] as usize..self.triangle_group_offsets[e + 1] as usize]
    }
}
