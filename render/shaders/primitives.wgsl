// primitives.rs: ray spans of convex polytopes, point tests, triangle hits, and the trimtope
// entry rules.

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
fn trimtope_entry(e: u32, origin: vec3<f32>, direction: vec3<f32>, t_min: f32, t_max: f32) -> Entry {
    let lo = element_bounds[2u * e].xyz;
    let hi = element_bounds[2u * e + 1u].xyz;
    if (!segment_meets_box(origin, direction, t_min, t_max, lo, hi)) {
        return no_entry();
    }
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
    if (any(entry < lo) || any(entry > hi)) {
        return no_entry();
    }
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
