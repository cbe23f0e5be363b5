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
}

// integrator.rs Branch
struct Branch {
    origin: vec3<f32>,
    direction: vec3<f32>,
    throughput: vec3<f32>,
    inside: u32,
    event: u32,
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

// integrator.rs trace_ray
fn trace_ray(origin: vec3<f32>, direction: vec3<f32>, pixel: u32, sample: u32) -> Traced {
    var result = Traced(vec3<f32>(0.0), 0.0, infinity(), vec3<f32>(0.0), 0u, NONE, SURFACE_NONE);
    let eps = 4.0 * params.scene_min.w;
    let ior = params.scene_max.w;
    let glass = params.counts.y == 0u && params.look_flags.y == 0u;
    pending = 0u;
    var path = Branch(origin, direction, vec3<f32>(1.0), NONE, 0u);
    var branch = 0u;
    loop {
        var ended = false;
        while (path.event < params.size.w) {
            let event = path.event;
            let first = branch == 0u && event == 0u;
            let chance = random(pixel, sample, event + branch * BRANCH_EVENTS);
            path.event += 1u;
            let o = path.origin;
            let d = path.direction;
            if (path.inside != NONE) {
                let exit = union_exit(path.inside, o, d);
                let p = o + exit.t * d;
                path.throughput *= exp(-params.absorption.xyz * exit.t);
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
            let hit = closest_hit(o, d, 0.0);
            let t_floor = floor_t(o, d);
            if (t_floor < hit.t) {
                let p = o + t_floor * d;
                if (first) {
                    result.alpha = 1.0;
                    result.depth = t_floor;
                    result.normal = vec3<f32>(0.0, 1.0, 0.0);
                    result.surface = SURFACE_FLOOR;
                }
                result.color += path.throughput * floor_radiance(p, d);
                ended = true;
                break;
            }
            if (hit.element == NONE) {
                if (!first || params.flags.w != 0u) {
                    result.color += path.throughput * environment_radiance(d);
                }
                ended = true;
                break;
            }
            if (first) {
                result.alpha = 1.0;
                result.depth = hit.t;
                result.normal = hit.normal;
                result.element = hit.element;
                result.fragment = fragments[hit.element] + 1u;
                result.surface = select(SURFACE_OUTER, SURFACE_FRACTURE, hit.fracture);
            }
            let p = o + hit.t * d;
            if (!glass) {
                let albedo = select(params.albedo.xyz, params.fracture_albedo.xyz, hit.fracture);
                result.color += path.throughput * shade_opaque(albedo, hit.normal, d, params.absorption.w);
                ended = true;
                break;
            }
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
                result.color += path.throughput * floor_radiance(path.origin + t_floor * path.direction, path.direction);
            } else {
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
