// The GPU ray tracer, one pixel per invocation: the twin of render/src/trace.rs (and of the
// functions of primitives.rs, element_kdtree.rs and lighting.rs it uses), step for step.

const NONE: u32 = 0xffffffffu;
const LEAF: u32 = 3u;
const SHORT_STACK: u32 = 4u;
const PI: f32 = 3.14159265358979;
const WG: u32 = 8u;

struct Params {
    camera_origin: vec4<f32>,
    camera_forward: vec4<f32>,
    camera_right: vec4<f32>,
    camera_up: vec4<f32>,
    // width, height, samples per pixel, max bounces
    size: vec4<u32>,
    // elements, element type (0 cube, 1 tet, 2 trimtope), environment width, environment height
    counts: vec4<u32>,
    // floor texture width, height, has floor, show environment
    flags: vec4<u32>,
    // k-d tree bounds; min.w = slack, max.w = index of refraction
    scene_min: vec4<f32>,
    scene_max: vec4<f32>,
    // glass absorption per metre; w = highlight strength
    absorption: vec4<f32>,
    // opaque albedo; w = highlight exponent
    albedo: vec4<f32>,
    // floor height, tile size, first pixel of this dispatch, pixels in this dispatch (bits)
    floor: vec4<f32>,
    key_direction: vec4<f32>,
    key_irradiance: vec4<f32>,
    sh: array<vec4<f32>, 9>,
    // opaque albedo of fracture faces; w unused
    fracture_albedo: vec4<f32>,
    // glass split events, opaque cubes (1) or glass (0), 0, 0
    look_flags: vec4<u32>,
}

struct PixelOut {
    color: vec4<f32>,   // rgb, alpha
    normal: vec4<f32>,  // xyz, w = depth
    ids: vec4<u32>,     // fragment + 1, element, surface kind, 0
}

// mattes.rs MatteCounts
struct MatteOut {
    fragments: array<vec2<u32>, 8>,  // (fragment + 1, samples), in order of first appearance
    surfaces: vec4<u32>,             // outer, fracture, floor, samples
}

const SURFACE_NONE: u32 = 0u;
const SURFACE_OUTER: u32 = 1u;
const SURFACE_FRACTURE: u32 = 2u;
const SURFACE_FLOOR: u32 = 3u;
const SPLIT_STACK: u32 = 4u;
const BRANCH_EVENTS: u32 = 128u;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> nodes: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read> items: array<u32>;
@group(0) @binding(3) var<storage, read> plane_offsets: array<u32>;
@group(0) @binding(4) var<storage, read> planes: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> triangle_offsets: array<u32>;
@group(0) @binding(6) var<storage, read> triangles: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> sites: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read> fragments: array<u32>;
@group(0) @binding(9) var<storage, read> environment: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read> floor_texels: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read_write> pixels: array<PixelOut>;
@group(0) @binding(12) var<storage, read> triangle_group_offsets: array<u32>;
// per group of TRIANGLE_GROUP triangles (a constant the host prepends): min, then max corner
@group(0) @binding(13) var<storage, read> triangle_groups: array<vec4<f32>>;
// scene.rs interior_faces: per element, bit k set when plane k rested against another element
@group(0) @binding(14) var<storage, read> interior_faces: array<u32>;
@group(0) @binding(15) var<storage, read_write> mattes: array<MatteOut>;
// scene.rs face_neighbours: parallel to planes, the element that rested against each plane, or NONE
@group(0) @binding(16) var<storage, read> face_neighbours: array<u32>;

fn infinity() -> f32 {
    return bitcast<f32>(0x7f800000u);
}

struct Span {
    t_in: f32,
    t_out: f32,
    plane_in: u32,
    plane_out: u32,
    hit: bool,
}

// primitives.rs polytope_span
fn polytope_span(e: u32, slack: f32, origin: vec3<f32>, direction: vec3<f32>) -> Span {
    var span = Span(-infinity(), infinity(), NONE, NONE, false);
    var wide_in = -infinity();
    var wide_out = infinity();
    let first = plane_offsets[e];
    let end = plane_offsets[e + 1u];
    for (var k = first; k < end; k++) {
        let plane = planes[k];
        let normal = plane.xyz;
        let facing = dot3(normal, direction);
        let room = plane.w - dot3(normal, origin);
        if (facing == 0.0) {
            if (room + slack < 0.0) {
                return span;
            }
            continue;
        }
        let t = room / facing;
        let wide = (room + slack) / facing;
        if (facing < 0.0) {
            wide_in = max(wide_in, wide);
            if (t > span.t_in) {
                span.t_in = t;
                span.plane_in = k - first;
            }
        } else {
            wide_out = min(wide_out, wide);
            if (t < span.t_out) {
                span.t_out = t;
                span.plane_out = k - first;
            }
        }
    }
    span.hit = wide_in <= wide_out;
    return span;
}

// a . b summed x, y, z in that order (as the CPU does)
fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

fn cross3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

// primitives.rs polytope_contains
fn polytope_contains(e: u32, slack: f32, point: vec3<f32>) -> bool {
    for (var k = plane_offsets[e]; k < plane_offsets[e + 1u]; k++) {
        let plane = planes[k];
        if (!(dot3(plane.xyz, point) <= plane.w + slack)) {
            return false;
        }
    }
    return true;
}

struct TriangleHit {
    t: f32,
    front: bool,
    hit: bool,
}

// primitives.rs triangle_hit
fn triangle_hit(origin: vec3<f32>, direction: vec3<f32>, index: u32) -> TriangleHit {
    var result = TriangleHit(0.0, false, false);
    let a = triangles[3u * index].xyz;
    let b = triangles[3u * index + 1u].xyz;
    let c = triangles[3u * index + 2u].xyz;
    let e1 = b - a;
    let e2 = c - a;
    let p = cross3(direction, e2);
    let det = dot3(e1, p);
    if (det == 0.0) {
        return result;
    }
    let inverse = 1.0 / det;
    let s = origin - a;
    let u = dot3(s, p) * inverse;
    if (!(u >= 0.0 && u <= 1.0)) {
        return result;
    }
    let q = cross3(s, e1);
    let v = dot3(direction, q) * inverse;
    if (v < 0.0 || u + v > 1.0) {
        return result;
    }
    result.t = dot3(e2, q) * inverse;
    result.front = det > 0.0;
    result.hit = true;
    return result;
}

struct Hit {
    t: f32,
    element: u32,
    normal: vec3<f32>,
    fracture: bool,
}

fn miss() -> Hit {
    return Hit(infinity(), NONE, vec3<f32>(0.0), false);
}

// scene.rs SceneGeometry::is_fracture_face
fn is_fracture_face(e: u32, plane: u32) -> bool {
    return params.counts.y == 2u || ((interior_faces[e] >> plane) & 1u) == 1u;
}

fn plane_normal(e: u32, plane: u32) -> vec3<f32> {
    return planes[plane_offsets[e] + plane].xyz;
}

// How a ray first meets an element (primitives.rs TrimtopeHit): kind ENTRY_MISS, ENTRY_FACE
// (index: the element's plane) or ENTRY_SURFACE (index: into the whole triangle array).
struct Entry {
    t: f32,
    kind: u32,
    index: u32,
}

const ENTRY_MISS: u32 = 0u;
const ENTRY_FACE: u32 = 1u;
const ENTRY_SURFACE: u32 = 2u;

fn no_entry() -> Entry {
    return Entry(infinity(), ENTRY_MISS, NONE);
}

// primitives.rs trimtope_hit
fn trimtope_entry(e: u32, origin: vec3<f32>, direction: vec3<f32>, t_min: f32) -> Entry {
    let slack = params.scene_min.w;
    let span = polytope_span(e, slack, origin, direction);
    if (!span.hit) {
        return no_entry();
    }
    let t_out = max(span.t_out, span.t_in);
    let t_in = max(span.t_in, t_min);
    if (t_in > t_out) {
        return no_entry();
    }
    let first = first_triangle(e, origin, direction, t_in, t_out);
    if (first.index != NONE) {
        if (first.front) {
            return Entry(first.t, ENTRY_SURFACE, first.index);
        }
        return Entry(t_in, ENTRY_FACE, span.plane_in);
    }
    let entry = origin + t_in * direction;
    let nearest = first_triangle(e, entry, sites[e].xyz - entry, 0.0, 1.0);
    if (nearest.index != NONE && nearest.front) {
        return no_entry();
    }
    return Entry(t_in, ENTRY_FACE, span.plane_in);
}

struct FirstTriangle {
    t: f32,
    front: bool,
    index: u32,
}

// primitives.rs first_triangle (index: into the whole triangle array; NONE when none is met)
fn first_triangle(e: u32, origin: vec3<f32>, direction: vec3<f32>, t0: f32, t1: f32) -> FirstTriangle {
    var first = FirstTriangle(infinity(), false, NONE);
    let start = triangle_offsets[e];
    let end = triangle_offsets[e + 1u];
    let groups = triangle_group_offsets[e];
    for (var g = groups; g < triangle_group_offsets[e + 1u]; g++) {
        if (!segment_meets_box(origin, direction, t0, t1, triangle_groups[2u * g].xyz, triangle_groups[2u * g + 1u].xyz)) {
            continue;
        }
        let group_start = start + (g - groups) * TRIANGLE_GROUP;
        for (var k = group_start; k < min(group_start + TRIANGLE_GROUP, end); k++) {
            let hit = triangle_hit(origin, direction, k);
            if (hit.hit && hit.t >= t0 && hit.t <= t1 && (first.index == NONE || hit.t < first.t)) {
                first = FirstTriangle(hit.t, hit.front, k);
            }
        }
    }
    return first;
}

// primitives.rs segment_meets_box
fn segment_meets_box(origin: vec3<f32>, direction: vec3<f32>, t0: f32, t1: f32, lo: vec3<f32>, hi: vec3<f32>) -> bool {
    var near = t0;
    var far = t1;
    for (var axis = 0u; axis < 3u; axis++) {
        if (direction[axis] == 0.0) {
            if (origin[axis] < lo[axis] || origin[axis] > hi[axis]) {
                return false;
            }
            continue;
        }
        let inverse = 1.0 / direction[axis];
        let a = (lo[axis] - origin[axis]) * inverse;
        let b = (hi[axis] - origin[axis]) * inverse;
        near = max(near, min(a, b));
        far = min(far, max(a, b));
    }
    return near <= far + 1e-5 * abs(far);
}

// trace.rs element_entry
fn element_entry(e: u32, origin: vec3<f32>, direction: vec3<f32>, t_min: f32) -> Entry {
    if (params.counts.y == 2u) {
        return trimtope_entry(e, origin, direction, t_min);
    }
    let span = polytope_span(e, params.scene_min.w, origin, direction);
    if (span.hit && span.t_in >= t_min && span.plane_in != NONE) {
        return Entry(span.t_in, ENTRY_FACE, span.plane_in);
    }
    return no_entry();
}

// trace.rs resolve: element e's entry as a hit, with its normal and fracture flag
fn resolve(e: u32, entry: Entry) -> Hit {
    if (entry.kind == ENTRY_FACE) {
        return Hit(entry.t, e, plane_normal(e, entry.index), is_fracture_face(e, entry.index));
    }
    if (entry.kind == ENTRY_SURFACE) {
        let k = entry.index;
        let a = triangles[3u * k].xyz;
        let n = cross3(triangles[3u * k + 1u].xyz - a, triangles[3u * k + 2u].xyz - a);
        return Hit(entry.t, e, n / sqrt(dot3(n, n)), false);
    }
    return miss();
}

// element_kdtree.rs inverse_component
fn inverse_component(d: f32) -> f32 {
    let tiny = 1e-30;
    if (abs(d) < tiny) {
        return 1.0 / select(tiny, -tiny, d < 0.0 || (d == 0.0 && bitcast<u32>(d) != 0u));
    }
    return 1.0 / d;
}

// trace.rs closest_hit through element_kdtree.rs traverse (short stack, push-down, kd-restart)
fn closest_hit(origin: vec3<f32>, direction: vec3<f32>, t_min_ray: f32) -> Hit {
    // trace.rs Nearest: the nearest entry so far, resolved into a hit at the end
    var best = no_entry();
    var best_element = NONE;
    let inverse = vec3<f32>(inverse_component(direction.x), inverse_component(direction.y), inverse_component(direction.z));
    // clip to the scene bounds
    var near = t_min_ray;
    var far = infinity();
    for (var axis = 0u; axis < 3u; axis++) {
        let t0 = (params.scene_min[axis] - origin[axis]) * inverse[axis];
        let t1 = (params.scene_max[axis] - origin[axis]) * inverse[axis];
        let lo = select(t1, t0, t0 <= t1);
        let hi = select(t0, t1, t0 <= t1);
        if (lo > near) {
            near = lo;
        }
        if (hi < far) {
            far = hi;
        }
    }
    if (!(near <= far)) {
        return miss();
    }
    let scene_max = far;
    var stack_node: array<u32, 4>;
    var stack_min: array<f32, 4>;
    var stack_max: array<f32, 4>;
    var stack_len = 0u;
    var root = 0u;
    var t_min = near;
    var t_max = far;
    var node = root;
    var push_down = true;
    loop {
        let entry = nodes[node];
        if ((entry.x & 3u) != LEAF) {
            let axis = entry.x & 3u;
            let split = bitcast<f32>(entry.y);
            let t_split = (split - origin[axis]) * inverse[axis];
            let below_first = origin[axis] < split || (origin[axis] == split && direction[axis] <= 0.0);
            let near_child = select(entry.x >> 2u, node + 1u, below_first);
            let far_child = select(node + 1u, entry.x >> 2u, below_first);
            if (t_split >= t_max || t_split < 0.0) {
                node = near_child;
            } else if (t_split <= t_min) {
                node = far_child;
            } else {
                if (stack_len == SHORT_STACK) {
                    for (var k = 1u; k < SHORT_STACK; k++) {
                        stack_node[k - 1u] = stack_node[k];
                        stack_min[k - 1u] = stack_min[k];
                        stack_max[k - 1u] = stack_max[k];
                    }
                    stack_len -= 1u;
                }
                stack_node[stack_len] = far_child;
                stack_min[stack_len] = t_split;
                stack_max[stack_len] = t_max;
                stack_len += 1u;
                node = near_child;
                t_max = t_split;
                push_down = false;
            }
            if (push_down) {
                root = node;
            }
            continue;
        }
        let first = entry.x >> 2u;
        for (var k = first; k < first + entry.y; k++) {
            let e = items[k];
            let entry = element_entry(e, origin, direction, t_min_ray);
            if (entry.t < best.t || (entry.t == best.t && e < best_element)) {
                best = entry;
                best_element = e;
            }
        }
        if (best.t <= t_max) {
            return resolve(best_element, best);
        }
        if (stack_len > 0u) {
            stack_len -= 1u;
            node = stack_node[stack_len];
            t_min = stack_min[stack_len];
            t_max = stack_max[stack_len];
            push_down = false;
        } else if (t_max >= scene_max) {
            return resolve(best_element, best);
        } else {
            t_min = t_max;
            t_max = scene_max;
            node = root;
            push_down = true;
        }
    }
    return resolve(best_element, best);
}

// trace.rs element_at through element_kdtree.rs for_each_at
fn element_at(point: vec3<f32>, except: u32) -> u32 {
    for (var axis = 0u; axis < 3u; axis++) {
        if (!(point[axis] >= params.scene_min[axis] && point[axis] <= params.scene_max[axis])) {
            return NONE;
        }
    }
    var node = 0u;
    loop {
        let entry = nodes[node];
        if ((entry.x & 3u) == LEAF) {
            let first = entry.x >> 2u;
            for (var k = first; k < first + entry.y; k++) {
                let e = items[k];
                if (e != except && polytope_contains(e, params.scene_min.w, point)) {
                    return e;
                }
            }
            return NONE;
        }
        let axis = entry.x & 3u;
        node = select(entry.x >> 2u, node + 1u, point[axis] < bitcast<f32>(entry.y));
    }
    return NONE;
}

// trace.rs next_element
fn next_element(current: u32, plane: u32, point: vec3<f32>) -> u32 {
    if (plane != NONE) {
        let neighbour = face_neighbours[plane_offsets[current] + plane];
        if (neighbour != NONE && polytope_contains(neighbour, params.scene_min.w, point)) {
            return neighbour;
        }
    }
    return element_at(point, current);
}

struct Exit {
    t: f32,
    normal: vec3<f32>,
    element: u32,
}

// trace.rs STALLED_STEPS
const STALLED_STEPS: u32 = 8u;

// trace.rs union_exit
fn union_exit(element: u32, origin: vec3<f32>, direction: vec3<f32>) -> Exit {
    let slack = params.scene_min.w;
    let step = 4.0 * slack;
    var current = element;
    var travelled = 0.0;
    var start = origin;
    var stalled = 0u;
    for (var guard = 0u; guard < 100000u; guard++) {
        let span = polytope_span(current, slack, start, direction);
        if (!span.hit) {
            break;
        }
        let t = max(span.t_out, 0.0);
        let exit = start + t * direction;
        let next = next_element(current, span.plane_out, exit + step * direction);
        stalled = select(0u, stalled + 1u, t < step);
        if (next == NONE || span.plane_out == NONE || stalled > STALLED_STEPS) {
            let count = plane_offsets[current + 1u] - plane_offsets[current];
            return Exit(travelled + t, plane_normal(current, min(span.plane_out, count - 1u)), current);
        }
        travelled += t;
        start = exit;
        current = next;
    }
    return Exit(travelled, vec3<f32>(0.0), current);
}

// trace.rs hash32 and random
fn hash32(x: u32) -> u32 {
    let state = x * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn random(pixel: u32, sample: u32, event: u32) -> f32 {
    let bits = hash32(pixel ^ hash32((sample * 0x9e3779b9u) ^ hash32(event)));
    return f32(bits >> 8u) / 16777216.0;
}

fn reflect3(d: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let k = 2.0 * dot3(d, n);
    return vec3<f32>(d.x - k * n.x, d.y - k * n.y, d.z - k * n.z);
}

struct Refraction {
    direction: vec3<f32>,
    ok: bool,
}

fn refract3(d: vec3<f32>, n: vec3<f32>, eta: f32) -> Refraction {
    let cos_i = -dot3(d, n);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if (sin2_t > 1.0) {
        return Refraction(vec3<f32>(0.0), false);
    }
    let cos_t = sqrt(1.0 - sin2_t);
    let k = eta * cos_i - cos_t;
    return Refraction(vec3<f32>(eta * d.x + k * n.x, eta * d.y + k * n.y, eta * d.z + k * n.z), true);
}

fn fresnel(cos_i: f32, eta: f32) -> f32 {
    let r = (1.0 - eta) / (1.0 + eta);
    let r0 = r * r;
    let m = 1.0 - clamp(cos_i, 0.0, 1.0);
    return r0 + (1.0 - r0) * (m * m * m * m * m);
}

// lighting.rs coordinates_of and EnvironmentMap::radiance
fn environment_radiance(d: vec3<f32>) -> vec3<f32> {
    let width = params.counts.z;
    let height = params.counts.w;
    let u = 0.5 + atan2(d.x, -d.z) / (2.0 * PI);
    let v = acos(clamp(d.y, -1.0, 1.0)) / PI;
    let fx = u * f32(width) - 0.5;
    let fy = clamp(v * f32(height) - 0.5, 0.0, f32(height - 1u));
    let x0 = floor(fx);
    let y0 = floor(fy);
    let ax = fx - x0;
    let ay = fy - y0;
    let a = texel(x0, y0);
    let b = texel(x0 + 1.0, y0);
    let c = texel(x0, y0 + 1.0);
    let e = texel(x0 + 1.0, y0 + 1.0);
    return (a * (1.0 - ax) + b * ax) * (1.0 - ay) + (c * (1.0 - ax) + e * ax) * ay;
}

fn texel(x: f32, y: f32) -> vec3<f32> {
    let width = i32(params.counts.z);
    let xi = ((i32(x) % width) + width) % width;
    let yi = min(u32(y), params.counts.w - 1u);
    return environment[yi * params.counts.z + u32(xi)].xyz;
}

// lighting.rs sh_basis and sh_irradiance
fn sh_irradiance(n: vec3<f32>) -> vec3<f32> {
    let x = n.x;
    let y = n.y;
    let z = n.z;
    var basis: array<f32, 9>;
    basis[0] = 0.282095;
    basis[1] = 0.488603 * y;
    basis[2] = 0.488603 * z;
    basis[3] = 0.488603 * x;
    basis[4] = 1.092548 * x * y;
    basis[5] = 1.092548 * y * z;
    basis[6] = 0.315392 * (3.0 * z * z - 1.0);
    basis[7] = 1.092548 * x * z;
    basis[8] = 0.546274 * (x * x - y * y);
    var weight: array<f32, 9>;
    weight[0] = PI;
    for (var k = 1u; k < 4u; k++) {
        weight[k] = 2.0 * PI / 3.0;
    }
    for (var k = 4u; k < 9u; k++) {
        weight[k] = PI / 4.0;
    }
    var e = vec3<f32>(0.0);
    for (var k = 0u; k < 9u; k++) {
        e += weight[k] * params.sh[k].xyz * basis[k];
    }
    return max(e, vec3<f32>(0.0));
}

// trace.rs shade_opaque
fn shade_opaque(albedo: vec3<f32>, normal: vec3<f32>, view: vec3<f32>, specular: f32) -> vec3<f32> {
    let irradiance = sh_irradiance(normal);
    let l = params.key_direction.xyz;
    let v = l - view;
    let h = v / max(sqrt(dot3(v, v)), 1e-12);
    var highlight = 0.0;
    let shininess = params.albedo.w;
    if (dot3(normal, l) > 0.0) {
        highlight = specular * (shininess + 8.0) / (8.0 * PI) * pow(max(dot3(normal, h), 0.0), shininess);
    }
    return albedo / PI * irradiance + highlight * params.key_irradiance.xyz;
}

// trace.rs FloorLook::albedo
fn floor_albedo(p: vec3<f32>) -> vec3<f32> {
    let tile = params.floor.y;
    let u = p.x / tile - floor(p.x / tile);
    let v = p.z / tile - floor(p.z / tile);
    let width = params.flags.x;
    let height = params.flags.y;
    let x = min(u32(u * f32(width)), width - 1u);
    let y = min(u32(v * f32(height)), height - 1u);
    return floor_texels[y * width + x].xyz;
}

// trace.rs floor_t
fn floor_t(o: vec3<f32>, d: vec3<f32>) -> f32 {
    if (params.flags.z != 0u && d.y < 0.0 && o.y > params.floor.x) {
        return (params.floor.x - o.y) / d.y;
    }
    return infinity();
}

// trace.rs floor_radiance
fn floor_radiance(p: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    return shade_opaque(floor_albedo(p), vec3<f32>(0.0, 1.0, 0.0), d, 0.0);
}

struct Traced {
    color: vec3<f32>,
    alpha: f32,
    depth: f32,
    normal: vec3<f32>,
    fragment: u32,
    element: u32,
    surface: u32,
}

// trace.rs Branch
struct Branch {
    origin: vec3<f32>,
    direction: vec3<f32>,
    throughput: vec3<f32>,
    inside: u32,
    event: u32,
}

var<private> stack: array<Branch, SPLIT_STACK>;
var<private> pending: u32;

// trace.rs split: pushes `reflected` weighted by `reflectance` and weights `path` by the rest
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

// trace.rs trace_ray
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

// scene.rs Camera::direction
fn camera_direction(px: f32, py: f32) -> vec3<f32> {
    let sx = 2.0 * px / f32(params.size.x) - 1.0;
    let sy = 1.0 - 2.0 * py / f32(params.size.y);
    let d = params.camera_forward.xyz + sx * params.camera_right.xyz + sy * params.camera_up.xyz;
    return d / sqrt(dot3(d, d));
}

// mattes.rs MatteCounts::add
fn add_matte_sample(matte: ptr<function, MatteOut>, fragment: u32, surface: u32) {
    (*matte).surfaces.w += 1u;
    if (surface != SURFACE_NONE) {
        (*matte).surfaces[surface - 1u] += 1u;
    }
    if (fragment == 0u) {
        return;
    }
    for (var k = 0u; k < 8u; k++) {
        let slot = (*matte).fragments[k];
        if (slot.x == fragment || slot.x == 0u) {
            (*matte).fragments[k] = vec2<u32>(fragment, slot.y + 1u);
            return;
        }
    }
}

// trace.rs sample_offset
fn sample_offset(pixel: u32, sample: u32, samples: u32) -> vec2<f32> {
    if (sample == 0u) {
        return vec2<f32>(0.5, 0.5);
    }
    let jx = random(pixel, sample, 1000u);
    let jy = random(pixel, sample, 1001u);
    let others = samples - 1u;
    var n = u32(sqrt(f32(others)));
    while ((n + 1u) * (n + 1u) <= others) {
        n += 1u;
    }
    while (n * n > others) {
        n -= 1u;
    }
    let k = sample - 1u;
    if (k >= n * n) {
        return vec2<f32>(jx, jy);
    }
    return vec2<f32>((f32(k % n) + jx) / f32(n), (f32(k / n) + jy) / f32(n));
}

// trace.rs render, for the pixels of this dispatch
@compute @workgroup_size(64)
fn trace(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let local = (wid.x + wid.y * nwg.x) * 64u + lid;
    let first_pixel = bitcast<u32>(params.floor.z);
    let count = bitcast<u32>(params.floor.w);
    if (local >= count) {
        return;
    }
    let pixel = first_pixel + local;
    let width = params.size.x;
    let x = pixel % width;
    let y = pixel / width;
    let samples = params.size.z;
    var sum = vec3<f32>(0.0);
    var alpha = 0.0;
    var out: PixelOut;
    var matte: MatteOut;
    for (var sample = 0u; sample < samples; sample++) {
        let offset = sample_offset(pixel, sample, samples);
        let d = camera_direction(f32(x) + offset.x, f32(y) + offset.y);
        let traced = trace_ray(params.camera_origin.xyz, d, pixel, sample);
        if (sample == 0u) {
            out.normal = vec4<f32>(traced.normal, traced.depth);
            out.ids = vec4<u32>(traced.fragment, traced.element, traced.surface, 0u);
        }
        add_matte_sample(&matte, traced.fragment, traced.surface);
        sum += traced.color;
        alpha += traced.alpha;
    }
    out.color = vec4<f32>(sum / f32(samples), alpha / f32(samples));
    pixels[local] = out;
    mattes[local] = matte;
}
