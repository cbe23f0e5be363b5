//! Placing a frame's elements: each moved by its fragment's rigid motion or, where the fragments
//! file carries them (deformed elements), mapped by its own affine map x = A X + b (an affine
//! image of a convex polytope is convex: the tracers need nothing else); and what every frame of
//! a render shares ([`SceneBasis`]).

use std::borrow::Cow;
use std::collections::HashMap;

use glam::{DMat3, DVec3, Quat, Vec3};
use rayon::prelude::*;
use shatter_core::fragments::{FragmentFrame, is_affine_rigid};
use shatter_core::particles::{ElementType, Elements, ParticleSet};

use crate::element_index::{ElementIndex, RestTree};
use crate::element_kdtree::Aabb;
use crate::face_seams::{cube_seams, face_neighbours, interior_faces};
use crate::primitives::{
    Plane, WIDEN, cube_planes, in_opposite_pairs, sort_triangles_spatially, tet_planes, triangle_groups,
};
use crate::scene_geometry::{CubeSlabs, SceneGeometry};
use crate::shutter::{FramePoses, SceneMotion};

/// One element's planes, triangles, site and bounds.
type ElementParts = (Vec<Plane>, Vec<[[f32; 3]; 3]>, [f32; 3], Aabb);

impl SceneGeometry {
    /// The scene of `particles` moved by `fragments` (the rest state when None).
    pub fn build(particles: &ParticleSet, fragments: Option<&FragmentFrame>) -> SceneGeometry {
        SceneGeometry::build_with(particles, fragments, &SceneBasis::new(particles, fragments.is_some()), None)
    }

    /// The scene of `particles` at the frame `poses` holds, with their motion over a shutter
    /// open `shutter` frames (see [`crate::shutter`]); still when the shutter is closed or
    /// nothing moves.
    pub fn build_over_shutter(particles: &ParticleSet, poses: FramePoses, shutter: f64) -> SceneGeometry {
        let motion = SceneMotion::new(&particles.rest_position_m, poses, shutter);
        let basis = SceneBasis::new(particles, poses.current.is_some());
        SceneGeometry::build_with(particles, poses.current, &basis, motion)
    }

    /// [`SceneGeometry::build`] on a render's [`SceneBasis`] (of these particles): what does not
    /// change from frame to frame is taken from it, and with its rest tree, rigidly moved
    /// fragments are found through that, without a k-d tree built for the frame. With `motion`
    /// (an open shutter), the elements' bounds hold them at every time of the shutter, and the
    /// index is one world tree over those.
    pub fn build_with(
        particles: &ParticleSet,
        fragments: Option<&FragmentFrame>,
        basis: &SceneBasis,
        motion: Option<SceneMotion>,
    ) -> SceneGeometry {
        let n = particles.len();
        // Each fragment's rigid motion x = q X + t, as the elements are placed (f32).
        let motions: Vec<(Quat, Vec3)> = fragments.map_or_else(Vec::new, |frame| {
            (0..frame.rotation.len())
                .map(|f| (Quat::from_array(frame.rotation[f]), DVec3::from_array(frame.translation_m[f]).as_vec3()))
                .collect()
        });
        let fragment = match fragments {
            Some(frame) => frame.fragment_of.clone(),
            None => vec![0; n],
        };
        let affine = fragments.and_then(|frame| frame.element_affine.as_ref());
        let deformed = affine.is_some_and(|maps| maps.iter().any(|map| !is_affine_rigid(map)));
        let slack = WIDEN * particles.meta.lambda_m as f32;
        let mut scene = SceneGeometry {
            element_type: particles.elements.element_type(),
            plane_offsets: Vec::new(),
            planes: Vec::new(),
            triangle_offsets: Vec::new(),
            triangles: Vec::new(),
            triangle_group_offsets: Vec::new(),
            triangle_groups: Vec::new(),
            sites: Vec::new(),
            fragment,
            interior_faces: Vec::new(),
            face_neighbours: basis.face_neighbours.clone(),
            element_bounds: Vec::new(),
            index: ElementIndex::world(&[]),
            slack,
            cube_slabs: Vec::new(),
            cube_axes: Vec::new(),
            motion: None,
        };
        match &particles.elements {
            Elements::Cubes { half_size_m, orientation } if !deformed => {
                let placed =
                    PlacedCubes { half_size_m, orientation: Quat::from_array(*orientation), motions: &motions };
                placed.fill(particles, &mut scene);
            }
            _ => {
                let motion = |e: usize| -> (Quat, Vec3) {
                    if motions.is_empty() { (Quat::IDENTITY, Vec3::ZERO) } else { motions[scene.fragment[e] as usize] }
                };
                let parts: Vec<ElementParts> = (0..n)
                    .into_par_iter()
                    .map(|e| match affine.map(|maps| &maps[e]).filter(|map| !is_affine_rigid(map)) {
                        Some(map) => deformed_element(particles, e, &Affine::of(map)),
                        None => {
                            let (q, t) = motion(e);
                            rigid_element(particles, e, q, t)
                        }
                    })
                    .collect();
                scene.fill_parts(parts);
            }
        }
        scene.interior_faces = match cube_seams(particles, fragments) {
            Some(seams) => interior_faces(&scene.face_neighbours, &scene.plane_offsets, Some(seams)),
            None => basis.interior_faces.clone(),
        };
        for (cube, faces) in scene.cube_slabs.iter_mut().zip(&scene.interior_faces) {
            cube.interior_faces = *faces;
        }
        if let Some(motion) = &motion {
            let slack = scene.slack;
            scene.element_bounds =
                scene.element_bounds.par_iter().enumerate().map(|(e, b)| motion.swept(e, *b, slack)).collect();
        }
        // the rest tree's instances: the fragments, or under an open shutter the motion's groups
        // (each group's elements share this frame's fragment, so its motion)
        let members = motion.as_ref().map_or(&scene.fragment, |motion| &motion.group_of);
        let member_motions: Cow<[(Quat, Vec3)]> = match &motion {
            Some(motion) if !motions.is_empty() => Cow::Owned(group_motions(motion, &scene.fragment, &motions)),
            _ => Cow::Borrowed(&motions),
        };
        let moved = match (fragments, &basis.rest) {
            (Some(_), Some(rest)) if !deformed => {
                ElementIndex::of_fragments(rest, members, &member_motions, &scene.element_bounds)
            }
            _ => None,
        };
        scene.motion = motion;
        scene.index = moved.unwrap_or_else(|| ElementIndex::world(&scene.element_bounds));
        scene
    }

    /// Fills the elements' arrays from each element's parts, in element order; cubes whose
    /// planes are all [`in_opposite_pairs`] get their [`CubeSlabs`] too.
    fn fill_parts(&mut self, parts: Vec<ElementParts>) {
        let n = parts.len();
        self.plane_offsets = Vec::with_capacity(n + 1);
        self.triangle_offsets = Vec::with_capacity(n + 1);
        self.triangle_group_offsets = Vec::with_capacity(n + 1);
        self.sites = Vec::with_capacity(n);
        self.element_bounds = Vec::with_capacity(n);
        self.plane_offsets.push(0);
        self.triangle_offsets.push(0);
        self.triangle_group_offsets.push(0);
        for (planes, triangles, site, b) in parts {
            self.planes.extend(planes);
            self.plane_offsets.push(self.planes.len() as u32);
            self.triangle_groups.extend(triangle_groups(&triangles));
            self.triangle_group_offsets.push(self.triangle_groups.len() as u32);
            self.triangles.extend(triangles);
            self.triangle_offsets.push(self.triangles.len() as u32);
            self.sites.push(site);
            self.element_bounds.push(widened(b, self.slack));
        }
        if self.element_type == ElementType::Cube
            && (0..n).into_par_iter().all(|e| in_opposite_pairs(self.planes_of(e)))
        {
            (self.cube_slabs, self.cube_axes) = cube_slabs(&self.planes);
        }
    }
}

/// Each of `motion`'s groups' rigid motion this frame: that of the fragment (in `fragment_of`)
/// its elements share, from `motions`.
fn group_motions(motion: &SceneMotion, fragment_of: &[u32], motions: &[(Quat, Vec3)]) -> Vec<(Quat, Vec3)> {
    let mut first = vec![u32::MAX; motion.groups.len()];
    for (e, &g) in motion.group_of.iter().enumerate().rev() {
        first[g as usize] = e as u32;
    }
    first.iter().map(|&e| motions[fragment_of[e as usize] as usize]).collect()
}

/// An element's world bounds `b` widened by twice the tracers' `slack` (see
/// [`SceneGeometry::element_bounds`]).
fn widened(b: Aabb, slack: f32) -> Aabb {
    Aabb { min: b.min.map(|v| v - 2.0 * slack), max: b.max.map(|v| v + 2.0 * slack) }
}

/// What every frame of a render shares: the elements' face neighbours and interior faces, which
/// follow from their rest adjacency, and, for the CPU tracer of a large scene, the k-d tree of
/// the elements at rest (see [`crate::element_index`]).
#[derive(Debug, Clone)]
pub struct SceneBasis {
    /// [`SceneGeometry::face_neighbours`].
    face_neighbours: Vec<u32>,
    /// [`SceneGeometry::interior_faces`] of every frame without deformed cubes.
    interior_faces: Vec<u32>,
    /// The rest tree, if any.
    rest: Option<RestTree>,
}

impl SceneBasis {
    /// The basis of `particles`' frames, with their rest tree when `rest_tree`.
    pub fn new(particles: &ParticleSet, rest_tree: bool) -> SceneBasis {
        let plane_offsets = plane_offsets(particles);
        let face_neighbours = face_neighbours(particles, &plane_offsets);
        let interior_faces = interior_faces(&face_neighbours, &plane_offsets, None);
        let rest = rest_tree.then(|| {
            let exact: Vec<Aabb> = (0..particles.len())
                .into_par_iter()
                .map(|e| rigid_element(particles, e, Quat::IDENTITY, Vec3::ZERO).3)
                .collect();
            let lambda = particles.meta.lambda_m as f32;
            RestTree::new(&exact, WIDEN * lambda, lambda)
        });
        SceneBasis { face_neighbours, interior_faces, rest }
    }
}

/// Where each element's planes start in [`SceneGeometry::planes`] (one more than there are
/// elements), as every frame places them: six for a cube, four for a tetrahedron, a trimtope's
/// cell planes.
fn plane_offsets(particles: &ParticleSet) -> Vec<u32> {
    match &particles.elements {
        Elements::Cubes { .. } => (0..=particles.len() as u32).map(|e| 6 * e).collect(),
        Elements::Tets { .. } => (0..=particles.len() as u32).map(|e| 4 * e).collect(),
        Elements::Trimtopes { plane_offsets, .. } => plane_offsets.iter().map(|&offset| offset as u32).collect(),
    }
}

/// Cubes of one size placed rigidly by their fragments' motions (none: at rest): each
/// fragment's axes are turned once, and every cube's planes, site, bounds and [`CubeSlabs`] are
/// written in place, what [`rigid_element`] and [`cube_slabs`] give them, to the bit.
struct PlacedCubes<'a> {
    /// Each cube's half size, metres.
    half_size_m: &'a [f32],
    /// The cubes' orientation at rest.
    orientation: Quat,
    /// Each fragment's motion (empty: at rest).
    motions: &'a [(Quat, Vec3)],
}

impl PlacedCubes<'_> {
    /// Fills `scene`'s element arrays (its `fragment` already set).
    fn fill(&self, particles: &ParticleSet, scene: &mut SceneGeometry) {
        let n = particles.len();
        let at_rest = [(Quat::IDENTITY, Vec3::ZERO)];
        let motions = if self.motions.is_empty() { &at_rest[..] } else { self.motions };
        let turned: Vec<[[f32; 3]; 3]> = motions.iter().map(|(q, _)| turned_axes(*q, self.orientation)).collect();
        // Each motion's entry in the distinct axes, in the order the cubes first show them.
        let motion_of = |e: usize| if self.motions.is_empty() { 0 } else { scene.fragment[e] as usize };
        let mut axes_of = vec![u32::MAX; motions.len()];
        let mut distinct = DistinctAxes::default();
        for e in 0..n {
            let f = motion_of(e);
            if axes_of[f] == u32::MAX {
                axes_of[f] = distinct.index(turned[f]);
            }
        }
        scene.cube_axes = distinct.axes;
        scene.planes = vec![[0.0; 4]; 6 * n];
        scene.sites = vec![[0.0; 3]; n];
        scene.element_bounds = vec![Aabb::EMPTY; n];
        scene.cube_slabs = vec![CubeSlabs { distances: [0.0; 6], axes: 0, interior_faces: 0 }; n];
        let slack = scene.slack;
        let rest_position = &particles.rest_position_m;
        (scene.planes.par_chunks_mut(6), &mut scene.sites, &mut scene.element_bounds, &mut scene.cube_slabs)
            .into_par_iter()
            .enumerate()
            .for_each(|(e, (planes, site, bounds, slabs))| {
                let f = motion_of(e);
                let ((q, t), axes, h) = (motions[f], turned[f], self.half_size_m[e]);
                *site = (q * Vec3::from_array(rest_position[e]) + t).to_array();
                *bounds = widened(cube_bounds(*site, h, axes), slack);
                planes.copy_from_slice(&cube_planes(*site, h, axes));
                *slabs =
                    CubeSlabs { distances: std::array::from_fn(|k| planes[k][3]), axes: axes_of[f], interior_faces: 0 };
            });
        scene.plane_offsets = plane_offsets(particles);
        scene.triangle_offsets = vec![0; n + 1];
        scene.triangle_group_offsets = vec![0; n + 1];
    }
}

/// The [`CubeSlabs`] of cubes whose planes (six each) are [`in_opposite_pairs`], and their
/// distinct axes.
fn cube_slabs(planes: &[Plane]) -> (Vec<CubeSlabs>, Vec<[[f32; 3]; 3]>) {
    let mut distinct = DistinctAxes::default();
    // a fragment's cubes are mostly neighbours in the element order: the last cube's axes first
    let mut last: Option<([[f32; 3]; 3], u32)> = None;
    let slabs = planes
        .chunks_exact(6)
        .map(|cube| {
            let normals = [0, 2, 4].map(|k| [cube[k][0], cube[k][1], cube[k][2]]);
            let at = match last {
                Some((last_normals, at)) if bits_of(&last_normals) == bits_of(&normals) => at,
                _ => distinct.index(normals),
            };
            last = Some((normals, at));
            CubeSlabs { distances: std::array::from_fn(|k| cube[k][3]), axes: at, interior_faces: 0 }
        })
        .collect();
    (slabs, distinct.axes)
}

/// The distinct sets of cube axes (bit for bit), in the order they were first met: what
/// [`SceneGeometry::cube_axes`] holds.
#[derive(Default)]
struct DistinctAxes {
    axes: Vec<[[f32; 3]; 3]>,
    index: HashMap<[u32; 9], u32>,
}

impl DistinctAxes {
    /// The index of `axes`, added if new.
    fn index(&mut self, axes: [[f32; 3]; 3]) -> u32 {
        *self.index.entry(bits_of(&axes)).or_insert_with(|| {
            self.axes.push(axes);
            self.axes.len() as u32 - 1
        })
    }
}

/// A set of axes as the bits of its nine components.
fn bits_of(axes: &[[f32; 3]; 3]) -> [u32; 9] {
    std::array::from_fn(|i| axes[i / 3][i % 3].to_bits())
}

/// A cube's axes (rows) at rest orientation `orientation`, turned by `q`.
fn turned_axes(q: Quat, orientation: Quat) -> [[f32; 3]; 3] {
    let rotation = q * orientation;
    [Vec3::X, Vec3::Y, Vec3::Z].map(|a| (rotation * a).to_array())
}

/// The exact bounds of a cube centred at `site`, of half size `h` and axes `axes`.
fn cube_bounds(site: [f32; 3], h: f32, axes: [[f32; 3]; 3]) -> Aabb {
    let reach = [0, 1, 2].map(|k| h * (axes[0][k].abs() + axes[1][k].abs() + axes[2][k].abs()));
    Aabb { min: [0, 1, 2].map(|k| site[k] - reach[k]), max: [0, 1, 2].map(|k| site[k] + reach[k]) }
}

/// Element `e` of `particles` moved rigidly: x = q X + t.
fn rigid_element(particles: &ParticleSet, e: usize, q: Quat, t: Vec3) -> ElementParts {
    let place = |p: [f32; 3]| (q * Vec3::from_array(p) + t).to_array();
    let site = place(particles.rest_position_m[e]);
    match &particles.elements {
        Elements::Cubes { half_size_m, orientation } => {
            let axes = turned_axes(q, Quat::from_array(*orientation));
            let h = half_size_m[e];
            (cube_planes(site, h, axes).to_vec(), Vec::new(), site, cube_bounds(site, h, axes))
        }
        Elements::Tets { vertices_m } => {
            let vertices = vertices_m[e].map(place);
            let bounds = vertices.iter().fold(Aabb::EMPTY, |b, v| b.union(&Aabb { min: *v, max: *v }));
            (tet_planes(vertices).to_vec(), Vec::new(), site, bounds)
        }
        Elements::Trimtopes { plane_offsets, planes, triangle_offsets, triangles_m, .. } => {
            let range = plane_offsets[e] as usize..plane_offsets[e + 1] as usize;
            let moved_planes: Vec<Plane> = planes[range]
                .iter()
                .map(|p| {
                    let n = q * Vec3::new(p[0], p[1], p[2]);
                    [n.x, n.y, n.z, p[3] + n.dot(t)]
                })
                .collect();
            let mut triangles: Vec<[[f32; 3]; 3]> = triangles_m
                [triangle_offsets[e] as usize..triangle_offsets[e + 1] as usize]
                .iter()
                .map(|tri| tri.map(place))
                .collect();
            sort_triangles_spatially(&mut triangles);
            let bounds = trimtope_bounds(particles, e, place).unwrap_or_else(|| polytope_bounds(&moved_planes, site));
            (moved_planes, triangles, site, bounds)
        }
    }
}

/// An element's affine map x = A X + b, in double precision.
struct Affine {
    a: DMat3,
    b: DVec3,
    /// A^-T, which takes a plane's normal to the moved plane's (before normalising).
    inverse_transpose: DMat3,
}

impl Affine {
    /// The map stored as the rows of [A | b].
    fn of(rows: &[f32; 12]) -> Affine {
        let column = |c: usize| DVec3::new(f64::from(rows[c]), f64::from(rows[4 + c]), f64::from(rows[8 + c]));
        let a = DMat3::from_cols(column(0), column(1), column(2));
        let b = column(3);
        Affine { a, b, inverse_transpose: a.inverse().transpose() }
    }

    fn point(&self, p: [f32; 3]) -> DVec3 {
        self.a * DVec3::from_array(p.map(f64::from)) + self.b
    }

    /// The image of the plane n . X <= d (n unit): unit normal and offset.
    fn plane(&self, p: &Plane) -> Plane {
        let n = DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
        let m = self.inverse_transpose * n;
        // n . X <= d with X = A^-1 (x - b): (A^-T n) . x <= d + (A^-T n) . b
        let d = f64::from(p[3]) + m.dot(self.b);
        let length = m.length();
        [(m.x / length) as f32, (m.y / length) as f32, (m.z / length) as f32, (d / length) as f32]
    }
}

/// Element `e` of `particles` in its deformed shape: the image of its rest polytope under `map`
/// (convex still: planes go to planes, a trimtope's triangles vertex by vertex).
fn deformed_element(particles: &ParticleSet, e: usize, map: &Affine) -> ElementParts {
    let site = map.point(particles.rest_position_m[e]).as_vec3().to_array();
    let point = |p: [f32; 3]| map.point(p).as_vec3().to_array();
    match &particles.elements {
        Elements::Cubes { half_size_m, orientation } => {
            let rest_axes = [Vec3::X, Vec3::Y, Vec3::Z].map(|a| (Quat::from_array(*orientation) * a).to_array());
            let h = half_size_m[e];
            // the rest cube's planes, in cube_planes' order (+axis k, then -axis k), moved
            let planes: Vec<Plane> =
                cube_planes(particles.rest_position_m[e], h, rest_axes).iter().map(|p| map.plane(p)).collect();
            let mut bounds = Aabb::EMPTY;
            for corner in 0..8 {
                let offset = |k: usize| if corner >> k & 1 == 1 { h } else { -h };
                let rest = [0, 1, 2].map(|c| {
                    particles.rest_position_m[e][c] + (0..3).map(|k| offset(k) * rest_axes[k][c]).sum::<f32>()
                });
                let v = point(rest);
                bounds = bounds.union(&Aabb { min: v, max: v });
            }
            (planes, Vec::new(), site, bounds)
        }
        Elements::Tets { vertices_m } => {
            let vertices = vertices_m[e].map(point);
            let bounds = vertices.iter().fold(Aabb::EMPTY, |b, v| b.union(&Aabb { min: *v, max: *v }));
            (tet_planes(vertices).to_vec(), Vec::new(), site, bounds)
        }
        Elements::Trimtopes { plane_offsets, planes, triangle_offsets, triangles_m, .. } => {
            let range = plane_offsets[e] as usize..plane_offsets[e + 1] as usize;
            let moved_planes: Vec<Plane> = planes[range].iter().map(|p| map.plane(p)).collect();
            let mut triangles: Vec<[[f32; 3]; 3]> = triangles_m
                [triangle_offsets[e] as usize..triangle_offsets[e + 1] as usize]
                .iter()
                .map(|tri| tri.map(point))
                .collect();
            sort_triangles_spatially(&mut triangles);
            let bounds = trimtope_bounds(particles, e, point).unwrap_or_else(|| polytope_bounds(&moved_planes, site));
            (moved_planes, triangles, site, bounds)
        }
    }
}

/// Bounds of what trimtope `e` of `particles` draws, placed by `place`: the part of its cell
/// inside the mesh, which its surface triangles and its faces' parts inside the mesh enclose
/// (their vertices' bounds, padded by 1e-4 of their size and 1e-6 of their distance from the
/// origin for rounding). Far tighter than the cell's own bounds where the cell reaches out from
/// the surface to the box every cell starts from. None where the set gives no faces (then the
/// triangles alone do not enclose it) or the cell has neither (nothing of it inside the mesh):
/// its cell's bounds hold it.
fn trimtope_bounds(particles: &ParticleSet, e: usize, place: impl Fn([f32; 3]) -> [f32; 3]) -> Option<Aabb> {
    let Elements::Trimtopes { triangle_offsets, triangles_m, face_offsets, face_triangles_m, .. } = &particles.elements
    else {
        return None;
    };
    if face_triangles_m.is_empty() {
        return None;
    }
    let surface = &triangles_m[triangle_offsets[e] as usize..triangle_offsets[e + 1] as usize];
    let faces = &face_triangles_m[face_offsets[e] as usize..face_offsets[e + 1] as usize];
    let b = surface.iter().chain(faces).flatten().fold(Aabb::EMPTY, |b, v| {
        let v = place(*v);
        b.union(&Aabb { min: v, max: v })
    });
    if b.min[0] > b.max[0] {
        return None;
    }
    let size = (0..3).map(|a| b.max[a] - b.min[a]).fold(0.0f32, f32::max);
    let far = b.min.iter().chain(&b.max).fold(0.0f32, |m, v| m.max(v.abs()));
    let pad = 1e-4 * size + 1e-6 * far;
    Some(Aabb { min: b.min.map(|v| v - pad), max: b.max.map(|v| v + pad) })
}

/// Bounds of a convex polytope around a point inside it: every vertex (three planes meeting,
/// inside all others).
fn polytope_bounds(planes: &[Plane], inside: [f32; 3]) -> Aabb {
    let mut bounds = Aabb { min: inside, max: inside };
    let n = planes.len();
    let normal = |p: &Plane| DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
    for a in 0..n {
        for b in a + 1..n {
            for c in b + 1..n {
                let (na, nb, nc) = (normal(&planes[a]), normal(&planes[b]), normal(&planes[c]));
                let det = na.dot(nb.cross(nc));
                if det.abs() < 1e-12 {
                    continue;
                }
                let (da, db, dc) = (f64::from(planes[a][3]), f64::from(planes[b][3]), f64::from(planes[c][3]));
                let vertex = (da * nb.cross(nc) + db * nc.cross(na) + dc * na.cross(nb)) / det;
                let tolerance = 1e-6 * (1.0 + vertex.length());
                if planes.iter().all(|p| normal(p).dot(vertex) <= f64::from(p[3]) + tolerance) {
                    let v = vertex.as_vec3().to_array();
                    bounds = bounds.union(&Aabb { min: v, max: v });
                }
            }
        }
    }
    bounds
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::primitives::polytope_contains;
    use glam::DQuat;
    use shatter_core::fragments::{AFFINE_RIGID, FragmentMeta};

    fn cubes(positions: Vec<[f32; 3]>) -> ParticleSet {
        let n = positions.len();
        let elements = Elements::Cubes { half_size_m: vec![0.05; n], orientation: [0.0, 0.0, 0.0, 1.0] };
        ParticleSet::unbonded(positions, elements, 0.1)
    }

    /// A plane's normal from a cube's axes is its plane's, bit for bit, for turned cubes and a
    /// sheared one; past the last plane, the last plane's.
    #[test]
    fn plane_normals_are_the_planes_own() {
        let mut particles = cubes(vec![[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.1, 0.3]]);
        particles.elements = Elements::Cubes {
            half_size_m: vec![0.05; 3],
            orientation: glam::Quat::from_euler(glam::EulerRot::XYZ, 0.3, -0.7, 1.1).to_array(),
        };
        let turned = SceneGeometry::build(&particles, None);
        assert!(turned.cube(0).is_some(), "turned cubes keep their axes");
        let a = [[1.2, 0.3, 0.0], [0.0, 0.9, 0.1], [0.05, 0.0, 1.1]];
        let rows = [a[0][0], a[0][1], a[0][2], 0.0, a[1][0], a[1][1], a[1][2], 0.0, a[2][0], a[2][1], a[2][2], 0.0];
        let frame = FragmentFrame {
            meta: FragmentMeta { frame: 2, step: 1, time_s: 0.0, smoothed: false, inputs: None },
            fragment_of: vec![0, 0, 0],
            rotation: vec![[0.0, 0.0, 0.0, 1.0]],
            translation_m: vec![[0.0; 3]],
            elements: vec![3],
            mass_kg: vec![3.0],
            element_affine: Some(vec![rows, AFFINE_RIGID, AFFINE_RIGID]),
        };
        let deformed = SceneGeometry::build(&particles, Some(&frame));
        for scene in [&turned, &deformed] {
            for e in 0..3 {
                let planes = scene.planes_of(e);
                for plane in (0..planes.len() as u32).chain([u32::MAX]) {
                    let p = planes[(plane as usize).min(planes.len() - 1)];
                    let want = [p[0], p[1], p[2]].map(f32::to_bits);
                    assert_eq!(scene.plane_normal(e, plane).map(f32::to_bits), want, "element {e}, plane {plane}");
                }
            }
        }
    }

    #[test]
    fn a_deformed_cube_is_the_image_of_its_rest_cube() {
        let particles = cubes(vec![[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]]);
        // a shear and stretch, and a translation
        let a = [[1.2, 0.3, 0.0], [0.0, 0.9, 0.1], [0.05, 0.0, 1.1]];
        let b = [0.5, -0.2, 0.1];
        let rows = [a[0][0], a[0][1], a[0][2], b[0], a[1][0], a[1][1], a[1][2], b[1], a[2][0], a[2][1], a[2][2], b[2]];
        let frame = FragmentFrame {
            meta: FragmentMeta { frame: 2, step: 1, time_s: 0.0, smoothed: false, inputs: None },
            fragment_of: vec![0, 0],
            rotation: vec![[0.0, 0.0, 0.0, 1.0]],
            translation_m: vec![[0.0; 3]],
            elements: vec![2],
            mass_kg: vec![2.0],
            element_affine: Some(vec![rows, AFFINE_RIGID]),
        };
        let scene = SceneGeometry::build(&particles, Some(&frame));
        let map = |p: [f32; 3]| [0, 1, 2].map(|r| (0..3).map(|c| a[r][c] * p[c]).sum::<f32>() + b[r]);
        for corner in 0..8 {
            let rest = [0, 1, 2].map(|k| if corner >> k & 1 == 1 { 0.05 } else { -0.05 });
            let v = map(rest);
            // on three of the planes, inside all
            let on =
                scene.planes_of(0).iter().filter(|p| (p[0] * v[0] + p[1] * v[1] + p[2] * v[2] - p[3]).abs() < 1e-6);
            assert_eq!(on.count(), 3, "corner {corner}");
            assert!(polytope_contains(scene.planes_of(0), 1e-6, v));
            let bounds = &scene.element_bounds[0];
            assert!((0..3).all(|k| bounds.min[k] <= v[k] && v[k] <= bounds.max[k]));
        }
        // plane k of the deformed cube is the image of the rest cube's plane k (face numbering kept)
        for k in 0..3 {
            let axis = map([0, 1, 2].map(|c| if c == k { 1.0 } else { 0.0 }));
            let axis = [0, 1, 2].map(|c| axis[c] - b[c]);
            let [plus, minus] = [scene.planes_of(0)[2 * k], scene.planes_of(0)[2 * k + 1]];
            assert!(plus[0] * axis[0] + plus[1] * axis[1] + plus[2] * axis[2] > 0.0, "plane {} faces +axis {k}", 2 * k);
            assert!(minus[0] * axis[0] + minus[1] * axis[1] + minus[2] * axis[2] < 0.0);
        }
        assert_eq!(scene.sites[0], map([0.0; 3]));
        // the other element moves with its fragment (at rest)
        assert_eq!(scene.planes_of(1), SceneGeometry::build(&particles, None).planes_of(1));
        // adjacent, in one fragment, one deformed: the seam between them is no fracture face;
        // in two fragments it is
        let adjacent = ParticleSet { adjacency: vec![[0, 1]], ..particles.clone() };
        assert_eq!(SceneGeometry::build(&adjacent, None).interior_faces, vec![1, 2]);
        assert_eq!(SceneGeometry::build(&adjacent, Some(&frame)).interior_faces, vec![0, 0]);
        let split = FragmentFrame {
            fragment_of: vec![0, 1],
            rotation: vec![[0.0, 0.0, 0.0, 1.0]; 2],
            translation_m: vec![[0.0; 3]; 2],
            elements: vec![1, 1],
            mass_kg: vec![1.0; 2],
            ..frame.clone()
        };
        assert_eq!(SceneGeometry::build(&adjacent, Some(&split)).interior_faces, vec![1, 2]);
        let rigid = FragmentFrame { element_affine: Some(vec![AFFINE_RIGID; 2]), ..frame.clone() };
        assert_eq!(SceneGeometry::build(&adjacent, Some(&rigid)).interior_faces, vec![1, 2]);
    }

    /// An 8 x 8 x 3 block of 0.1 m cubes in four quarters, each turned and moved apart a little
    /// as the pieces of a broken plate are, and the frame that places them.
    fn broken_block() -> (ParticleSet, FragmentFrame) {
        let mut positions = Vec::new();
        for z in 0..3 {
            for y in 0..8 {
                for x in 0..8 {
                    positions.push([x as f32 * 0.1, y as f32 * 0.1 + 0.3, z as f32 * 0.1]);
                }
            }
        }
        let fragment_of: Vec<u32> =
            positions.iter().map(|p| u32::from(p[0] > 0.35) + 2 * u32::from(p[1] > 0.65)).collect();
        let turn = |f: usize| {
            let axis = DVec3::new(1.0 + f as f64, 2.0, 0.5 - f as f64).normalize();
            DQuat::from_axis_angle(axis, 0.02 * (f as f64 + 1.0)).as_quat().to_array()
        };
        let frame = FragmentFrame {
            meta: FragmentMeta { frame: 2, step: 1, time_s: 0.0, smoothed: false, inputs: None },
            elements: (0..4).map(|f| fragment_of.iter().filter(|&&g| g == f).count() as u32).collect(),
            fragment_of,
            rotation: (0..4).map(turn).collect(),
            translation_m: (0..4).map(|f| [0.01 * f as f64, -0.004 * f as f64, 0.003]).collect(),
            mass_kg: vec![1.0; 4],
            element_affine: None,
        };
        (cubes(positions), frame)
    }

    /// Rigidly placed cubes, whose fragments' axes are turned once and whose planes, bounds and
    /// slabs are written in place, are what the general build gives them element by element
    /// ([`rigid_element`], then [`cube_slabs`]), bit for bit: at rest, moved, turned at rest,
    /// and with two fragments sharing a turn (one entry in the distinct axes).
    #[test]
    fn placed_cubes_are_what_the_general_build_gives_them() {
        let (mut particles, frame) = broken_block();
        let mut shared = frame.clone();
        shared.rotation[3] = shared.rotation[1];
        let turned = DQuat::from_axis_angle(DVec3::new(0.3, -1.0, 0.2).normalize(), 0.7).as_quat().to_array();
        for orientation in [[0.0, 0.0, 0.0, 1.0], turned] {
            let Elements::Cubes { orientation: o, .. } = &mut particles.elements else { unreachable!() };
            *o = orientation;
            for fragments in [None, Some(&frame), Some(&shared)] {
                let scene = SceneGeometry::build(&particles, fragments);
                let parts: Vec<ElementParts> = (0..particles.len())
                    .map(|e| {
                        let (q, t) = fragments.map_or((Quat::IDENTITY, Vec3::ZERO), |frame| {
                            let f = frame.fragment_of[e] as usize;
                            (Quat::from_array(frame.rotation[f]), DVec3::from_array(frame.translation_m[f]).as_vec3())
                        });
                        rigid_element(&particles, e, q, t)
                    })
                    .collect();
                let mut general = scene.clone();
                (general.planes, general.triangles, general.triangle_groups) = (Vec::new(), Vec::new(), Vec::new());
                (general.cube_slabs, general.cube_axes) = (Vec::new(), Vec::new());
                general.fill_parts(parts);
                for (cube, faces) in general.cube_slabs.iter_mut().zip(&scene.interior_faces) {
                    cube.interior_faces = *faces;
                }
                assert_eq!(general, scene);
                let distinct = match fragments {
                    None => 1,
                    Some(frame) if frame.rotation[3] == frame.rotation[1] => 3,
                    Some(_) => 4,
                };
                assert_eq!(scene.cube_axes.len(), distinct);
            }
        }
    }

    #[test]
    fn the_fragments_index_finds_what_a_search_of_every_element_finds() {
        use crate::hit_search::{NONE, closest_hit, closest_hits, element_at};
        use crate::primitives::polytope_span;
        use crate::sampling::random;
        let unit = |k: u64| random(k as u32, 0, 0);
        let (particles, frame) = broken_block();
        let scene = SceneGeometry::build(&particles, Some(&frame));
        let world = SceneGeometry::build_with(&particles, Some(&frame), &SceneBasis::new(&particles, false), None);
        assert!(scene.index.world_tree().is_none(), "the fragments are found through the rest tree");
        assert!(world.index.world_tree().is_some());
        // the cubes are tested from their slabs, one set of axes for each fragment's turn
        assert_eq!((scene.cube_slabs.len(), scene.cube_axes.len()), (scene.len(), 4));
        let point = |k: u64| [unit(k) * 1.0 - 0.1, unit(k + 1) * 1.0 + 0.2, unit(k + 2) * 0.5 - 0.1];
        let (mut hits, mut inside) = (0, 0);
        for k in 0..400u64 {
            // rays from all around (some from inside the block) through points of the block
            let origin = [unit(7 * k) * 3.0 - 1.0, unit(7 * k + 1) * 3.0 - 0.5, unit(7 * k + 2) * 3.0 - 1.5];
            let directions: Vec<[f32; 3]> = (0..16u64)
                .map(|r| {
                    let target = point(1000 + 16 * k + 3 * r);
                    let d = DVec3::from_array([0, 1, 2].map(|a| f64::from(target[a] - origin[a]))).normalize();
                    d.as_vec3().to_array()
                })
                .collect();
            let mut packet = vec![closest_hit(&scene, origin, directions[0], 0.0, 0.0); 16];
            closest_hits(&scene, origin, &directions, None, &mut packet);
            for (r, &direction) in directions.iter().enumerate() {
                // every element tested: the nearest entry, ties to the lower element
                let mut nearest = (f32::INFINITY, NONE);
                for e in 0..scene.len() {
                    if let Some(span) = polytope_span(scene.planes_of(e), scene.slack, origin, direction)
                        && span.t_in >= 0.0
                        && span.plane_in != NONE
                        && (span.t_in, e as u32) < nearest
                    {
                        nearest = (span.t_in, e as u32);
                    }
                }
                let hit = closest_hit(&scene, origin, direction, 0.0, 0.0);
                assert_eq!((hit.t, hit.element), nearest, "ray {k}.{r}");
                assert_eq!((packet[r].t, packet[r].element), nearest, "packet {k}, ray {r}");
                let in_world = closest_hit(&world, origin, direction, 0.0, 0.0);
                assert_eq!((in_world.t, in_world.element), nearest, "world tree, ray {k}.{r}");
                hits += usize::from(nearest.1 != NONE);
            }
            // the element holding a point: the lowest of those that hold it
            let p = point(3 * k);
            let holding =
                (0..scene.len() as u32).find(|&e| polytope_contains(scene.planes_of(e as usize), scene.slack, p));
            assert_eq!(element_at(&scene, p, NONE), holding.unwrap_or(NONE), "point {k}");
            assert_eq!(element_at(&world, p, NONE), holding.unwrap_or(NONE), "point {k}, world tree");
            inside += usize::from(holding.is_some());
        }
        assert!(hits > 3000 && inside > 100, "{hits} hits, {inside} points inside");
    }

    /// Under an open shutter the rest tree's instances are the motion's groups, each ray carried
    /// to the frame's centre per group: its hits are those of a world tree over the swept boxes
    /// and of a search of every element, each ray at its own time; alone or in a packet.
    #[test]
    fn a_moving_frames_index_finds_what_a_search_of_every_element_finds() {
        use crate::hit_search::{Hit, NONE, closest_hit, closest_hits};
        use crate::primitives::polytope_span;
        use crate::sampling::random;
        let unit = |k: u64| random(k as u32, 7, 0);
        let (particles, now) = broken_block();
        let moved = |s: f64| {
            let mut frame = now.clone();
            for f in 0..4 {
                let turn = DQuat::from_axis_angle(DVec3::new(f as f64, 1.0, 0.3).normalize(), s * 0.2 * f as f64);
                frame.rotation[f] = (turn * DQuat::from_array(now.rotation[f].map(f64::from))).as_quat().to_array();
                frame.translation_m[f] = [s * 0.05 * f as f64, -s * 0.03, s * 0.02 * f as f64];
            }
            frame
        };
        // fragment 3 splits in the next frame: its elements fall in two groups
        let mut after = moved(1.0);
        for (e, f) in after.fragment_of.iter_mut().enumerate() {
            if *f == 3 && e % 2 == 0 {
                *f = 4;
            }
        }
        after.rotation.push(after.rotation[1]);
        after.translation_m.push([0.0, -0.2, 0.0]);
        let before = moved(-1.0);
        let poses = FramePoses { current: Some(&now), previous: Some(Some(&before)), next: Some(Some(&after)) };
        let motion = || SceneMotion::new(&particles.rest_position_m, poses, 0.5);
        assert_eq!(motion().expect("moving").groups.len(), 5);
        let scene = SceneGeometry::build_with(&particles, Some(&now), &SceneBasis::new(&particles, true), motion());
        let world = SceneGeometry::build_with(&particles, Some(&now), &SceneBasis::new(&particles, false), motion());
        assert!(scene.index.world_tree().is_none() && world.index.world_tree().is_some());
        let moving = scene.motion.as_ref().expect("moving");
        let mut hits = 0;
        for k in 0..200u64 {
            let origin = [unit(5 * k) * 3.0 - 1.0, unit(5 * k + 1) * 3.0 - 0.5, unit(5 * k + 2) * 3.0 + 0.6];
            let times: Vec<f32> = (0..16u64).map(|r| 0.5 * unit(900 + 16 * k + r) - 0.25).collect();
            let directions: Vec<[f32; 3]> = (0..16u64)
                .map(|r| {
                    let target = [unit(3000 + 3 * (16 * k + r)) * 0.8, unit(3001 + 3 * (16 * k + r)) * 0.8 + 0.3, 0.1];
                    let d = DVec3::from_array([0, 1, 2].map(|a| f64::from(target[a] - origin[a]))).normalize();
                    d.as_vec3().to_array()
                })
                .collect();
            let mut packet = vec![Hit::MISS; 16];
            closest_hits(&scene, origin, &directions, Some(&times), &mut packet);
            for (r, (&direction, &time)) in directions.iter().zip(&times).enumerate() {
                let mut nearest = (f32::INFINITY, NONE);
                for e in 0..scene.len() {
                    let (o, d) = match moving.to_centre(e, time) {
                        Some(map) => (map.point(origin), map.vector(direction)),
                        None => (origin, direction),
                    };
                    if let Some(span) = polytope_span(scene.planes_of(e), scene.slack, o, d)
                        && span.t_in >= 0.0
                        && span.plane_in != NONE
                        && (span.t_in, e as u32) < nearest
                    {
                        nearest = (span.t_in, e as u32);
                    }
                }
                let hit = closest_hit(&scene, origin, direction, 0.0, time);
                assert_eq!((hit.t, hit.element), nearest, "ray {k}.{r}");
                assert_eq!(hit, closest_hit(&world, origin, direction, 0.0, time), "world tree, ray {k}.{r}");
                assert_eq!(packet[r], hit, "packet {k}, ray {r}");
                hits += usize::from(nearest.1 != NONE);
            }
        }
        assert!(hits > 1000, "{hits} hits");
    }

    #[test]
    fn pieces_beyond_the_rest_trees_margin_get_a_world_tree() {
        let (particles, mut frame) = broken_block();
        frame.translation_m[2] = [4000.0, 0.0, 0.0];
        let scene = SceneGeometry::build(&particles, Some(&frame));
        assert!(scene.index.world_tree().is_some());
    }
}
