//! Art direction of the cracks: per-bond threshold multipliers from weakened random-walk paths,
//! pre-scored seams (planes or meshes) and Voronoi shard patterns.
//!
//! Every rule is a symmetric function of the bond's two rest positions, so a bond's two CSR
//! entries always get the same factor, and every random choice is seeded by `scene.seed`.

use glam::{DQuat, DVec3};
use rayon::prelude::*;
use shatter_core::config::sim::{SeamConfig, ShardsConfig, SimConfig, WeakenedPathConfig};
use shatter_core::particles::ParticleSet;
use shatter_core::random::{SplitMix64, splitmix64};
use shatter_geometry::PointKdTree;
use shatter_geometry::mesh::TriangleMesh;

use crate::SimError;

/// Threshold multipliers, one per CSR entry of the particle file's bonds; `None` when the config
/// asks for no art direction.
pub fn threshold_factors(sim: &SimConfig, particles: &ParticleSet, seed: u64) -> Result<Option<Vec<f32>>, SimError> {
    if sim.weakened_path.is_empty() && sim.seam.is_empty() && sim.shards.is_none() {
        return Ok(None);
    }
    let rest: Vec<DVec3> = particles.rest_position_m.iter().map(|p| DVec3::from_array(p.map(f64::from))).collect();
    let mut rules: Vec<Box<dyn Fn(usize, usize) -> f64 + Sync>> = Vec::new();
    for (index, path) in sim.weakened_path.iter().enumerate() {
        let walk = random_walk(path, splitmix64(seed ^ splitmix64(index as u64 + 1)));
        rules.push(Box::new(weakened_band(walk, path.radius_m, path.threshold_factor, &rest, particles.meta.delta_m)));
    }
    for seam in &sim.seam {
        rules.push(seam_rule(seam, &rest, particles.meta.delta_m)?);
    }
    if let Some(shards) = &sim.shards {
        if shards.count as usize > rest.len() {
            return Err(SimError::BadInput(format!(
                "sim.shards.count = {}: more shards than the particle file's {} particles",
                shards.count,
                rest.len()
            )));
        }
        rules.push(Box::new(shard_rule(shards, particles, &rest, seed)));
    }
    let bonds = &particles.bonds;
    let mut factors = vec![1.0f32; bonds.neighbor.len()];
    factors.par_chunks_mut(4096).enumerate().for_each(|(chunk, out)| {
        let first = chunk * 4096;
        let mut i = bonds.offsets.partition_point(|offset| *offset as usize <= first) - 1;
        for (k, factor) in (first..).zip(out.iter_mut()) {
            while bonds.offsets[i + 1] as usize <= k {
                i += 1;
            }
            let j = bonds.neighbor[k] as usize;
            *factor = rules.iter().map(|rule| rule(i, j)).product::<f64>() as f32;
        }
    });
    Ok(Some(factors))
}

/// The walk's vertices: `steps` steps of `step_length_m`, each turned by a random angle of at
/// most `max_turn_deg`, about the plane normal if given, else about a random axis.
pub fn random_walk(path: &WeakenedPathConfig, seed: u64) -> Vec<DVec3> {
    let mut rng = SplitMix64::new(seed);
    let normal = path.plane_normal.map(|n| DVec3::from_array(n).normalize());
    let mut direction = DVec3::from_array(path.direction).normalize();
    if let Some(normal) = normal {
        let in_plane = direction - normal * direction.dot(normal);
        direction = if in_plane.length() > 1e-9 { in_plane.normalize() } else { normal.any_orthonormal_vector() };
    }
    let mut point = DVec3::from_array(path.start_m);
    let mut vertices = vec![point];
    let max_turn = path.max_turn_deg.to_radians();
    for _ in 0..path.steps {
        let angle = (2.0 * rng.next_f64() - 1.0) * max_turn;
        let axis = match normal {
            Some(normal) => normal,
            None => {
                let (a, b) = direction.any_orthonormal_pair();
                let around = std::f64::consts::TAU * rng.next_f64();
                a * around.cos() + b * around.sin()
            }
        };
        direction = (DQuat::from_axis_angle(axis, angle) * direction).normalize();
        point += direction * path.step_length_m;
        vertices.push(point);
    }
    vertices
}

/// Distance from `p` to the segment a-b.
fn segment_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let t = if ab.length_squared() > 0.0 { ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0) } else { 0.0 };
    p.distance(a + ab * t)
}

/// Bonds whose midpoint lies within `radius` of the walk get `factor`.
fn weakened_band(
    walk: Vec<DVec3>,
    radius: f64,
    factor: f64,
    rest: &[DVec3],
    delta: f64,
) -> impl Fn(usize, usize) -> f64 + Sync {
    // Only particles near the walk can have a bond whose midpoint is near it.
    let tree = PointKdTree::new(rest);
    let mut near = vec![false; rest.len()];
    let mut found = Vec::new();
    for pair in walk.windows(2) {
        let reach = radius + 0.5 * delta + 0.5 * pair[0].distance(pair[1]);
        found.clear();
        tree.within((pair[0] + pair[1]) * 0.5, reach * reach, &mut found);
        for &i in &found {
            near[i as usize] = true;
        }
    }
    let rest = rest.to_vec();
    move |i: usize, j: usize| {
        if !(near[i] || near[j]) {
            return 1.0;
        }
        let middle = (rest[i] + rest[j]) * 0.5;
        let inside = walk.windows(2).any(|pair| segment_distance(middle, pair[0], pair[1]) <= radius);
        if inside { factor } else { 1.0 }
    }
}

type Rule = Box<dyn Fn(usize, usize) -> f64 + Sync>;

/// Bonds crossing the seam get its factor.
fn seam_rule(seam: &SeamConfig, rest: &[DVec3], delta: f64) -> Result<Rule, SimError> {
    let factor = seam.threshold_factor;
    if let Some(mesh_path) = &seam.mesh {
        let (mesh, _) =
            TriangleMesh::load_obj(mesh_path).map_err(|error| SimError::BadInput(format!("sim.seam: {error}")))?;
        let crossing = bonds_crossing_mesh(&mesh, rest, delta);
        return Ok(Box::new(move |i, j| {
            let key = (i.min(j) as u64) << 32 | i.max(j) as u64;
            if crossing.binary_search(&key).is_ok() { factor } else { 1.0 }
        }));
    }
    let (Some(point), Some(normal)) = (seam.point_m, seam.normal) else {
        unreachable!("validated: a seam is a plane or a mesh")
    };
    let point = DVec3::from_array(point);
    let normal = DVec3::from_array(normal).normalize();
    let radius = seam.radius_m;
    let rest = rest.to_vec();
    Ok(Box::new(move |i, j| {
        let (a, b) = (rest[i], rest[j]);
        let (da, db) = ((a - point).dot(normal), (b - point).dot(normal));
        if (da < 0.0) == (db < 0.0) {
            return 1.0;
        }
        let crossing = a + (b - a) * (da / (da - db));
        let within = radius.is_none_or(|radius| crossing.distance(point) <= radius);
        if within { factor } else { 1.0 }
    }))
}

/// Sorted keys (min << 32 | max) of the particle pairs within `delta` whose segment crosses a
/// triangle of `mesh`.
fn bonds_crossing_mesh(mesh: &TriangleMesh, rest: &[DVec3], delta: f64) -> Vec<u64> {
    let tree = PointKdTree::new(rest);
    let mut keys: Vec<u64> = (0..mesh.triangles.len())
        .into_par_iter()
        .flat_map_iter(|t| {
            let [a, b, c] = mesh.corners(t);
            let centre = (a + b + c) / 3.0;
            let reach = centre.distance(a).max(centre.distance(b)).max(centre.distance(c)) + delta;
            let mut near = Vec::new();
            tree.within(centre, reach * reach, &mut near);
            let mut keys = Vec::new();
            for (index, &i) in near.iter().enumerate() {
                for &j in &near[index + 1..] {
                    let (p, q) = (rest[i as usize], rest[j as usize]);
                    if p.distance_squared(q) <= delta * delta && segment_crosses_triangle(p, q, [a, b, c]) {
                        keys.push((i.min(j) as u64) << 32 | i.max(j) as u64);
                    }
                }
            }
            keys
        })
        .collect();
    keys.par_sort_unstable();
    keys.dedup();
    keys
}

/// Whether segment p-q passes through triangle abc (Moller-Trumbore on the segment).
fn segment_crosses_triangle(p: DVec3, q: DVec3, [a, b, c]: [DVec3; 3]) -> bool {
    let direction = q - p;
    let (e1, e2) = (b - a, c - a);
    let h = direction.cross(e2);
    let det = e1.dot(h);
    if det.abs() < 1e-300 {
        return false;
    }
    let inv = 1.0 / det;
    let s = p - a;
    let u = inv * s.dot(h);
    let qv = s.cross(e1);
    let v = inv * direction.dot(qv);
    let t = inv * e2.dot(qv);
    (0.0..=1.0).contains(&u) && v >= 0.0 && u + v <= 1.0 && (0.0..=1.0).contains(&t)
}

/// Shards: each particle joins the nearest centre ([`ShardsConfig::centres`]: `count` particles
/// chosen by hashed rank, or the centres the config gives).
fn shard_rule(
    shards: &ShardsConfig,
    particles: &ParticleSet,
    rest: &[DVec3],
    seed: u64,
) -> impl Fn(usize, usize) -> f64 + Sync {
    let centres: Vec<DVec3> =
        shards.centres(&particles.rest_position_m, seed).into_iter().map(DVec3::from_array).collect();
    let shard: Vec<u32> = rest
        .par_iter()
        .map(|p| {
            (0..centres.len())
                .min_by(|a, b| p.distance_squared(centres[*a]).total_cmp(&p.distance_squared(centres[*b])))
                .unwrap_or(0) as u32
        })
        .collect();
    let (inside, across) = (shards.inside_factor, shards.across_factor);
    move |i, j| if shard[i] == shard[j] { inside } else { across }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn walk(plane_normal: Option<[f64; 3]>) -> WeakenedPathConfig {
        WeakenedPathConfig {
            start_m: [0.0; 3],
            direction: [1.0, 0.0, 0.0],
            plane_normal,
            steps: 50,
            step_length_m: 0.01,
            max_turn_deg: 30.0,
            radius_m: 0.001,
            threshold_factor: 0.5,
        }
    }

    #[test]
    fn random_walks_are_seeded_steady_and_stay_in_their_plane() {
        let path = walk(Some([0.0, 0.0, 1.0]));
        let a = random_walk(&path, 7);
        assert_eq!(a, random_walk(&path, 7));
        assert_ne!(a, random_walk(&path, 8));
        assert_eq!(a.len(), 51);
        for pair in a.windows(2) {
            assert!((pair[0].distance(pair[1]) - 0.01).abs() < 1e-12);
            assert!(pair[1].z.abs() < 1e-12);
        }
        for triple in a.windows(3) {
            let turn = (triple[1] - triple[0]).angle_between(triple[2] - triple[1]);
            assert!(turn <= 30f64.to_radians() + 1e-9);
        }
    }

    #[test]
    fn segment_triangle_crossing() {
        let triangle = [DVec3::ZERO, DVec3::X, DVec3::Y];
        assert!(segment_crosses_triangle(DVec3::new(0.2, 0.2, -1.0), DVec3::new(0.2, 0.2, 1.0), triangle));
        assert!(!segment_crosses_triangle(DVec3::new(0.2, 0.2, 0.5), DVec3::new(0.2, 0.2, 1.0), triangle));
        assert!(!segment_crosses_triangle(DVec3::new(0.8, 0.8, -1.0), DVec3::new(0.8, 0.8, 1.0), triangle));
    }
}
