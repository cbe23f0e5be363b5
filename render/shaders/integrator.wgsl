// integrator.rs: radiance along one camera ray, and its first-surface layers.

const SPLIT_STACK: u32 = 4u;
const BRANCH_EVENTS: u32 = 128u;

struct Traced {
    color: vec3<f32>,
    alpha: f32,
    depth: f32,
    normal: vec3<f32>,
    fragment: u32,
    element: u32,
    surface: u32,
    // integrator.rs Pixel::denoising_albedo and denoising_normal
    denoising_albedo: vec3<f32>,
    denoising_normal: vec3<f32>,
}

// integrator.rs Pixel::EMPTY
fn empty_traced() -> Traced {
    return Traced(vec3<f32>(0.0), 0.0, infinity(), vec3<f32>(0.0), 0u, NONE, SURFACE_NONE, vec3<f32>(0.0), vec3<f32>(0.0));
}

// integrator.rs Guide: the first branch's guides not yet set, and its first glass normal
var<private> guide_open: bool;
var<private> glass_normal: vec3<f32>;
var<private> has_glass_normal: bool;

// integrator.rs PathTracer::set_guides
fn set_guides(result: ptr<function, Traced>, throughput: vec3<f32>, albedo: vec3<f32>, normal: vec3<f32>) {
    if (guide_open) {
        (*result).denoising_albedo = throughput * albedo;
        (*result).denoising_normal = normal;
        guide_open = false;
    }
}

// the glass normal for a path that ends in the environment
fn environment_guide_normal() -> vec3<f32> {
    return select(vec3<f32>(0.0), glass_normal, has_glass_normal);
}

// integrator.rs Branch
struct Branch {
    origin: vec3<f32>,
    direction: vec3<f32>,
    throughput: vec3<f32>,
    inside: u32,
    event: u32,
    // integrator.rs Branch::travelled
    travelled: f32,
}

var<private> stack: array<Branch, SPLIT_STACK>;
var<private> pending: u32;

// integrator.rs split: pushes `reflected` weighted by `reflectance` and weights `path` by the rest
fn split(path: ptr<function, Branch>, reflected: Branch, reflectance: f32) -> bool {
    if ((*path).event > params.look_flags.x || pending == SPLIT_STACK) {
        return false;
    }
    var pushed = reflected;
    pushed.throughput = reflected.throughput * reflectance;
    stack[pending] = pushed;
    pending += 1u;
    (*path).throughput = (*path).throughput * (1.0 - reflectance);
    return true;
}

// integrator.rs first_layers: what a camera ray whose nearest element surface is `hit` sees first
fn first_layers(origin: vec3<f32>, direction: vec3<f32>, hit: Hit) -> Traced {
    var layers = empty_traced();
    let t_floor = floor_t(origin, direction);
    if (t_floor < hit.t) {
        layers.alpha = 1.0;
        layers.depth = t_floor;
        layers.normal = vec3<f32>(0.0, 1.0, 0.0);
        layers.surface = SURFACE_FLOOR;
        return layers;
    }
    if (hit.element == NONE) {
        return layers;
    }
    layers.alpha = 1.0;
    layers.depth = hit.t;
    layers.normal = hit.normal;
    layers.element = hit.element;
    layers.fragment = fragments[hit.element] + 1u;
    layers.surface = select(SURFACE_OUTER, SURFACE_FRACTURE, hit.fracture);
    return layers;
}

// integrator.rs trace_ray, at `time` (frames from the frame's centre)
fn trace_ray(origin: vec3<f32>, direction: vec3<f32>, pixel: u32, sample: u32, time: f32) -> Traced {
    var result = empty_traced();
    has_glass_normal = false;
    let eps = 4.0 * params.scene_min.w;
    let ior = params.scene_max.w;
    let glass = params.counts.y == 0u && params.look_flags.y == 0u;
    pending = 0u;
    var path = Branch(origin, direction, vec3<f32>(1.0), NONE, 0u, 0.0);
    let spread = params.shutter.y;
    var branch = 0u;
    loop {
        guide_open = branch == 0u;
        var ended = false;
        while (path.event < params.size.w) {
            let event = path.event;
            let first = branch == 0u && event == 0u;
            let chance = random(pixel, sample, event + branch * BRANCH_EVENTS);
            path.event += 1u;
            let o = path.origin;
            let d = path.direction;
            if (path.inside != NONE) {
                let exit = union_exit(path.inside, o, d, time);
                let p = o + exit.t * d;
                path.throughput *= exp(-params.absorption.xyz * exit.t);
                path.travelled += exit.t;
                var reflected = path;
                reflected.origin = p - eps * exit.normal;
                reflected.direction = reflect3(d, exit.normal);
                reflected.inside = exit.element;
                let out = refract3(d, -exit.normal, ior);
                if (out.ok) {
                    let reflectance = fresnel(dot3(d, exit.normal), ior);
                    if (split(&path, reflected, reflectance) || chance >= reflectance) {
                        path.origin = p + eps * exit.normal;
                        path.direction = out.direction;
                        path.inside = NONE;
                    } else {
                        path = reflected;
                    }
                } else {
                    path = reflected;
                }
                continue;
            }
            let hit = closest_hit(o, d, 0.0, time);
            if (first) {
                let color = result.color;
                result = first_layers(o, d, hit);
                result.color = color;
            }
            let t_floor = floor_t(o, d);
            if (t_floor < hit.t) {
                let p = o + t_floor * d;
                let albedo = floor_albedo(p, d, spread * (path.travelled + t_floor));
                set_guides(&result, path.throughput, albedo, vec3<f32>(0.0, 1.0, 0.0));
                result.color += path.throughput * floor_radiance(albedo, d);
                ended = true;
                break;
            }
            if (hit.element == NONE) {
                set_guides(&result, path.throughput, vec3<f32>(1.0), environment_guide_normal());
                if (!first || params.flags.w != 0u) {
                    result.color += path.throughput * environment_radiance(d);
                }
                ended = true;
                break;
            }
            let p = o + hit.t * d;
            if (!glass) {
                let albedo = select(params.albedo.xyz, params.fracture_albedo.xyz, hit.fracture);
                set_guides(&result, path.throughput, albedo, hit.normal);
                result.color += path.throughput * shade_opaque(albedo, hit.normal, d, params.absorption.w);
                ended = true;
                break;
            }
            if (guide_open && !has_glass_normal) {
                glass_normal = hit.normal;
                has_glass_normal = true;
            }
            path.travelled += hit.t;
            let reflectance = fresnel(-dot3(d, hit.normal), 1.0 / ior);
            var reflected = path;
            reflected.origin = p + eps * hit.normal;
            reflected.direction = reflect3(d, hit.normal);
            reflected.inside = NONE;
            let into = refract3(d, hit.normal, 1.0 / ior);
            if (into.ok) {
                if (split(&path, reflected, reflectance) || chance >= reflectance) {
                    path.origin = p - eps * hit.normal;
                    path.direction = into.direction;
                    path.inside = hit.element;
                } else {
                    path = reflected;
                }
            } else if (chance < reflectance) {
                path = reflected;
            }
        }
        if (!ended) {
            // out of bounces: escape along the last direction to the floor or the environment
            let t_floor = floor_t(path.origin, path.direction);
            if (t_floor < infinity()) {
                let p = path.origin + t_floor * path.direction;
                let albedo = floor_albedo(p, path.direction, spread * (path.travelled + t_floor));
                set_guides(&result, path.throughput, albedo, vec3<f32>(0.0, 1.0, 0.0));
                result.color += path.throughput * floor_radiance(albedo, path.direction);
            } else {
                set_guides(&result, path.throughput, vec3<f32>(1.0), environment_guide_normal());
                result.color += path.throughput * environment_radiance(path.direction);
            }
        }
        if (pending == 0u) {
            return result;
        }
        pending -= 1u;
        path = stack[pending];
        branch += 1u;
    }
    return result;
}
