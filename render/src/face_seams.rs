//! Which element faces rest against another element: the face neighbours a union walk tries
//! first, and the interior faces that show as fracture faces where a ray sees them (with
//! deformed cubes, not the seams between one fragment's cubes).

use shatter_core::fragments::{FragmentFrame, is_affine_rigid};
use shatter_core::particles::{Elements, ParticleSet};

use crate::hit_search::NONE;

/// With deformed cubes, the fragments file (its fragments and affine maps): neighbouring cubes
/// mapped by different affine maps meet with a seam (a sliver of face, of order lambda^2 over
/// the bend's radius), which is not a fracture face; only faces against another fragment are.
/// None otherwise.
pub(crate) fn cube_seams<'a>(
    particles: &ParticleSet,
    fragments: Option<&'a FragmentFrame>,
) -> Option<&'a FragmentFrame> {
    let frame = fragments?;
    let cubes = matches!(particles.elements, Elements::Cubes { .. });
    (cubes && frame.element_affine.is_some()).then_some(frame)
}

/// [`SceneGeometry::interior_faces`](crate::scene_geometry::SceneGeometry::interior_faces): the planes with a face neighbour (`face_neighbours`,
/// planes starting at `plane_offsets`); with deformed cubes (`seams`), a face between two
/// elements of one fragment of which one or both are deformed is not one.
pub(crate) fn interior_faces(
    face_neighbours: &[u32],
    plane_offsets: &[u32],
    seams: Option<&FragmentFrame>,
) -> Vec<u32> {
    let seam = |a: usize, b: usize| {
        seams.is_some_and(|frame| {
            let deformed = |e: usize| frame.element_affine.as_ref().is_some_and(|maps| !is_affine_rigid(&maps[e]));
            frame.fragment_of[a] == frame.fragment_of[b] && (deformed(a) || deformed(b))
        })
    };
    plane_offsets
        .windows(2)
        .enumerate()
        .map(|(e, planes)| {
            let neighbours = &face_neighbours[planes[0] as usize..planes[1] as usize];
            neighbours
                .iter()
                .enumerate()
                .filter(|&(_, &n)| n != NONE && !seam(e, n as usize))
                .fold(0, |mask, (plane, _)| mask | 1 << plane)
        })
        .collect()
}

/// [`SceneGeometry::face_neighbours`](crate::scene_geometry::SceneGeometry::face_neighbours) of `particles`, whose elements' planes start at
/// `plane_offsets`: from their rest adjacency.
pub(crate) fn face_neighbours(particles: &ParticleSet, plane_offsets: &[u32]) -> Vec<u32> {
    let mut neighbours = vec![NONE; *plane_offsets.last().unwrap_or(&0) as usize];
    for &[a, b] in &particles.adjacency {
        for (from, to) in [(a, b), (b, a)] {
            let (first, end) = (plane_offsets[from as usize], plane_offsets[from as usize + 1]);
            if let Some(face) = particles.shared_face(from as usize, to as usize)
                && first + (face as u32) < end
            {
                neighbours[(first + face as u32) as usize] = to;
            }
        }
    }
    neighbours
}
