//! The path integrator: radiance along one camera ray through glass unions (reflection and
//! refraction weighted by Fresnel, the first few interface events followed both ways, later ones
//! chosen at random), opaque elements, the floor and the environment; and the ray's first-surface
//! layers. The twin of `shaders/integrator.wgsl`.
//!
//! Union semantics: a ray from outside first meets the union of elements at the nearest entry
//! of any element, so inner faces are never seen. Inside glass, the ray walks from element to
//! element that holds the point where it leaves the previous one, and only leaves the glass where
//! no element continues: the last element's face gives the exit normal (refraction out, or
//! internal reflection).

use shatter_core::particles::ElementType;

use crate::hit_search::{Hit, NONE, closest_hit, union_exit};
use crate::materials::Look;
use crate::mattes::{SURFACE_FLOOR, SURFACE_FRACTURE, SURFACE_NONE, SURFACE_OUTER};
use crate::primitives::{along, dot};
use crate::sampling::random;
use crate::scene_geometry::SceneGeometry;
use crate::shading::{floor_albedo, floor_radiance, floor_t, fresnel, reflect, refract, shade_opaque};
use crate::texture_filter::Footprint;

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
    /// The denoisers' albedo guide: the albedo of the first diffuse surface along the path (the
    /// opaque material or the floor; 1 for the environment), times the glass's tint on the way.
    pub denoising_albedo: [f32; 3],
    /// The denoisers' normal guide: the world-space normal of that surface (for the environment,
    /// of the first glass surface on the way, else zero).
    pub denoising_normal: [f32; 3],
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
        denoising_albedo: [0.0; 3],
        denoising_normal: [0.0; 3],
    };
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
    /// How far the path has come from the camera, metres (its cone's width there is this times
    /// the ray's spread).
    travelled: f32,
}

/// One camera ray: where it starts and goes, and which pixel and sample it is (they seed its
/// random choices).
#[derive(Debug, Clone, Copy)]
pub(crate) struct CameraRay {
    /// The eye.
    pub origin: [f32; 3],
    /// Unit direction.
    pub direction: [f32; 3],
    /// Row-major pixel index.
    pub pixel: u32,
    /// Sample number within the pixel.
    pub sample: u32,
    /// Its time, frames from the frame's centre (see [`crate::shutter`]).
    pub time: f32,
    /// Its cone's spread, radians: the pixel's angle (the floor texture's footprint).
    pub spread_rad: f32,
}

/// A camera ray's first surface, as the image loop finds it for a packet of rays: its nearest hit
/// (as [`closest_hit`] finds it from t = 0) and, where the ray meets the floor first, the
/// floor's albedo there. The shader's `trace_ray` finds both itself.
#[derive(Debug, Clone, Copy)]
pub(crate) struct FirstSurface {
    /// The nearest element surface.
    pub hit: Hit,
    /// The floor's albedo where the ray meets it, if it meets the floor before `hit`.
    pub floor_albedo: [f32; 3],
}

/// The layers of a camera ray from `origin` along `direction` whose nearest element surface is
/// `hit`: what it sees first (the floor, an element or nothing), its depth, normal, element,
/// fragment and surface kind, and coverage (alpha); no colour.
pub(crate) fn first_layers(
    scene: &SceneGeometry,
    look: &Look,
    origin: [f32; 3],
    direction: [f32; 3],
    hit: Hit,
) -> Pixel {
    let t_floor = floor_t(look, origin, direction);
    if t_floor < hit.t {
        return Pixel { alpha: 1.0, depth: t_floor, normal: [0.0, 1.0, 0.0], surface: SURFACE_FLOOR, ..Pixel::EMPTY };
    }
    if hit.element == NONE {
        return Pixel::EMPTY;
    }
    Pixel {
        alpha: 1.0,
        depth: hit.t,
        normal: hit.normal,
        fragment: scene.fragment[hit.element as usize] + 1,
        element: hit.element,
        surface: if hit.fracture { SURFACE_FRACTURE } else { SURFACE_OUTER },
        ..Pixel::EMPTY
    }
}

/// Radiance along one camera ray, and its first-surface layers.
pub(crate) fn trace_ray(scene: &SceneGeometry, look: &Look, ray: CameraRay, first: FirstSurface) -> Pixel {
    let (origin, direction) = (ray.origin, ray.direction);
    let mut tracer = PathTracer {
        scene,
        look,
        ray,
        eps: 4.0 * scene.slack,
        glass: scene.element_type == ElementType::Cube && !look.opaque_cubes,
        stack: [Branch { origin, direction, throughput: [0.0; 3], inside: NONE, event: 0, travelled: 0.0 };
            SPLIT_STACK],
        pending: 0,
        result: Pixel::EMPTY,
        guide: Guide::default(),
    };
    let mut path = Branch { origin, direction, throughput: [1.0; 3], inside: NONE, event: 0, travelled: 0.0 };
    let mut branch = 0u32;
    loop {
        tracer.guide.open = branch == 0;
        tracer.follow(&mut path, branch, &first);
        if tracer.pending == 0 {
            return tracer.result;
        }
        tracer.pending -= 1;
        path = tracer.stack[tracer.pending];
        branch += 1;
    }
}

/// One camera ray's trace in progress: its branches still to follow and its pixel so far.
struct PathTracer<'a> {
    scene: &'a SceneGeometry,
    look: &'a Look,
    ray: CameraRay,
    /// How far a new branch starts off the surface it leaves (4 x the tracers' slack).
    eps: f32,
    /// Cubes are glass.
    glass: bool,
    stack: [Branch; SPLIT_STACK],
    pending: usize,
    result: Pixel,
    guide: Guide,
}

/// Where the denoising guides stand: set once, by the first branch's first diffuse surface.
#[derive(Debug, Default, Clone, Copy)]
struct Guide {
    /// The branch being followed is the first, and no diffuse surface has set the guides yet.
    open: bool,
    /// The first glass surface's normal, for a path that ends in the environment.
    glass_normal: Option<[f32; 3]>,
}

impl PathTracer<'_> {
    /// Follows `path` (branch number `branch` of the ray) until it ends at an opaque surface,
    /// the floor or the environment, or runs out of events and escapes along its last direction.
    fn follow(&mut self, path: &mut Branch, branch: u32, first: &FirstSurface) {
        while path.event < self.look.max_bounces {
            let event = path.event;
            let is_first = branch == 0 && event == 0;
            let chance = random(self.ray.pixel, self.ray.sample, event + branch * BRANCH_EVENTS);
            path.event += 1;
            if path.inside != NONE {
                self.leave_glass(path, chance);
            } else if self.meet_surface(path, is_first.then_some(first), chance) {
                return;
            }
        }
        self.escape(path);
    }

    /// Through the glass to where the union ends; reflect inside or refract out.
    fn leave_glass(&mut self, path: &mut Branch, chance: f32) {
        let (o, d) = (path.origin, path.direction);
        let (t, m, last) = union_exit(self.scene, path.inside, o, d, self.ray.time);
        let exit = along(o, d, t);
        for (weight, absorption) in path.throughput.iter_mut().zip(self.look.absorption) {
            *weight *= (-absorption * t).exp();
        }
        path.travelled += t;
        let reflected = Branch { origin: along(exit, m, -self.eps), direction: reflect(d, m), inside: last, ..*path };
        match refract(d, m.map(|v| -v), self.look.ior) {
            Some(refracted) => {
                let reflectance = fresnel(dot(d, m), self.look.ior);
                if self.split(path, reflected, reflectance) || chance >= reflectance {
                    *path = Branch { origin: along(exit, m, self.eps), direction: refracted, inside: NONE, ..*path };
                } else {
                    *path = reflected;
                }
            }
            None => *path = reflected,
        }
    }

    /// The path from outside meets the floor, the environment or an element (`first`: the
    /// camera ray's first surface, for its first event); true when the path ends there.
    fn meet_surface(&mut self, path: &mut Branch, first: Option<&FirstSurface>, chance: f32) -> bool {
        let (o, d) = (path.origin, path.direction);
        let hit = match first {
            Some(surface) => surface.hit,
            None => closest_hit(self.scene, o, d, 0.0, self.ray.time),
        };
        if first.is_some() {
            self.result = Pixel { color: self.result.color, ..first_layers(self.scene, self.look, o, d, hit) };
        }
        let t_floor = floor_t(self.look, o, d);
        if t_floor < hit.t {
            let albedo = match first {
                Some(surface) => surface.floor_albedo,
                None => floor_albedo(self.look, along(o, d, t_floor), self.footprint(path, t_floor)),
            };
            self.set_guides(path.throughput, albedo, [0.0, 1.0, 0.0]);
            self.add(path.throughput, floor_radiance(self.look, albedo, d));
            return true;
        }
        if hit.element == NONE {
            self.set_guides(path.throughput, [1.0; 3], self.guide.glass_normal.unwrap_or([0.0; 3]));
            if first.is_none() || self.look.show_environment {
                self.add(path.throughput, self.look.environment.radiance(d));
            }
            return true;
        }
        let p = along(o, d, hit.t);
        if !self.glass {
            let albedo = if hit.fracture { self.look.fracture_albedo } else { self.look.albedo };
            self.set_guides(path.throughput, albedo, hit.normal);
            self.add(path.throughput, shade_opaque(self.look, albedo, hit.normal, d, self.look.specular));
            return true;
        }
        if self.guide.open && self.guide.glass_normal.is_none() {
            self.guide.glass_normal = Some(hit.normal);
        }
        self.enter_glass(path, hit, p, chance);
        false
    }

    /// Glass met at `p` from outside: reflect, or refract into the union.
    fn enter_glass(&mut self, path: &mut Branch, hit: Hit, p: [f32; 3], chance: f32) {
        let d = path.direction;
        path.travelled += hit.t;
        let reflectance = fresnel(-dot(d, hit.normal), 1.0 / self.look.ior);
        let reflected =
            Branch { origin: along(p, hit.normal, self.eps), direction: reflect(d, hit.normal), inside: NONE, ..*path };
        if let Some(refracted) = refract(d, hit.normal, 1.0 / self.look.ior) {
            if self.split(path, reflected, reflectance) || chance >= reflectance {
                *path = Branch {
                    origin: along(p, hit.normal, -self.eps),
                    direction: refracted,
                    inside: hit.element,
                    ..*path
                };
            } else {
                *path = reflected;
            }
        } else if chance < reflectance {
            *path = reflected;
        }
    }

    /// Out of bounces: the path escapes the glass along its last direction, to the floor or the
    /// environment, rather than going black.
    fn escape(&mut self, path: &Branch) {
        let t_floor = floor_t(self.look, path.origin, path.direction);
        let escape = if t_floor.is_finite() {
            let albedo =
                floor_albedo(self.look, along(path.origin, path.direction, t_floor), self.footprint(path, t_floor));
            self.set_guides(path.throughput, albedo, [0.0, 1.0, 0.0]);
            floor_radiance(self.look, albedo, path.direction)
        } else {
            self.set_guides(path.throughput, [1.0; 3], self.guide.glass_normal.unwrap_or([0.0; 3]));
            self.look.environment.radiance(path.direction)
        };
        self.add(path.throughput, escape);
    }

    /// The footprint of `path`'s ray `t` further on.
    fn footprint(&self, path: &Branch, t: f32) -> Footprint {
        Footprint { direction: path.direction, width_m: self.ray.spread_rad * (path.travelled + t) }
    }

    /// Sets the denoising guides, if still open: `albedo` seen through `throughput`, and `normal`.
    fn set_guides(&mut self, throughput: [f32; 3], albedo: [f32; 3], normal: [f32; 3]) {
        if self.guide.open {
            self.result.denoising_albedo = std::array::from_fn(|k| throughput[k] * albedo[k]);
            self.result.denoising_normal = normal;
            self.guide.open = false;
        }
    }

    /// Adds `radiance` weighted by `throughput` to the pixel's colour.
    fn add(&mut self, throughput: [f32; 3], radiance: [f32; 3]) {
        for ((colour, weight), light) in self.result.color.iter_mut().zip(throughput).zip(radiance) {
            *colour += weight * light;
        }
    }

    /// Splits a glass interface event into the branch `path` goes on with (weight 1 -
    /// `reflectance`) and `reflected`, pushed on the stack with weight `reflectance`, when `path`
    /// is early enough and the stack has room (true); else leaves both alone (false).
    fn split(&mut self, path: &mut Branch, reflected: Branch, reflectance: f32) -> bool {
        if path.event > self.look.glass_split_events || self.pending == SPLIT_STACK {
            return false;
        }
        self.stack[self.pending] = Branch { throughput: reflected.throughput.map(|v| v * reflectance), ..reflected };
        self.pending += 1;
        path.throughput = path.throughput.map(|v| v * (1.0 - reflectance));
        true
    }
}
