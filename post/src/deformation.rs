//! Deformed elements (`post.element_shapes = "deformed"`): each element's affine map x = A X + b
//! from the rest frame at one frame, written into the fragments file for the renderer, which
//! draws the element as the image of its rest polytope under it (still convex).
//!
//! - Cubes and trimtopes: A = F_i, the particle's deformation gradient from the peridynamic
//!   shape tensor over its intact bonds, K_i = sum_j V_j xi (x) xi, N_i = sum_j V_j eta (x) xi,
//!   F_i = N_i K_i^-1 (influence function 1; xi the rest bond vector, eta the deformed one), and
//!   b = x_i - F_i X_i, so the element stays centred on its particle.
//! - Tetrahedra: the embedded mesh of Chen et al. (section 5.2). Around each vertex the
//!   tetrahedra sharing it fall into groups joined through shared faces whose bond is intact
//!   (and, where that leaves the vertex's star in pieces, through intact bonds between
//!   tetrahedra of the same fragment: a non-manifold vertex of the mesh, or a crack that ends
//!   there); each group has its own copy of the vertex (so a crack splits vertices and opens its faces),
//!   placed at the mass-weighted mean (eqs 19-21, weights m_p / 4) of its tetrahedra's particles'
//!   first-order predictions x_p + F_p (V - X_p). A tetrahedron's map then follows from its four
//!   rest and deformed vertices.
//!
//! A particle without a deformation gradient (fewer than three non-coplanar intact bonds: dust)
//! takes its fragment's rotation instead; a tetrahedron whose map is inverted or degenerate, and
//! any element whose map moves it by at most [`RIGID_SNAP`] λ from where its fragment's rigid
//! motion puts it, is written [`AFFINE_RIGID`]: drawn exactly as in rigid mode.

// Matrix code indexes rows and columns explicitly.
#![allow(clippy::needless_range_loop)]

use glam::{DMat3, DVec3};
use shatter_core::disjoint_sets::DisjointSets;
use shatter_core::fragments::AFFINE_RIGID;
use shatter_core::particles::{Elements, ParticleSet};

use crate::kabsch::RigidMotion;

/// An element whose deformed corners all lie within this fraction of the particle spacing λ of
/// where its fragment's rigid motion puts them is drawn by that rigid motion (far below a pixel
/// unless one element spans thousands of pixels), so an undeformed body renders exactly as in
/// rigid mode.
pub const RIGID_SNAP: f64 = 1e-4;

/// K_i's determinant must be at least this fraction of (trace / 3)^3: below it the intact bonds
/// are (nearly) coplanar and F_i is not determined.
const SHAPE_CONDITION: f64 = 1e-6;

/// The smallest det A of a tetrahedron's map (or of F_i) that is drawn deformed: below it the
/// element is inverted or crushed flat, and moves with its fragment.
const MIN_DET: f64 = 1e-3;

/// One face shared by two adjacent tetrahedra: the bond across it and which vertex slots of the
/// two coincide.
#[derive(Debug, Clone, Copy)]
struct SharedFace {
    /// The bond's entry (in the lower particle's row).
    bond: usize,
    /// Vertex slots (4 t + k) of the first and second tetrahedron at the same rest position.
    slots: [[u32; 2]; 3],
}

/// The state of the bonds (which are broken) and what the maps need of the particle file.
#[derive(Debug, Clone)]
pub struct ElementDeformation {
    /// One bit per bond entry (both directions of a bond): set when broken.
    broken: Vec<u64>,
    /// Tetrahedra: the faces they share.
    shared_faces: Vec<SharedFace>,
    /// Tetrahedra: every vertex slot (4 t + k), grouped by rest position (the vertex's star).
    star_slots: Vec<u32>,
    /// Offsets into `star_slots`, one more than there are vertices.
    star_offsets: Vec<u32>,
}

impl ElementDeformation {
    /// Every bond of `particles` intact.
    pub fn new(particles: &ParticleSet) -> ElementDeformation {
        let entries = particles.bonds.neighbor.len();
        let mut shared_faces = Vec::new();
        if let Elements::Tets { vertices_m } = &particles.elements {
            for &[a, b] in &particles.adjacency {
                let (a, b) = (a.min(b) as usize, a.max(b) as usize);
                let Some(bond) = particles.bonds.find(a, b as u32) else { continue };
                let mut slots = Vec::with_capacity(3);
                for ka in 0..4 {
                    if let Some(kb) = (0..4).find(|&kb| vertices_m[b][kb] == vertices_m[a][ka]) {
                        slots.push([(4 * a + ka) as u32, (4 * b + kb) as u32]);
                    }
                }
                if let Ok(slots) = <[[u32; 2]; 3]>::try_from(slots) {
                    shared_faces.push(SharedFace { bond, slots });
                }
            }
        }
        let (star_slots, star_offsets) = match &particles.elements {
            Elements::Tets { vertices_m } => stars(vertices_m),
            _ => (Vec::new(), Vec::new()),
        };
        ElementDeformation { broken: vec![0; entries.div_ceil(64)], shared_faces, star_slots, star_offsets }
    }

    /// Marks bond `bond` (an entry of the lower particle's row, as the break log names it)
    /// broken, in both particles' rows.
    pub fn break_bond(&mut self, particles: &ParticleSet, bond: u64) {
        let bond = bond as usize;
        let bonds = &particles.bonds;
        if bond >= bonds.neighbor.len() {
            return;
        }
        let i = bonds.offsets.partition_point(|&o| o as usize <= bond) - 1;
        let j = bonds.neighbor[bond] as usize;
        self.set_broken(bond);
        if let Some(twin) = bonds.find(j, i as u32) {
            self.set_broken(twin);
        }
    }

    fn set_broken(&mut self, entry: usize) {
        self.broken[entry / 64] |= 1 << (entry % 64);
    }

    fn is_intact(&self, entry: usize) -> bool {
        self.broken[entry / 64] >> (entry % 64) & 1 == 0
    }

    /// Each particle's deformation gradient over its intact bonds at positions `position` (x, y,
    /// z arrays); None where the intact bonds do not span space or F is inverted.
    pub fn deformation_gradients(&self, particles: &ParticleSet, position: [&[f32]; 3]) -> Vec<Option<DMat3>> {
        let rest = |i: usize| DVec3::from_array(particles.rest_position_m[i].map(f64::from));
        let current =
            |i: usize| DVec3::new(f64::from(position[0][i]), f64::from(position[1][i]), f64::from(position[2][i]));
        (0..particles.len())
            .map(|i| {
                let (rest_i, current_i) = (rest(i), current(i));
                let mut k = [[0.0f64; 3]; 3];
                let mut n = [[0.0f64; 3]; 3];
                for entry in particles.bonds.row(i) {
                    if !self.is_intact(entry) {
                        continue;
                    }
                    let j = particles.bonds.neighbor[entry] as usize;
                    let v = f64::from(particles.volume_m3[j]);
                    let xi = rest(j) - rest_i;
                    let eta = current(j) - current_i;
                    for r in 0..3 {
                        for c in 0..3 {
                            k[r][c] += v * xi[r] * xi[c];
                            n[r][c] += v * eta[r] * xi[c];
                        }
                    }
                }
                let k = DMat3::from_cols_array_2d(&k).transpose();
                let n = DMat3::from_cols_array_2d(&n).transpose();
                let trace = k.x_axis.x + k.y_axis.y + k.z_axis.z;
                if trace.is_nan() || trace <= 0.0 || k.determinant() <= SHAPE_CONDITION * (trace / 3.0).powi(3) {
                    return None;
                }
                let f = n * k.inverse();
                (f.is_finite() && f.determinant() > MIN_DET).then_some(f)
            })
            .collect()
    }

    /// Every element's affine map as rows of [A | b] ([`AFFINE_RIGID`] where it moves with its
    /// fragment), for positions `position`, the elements' fragments `fragment_of` and the
    /// fragments' rigid motions `motion`.
    pub fn element_affine(
        &self,
        particles: &ParticleSet,
        position: [&[f32]; 3],
        fragment_of: &[u32],
        motion: &[RigidMotion],
    ) -> Vec<[f32; 12]> {
        let gradients = self.deformation_gradients(particles, position);
        let lambda = particles.meta.lambda_m;
        let rigid = |e: usize| {
            let m = &motion[fragment_of[e] as usize];
            (DMat3::from_quat(m.rotation), m.translation)
        };
        let current =
            |i: usize| DVec3::new(f64::from(position[0][i]), f64::from(position[1][i]), f64::from(position[2][i]));
        let rest = |i: usize| DVec3::from_array(particles.rest_position_m[i].map(f64::from));
        // A particle's gradient, its fragment's rotation where it has none.
        let gradient = |i: usize| gradients[i].unwrap_or_else(|| rigid(i).0);
        match &particles.elements {
            Elements::Tets { vertices_m } => {
                let deformed = self.tet_vertices(particles, vertices_m, fragment_of, &|i| (current(i), gradient(i)));
                (0..particles.len())
                    .map(|e| {
                        let corners = vertices_m[e].map(|v| DVec3::from_array(v.map(f64::from)));
                        let moved: [DVec3; 4] = std::array::from_fn(|k| deformed[4 * e + k]);
                        let edges = |p: &[DVec3; 4]| DMat3::from_cols(p[1] - p[0], p[2] - p[0], p[3] - p[0]);
                        let a = edges(&moved) * edges(&corners).inverse();
                        if !a.is_finite() || a.determinant() <= MIN_DET {
                            return AFFINE_RIGID;
                        }
                        let b = moved[0] - a * corners[0];
                        snapped(a, b, rigid(e), &corners, lambda)
                    })
                    .collect()
            }
            Elements::Cubes { half_size_m, orientation } => {
                let axes = DMat3::from_quat(glam::DQuat::from_array(orientation.map(f64::from)).normalize());
                (0..particles.len())
                    .map(|e| {
                        let a = gradient(e);
                        let b = current(e) - a * rest(e);
                        let h = f64::from(half_size_m[e]);
                        let corners: [DVec3; 8] = std::array::from_fn(|c| {
                            let sign = |bit: usize| if c >> bit & 1 == 1 { h } else { -h };
                            rest(e) + axes * DVec3::new(sign(0), sign(1), sign(2))
                        });
                        snapped(a, b, rigid(e), &corners, lambda)
                    })
                    .collect()
            }
            Elements::Trimtopes { .. } => (0..particles.len())
                .map(|e| {
                    let a = gradient(e);
                    let b = current(e) - a * rest(e);
                    // the cell's extent is about λ around its site
                    let corners: [DVec3; 6] = std::array::from_fn(|c| {
                        let mut offset = DVec3::ZERO;
                        offset[c / 2] = if c % 2 == 0 { lambda } else { -lambda };
                        rest(e) + offset
                    });
                    snapped(a, b, rigid(e), &corners, lambda)
                })
                .collect(),
        }
    }

    /// The deformed position of every tetrahedron vertex slot (4 t + k): the vertex copy of its
    /// group, given each particle's (position, gradient).
    fn tet_vertices(
        &self,
        particles: &ParticleSet,
        vertices_m: &[[[f32; 3]; 4]],
        fragment_of: &[u32],
        particle: &dyn Fn(usize) -> (DVec3, DMat3),
    ) -> Vec<DVec3> {
        self.tet_vertex_copies(particles, vertices_m, fragment_of, particle).1
    }

    /// The vertex copy of every tetrahedron vertex slot (the lowest slot of its group) and its
    /// deformed position.
    fn tet_vertex_copies(
        &self,
        particles: &ParticleSet,
        vertices_m: &[[[f32; 3]; 4]],
        fragment_of: &[u32],
        particle: &dyn Fn(usize) -> (DVec3, DMat3),
    ) -> (Vec<u32>, Vec<DVec3>) {
        let slots = 4 * vertices_m.len();
        let mut sets = DisjointSets::new(slots);
        for face in &self.shared_faces {
            if self.is_intact(face.bond) {
                for [a, b] in face.slots {
                    sets.join(a, b);
                }
            }
        }
        // A star still in pieces (a crack runs through the vertex, or the mesh is not manifold
        // there): pieces of one fragment that an intact bond joins share the vertex copy.
        for star in self.star_offsets.windows(2) {
            let star = &self.star_slots[star[0] as usize..star[1] as usize];
            let first = sets.root(star[0]);
            if star.iter().all(|s| sets.root(*s) == first) {
                continue;
            }
            for (x, &a) in star.iter().enumerate() {
                for &b in &star[x + 1..] {
                    let (ta, tb) = (a as usize / 4, b as usize / 4);
                    if fragment_of[ta] != fragment_of[tb] || sets.root(a) == sets.root(b) {
                        continue;
                    }
                    let bond = particles.bonds.find(ta, tb as u32);
                    if bond.is_some_and(|bond| self.is_intact(bond)) {
                        sets.join(a, b);
                    }
                }
            }
        }
        let mut sum = vec![DVec3::ZERO; slots];
        let mut weight = vec![0.0f64; slots];
        for (t, vertices) in vertices_m.iter().enumerate() {
            let (x, f) = particle(t);
            let rest_t = DVec3::from_array(particles.rest_position_m[t].map(f64::from));
            let w = 0.25 * f64::from(particles.mass_kg[t]).max(f64::MIN_POSITIVE);
            for (k, v) in vertices.iter().enumerate() {
                let r = sets.root((4 * t + k) as u32) as usize;
                sum[r] += w * (x + f * (DVec3::from_array(v.map(f64::from)) - rest_t));
                weight[r] += w;
            }
        }
        let copies: Vec<u32> = (0..slots as u32).map(|s| sets.root(s)).collect();
        let positions = copies.iter().map(|&r| sum[r as usize] / weight[r as usize]).collect();
        (copies, positions)
    }
}

/// [`ElementDeformation::star_slots`] and [`ElementDeformation::star_offsets`] of a tetrahedral
/// mesh (vertices are the same where their coordinates are bitwise equal).
fn stars(vertices_m: &[[[f32; 3]; 4]]) -> (Vec<u32>, Vec<u32>) {
    let mut slots: Vec<([u32; 3], u32)> = vertices_m
        .iter()
        .enumerate()
        // (+ 0.0 makes -0.0 the same key as 0.0, as == takes them)
        .flat_map(|(t, tet)| {
            tet.iter().enumerate().map(move |(k, v)| (v.map(|c| (c + 0.0).to_bits()), (4 * t + k) as u32))
        })
        .collect();
    slots.sort_unstable();
    let mut offsets = vec![0u32];
    for star in slots.chunk_by(|a, b| a.0 == b.0) {
        offsets.push(offsets[offsets.len() - 1] + star.len() as u32);
    }
    (slots.into_iter().map(|(_, s)| s).collect(), offsets)
}

/// [`AFFINE_RIGID`] when x = A X + b moves every one of `corners` within [`RIGID_SNAP`] λ of
/// where the rigid motion puts it, else the rows of [A | b].
fn snapped(a: DMat3, b: DVec3, (rotation, translation): (DMat3, DVec3), corners: &[DVec3], lambda: f64) -> [f32; 12] {
    let tolerance = RIGID_SNAP * lambda;
    if corners.iter().all(|c| ((a * *c + b) - (rotation * *c + translation)).length() <= tolerance) {
        return AFFINE_RIGID;
    }
    affine_rows(a, b)
}

/// The rows of [A | b] in single precision.
pub fn affine_rows(a: DMat3, b: DVec3) -> [f32; 12] {
    let mut out = [0.0f32; 12];
    for r in 0..3 {
        for c in 0..3 {
            out[4 * r + c] = a.col(c)[r] as f32;
        }
        out[4 * r + 3] = b[r] as f32;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;
    use shatter_core::NoProgress;
    use shatter_core::config::PipelineConfig;
    use std::path::Path;

    /// Particles of a box `size_m` sampled by `sampler` ("grid" or "tet_shell") at spacing 1 mm.
    pub(crate) fn sampled(sampler: &str, size_m: [f64; 3], horizon: f64) -> ParticleSet {
        let text = format!(
            "[scene]\nname = \"t\"\noutput_dir = \"out\"\nseed = 1\n[geometry]\nsource = \"box\"\n\
             box_size_m = {size_m:?}\nsampler = \"{sampler}\"\nspacing_m = 0.001\nhorizon_factor = {horizon:?}\n\
             [material]\ndensity_kg_m3 = 2200.0\nbulk_modulus_pa = 14.9e9\n"
        );
        let config = PipelineConfig::from_toml_str(&text, Path::new("/nonexistent/p.toml")).expect("config");
        shatter_preprocess::preprocess(&config, &NoProgress).expect("preprocess").particles
    }

    fn grid(n: usize, horizon: f64) -> ParticleSet {
        sampled("grid", [n as f64 * 1e-3; 3], horizon)
    }

    fn moved(particles: &ParticleSet, map: impl Fn(DVec3) -> DVec3) -> [Vec<f32>; 3] {
        let mut out = [Vec::new(), Vec::new(), Vec::new()];
        for p in &particles.rest_position_m {
            let x = map(DVec3::from_array(p.map(f64::from)));
            for c in 0..3 {
                out[c].push(x[c] as f32);
            }
        }
        out
    }

    fn slices(p: &[Vec<f32>; 3]) -> [&[f32]; 3] {
        [&p[0], &p[1], &p[2]]
    }

    #[test]
    fn a_uniform_affine_field_gives_its_gradient_and_a_rotation_gives_the_rotation() {
        let particles = grid(5, 2.0);
        let state = ElementDeformation::new(&particles);
        let f0 = DMat3::from_cols_array(&[1.05, 0.02, -0.01, 0.03, 0.97, 0.04, -0.02, 0.01, 1.1]);
        let c = DVec3::new(0.01, -0.02, 0.005);
        let field = moved(&particles, |x| f0 * x + c);
        for (i, f) in state.deformation_gradients(&particles, slices(&field)).iter().enumerate() {
            let f = f.expect("every particle of a grid has a gradient");
            assert!((f - f0).abs().to_cols_array().iter().all(|d| *d < 1e-5), "particle {i}: {f} vs {f0}");
        }
        let r = DMat3::from_quat(DQuat::from_axis_angle(DVec3::new(1.0, 2.0, -0.5).normalize(), 0.8));
        let field = moved(&particles, |x| r * x + c);
        for f in state.deformation_gradients(&particles, slices(&field)) {
            let f = f.expect("gradient");
            assert!((f - r).abs().to_cols_array().iter().all(|d| *d < 1e-5), "{f} vs {r}");
        }
    }

    #[test]
    fn a_particle_without_spanning_bonds_has_no_gradient() {
        let particles = grid(3, 1.0);
        let mut state = ElementDeformation::new(&particles);
        // cut particle 0 down to one bond
        let row = particles.bonds.row(0);
        let kept = particles.bonds.neighbor[row.start] as usize;
        for entry in row.clone().skip(1) {
            state.break_bond(&particles, entry as u64);
        }
        let field = moved(&particles, |x| x);
        let gradients = state.deformation_gradients(&particles, slices(&field));
        assert!(gradients[0].is_none());
        assert!(gradients[kept].is_some());
        // the break is seen from both ends
        let other = particles.bonds.neighbor[row.start + 1] as usize;
        assert!(!state.is_intact(particles.bonds.find(other, 0).expect("bond")));
        assert!(state.is_intact(particles.bonds.find(kept, 0).expect("bond")));
    }

    /// The tetrahedra of a small box shell and each vertex's slots, by rest position.
    /// Each rest vertex's slots (4 t + k).
    type Stars = std::collections::HashMap<[u32; 3], Vec<usize>>;

    fn tet_box() -> (ParticleSet, Vec<[[f32; 3]; 4]>, Stars) {
        let particles = sampled("tet_shell", [0.006, 0.005, 0.004], 2.0);
        let Elements::Tets { vertices_m } = &particles.elements else { panic!("tets") };
        let vertices = vertices_m.clone();
        let mut slots: std::collections::HashMap<[u32; 3], Vec<usize>> = Default::default();
        for (t, tet) in vertices.iter().enumerate() {
            for (k, v) in tet.iter().enumerate() {
                slots.entry(v.map(f32::to_bits)).or_default().push(4 * t + k);
            }
        }
        (particles, vertices, slots)
    }

    #[test]
    fn an_intact_tet_body_maps_every_tet_by_the_field_with_no_gaps() {
        let (particles, vertices, slots) = tet_box();
        assert!(particles.len() > 50, "{} tets", particles.len());
        // the shell's tetrahedra share vertices with bitwise-equal coordinates
        assert!(slots.values().filter(|s| s.len() > 1).count() * 2 > slots.len(), "shared vertices");
        let state = ElementDeformation::new(&particles);
        assert!(state.shared_faces.len() >= particles.adjacency.len() / 2, "adjacent tets share faces");
        let f0 = DMat3::from_cols_array(&[1.05, 0.02, -0.01, 0.03, 0.97, 0.04, -0.02, 0.01, 1.1]);
        let c = DVec3::new(0.01, -0.02, 0.005);
        let field = moved(&particles, |x| f0 * x + c);
        let motion = [RigidMotion { rotation: DQuat::IDENTITY, translation: DVec3::ZERO }];
        let fragment_of = vec![0; particles.len()];
        let affine = state.element_affine(&particles, slices(&field), &fragment_of, &motion);
        let expected = affine_rows(f0, c);
        for (t, m) in affine.iter().enumerate() {
            let worst = (0..12).map(|k| (m[k] - expected[k]).abs()).fold(0.0f32, f32::max);
            assert!(worst < 2e-5, "tet {t}: {m:?} vs {expected:?}");
        }
        let gradients = state.deformation_gradients(&particles, slices(&field));
        let (copies, deformed) = state.tet_vertex_copies(&particles, &vertices, &fragment_of, &|i| {
            (
                DVec3::new(f64::from(field[0][i]), f64::from(field[1][i]), f64::from(field[2][i])),
                gradients[i].expect("F"),
            )
        });
        for group in slots.values() {
            for s in group {
                assert_eq!(copies[*s], copies[group[0]], "a vertex split in an intact body");
                // one copy, where the field puts the vertex (to the rounding of f32 positions)
                let rest = DVec3::from_array(vertices[s / 4][s % 4].map(f64::from));
                assert!((deformed[*s] - (f0 * rest + c)).length() < 1e-8);
            }
        }
    }

    #[test]
    fn a_crack_splits_the_vertices_on_it() {
        let (particles, vertices, slots) = tet_box();
        let left = |i: usize| particles.rest_position_m[i][0] < 0.0;
        let mut state = ElementDeformation::new(&particles);
        for i in 0..particles.len() {
            for entry in particles.bonds.row(i) {
                let j = particles.bonds.neighbor[entry] as usize;
                if i < j && left(i) != left(j) {
                    state.break_bond(&particles, entry as u64);
                }
            }
        }
        // the right half moves 1 mm along x; both halves keep F = I
        let gap = DVec3::new(1e-3, 0.0, 0.0);
        let field = moved(&particles, |x| if x.x < 0.0 { x } else { x + gap });
        let fragment_of: Vec<u32> = (0..particles.len()).map(|i| u32::from(!left(i))).collect();
        let gradients = state.deformation_gradients(&particles, slices(&field));
        let (copies, deformed) = state.tet_vertex_copies(&particles, &vertices, &fragment_of, &|i| {
            (
                DVec3::new(f64::from(field[0][i]), f64::from(field[1][i]), f64::from(field[2][i])),
                gradients[i].expect("F"),
            )
        });
        let mut split = 0;
        for (bits, group) in &slots {
            let rest = DVec3::from_array(bits.map(f32::from_bits).map(f64::from));
            let sides: Vec<bool> = group.iter().map(|s| left(s / 4)).collect();
            for (s, side) in group.iter().zip(&sides) {
                let expected = if *side { rest } else { rest + gap };
                assert!((deformed[*s] - expected).length() < 1e-8, "each copy follows its own side");
            }
            // two copies where both sides meet, one copy elsewhere
            let mut distinct: Vec<u32> = group.iter().map(|s| copies[*s]).collect();
            distinct.sort_unstable();
            distinct.dedup();
            let both = sides.contains(&true) && sides.contains(&false);
            assert_eq!(distinct.len(), if both { 2 } else { 1 }, "copies of a vertex at {rest}");
            split += usize::from(sides.contains(&true) && sides.contains(&false));
        }
        assert!(split > 10, "{split} vertices on the crack split in two");
        // and the tets on either side keep their rest shape: all drawn rigid (the fragments'
        // motions given: the left at rest, the right moved by the gap)
        let motion = [
            RigidMotion { rotation: DQuat::IDENTITY, translation: DVec3::ZERO },
            RigidMotion { rotation: DQuat::IDENTITY, translation: gap },
        ];
        let affine = state.element_affine(&particles, slices(&field), &fragment_of, &motion);
        assert!(affine.iter().all(|m| *m == AFFINE_RIGID));
    }

    #[test]
    fn undeformed_and_rigidly_moved_elements_snap_to_their_fragment() {
        let particles = grid(4, 2.0);
        let state = ElementDeformation::new(&particles);
        let rotation = DQuat::from_axis_angle(DVec3::new(0.3, 1.0, 0.2).normalize(), 1.1);
        let t = DVec3::new(0.1, 0.2, -0.3);
        let field = moved(&particles, |x| rotation * x + t);
        let motion = [RigidMotion { rotation, translation: t }];
        let fragment_of = vec![0; particles.len()];
        let affine = state.element_affine(&particles, slices(&field), &fragment_of, &motion);
        assert!(affine.iter().all(|m| *m == AFFINE_RIGID));
        // stretched by 1 %: every element deformed, centred on its particle
        let field = moved(&particles, |x| rotation * DVec3::new(1.01 * x.x, x.y, x.z) + t);
        let affine = state.element_affine(&particles, slices(&field), &fragment_of, &motion);
        for (e, m) in affine.iter().enumerate() {
            assert_ne!(*m, AFFINE_RIGID);
            let x = DVec3::from_array(particles.rest_position_m[e].map(f64::from));
            let image = [0, 1, 2].map(|r| {
                f64::from(m[4 * r]) * x.x
                    + f64::from(m[4 * r + 1]) * x.y
                    + f64::from(m[4 * r + 2]) * x.z
                    + f64::from(m[4 * r + 3])
            });
            let target = [0, 1, 2].map(|c| f64::from(field[c][e]));
            assert!((0..3).all(|c| (image[c] - target[c]).abs() < 1e-7), "element {e}");
        }
    }
}
