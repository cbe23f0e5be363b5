//! The CPU ray tracer, step for step the twin of `shaders/trace.wgsl`: nearest hits through the
//! k-d tree with CSG union semantics, glass paths through unions of touching cubes, opaque
//! tetrahedra and trimtopes, the floor and the environment. One difference of method, not of
//! result: [`render`] finds its camera rays' first surfaces in packets ([`closest_hits`]), each
//! exactly what the shader's single-ray search finds (the packet's rays share their origin's
//! rooms to a cube's planes, [`crate::primitives::CubeFromOrigin`]).
//!
//! Union semantics: a ray from outside first meets the union of elements at the nearest entry
//! of any element, so inner faces are never seen. Inside glass, the ray walks from element to
//! element that holds the point where it leaves the previous one, and only leaves the glass where
//! no element continues: the last element's face gives the exit normal (refraction out, or
//! internal reflection).

// Indexed loops mirror the shader this is the twin of.
#![allow(clippy::needless_range_loop)]
use rayon::prelude::*;
use shatter_core::particles::ElementType;

use crate::element_kdtree::{PACKET, each_ray};
use crate::lighting::{EnvironmentMap, KeyLight, sh_irradiance};
use crate::mattes::{MatteCounts, SURFACE_FLOOR, SURFACE_FRACTURE, SURFACE_NONE, SURFACE_OUTER};
use crate::primitives::{CubeFromOrigin, TrimtopeHit, along, dot, polytope_span, trimtope_hit};
use crate::scene::{Camera, SceneGeometry};

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
    const MISS: Hit = Hit { t: f32::INFINITY, element: NONE, normal: [0.0; 3], fracture: false };
}

/// Where the ray first meets element `e` from `t_min` on: a polytope's entry (or, for a
/// trimtope, the rules of Fig. 4), as the plane or triangle it meets there; [`resolve`] turns it
/// into a [`Hit`]. Nearest-hit searches compare entries and resolve only the nearest (a normal
/// and a fracture-face lookup for one element, not for every one).
fn element_entry(scene: &SceneGeometry, e: usize, origin: [f32; 3], direction: [f32; 3], t_min: f32) -> TrimtopeHit {
    if scene.element_type == ElementType::Trimtope {
        let (planes, triangles, groups) = (scene.planes_of(e), scene.triangles_of(e), scene.triangle_groups_of(e));
        return trimtope_hit(planes, triangles, groups, scene.sites[e], scene.slack, origin, direction, t_min);
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

/// The nearest element surface along the ray from `t_min` on (ties go to the lower element).
pub fn closest_hit(scene: &SceneGeometry, origin: [f32; 3], direction: [f32; 3], t_min: f32) -> Hit {
    let mut nearest = Nearest::NONE;
    scene.index.traverse(&scene.fragment, origin, direction, t_min, |e| {
        nearest.offer(e, element_entry(scene, e as usize, origin, direction, t_min));
        nearest.t
    });
    resolve(scene, nearest.element, nearest.entry)
}

/// The nearest element surfaces along a packet of rays from one `origin` (at most
/// [`PACKET`] `directions`, t from 0 on), into `hits`: each exactly what [`closest_hit`] gives
/// its ray, found in one traversal of the k-d tree for them all (see
/// [`crate::element_kdtree::KdTree::traverse_packet`]).
pub fn closest_hits(scene: &SceneGeometry, origin: [f32; 3], directions: &[[f32; 3]], hits: &mut [Hit]) {
    let mut nearest = [Nearest::NONE; PACKET];
    let traversed = scene.index.traverse_packet(&scene.fragment, origin, directions, 0.0, |e, rays| {
        if let Some((axes, distances)) = scene.cube(e as usize) {
            let cube = CubeFromOrigin::new(axes, distances, origin);
            for r in each_ray(rays) {
                nearest[r].offer(e, face_entry(cube.entry(scene.slack, directions[r], 0.0)));
            }
        } else {
            for r in each_ray(rays) {
                nearest[r].offer(e, element_entry(scene, e as usize, origin, directions[r], 0.0));
            }
        }
        nearest.map(|n| n.t)
    });
    for ((hit, &direction), n) in hits.iter_mut().zip(directions).zip(nearest) {
        *hit = if traversed { resolve(scene, n.element, n.entry) } else { closest_hit(scene, origin, direction, 0.0) };
    }
}

/// The lowest element (other than `except`) holding `point`, if any.
pub fn element_at(scene: &SceneGeometry, point: [f32; 3], except: u32) -> u32 {
    let mut found = NONE;
    scene.index.for_each_at(&scene.fragment, point, |e| {
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

/// Where a ray inside the union containing `element` leaves it: (distance, unit outward normal of
/// the last element's exit face, last element).
pub fn union_exit(scene: &SceneGeometry, element: u32, origin: [f32; 3], direction: [f32; 3]) -> (f32, [f32; 3], u32) {
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

/// What the renderer needs besides the geometry.
#[derive(Debug, Clone)]
pub struct Look {
    /// The environment.
    pub environment: EnvironmentMap,
    /// Its 9 SH coefficients.
    pub sh: [[f32; 3]; 9],
    /// Its key light.
    pub key: KeyLight,
    /// Show it as background.
    pub show_environment: bool,
    /// Glass index of refraction.
    pub ior: f32,
    /// Glass absorption per metre.
    pub absorption: [f32; 3],
    /// Opaque albedo.
    pub albedo: [f32; 3],
    /// Opaque albedo of fracture faces.
    pub fracture_albedo: [f32; 3],
    /// Highlight strength.
    pub specular: f32,
    /// Highlight exponent.
    pub shininess: f32,
    /// The floor, if any.
    pub floor: Option<FloorLook>,
    /// Longest glass path: a path still going after this many events takes the environment's
    /// radiance along its last direction.
    pub max_bounces: u32,
    /// Glass interface events (counted along a path from the camera) at which both the reflected
    /// and the refracted branch are followed, weighted by Fresnel; later events pick one at random.
    pub glass_split_events: u32,
    /// Cubes are opaque (as tetrahedra and trimtopes are) instead of glass.
    pub opaque_cubes: bool,
}

/// A floor plane with a tiled albedo texture.
#[derive(Debug, Clone)]
pub struct FloorLook {
    /// Height, metres.
    pub height: f32,
    /// Tile size, metres.
    pub tile: f32,
    /// Texture width and height (1 x 1 for a plain albedo).
    pub size: [usize; 2],
    /// Albedo texels, row-major.
    pub texels: FloorTexels,
}

impl FloorLook {
    fn albedo(&self, p: [f32; 3]) -> [f32; 3] {
        // x - floor(x) is rem_euclid(x, 1) without its library call: the same real number
        // rounded once (exactly, for x >= 0), but +0 for -0 and whole negative x (texel 0 either way).
        let fraction = |x: f32| x - x.floor();
        let (u, v) = (fraction(p[0] / self.tile), fraction(p[2] / self.tile));
        let x = ((u * self.size[0] as f32) as usize).min(self.size[0] - 1);
        let y = ((v * self.size[1] as f32) as usize).min(self.size[1] - 1);
        self.texels.linear_at(y * self.size[0] + x)
    }
}

/// A floor's albedo texels, row-major.
#[derive(Debug, Clone)]
pub enum FloorTexels {
    /// Linear albedo.
    Linear(Vec<[f32; 3]>),
    /// 8-bit sRGB (an image file's), decoded through a table of the 256 values' linear albedo:
    /// the same linear values bit for bit, in a quarter of the bytes, so that more of a large
    /// texture stays in cache (the floor's texel loads were most of its shading time).
    Srgb8 {
        /// The texels as stored.
        texels: Vec<[u8; 3]>,
        /// Linear albedo of each 8-bit value.
        linear: Box<[f32; 256]>,
    },
}

impl FloorTexels {
    /// 8-bit sRGB texels.
    pub fn srgb8(texels: Vec<[u8; 3]>) -> FloorTexels {
        let linear = Box::new(std::array::from_fn(|v| srgb_to_linear(v as u8)));
        FloorTexels::Srgb8 { texels, linear }
    }

    /// Number of texels.
    pub fn len(&self) -> usize {
        match self {
            FloorTexels::Linear(texels) => texels.len(),
            FloorTexels::Srgb8 { texels, .. } => texels.len(),
        }
    }

    /// True without texels.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Texel `i`'s linear albedo.
    pub fn linear_at(&self, i: usize) -> [f32; 3] {
        match self {
            FloorTexels::Linear(texels) => texels[i],
            FloorTexels::Srgb8 { texels, linear } => texels[i].map(|v| linear[usize::from(v)]),
        }
    }
}

/// The linear value of an 8-bit sRGB value (IEC 61966-2-1's decoding).
fn srgb_to_linear(v: u8) -> f32 {
    let c = f32::from(v) / 255.0;
    if c <= 0.040_45 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// One pixel's layers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pixel {
    /// Linear RGB.
    pub color: [f32; 3],
    /// Coverage: 1 where an element or the floor was seen first.
    pub alpha: f32,
    /// Distance along the ray to the first surface (infinity for none).
    pub depth: f32,
    /// Unit normal at the first surface (zero for none).
    pub normal: [f32; 3],
    /// Fragment id + 1 of the first element seen (0 for none).
    pub fragment: u32,
    /// The first element seen ([`NONE`] for none).
    pub element: u32,
    /// What kind of surface was seen first ([`crate::mattes::SURFACE_NONE`] and so on).
    pub surface: u32,
}

impl Pixel {
    /// A pixel that saw nothing.
    pub const EMPTY: Pixel = Pixel {
        color: [0.0; 3],
        alpha: 0.0,
        depth: f32::INFINITY,
        normal: [0.0; 3],
        fragment: 0,
        element: NONE,
        surface: SURFACE_NONE,
    };
}

/// A rendered image: its pixels (row-major, top row first) and their matte counts.
#[derive(Debug, Clone, PartialEq)]
pub struct Rendered {
    /// The pixels.
    pub pixels: Vec<Pixel>,
    /// Each pixel's matte counts over its samples.
    pub mattes: Vec<MatteCounts>,
}

/// Pending glass branches per sample (the shader's `SPLIT_STACK`).
pub const SPLIT_STACK: usize = 4;
/// Random event numbers of a sample's branches are `event + branch * BRANCH_EVENTS`.
const BRANCH_EVENTS: u32 = 128;

/// A path (or branch of one) still to follow.
#[derive(Debug, Clone, Copy)]
struct Branch {
    origin: [f32; 3],
    direction: [f32; 3],
    throughput: [f32; 3],
    /// The glass element it is inside, or [`NONE`].
    inside: u32,
    /// Interface and surface events so far.
    event: u32,
}

/// A 32-bit integer hash (the PCG output permutation): WGSL has no 64-bit integers, so the
/// tracer's randomness is 32-bit on both sides.
pub fn hash32(x: u32) -> u32 {
    let state = x.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// A deterministic uniform number in [0, 1) for (pixel, sample, event).
pub fn random(pixel: u32, sample: u32, event: u32) -> f32 {
    let bits = hash32(pixel ^ hash32(sample.wrapping_mul(0x9e37_79b9) ^ hash32(event)));
    (bits >> 8) as f32 / (1u32 << 24) as f32
}

fn reflect(d: [f32; 3], n: [f32; 3]) -> [f32; 3] {
    let k = 2.0 * dot(d, n);
    [d[0] - k * n[0], d[1] - k * n[1], d[2] - k * n[2]]
}

/// Refraction of unit `d` at unit normal `n` facing against it, index ratio `eta` = n1 / n2;
/// None on total internal reflection.
fn refract(d: [f32; 3], n: [f32; 3], eta: f32) -> Option<[f32; 3]> {
    let cos_i = -dot(d, n);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if sin2_t > 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let k = eta * cos_i - cos_t;
    Some([eta * d[0] + k * n[0], eta * d[1] + k * n[1], eta * d[2] + k * n[2]])
}

/// Schlick's Fresnel reflectance for cosine `cos_i` between media of index ratio n1 / n2 = `eta`.
fn fresnel(cos_i: f32, eta: f32) -> f32 {
    let r0 = ((1.0 - eta) / (1.0 + eta)).powi(2);
    r0 + (1.0 - r0) * (1.0 - cos_i.clamp(0.0, 1.0)).powi(5)
}

fn floor_t(look: &Look, origin: [f32; 3], direction: [f32; 3]) -> f32 {
    match &look.floor {
        Some(floor) if direction[1] < 0.0 && origin[1] > floor.height => (floor.height - origin[1]) / direction[1],
        _ => f32::INFINITY,
    }
}

/// Albedo of the floor at `p`.
fn floor_albedo(look: &Look, p: [f32; 3]) -> [f32; 3] {
    look.floor.as_ref().map_or([0.5; 3], |f| f.albedo(p))
}

/// Radiance of the floor, of albedo `albedo` where it is seen, along `d`.
fn floor_radiance(look: &Look, albedo: [f32; 3], d: [f32; 3]) -> [f32; 3] {
    shade_opaque(look, albedo, [0.0, 1.0, 0.0], d, 0.0)
}

/// The floor's albedo where each camera ray of a packet meets it, for those that meet it before
/// their nearest hit (`hits`); the others' are left as they are. Looked up in one pass, the
/// texel loads of a packet overlap, where each ray's trace would otherwise wait on its own.
fn first_floor_albedos(look: &Look, origin: [f32; 3], directions: &[[f32; 3]], hits: &[Hit], out: &mut [[f32; 3]]) {
    for ((d, hit), albedo) in directions.iter().zip(hits).zip(out) {
        let t_floor = floor_t(look, origin, *d);
        if t_floor < hit.t {
            *albedo = floor_albedo(look, along(origin, *d, t_floor));
        }
    }
}

/// Diffuse irradiance from the SH plus a normalized Blinn-Phong highlight of the key light.
fn shade_opaque(look: &Look, albedo: [f32; 3], normal: [f32; 3], view: [f32; 3], specular: f32) -> [f32; 3] {
    let irradiance = sh_irradiance(&look.sh, normal);
    let l = look.key.direction;
    // A matte surface (specular +0, as the floor) has no highlight: +0 (a positive shininess
    // keeps the power finite, so the product would be +0 too).
    let highlight = if specular.to_bits() != 0 && dot(normal, l) > 0.0 {
        let v = [l[0] - view[0], l[1] - view[1], l[2] - view[2]];
        let length = dot(v, v).sqrt().max(1e-12);
        let h = v.map(|c| c / length);
        specular * (look.shininess + 8.0) / (8.0 * std::f32::consts::PI) * dot(normal, h).max(0.0).powf(look.shininess)
    } else {
        0.0
    };
    [0, 1, 2].map(|c| albedo[c] / std::f32::consts::PI * irradiance[c] + highlight * look.key.irradiance[c])
}

/// Splits a glass interface event into the branch `path` goes on with (weight 1 - `reflectance`)
/// and `reflected`, pushed on `stack` with weight `reflectance`, when `path` is early enough and
/// the stack has room (true); else leaves both alone (false).
fn split(
    look: &Look,
    path: &mut Branch,
    reflected: Branch,
    reflectance: f32,
    stack: &mut [Branch; SPLIT_STACK],
    pending: &mut usize,
) -> bool {
    if path.event > look.glass_split_events || *pending == SPLIT_STACK {
        return false;
    }
    stack[*pending] = Branch { throughput: reflected.throughput.map(|v| v * reflectance), ..reflected };
    *pending += 1;
    path.throughput = path.throughput.map(|v| v * (1.0 - reflectance));
    true
}

/// Radiance along one camera ray, and its first-surface layers, given its nearest hit
/// (`first_hit`, as [`closest_hit`] finds it from t = 0; [`render`] finds them in packets) and,
/// where the ray meets the floor first, the floor's albedo there (`first_floor_albedo`, as
/// [`first_floor_albedos`] finds it). The shader's `trace_ray` finds both itself.
#[allow(clippy::too_many_arguments)]
fn trace_ray(
    scene: &SceneGeometry,
    look: &Look,
    origin: [f32; 3],
    direction: [f32; 3],
    pixel: u32,
    sample: u32,
    first_hit: Hit,
    first_floor_albedo: [f32; 3],
) -> Pixel {
    let mut result = Pixel::EMPTY;
    let eps = 4.0 * scene.slack;
    let glass = scene.element_type == ElementType::Cube && !look.opaque_cubes;
    let mut stack = [Branch { origin, direction, throughput: [0.0; 3], inside: NONE, event: 0 }; SPLIT_STACK];
    let mut pending = 0usize;
    let mut path = Branch { origin, direction, throughput: [1.0; 3], inside: NONE, event: 0 };
    let mut branch = 0u32;
    loop {
        let mut ended = false;
        while path.event < look.max_bounces {
            let event = path.event;
            let first = branch == 0 && event == 0;
            let chance = random(pixel, sample, event + branch * BRANCH_EVENTS);
            path.event += 1;
            let (o, d) = (path.origin, path.direction);
            if path.inside != NONE {
                // Through the glass to where the union ends; reflect inside or refract out.
                let (t, m, last) = union_exit(scene, path.inside, o, d);
                let exit = along(o, d, t);
                for c in 0..3 {
                    path.throughput[c] *= (-look.absorption[c] * t).exp();
                }
                let reflected = Branch { origin: along(exit, m, -eps), direction: reflect(d, m), inside: last, ..path };
                match refract(d, m.map(|v| -v), look.ior) {
                    Some(refracted) => {
                        let reflectance = fresnel(dot(d, m), look.ior);
                        if split(look, &mut path, reflected, reflectance, &mut stack, &mut pending)
                            || chance >= reflectance
                        {
                            path = Branch { origin: along(exit, m, eps), direction: refracted, inside: NONE, ..path };
                        } else {
                            path = reflected;
                        }
                    }
                    None => path = reflected,
                }
                continue;
            }
            let hit = if first { first_hit } else { closest_hit(scene, o, d, 0.0) };
            let t_floor = floor_t(look, o, d);
            if t_floor < hit.t {
                let p = along(o, d, t_floor);
                if first {
                    result =
                        Pixel { alpha: 1.0, depth: t_floor, normal: [0.0, 1.0, 0.0], surface: SURFACE_FLOOR, ..result };
                }
                let albedo = if first { first_floor_albedo } else { floor_albedo(look, p) };
                let shade = floor_radiance(look, albedo, d);
                for c in 0..3 {
                    result.color[c] += path.throughput[c] * shade[c];
                }
                ended = true;
                break;
            }
            if hit.element == NONE {
                if !first || look.show_environment {
                    let sky = look.environment.radiance(d);
                    for c in 0..3 {
                        result.color[c] += path.throughput[c] * sky[c];
                    }
                }
                ended = true;
                break;
            }
            if first {
                result.alpha = 1.0;
                result.depth = hit.t;
                result.normal = hit.normal;
                result.element = hit.element;
                result.fragment = scene.fragment[hit.element as usize] + 1;
                result.surface = if hit.fracture { SURFACE_FRACTURE } else { SURFACE_OUTER };
            }
            let p = along(o, d, hit.t);
            if !glass {
                let albedo = if hit.fracture { look.fracture_albedo } else { look.albedo };
                let shade = shade_opaque(look, albedo, hit.normal, d, look.specular);
                for c in 0..3 {
                    result.color[c] += path.throughput[c] * shade[c];
                }
                ended = true;
                break;
            }
            // Glass: reflect, or refract into the union.
            let reflectance = fresnel(-dot(d, hit.normal), 1.0 / look.ior);
            let reflected =
                Branch { origin: along(p, hit.normal, eps), direction: reflect(d, hit.normal), inside: NONE, ..path };
            if let Some(refracted) = refract(d, hit.normal, 1.0 / look.ior) {
                if split(look, &mut path, reflected, reflectance, &mut stack, &mut pending) || chance >= reflectance {
                    path = Branch {
                        origin: along(p, hit.normal, -eps),
                        direction: refracted,
                        inside: hit.element,
                        ..path
                    };
                } else {
                    path = reflected;
                }
            } else if chance < reflectance {
                path = reflected;
            }
        }
        if !ended {
            // Out of bounces: the path escapes the glass along its last direction, to the floor
            // or the environment, rather than going black.
            let t_floor = floor_t(look, path.origin, path.direction);
            let escape = if t_floor.is_finite() {
                floor_radiance(look, floor_albedo(look, along(path.origin, path.direction, t_floor)), path.direction)
            } else {
                look.environment.radiance(path.direction)
            };
            for c in 0..3 {
                result.color[c] += path.throughput[c] * escape[c];
            }
        }
        if pending == 0 {
            return result;
        }
        pending -= 1;
        path = stack[pending];
        branch += 1;
    }
}

/// Where sample `sample` of `samples` goes in pixel `pixel`, as an offset from its corner in
/// [0, 1)^2: sample 0 through the centre; the others stratified, one in each cell of the largest
/// square grid they fill (jittered in it), any left over anywhere at random.
pub fn sample_offset(pixel: u32, sample: u32, samples: u32) -> (f32, f32) {
    if sample == 0 {
        return (0.5, 0.5);
    }
    let (jx, jy) = (random(pixel, sample, 1000), random(pixel, sample, 1001));
    let others = samples - 1;
    let mut n = (others as f32).sqrt() as u32;
    while (n + 1) * (n + 1) <= others {
        n += 1;
    }
    while n * n > others {
        n -= 1;
    }
    let k = sample - 1;
    if k >= n * n {
        return (jx, jy);
    }
    (((k % n) as f32 + jx) / n as f32, ((k / n) as f32 + jy) / n as f32)
}

/// Traces every pixel of `camera`'s image with `samples` samples each (the first through the
/// pixel centre gives the depth, normal and fragment layers), counting each sample's first
/// surface in the pixel's mattes. Bands of [`TILE_ROWS`] rows in parallel; each sample's camera
/// rays of a tile find their first surfaces as one packet. Deterministic: each
/// pixel's samples are summed in order, whatever the bands and threads.
pub fn render(scene: &SceneGeometry, look: &Look, camera: &Camera, samples: u32) -> Rendered {
    let (width, height) = (camera.width as usize, camera.height as usize);
    let mut pixels = vec![Pixel::EMPTY; width * height];
    let mut mattes = vec![MatteCounts::default(); width * height];
    let band = width * TILE_ROWS;
    pixels.par_chunks_mut(band).zip(mattes.par_chunks_mut(band)).enumerate().for_each(|(b, (rows, matte_rows))| {
        let top = b * TILE_ROWS;
        let mut sums = [[0.0f32; 3]; PACKET];
        let mut alphas = [0.0f32; PACKET];
        let mut directions = [[0.0f32; 3]; PACKET];
        let mut hits = [Hit::MISS; PACKET];
        let mut floor_albedos = [[0.0f32; 3]; PACKET];
        for tile in Tile::across(width, top, rows.len() / width) {
            let count = tile.len();
            sums[..count].fill([0.0; 3]);
            alphas[..count].fill(0.0);
            for sample in 0..samples {
                tile.first_hits(scene, camera, (sample, samples), &mut directions, &mut hits);
                first_floor_albedos(look, camera.origin, &directions[..count], &hits[..count], &mut floor_albedos);
                for k in 0..count {
                    let (x, y) = tile.pixel(k);
                    let pixel = (y * width + x) as u32;
                    let (direction, hit, floor) = (directions[k], hits[k], floor_albedos[k]);
                    let traced = trace_ray(scene, look, camera.origin, direction, pixel, sample, hit, floor);
                    let local = (y - top) * width + x;
                    if sample == 0 {
                        rows[local] = traced;
                    }
                    matte_rows[local].add(traced.fragment, traced.surface);
                    for c in 0..3 {
                        sums[k][c] += traced.color[c];
                    }
                    alphas[k] += traced.alpha;
                }
            }
            for k in 0..count {
                let (x, y) = tile.pixel(k);
                let out = &mut rows[(y - top) * width + x];
                out.color = sums[k].map(|v| v / samples as f32);
                out.alpha = alphas[k] / samples as f32;
            }
        }
    });
    Rendered { pixels, mattes }
}

/// A tile of image pixels: `width` columns from `left`, `height` rows from `top`; its rays are
/// numbered row by row.
#[derive(Clone, Copy)]
struct Tile {
    left: usize,
    top: usize,
    width: usize,
    height: usize,
}

impl Tile {
    /// The tiles of the band of `height` rows from `top` across an image `image_width` wide.
    fn across(image_width: usize, top: usize, height: usize) -> impl Iterator<Item = Tile> {
        (0..image_width).step_by(PACKET / TILE_ROWS).map(move |left| Tile {
            left,
            top,
            width: (PACKET / TILE_ROWS).min(image_width - left),
            height,
        })
    }

    /// Number of rays.
    fn len(&self) -> usize {
        self.width * self.height
    }

    /// Image column and row of ray `k`.
    fn pixel(&self, k: usize) -> (usize, usize) {
        (self.left + k % self.width, self.top + k / self.width)
    }

    /// Sample `sample` (of `samples`) of the tile's camera rays, into `directions`, and each
    /// one's nearest hit, into `hits`, as one packet.
    fn first_hits(
        &self,
        scene: &SceneGeometry,
        camera: &Camera,
        (sample, samples): (u32, u32),
        directions: &mut [[f32; 3]; PACKET],
        hits: &mut [Hit; PACKET],
    ) {
        let count = self.len();
        for (k, direction) in directions[..count].iter_mut().enumerate() {
            let (x, y) = self.pixel(k);
            let (jx, jy) = sample_offset((y * camera.width as usize + x) as u32, sample, samples);
            *direction = camera.direction(x as f32 + jx, y as f32 + jy);
        }
        closest_hits(scene, camera.origin, &directions[..count], &mut hits[..count]);
    }
}

/// Rows of the tiles whose camera rays [`render`] and [`pixel_hits`] trace as one packet
/// ([`PACKET`] / `TILE_ROWS` columns each).
pub const TILE_ROWS: usize = 2;

/// The nearest element surface along each pixel's centre ray (row-major, top row first), each
/// exactly what [`closest_hit`] gives it, traced in packets as [`render`] traces first surfaces:
/// what a ray-casting query answers, without shading.
pub fn pixel_hits(scene: &SceneGeometry, camera: &Camera) -> Vec<Hit> {
    let width = camera.width as usize;
    let mut hits = vec![Hit::MISS; width * camera.height as usize];
    hits.par_chunks_mut(width * TILE_ROWS).enumerate().for_each(|(b, rows)| {
        let (top, mut directions, mut tile_hits) = (b * TILE_ROWS, [[0.0f32; 3]; PACKET], [Hit::MISS; PACKET]);
        for tile in Tile::across(width, top, rows.len() / width) {
            // sample 0 of 1 goes through the pixel's centre
            tile.first_hits(scene, camera, (0, 1), &mut directions, &mut tile_hits);
            for (k, hit) in tile_hits[..tile.len()].iter().enumerate() {
                let (x, y) = tile.pixel(k);
                rows[(y - top) * width + x] = *hit;
            }
        }
    });
    hits
}

#[cfg(test)]
mod tests {
    use glam::DVec3;
    use shatter_core::particles::{Bonds, Elements, ParticleMeta, ParticleSet};

    use super::*;
    use crate::lighting::{EnvironmentMap, key_light, sh_project};

    #[test]
    fn an_srgb8_floor_texel_decodes_to_the_standards_linear_value() {
        let texels = FloorTexels::srgb8((0..=255u8).map(|v| [v, 255 - v, v / 2]).collect());
        assert_eq!(texels.len(), 256);
        for v in 0..=255u8 {
            let reference = |v: u8| {
                let c = f64::from(v) / 255.0;
                if c <= 0.040_45 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
            };
            let got = texels.linear_at(usize::from(v));
            for (channel, byte) in [v, 255 - v, v / 2].into_iter().enumerate() {
                let want = reference(byte);
                assert!((f64::from(got[channel]) - want).abs() <= 1e-6 * want.max(1e-3), "{byte}: {got:?} vs {want}");
            }
        }
        assert_eq!(texels.linear_at(0)[0], 0.0);
        assert_eq!(texels.linear_at(255)[0], 1.0);
        // the floor looks the texel up where the point falls in its tile
        let floor = FloorLook { height: 0.0, tile: 1.0, size: [16, 16], texels };
        assert_eq!(floor.albedo([0.5 / 16.0, 0.0, 1.5 / 16.0]), floor.texels.linear_at(16));
        assert_eq!(floor.albedo([-0.5 / 16.0, 0.0, 0.0]), floor.texels.linear_at(15));
    }

    fn set(positions: Vec<[f32; 3]>, elements: Elements) -> ParticleSet {
        let n = positions.len();
        ParticleSet {
            meta: ParticleMeta {
                scene_name: "t".into(),
                source: "box".into(),
                sampler: "grid".into(),
                lambda_m: 1.0,
                horizon_factor: 1.0,
                delta_m: 1.0,
                density_kg_m3: 1.0,
                bulk_modulus_pa: 1.0,
                mean_critical_stretch: 0.01,
                threshold_jitter: 0.0,
                seed: 0,
            },
            rest_position_m: positions,
            volume_m3: vec![1.0; n],
            mass_kg: vec![1.0; n],
            elements,
            bonds: Bonds { offsets: vec![0; n + 1], ..Bonds::default() },
            adjacency: Vec::new(),
        }
    }

    fn cubes(centres: Vec<[f32; 3]>) -> SceneGeometry {
        let n = centres.len();
        let elements = Elements::Cubes { half_size_m: vec![0.5; n], orientation: [0.0, 0.0, 0.0, 1.0] };
        SceneGeometry::build(&set(centres, elements), None)
    }

    fn look() -> Look {
        let environment = EnvironmentMap::constant([0.5; 3]);
        Look {
            sh: sh_project(&environment),
            key: key_light(&environment),
            environment,
            show_environment: true,
            ior: 1.5,
            absorption: [0.0; 3],
            albedo: [0.8; 3],
            fracture_albedo: [0.8; 3],
            specular: 0.0,
            shininess: 32.0,
            floor: None,
            max_bounces: 8,
            glass_split_events: 2,
            opaque_cubes: false,
        }
    }

    /// Entry distance and normal of a ray into an axis-aligned box, in f64; None if it misses
    /// the box shrunk by `margin` (a sure hit needs that), Some(None) if it hits the box grown by
    /// `margin` only (ambiguous: skip).
    fn analytic_box(lo: DVec3, hi: DVec3, o: DVec3, d: DVec3, margin: f64) -> Option<Option<(f64, DVec3)>> {
        let slab = |lo: DVec3, hi: DVec3| {
            let (mut near, mut far, mut normal) = (f64::NEG_INFINITY, f64::INFINITY, DVec3::ZERO);
            for a in 0..3 {
                let (t0, t1) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
                let (enter, leave, sign) = if t0 < t1 { (t0, t1, -1.0) } else { (t1, t0, 1.0) };
                if enter > near {
                    near = enter;
                    normal = DVec3::ZERO;
                    normal[a] = sign;
                }
                far = far.min(leave);
            }
            (near <= far && near > 0.0).then_some((near, normal))
        };
        match (slab(lo + margin, hi - margin), slab(lo - margin, hi + margin)) {
            (Some(_), _) => Some(slab(lo, hi)),
            (None, Some(_)) => Some(None),
            (None, None) => None,
        }
    }

    #[test]
    fn a_single_cube_has_analytic_depth_and_normals() {
        let scene = cubes(vec![[0.0; 3]]);
        let camera = Camera::look_at(DVec3::new(1.3, 1.7, 4.0), DVec3::ZERO, DVec3::Y, 30.0, 64, 48);
        let image = render(&scene, &look(), &camera, 1).pixels;
        let mut checked = 0;
        for y in 0..48 {
            for x in 0..64 {
                let pixel = image[y * 64 + x];
                let d = DVec3::from_array(camera.direction(x as f32 + 0.5, y as f32 + 0.5).map(f64::from));
                let o = DVec3::from_array(camera.origin.map(f64::from));
                match analytic_box(DVec3::splat(-0.5), DVec3::splat(0.5), o, d, 1e-4) {
                    Some(Some((t, n))) => {
                        assert!((f64::from(pixel.depth) - t).abs() < 1e-4, "({x}, {y}): depth {} vs {t}", pixel.depth);
                        for a in 0..3 {
                            assert!((f64::from(pixel.normal[a]) - n[a]).abs() < 1e-4, "({x}, {y}) normal");
                        }
                        assert_eq!(pixel.fragment, 1);
                        checked += 1;
                    }
                    None => assert_eq!(pixel.element, NONE, "({x}, {y}) should miss"),
                    Some(None) => {}
                }
            }
        }
        assert!(checked > 300, "{checked} pixels on the cube");
    }

    /// Camera rays traced in packets find exactly what each finds alone: on a grid of touching
    /// cubes (rays along the seams meet exact ties), on scattered tetrahedra, and from an eye on
    /// the tree's first split plane (where packets whose rays cross it both ways go alone).
    #[test]
    fn packets_of_camera_rays_find_what_single_rays_find() {
        let grid: Vec<[f32; 3]> =
            (0..6 * 6 * 3).map(|k| [(k % 6) as f32, ((k / 6) % 6) as f32, (k / 36) as f32]).collect();
        let mut rng = shatter_core::random::SplitMix64::new(4);
        let mut r = move || rng.next_f64() as f32;
        let tets: Vec<[[f32; 3]; 4]> = (0..200)
            .map(|_| {
                let c = [r() * 4.0, r() * 4.0, r() * 4.0];
                [0, 1, 2, 3].map(|k| {
                    let corner = [[0.0, 0.0, 0.0], [0.6, 0.0, 0.0], [0.0, 0.6, 0.0], [0.0, 0.0, 0.6]][k];
                    [c[0] + corner[0], c[1] + corner[1], c[2] + corner[2]]
                })
            })
            .collect();
        let tet_set = set(tets.iter().map(|t| t[0]).collect(), Elements::Tets { vertices_m: tets.clone() });
        let scenes = [cubes(grid), SceneGeometry::build(&tet_set, None)];
        for (s, scene) in scenes.iter().enumerate() {
            let [a, b] = crate::element_kdtree::KdTree::build(&scene.element_bounds).nodes[0];
            let (axis, split) = ((a & 3) as usize, f32::from_bits(b));
            let mut on_split = DVec3::new(2.5, 2.5, 9.0);
            on_split[axis] = f64::from(split);
            let mut looking = DVec3::new(2.5, 2.5, 1.0);
            looking[axis] = f64::from(split);
            for (eye, target) in [
                (DVec3::new(2.5, 2.5, 9.0), DVec3::new(2.5, 2.5, 1.0)),
                (DVec3::new(-3.0, 8.0, 7.0), DVec3::new(2.0, 2.0, 1.0)),
                (on_split, looking),
            ] {
                let camera = Camera::look_at(eye, target, DVec3::Y, 50.0, 61, 47);
                let hits = pixel_hits(scene, &camera);
                let mut seen = 0;
                for y in 0..47 {
                    for x in 0..61 {
                        let d = camera.direction(x as f32 + 0.5, y as f32 + 0.5);
                        let alone = closest_hit(scene, camera.origin, d, 0.0);
                        assert_eq!(hits[y * 61 + x], alone, "scene {s}, eye {eye}, pixel ({x}, {y})");
                        seen += usize::from(alone.element != NONE);
                    }
                }
                assert!(seen > 100, "scene {s}, eye {eye}: {seen} pixels see an element");
            }
        }
    }

    #[test]
    fn a_single_tet_has_analytic_depth_and_normals() {
        let vertices = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let set = set(vec![[0.25; 3]], Elements::Tets { vertices_m: vec![vertices] });
        let scene = SceneGeometry::build(&set, None);
        let camera = Camera::look_at(DVec3::new(2.0, 1.5, 3.0), DVec3::splat(0.25), DVec3::Y, 30.0, 64, 48);
        let image = render(&scene, &look(), &camera, 1).pixels;
        let v = vertices.map(|p| DVec3::from_array(p.map(f64::from)));
        let faces = [[v[1], v[2], v[3]], [v[0], v[2], v[3]], [v[0], v[1], v[3]], [v[0], v[1], v[2]]];
        let mut checked = 0;
        for y in 0..48 {
            for x in 0..64 {
                let pixel = image[y * 64 + x];
                let d = DVec3::from_array(camera.direction(x as f32 + 0.5, y as f32 + 0.5).map(f64::from));
                let o = DVec3::from_array(camera.origin.map(f64::from));
                // nearest face by Moller-Trumbore in f64, keeping how far inside the triangle it is
                let mut best: Option<(f64, DVec3, f64)> = None;
                for face in &faces {
                    let (e1, e2) = (face[1] - face[0], face[2] - face[0]);
                    let p = d.cross(e2);
                    let det = e1.dot(p);
                    let s = o - face[0];
                    let (u, w) = (s.dot(p) / det, d.dot(s.cross(e1)) / det);
                    let t = e2.dot(s.cross(e1)) / det;
                    let inset = u.min(w).min(1.0 - u - w);
                    if inset >= -1e-4 && t > 0.0 && best.is_none_or(|(b, _, _)| t < b) {
                        let mut n = e1.cross(e2).normalize();
                        if n.dot(face[0] - DVec3::splat(0.25)) < 0.0 {
                            n = -n;
                        }
                        best = Some((t, n, inset));
                    }
                }
                match best {
                    Some((t, n, inset)) if inset > 1e-4 => {
                        assert!((f64::from(pixel.depth) - t).abs() < 1e-4, "({x}, {y}) depth");
                        assert!(
                            (DVec3::from_array(pixel.normal.map(f64::from)) - n).length() < 1e-4,
                            "({x}, {y}) normal"
                        );
                        checked += 1;
                    }
                    Some(_) => {}
                    None => assert_eq!(pixel.element, NONE, "({x}, {y}) should miss"),
                }
            }
        }
        assert!(checked > 100, "{checked} pixels on the tet");
    }

    #[test]
    fn touching_cubes_show_no_seam_and_no_inner_face() {
        let scene = cubes(vec![[0.0; 3], [1.0, 0.0, 0.0]]);
        // Looking straight at the shared face's edge: every pixel inside the union must hit it.
        let camera = Camera::look_at(DVec3::new(0.5, 0.0, 4.0), DVec3::new(0.5, 0.0, 0.0), DVec3::Y, 40.0, 81, 61);
        let image = render(&scene, &look(), &camera, 1).pixels;
        let o = DVec3::from_array(camera.origin.map(f64::from));
        for y in 0..61 {
            for x in 0..81 {
                let d = DVec3::from_array(camera.direction(x as f32 + 0.5, y as f32 + 0.5).map(f64::from));
                if let Some(Some((t, _))) =
                    analytic_box(DVec3::new(-0.5, -0.5, -0.5), DVec3::new(1.5, 0.5, 0.5), o, d, 1e-4)
                {
                    let pixel = image[y * 81 + x];
                    assert_ne!(pixel.element, NONE, "crack pixel at ({x}, {y})");
                    assert!((f64::from(pixel.depth) - t).abs() < 1e-4, "({x}, {y}): depth {} vs {t}", pixel.depth);
                }
            }
        }
        // Inside the glass a ray walks on to the far side of the union, not to the inner face.
        let (t, normal, last) = union_exit(&scene, 0, [-0.4, 0.1, 0.0], [1.0, 0.0, 0.0]);
        assert!((t - 1.9).abs() < 1e-4, "exit at x = 1.5, not 0.5: t = {t}");
        assert_eq!(normal, [1.0, 0.0, 0.0]);
        assert_eq!(last, 1);
    }

    #[test]
    fn a_walk_out_through_a_face_two_cubes_share_near_their_edge_ends_there() {
        // A above B, touching: their -x faces lie in one plane. A ray inside A leaves through
        // that plane just above the shared edge, heading down and nearly along the face, so the
        // probe point past A's face lies inside both widened rims, and B's span ends where A's
        // does: the walk must leave there, not pass between A and B until its guard runs out.
        let scene = cubes(vec![[0.0; 3], [0.0, -1.0, 0.0]]);
        let slack = scene.slack;
        let direction = DVec3::new(-0.135, -0.29, -0.95).normalize().as_vec3().to_array();
        let edge = [-0.5, -0.5 + 0.3 * slack, 0.0];
        let s = 0.3;
        let origin = along(edge, direction, -s);
        let (t, normal, last) = union_exit(&scene, 0, origin, direction);
        assert_eq!(normal, [-1.0, 0.0, 0.0], "leaves through the shared -x plane (ended in element {last})");
        assert!((t - s).abs() < 1e-5, "at the face, t = {t} against {s}");
    }

    #[test]
    fn the_walk_across_face_neighbours_leaves_where_the_tree_walk_does() {
        // a 4 x 4 x 4 block of touching unit cubes with its face adjacency
        let index = |x: usize, y: usize, z: usize| (x * 16 + y * 4 + z) as u32;
        let (mut centres, mut adjacency) = (Vec::new(), Vec::new());
        for x in 0..4 {
            for y in 0..4 {
                for z in 0..4 {
                    centres.push([x as f32, y as f32, z as f32]);
                    for (inside, next) in [(x < 3, (x + 1, y, z)), (y < 3, (x, y + 1, z)), (z < 3, (x, y, z + 1))] {
                        if inside {
                            adjacency.push([index(x, y, z), index(next.0, next.1, next.2)]);
                        }
                    }
                }
            }
        }
        let elements = Elements::Cubes { half_size_m: vec![0.5; 64], orientation: [0.0, 0.0, 0.0, 1.0] };
        let particles = ParticleSet { adjacency, ..set(centres, elements) };
        let scene = SceneGeometry::build(&particles, None);
        assert_eq!(scene.face_neighbours.len(), 6 * 64);
        assert_eq!(scene.face_neighbours.iter().filter(|&&n| n != NONE).count(), 2 * 3 * 48);
        let mut tree_only = SceneGeometry::build(&particles, None);
        tree_only.face_neighbours.fill(NONE);
        for k in 0..200u32 {
            let origin = [0, 1, 2].map(|a| random(k, 0, a) * 3.0);
            let direction = {
                let v = DVec3::new(
                    f64::from(random(k, 1, 0)) - 0.5,
                    f64::from(random(k, 1, 1)) - 0.5,
                    f64::from(random(k, 1, 2)) - 0.5,
                )
                .normalize();
                v.as_vec3().to_array()
            };
            let start = element_at(&scene, origin, NONE);
            let (t, normal, _) = union_exit(&scene, start, origin, direction);
            let (t_tree, normal_tree, _) = union_exit(&tree_only, start, origin, direction);
            assert!((t - t_tree).abs() < 1e-5, "ray {k}: {t} vs {t_tree}");
            assert_eq!(normal, normal_tree, "ray {k}");
            // and it is where the ray leaves the block [-0.5, 3.5]^3
            let t_far = (0..3)
                .map(|a| {
                    ((-0.5 - f64::from(origin[a])) / f64::from(direction[a]))
                        .max((3.5 - f64::from(origin[a])) / f64::from(direction[a]))
                })
                .fold(f64::INFINITY, f64::min);
            assert!((f64::from(t) - t_far).abs() < 1e-4, "ray {k}: {t} vs {t_far}");
        }
        // a neighbour that has moved away is no shortcut: the walk ends at the face it left by
        let mut apart = cubes(vec![[0.0; 3], [5.0, 0.0, 0.0]]);
        apart.face_neighbours[0] = 1;
        let (t, normal, last) = union_exit(&apart, 0, [0.0; 3], [1.0, 0.0, 0.0]);
        assert_eq!((t, normal, last), (0.5, [1.0, 0.0, 0.0], 0));
    }

    #[test]
    fn a_ray_through_a_glass_slab_of_touching_cubes_leaves_parallel() {
        let mut centres = Vec::new();
        for x in 0..5 {
            for z in 0..5 {
                centres.push([x as f32 - 2.0, 0.0, z as f32 - 2.0]);
            }
        }
        let scene = cubes(centres);
        let look = look();
        let d = {
            let v = DVec3::new(0.3, -1.0, 0.2).normalize();
            v.as_vec3().to_array()
        };
        let o = [-0.7, 2.0, -0.4];
        let entry = closest_hit(&scene, o, d, 0.0);
        assert_eq!(entry.normal, [0.0, 1.0, 0.0], "enters through the top");
        let inside_d = refract(d, entry.normal, 1.0 / look.ior).expect("refracts in");
        let p = along(o, d, entry.t);
        let (t, m, _) = union_exit(&scene, entry.element, along(p, entry.normal, -1e-4), inside_d);
        assert_eq!(m, [0.0, -1.0, 0.0], "leaves through the bottom face of the slab");
        assert!(t > 1.0, "crosses the slab's full thickness: {t}");
        let out = refract(inside_d, m.map(|v| -v), look.ior).expect("refracts out");
        for a in 0..3 {
            assert!((out[a] - d[a]).abs() < 1e-5, "leaves parallel: {out:?} vs {d:?}");
        }
    }
}
