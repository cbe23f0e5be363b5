//! The `tet_shell` sampler (the paper's vase): a tetrahedral mesh of a layered shell under the
//! surface, whose tets become the particles.
//!
//! # Layers
//!
//! Layer `k` (0 = the surface, `layers - 1` the innermost) is the inside part of the level set at
//! depth `k h` of the distance to the surface (`h` the layer spacing). Each layer is sampled the
//! same way:
//!
//! 1. **Candidates**: dense area-weighted random points `y` on the mesh triangles
//!    ([`CANDIDATE_DENSITY`] per `r^2` of area, `r` the point spacing), each with the normal
//!    interpolated from the vertex normals (so that candidates also fan out round sharp edges).
//! 2. **Projection** (layers under the surface): from `x = y - n k h`, repeatedly move `x` along
//!    the line from its closest surface point `c` to depth `k h`: `x = c + (x - c) k h / |x - c|`
//!    ([`MeshQuery::closest`]), until `|x - c|` is `k h` to within [`LEVEL_TOLERANCE`] of `h`.
//!    A candidate whose offset crosses the medial axis of a part thinner than `2 k h` finds no
//!    such point inside the mesh and is dropped (also when the iteration does not settle or ends
//!    outside the mesh by the exact [`MeshQuery::contains`]). Kept points lie on the exact offset
//!    surface, wherever it exists.
//! 3. **Thinning**: the projected candidates in a seeded random order; each is kept when no kept
//!    point of its layer is closer than `r` (with a relative margin of 1e-12 on the squared
//!    distance that covers its rounding, as [`blue_noise`](super::blue_noise) does: [`thin`]).
//!    This is Poisson disk sampling on the layer: no two points of a layer are closer than `r`,
//!    and the candidates being dense, every point of the layer is within about `r` of a kept
//!    point.
//!
//! A layer that comes out empty (the solid is nowhere thicker than twice its depth) ends the
//! sampling: the deeper layers would lie inside it.
//!
//! Points of different layers are at least `h (1 - 2e-9)` apart, because the distance to the
//! surface changes by at most the distance moved (it is 1-Lipschitz). So no two points are closer
//! than `min(r, h)` (up to that margin). With `filled_core`, blue-noise points
//! ([`blue_noise::poisson_disk`](super::blue_noise::poisson_disk) at `r`) deeper than one more
//! layer spacing under the innermost layer fill the core.
//!
//! # Tets
//!
//! All points are tetrahedralized together ([`crate::delaunay::tetrahedralize`]: Bowyer-Watson
//! on exact predicates). A tet is removed when
//!
//! - its four vertices all lie on the surface layer and its barycentre is no deeper than
//!   [`THICK_SURFACE_TET`] of its longest edge (the paper removes every tet of surface points
//!   only: such tets fill concave regions outside the mesh or are slivers lying on the surface;
//!   with [`ShellParams::keep_thick_surface_tets`] we keep the thick ones, which are material in
//!   parts too thin for a second layer and round sharp edges),
//! - its four vertices all lie on the innermost layer (the paper's rule; not with `filled_core`),
//! - its barycentre is not strictly inside the mesh ([`MeshQuery::contains`]),
//! - its barycentre is deeper than the innermost layer (not with `filled_core`),
//! - or its vertices, rounded to the f32 world coordinates the particle file stores, do not form a
//!   positively oriented tet (exactly, by [`robust::orient3d`]): no kept tet is inverted or flat
//!   as stored.
//!
//! The kept tets are ordered along a Z-curve of their barycentres; two kept tets are adjacent when
//! they share a face (from the Delaunay neighbours).

use glam::DVec3;
use rayon::prelude::*;
use robust::{Coord3D, orient3d};
use shatter_core::config::PipelineConfig;
use shatter_core::particles::{Elements, ParticleSet};
use shatter_core::random::{SplitMix64, splitmix64};
use shatter_core::{NoProgress, Progress};

use crate::delaunay::{DelaunayError, NO_NEIGHBOR, tet_volume, tetrahedralize};
use crate::mesh_query::MeshQuery;
use crate::order::z_order;
use crate::preprocess_driver::PreprocessError;
use crate::samplers::blue_noise::{MAX_GRID_CUBES, poisson_disk, thin};
use crate::samplers::particle_assembly::{Placement, Sampled, assemble, check_count};
use shatter_geometry::mesh::TriangleMesh;

/// Candidates per `r^2` of surface area (`r` the point spacing). Thinning keeps about 0.6 per
/// `r^2` (one candidate in thirty); the gaps between candidates (about 0.2 `r`) bound how far any
/// point of a layer is from a kept point (on bob at r = 3 cm: 1.15 `r` at most, measured).
pub const CANDIDATE_DENSITY: f64 = 20.0;

/// A projected point counts as on its layer when its depth is within this fraction of the layer
/// spacing of the layer's depth.
pub const LEVEL_TOLERANCE: f64 = 1e-9;

/// The most candidate points made for one layer (about 3 GB).
pub const MAX_CANDIDATES: usize = 1 << 27;

/// Projection steps a candidate gets to settle on its layer.
const MAX_PROJECTION_STEPS: usize = 8;

/// Mixed into the seed, so this sampler's streams differ from other users of the same seed.
const SEED_SALT: u64 = 0x7E75_11E1_0000_0004;

/// No kept tet (the new index of a removed one).
const NONE: u32 = u32::MAX;

/// How the shell is built.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShellParams {
    /// `r`: the minimum distance between points of a layer, metres.
    pub spacing: f64,
    /// Number of layers, the surface included (at least 2).
    pub layers: u32,
    /// `h`: the distance between consecutive layers, metres.
    pub layer_spacing: f64,
    /// Fill the core under the innermost layer with points and keep its tets.
    pub filled_core: bool,
    /// Seed of every random choice.
    pub seed: u64,
    /// Keep tets of surface points only whose barycentre lies deeper than [`THICK_SURFACE_TET`]
    /// of their longest edge (thin parts, sharp edges); else the paper's rule removes them all.
    pub keep_thick_surface_tets: bool,
}

/// A tet of surface points only is thick (material, not a sliver on the surface) when its
/// barycentre lies deeper than this fraction of its longest edge.
pub const THICK_SURFACE_TET: f64 = 0.1;

impl ShellParams {
    /// Depth of the innermost layer, `(layers - 1) h`.
    pub fn innermost_depth(&self) -> f64 {
        f64::from(self.layers.saturating_sub(1)) * self.layer_spacing
    }
}

/// The label of core points in [`ShellPoints::layer`].
pub const CORE: u32 = u32::MAX;

/// The points of a shell: every layer's, then the core's.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ShellPoints {
    /// Positions in the sampling frame.
    pub points: Vec<DVec3>,
    /// Each point's layer (0 = the surface), or [`CORE`].
    pub layer: Vec<u32>,
    /// Points per layer.
    pub per_layer: Vec<usize>,
    /// Core points (only with `filled_core`).
    pub core: usize,
}

/// Why tets were left out, counted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Removed {
    /// All four vertices on the surface layer.
    pub outer: usize,
    /// All four vertices on the innermost layer.
    pub inner: usize,
    /// Barycentre not inside the mesh.
    pub outside: usize,
    /// Barycentre deeper than the innermost layer.
    pub deep: usize,
    /// Not positively oriented once rounded to f32 world coordinates.
    pub flat: usize,
}

/// The tetrahedral shell.
#[derive(Debug, Clone, PartialEq)]
pub struct TetShell {
    /// The layer (and core) points.
    pub points: ShellPoints,
    /// Kept tets as indices into `points.points`, positively oriented (exactly, in the sampling
    /// frame and once rounded to f32 world coordinates), in Z-curve order of their barycentres.
    pub tets: Vec<[u32; 4]>,
    /// Each kept tet's barycentre, sampling frame.
    pub barycentres: Vec<DVec3>,
    /// Each kept tet's volume (positive).
    pub volumes: Vec<f64>,
    /// Kept tets sharing a face: (a, b), a < b, sorted.
    pub adjacency: Vec<[u32; 2]>,
    /// Tets of the whole Delaunay tetrahedralization.
    pub delaunay_tets: usize,
    /// Why the others were left out.
    pub removed: Removed,
}

/// Why a shell cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ShellError {
    /// The spacing is so small for this mesh that the candidates or a sampling grid would be too
    /// large.
    #[error(
        "the spacing is too fine for this mesh: a layer would need {candidates:.3e} candidate points (at most \
         {MAX_CANDIDATES} are made) or a sampling grid of more than {MAX_GRID_CUBES} cells"
    )]
    TooFine {
        /// Candidate points per layer the spacing asks for.
        candidates: f64,
    },
    /// The points span no volume (too few of them, or all in a plane).
    #[error("the layer points cannot be tetrahedralized: {0}")]
    Delaunay(DelaunayError),
    /// No tet is left.
    #[error("no tet of the shell is left: the spacing is too coarse for this mesh")]
    Empty,
}

/// Builds the tetrahedral shell of `mesh` (`query` built from it). `world` rounds a sampling-frame
/// point to the f32 world coordinates the particle file stores. Reports the phases "layer points"
/// (in layers), "delaunay" and "select tets" to `progress`. See the [module documentation](self).
pub fn tet_shell(
    mesh: &TriangleMesh,
    query: &MeshQuery,
    params: &ShellParams,
    world: &(dyn Fn(DVec3) -> [f32; 3] + Sync),
    progress: &dyn Progress,
) -> Result<TetShell, ShellError> {
    progress.start("layer points", u64::from(params.layers) + u64::from(params.filled_core));
    let points = shell_points_reporting(mesh, query, params, progress);
    progress.finish();
    let points = points?;
    progress.start("delaunay", 0);
    let tetrahedralization = tetrahedralize(&points.points).map_err(ShellError::Delaunay);
    progress.finish();
    let tetrahedralization = tetrahedralization?;
    progress.start("select tets", tetrahedralization.tets.len() as u64);
    let verdicts: Vec<Verdict> = tetrahedralization
        .tets
        .par_chunks(4096)
        .flat_map_iter(|chunk| {
            progress.advance(chunk.len() as u64);
            chunk.iter().map(|tet| classify(*tet, &points, query, params, world))
        })
        .collect();
    progress.finish();
    let mut removed = Removed::default();
    let mut kept = Vec::new();
    for (t, verdict) in verdicts.iter().enumerate() {
        match verdict {
            Verdict::Keep => kept.push(t as u32),
            Verdict::Outer => removed.outer += 1,
            Verdict::Inner => removed.inner += 1,
            Verdict::Outside => removed.outside += 1,
            Verdict::Deep => removed.deep += 1,
            Verdict::Flat => removed.flat += 1,
        }
    }
    if kept.is_empty() {
        return Err(ShellError::Empty);
    }
    let barycentre = |t: u32| {
        let tet = tetrahedralization.tets[t as usize];
        tet.iter().map(|&v| points.points[v as usize]).sum::<DVec3>() * 0.25
    };
    let unordered: Vec<DVec3> = kept.iter().map(|&t| barycentre(t)).collect();
    let order = z_order(&unordered);
    let kept: Vec<u32> = order.iter().map(|&k| kept[k as usize]).collect();
    let barycentres: Vec<DVec3> = order.iter().map(|&k| unordered[k as usize]).collect();
    let tets: Vec<[u32; 4]> = kept.iter().map(|&t| tetrahedralization.tets[t as usize]).collect();
    let volumes = tets.iter().map(|tet| tet_volume(&points.points, *tet)).collect();

    // New index of every Delaunay tet (NONE when removed), then the faces between kept tets.
    let mut new_index = vec![NONE; tetrahedralization.tets.len()];
    for (k, &t) in kept.iter().enumerate() {
        new_index[t as usize] = k as u32;
    }
    let mut adjacency: Vec<[u32; 2]> = kept
        .iter()
        .enumerate()
        .flat_map(|(k, &t)| {
            let new_index = &new_index;
            tetrahedralization.neighbors[t as usize].into_iter().filter_map(move |other| {
                let other = if other == NO_NEIGHBOR { NONE } else { new_index[other as usize] };
                (other != NONE && (k as u32) < other).then_some([k as u32, other])
            })
        })
        .collect();
    adjacency.sort_unstable();
    Ok(TetShell {
        points,
        tets,
        barycentres,
        volumes,
        adjacency,
        delaunay_tets: tetrahedralization.tets.len(),
        removed,
    })
}

/// What becomes of a tet.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Verdict {
    Keep,
    Outer,
    Inner,
    Outside,
    Deep,
    Flat,
}

fn classify(
    tet: [u32; 4],
    points: &ShellPoints,
    query: &MeshQuery,
    params: &ShellParams,
    world: &(dyn Fn(DVec3) -> [f32; 3] + Sync),
) -> Verdict {
    let layers = tet.map(|v| points.layer[v as usize]);
    let innermost = params.layers - 1;
    let corners = tet.map(|v| points.points[v as usize]);
    let barycentre = corners.iter().sum::<DVec3>() * 0.25;
    if layers.iter().all(|&l| l == 0) {
        let thick = params.keep_thick_surface_tets && {
            let longest = (0..4)
                .flat_map(|i| (i + 1..4).map(move |j| (i, j)))
                .map(|(i, j)| corners[i].distance(corners[j]))
                .fold(0.0, f64::max);
            query.distance(barycentre) > THICK_SURFACE_TET * longest
        };
        if !thick {
            return Verdict::Outer;
        }
    }
    if !params.filled_core && layers.iter().all(|&l| l == innermost) {
        return Verdict::Inner;
    }
    if !query.contains(barycentre) {
        return Verdict::Outside;
    }
    if !params.filled_core && query.distance(barycentre) > params.innermost_depth() {
        return Verdict::Deep;
    }
    let stored = corners.map(|p| {
        let [x, y, z] = world(p).map(f64::from);
        Coord3D { x, y, z }
    });
    if orient3d(stored[0], stored[1], stored[2], stored[3]) <= 0.0 {
        return Verdict::Flat;
    }
    Verdict::Keep
}

/// Samples every layer (and the core with `filled_core`). See the [module documentation](self).
pub fn shell_points(mesh: &TriangleMesh, query: &MeshQuery, params: &ShellParams) -> Result<ShellPoints, ShellError> {
    shell_points_reporting(mesh, query, params, &NoProgress)
}

/// [`shell_points`], advancing `progress` by one per layer (and one for the core).
fn shell_points_reporting(
    mesh: &TriangleMesh,
    query: &MeshQuery,
    params: &ShellParams,
    progress: &dyn Progress,
) -> Result<ShellPoints, ShellError> {
    let surface = Surface::new(mesh);
    let candidates = mesh.area() * CANDIDATE_DENSITY / (params.spacing * params.spacing);
    if candidates.is_nan() || candidates > MAX_CANDIDATES as f64 {
        return Err(ShellError::TooFine { candidates });
    }
    let mut shell = ShellPoints::default();
    for layer in 0..params.layers {
        // A deeper layer lies inside this one (the distance is continuous): once a layer is empty,
        // so are all below it.
        let empty = shell.per_layer.last() == Some(&0);
        let points = if empty { Vec::new() } else { sample_layer(&surface, query, params, layer)? };
        shell.per_layer.push(points.len());
        shell.layer.extend(std::iter::repeat_n(layer, points.len()));
        shell.points.extend(points);
        progress.advance(1);
    }
    if params.filled_core {
        let bounds = mesh.bounds();
        let cubes = ((bounds.1 - bounds.0) / (params.spacing / 3f64.sqrt())).ceil().max(DVec3::ONE);
        if cubes.x * cubes.y * cubes.z > MAX_GRID_CUBES as f64 {
            return Err(ShellError::TooFine { candidates });
        }
        let floor = params.innermost_depth() + params.layer_spacing;
        let core: Vec<DVec3> = poisson_disk(query, bounds, params.spacing, params.seed ^ SEED_SALT)
            .into_par_iter()
            .filter(|p| query.distance(*p) >= floor)
            .collect();
        shell.core = core.len();
        shell.layer.extend(std::iter::repeat_n(CORE, core.len()));
        shell.points.extend(core);
        progress.advance(1);
    }
    Ok(shell)
}

/// The mesh prepared for sampling: triangle areas and vertex normals.
struct Surface<'a> {
    mesh: &'a TriangleMesh,
    /// Unit vertex normals, the triangles' normals weighted by their angles at the vertex.
    normals: Vec<DVec3>,
}

impl<'a> Surface<'a> {
    fn new(mesh: &'a TriangleMesh) -> Surface<'a> {
        let mut normals = vec![DVec3::ZERO; mesh.positions.len()];
        for t in 0..mesh.triangles.len() {
            let corners = mesh.corners(t);
            let normal = (corners[1] - corners[0]).cross(corners[2] - corners[0]).normalize_or_zero();
            for k in 0..3 {
                let (a, b) = (corners[(k + 1) % 3] - corners[k], corners[(k + 2) % 3] - corners[k]);
                let angle = a.angle_between(b);
                if angle.is_finite() {
                    normals[mesh.triangles[t][k] as usize] += normal * angle;
                }
            }
        }
        for normal in &mut normals {
            *normal = normal.normalize_or_zero();
        }
        Surface { mesh, normals }
    }

    /// About `density` random points per unit area on triangle `t`, each with its interpolated
    /// normal (the face normal where that vanishes), from a generator seeded by `(seed, t)`.
    fn candidates(&self, t: usize, density: f64, seed: u64, out: &mut Vec<(DVec3, DVec3)>) {
        let [a, b, c] = self.mesh.corners(t);
        let cross = (b - a).cross(c - a);
        let area = cross.length() * 0.5;
        let face = cross.normalize_or_zero();
        let mut rng = SplitMix64::new(splitmix64(seed ^ splitmix64(t as u64)));
        let expected = area * density;
        let count = (expected + rng.next_f64()).floor() as usize;
        let [na, nb, nc] = self.mesh.triangles[t].map(|v| self.normals[v as usize]);
        for _ in 0..count {
            // Uniform on the triangle: the square-root map of two uniforms.
            let (s, u) = (rng.next_f64().sqrt(), rng.next_f64());
            let (wa, wb, wc) = (1.0 - s, s * (1.0 - u), s * u);
            let point = a * wa + b * wb + c * wc;
            let normal = (na * wa + nb * wb + nc * wc).try_normalize().unwrap_or(face);
            out.push((point, normal));
        }
    }
}

/// The points of one layer: candidates, projected to the layer's depth, thinned to the spacing.
fn sample_layer(
    surface: &Surface,
    query: &MeshQuery,
    params: &ShellParams,
    layer: u32,
) -> Result<Vec<DVec3>, ShellError> {
    let r = params.spacing;
    let depth = f64::from(layer) * params.layer_spacing;
    let tolerance = LEVEL_TOLERANCE * params.layer_spacing;
    let density = CANDIDATE_DENSITY / (r * r);
    let seed = splitmix64(params.seed ^ SEED_SALT ^ (u64::from(layer) << 32));
    let triangles = surface.mesh.triangles.len();
    // Rayon's collect keeps the triangles' order, so the result does not depend on the threads.
    let mut candidates: Vec<DVec3> = (0..triangles)
        .into_par_iter()
        .flat_map_iter(|t| {
            let mut scratch = Vec::new();
            surface.candidates(t, density, seed, &mut scratch);
            scratch
                .into_iter()
                .filter_map(move |(y, n)| if layer == 0 { Some(y) } else { project(query, y, n, depth, tolerance) })
        })
        .collect();
    let mut rng = SplitMix64::new(splitmix64(seed ^ 0x5EED));
    for i in (1..candidates.len()).rev() {
        let j = (rng.next_u64() % (i as u64 + 1)) as usize;
        candidates.swap(i, j);
    }
    let count = candidates.len() as f64;
    thin(&candidates, r).ok_or(ShellError::TooFine { candidates: count })
}

/// The inside point at depth `depth` reached from surface point `y` with inward direction `-n`,
/// by moving along the line from the closest surface point; `None` where there is none (the
/// layer does not exist there or the iteration leaves the mesh). See the [module documentation](self).
pub fn project(query: &MeshQuery, y: DVec3, n: DVec3, depth: f64, tolerance: f64) -> Option<DVec3> {
    let mut x = y - n * depth;
    for _ in 0..MAX_PROJECTION_STEPS {
        let (_, c) = query.closest(x)?;
        let offset = x - c;
        let distance = offset.length();
        if (distance - depth).abs() <= tolerance {
            return query.contains(x).then_some(x);
        }
        if distance <= tolerance {
            return None; // on the surface: the direction is lost
        }
        x = c + offset * (depth / distance);
    }
    None
}

// The shell as particles, for the dispatch in `samplers/sampler_dispatch.rs`.

/// The tets of the layered shell as particles: barycentres, tet volumes, the tets in the world.
pub(super) fn tet_shell_particles(
    config: &PipelineConfig,
    mesh: &TriangleMesh,
    query: &MeshQuery,
    progress: &dyn Progress,
    notes: &mut Vec<String>,
) -> Result<ParticleSet, PreprocessError> {
    let geometry = &config.geometry;
    let params = ShellParams {
        spacing: geometry.spacing_m,
        layers: geometry.tet_shell_layers(),
        layer_spacing: geometry.tet_shell_layer_spacing_m(),
        filled_core: geometry.tet_shell.filled_core,
        seed: config.scene.seed,
        keep_thick_surface_tets: true,
    };
    if f64::from(params.layers) <= geometry.horizon_factor {
        notes.push(format!(
            "geometry.tet_shell.layers = {} is not more than geometry.horizon_factor = {}: the shell is thinner than \
             the horizon (Levine et al. found that the layers should outnumber N)",
            params.layers, geometry.horizon_factor
        ));
    }
    let placement = Placement::new(&geometry.transform);
    let shell = tet_shell(mesh, query, &params, &|p| placement.world(p), progress);
    let shell = shell.map_err(|error| match error {
        ShellError::TooFine { .. } | ShellError::Empty => PreprocessError::Setting {
            key: "geometry.spacing_m",
            value: geometry.spacing_m.to_string(),
            message: error.to_string(),
        },
        ShellError::Delaunay(_) => PreprocessError::Sampler { sampler: "tet_shell", message: error.to_string() },
    })?;
    check_count("geometry.spacing_m", geometry.spacing_m.to_string(), shell.tets.len())?;
    notes.push(shell_note(&shell, &params));
    let TetShell { points, tets, barycentres, volumes, adjacency, .. } = shell;
    let vertices_m = tets.iter().map(|tet| tet.map(|v| placement.world(points.points[v as usize]))).collect();
    let elements = Elements::Tets { vertices_m };
    let stored = placement.stored_positions(&barycentres);
    let sampled = Sampled {
        lambda_m: geometry.spacing_m,
        points: &barycentres,
        rest_position_m: stored,
        volume_m3: &volumes,
        elements,
        adjacency,
    };
    Ok(assemble(config, sampled, progress, notes))
}

/// What the shell is made of, for the user.
fn shell_note(shell: &TetShell, params: &ShellParams) -> String {
    let removed = &shell.removed;
    let core = if params.filled_core { format!(" and {} core points", shell.points.core) } else { String::new() };
    format!(
        "tet shell: {} layers {:.4e} m apart ({} points per layer from the surface in){core}; {} of {} Delaunay \
         tets kept (left out: {} on the surface only, {} on the innermost layer only, {} outside the mesh, {} \
         deeper than the innermost layer, {} flat in f32)",
        params.layers,
        params.layer_spacing,
        shell.points.per_layer.iter().map(|n| n.to_string()).collect::<Vec<_>>().join(", "),
        shell.tets.len(),
        shell.delaunay_tets,
        removed.outer,
        removed.inner,
        removed.outside,
        removed.deep,
        removed.flat,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_meshes::cube;

    fn params(layers: u32, filled_core: bool) -> ShellParams {
        ShellParams { spacing: 0.05, layers, layer_spacing: 0.1, filled_core, seed: 5, keep_thick_surface_tets: true }
    }

    fn world(p: DVec3) -> [f32; 3] {
        p.as_vec3().to_array()
    }

    #[test]
    fn layers_of_a_cube_sit_at_their_depth_and_keep_their_distance() {
        let mesh = cube(1.0);
        let query = MeshQuery::new(&mesh);
        let shell = shell_points(&mesh, &query, &params(3, false)).expect("points");
        assert_eq!(shell.per_layer.len(), 3);
        for (p, layer) in shell.points.iter().zip(&shell.layer) {
            let depth = query.distance(*p);
            assert!((depth - 0.1 * f64::from(*layer)).abs() < 1e-9, "{p} on layer {layer} at depth {depth}");
        }
        for i in 0..shell.points.len() {
            for j in i + 1..shell.points.len() {
                assert!(shell.points[i].distance(shell.points[j]) >= 0.05);
            }
        }
        // The surface (area 6) holds about 0.7 points per r^2.
        let density = shell.per_layer[0] as f64 * 0.0025 / 6.0;
        eprintln!("surface density {density}");
        assert!(density > 0.6 && density < 0.8, "{density}");
    }

    #[test]
    fn a_cube_shell_is_tiled_by_positive_tets() {
        let mesh = cube(1.0);
        let query = MeshQuery::new(&mesh);
        let shell = tet_shell(&mesh, &query, &params(3, false), &world, &NoProgress).expect("shell");
        assert!(shell.volumes.iter().all(|v| *v > 0.0));
        let total: f64 = shell.volumes.iter().sum();
        // The shell between the surface and the cube of side 0.6 inside it.
        let expected = 1.0 - 0.6f64.powi(3);
        eprintln!("{total} against {expected}");
        assert!((total / expected - 1.0).abs() < 0.03, "{total} against {expected}");
        let solid = tet_shell(&mesh, &query, &params(3, true), &world, &NoProgress).expect("solid");
        let total: f64 = solid.volumes.iter().sum();
        eprintln!("{total} against 1");
        assert!((total - 1.0).abs() < 0.01, "{total}");
        assert!(solid.points.core > 0);
    }
}
