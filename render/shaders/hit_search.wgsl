// hit_search.rs: the nearest hit over unions of elements through the k-d tree, the element
// holding a point, and where a ray inside a union leaves it.

struct Hit {
    t: f32,
    element: u32,
    normal: vec3<f32>,
    fracture: bool,
}

fn miss() -> Hit {
    return Hit(infinity(), NONE, vec3<f32>(0.0), false);
}

// hit_search.rs element_entry
// (a trimtope's hit beyond t_max may be given or not)
fn element_entry(e: u32, origin: vec3<f32>, direction: vec3<f32>, t_min: f32, t_max: f32) -> Entry {
    if (params.counts.y == 2u) {
        return trimtope_entry(e, origin, direction, t_min, t_max);
    }
    let span = polytope_span(e, params.scene_min.w, origin, direction);
    if (span.hit && span.t_in >= t_min && span.plane_in != NONE) {
        return Entry(span.t_in, ENTRY_FACE, span.plane_in);
    }
    return no_entry();
}

// hit_search.rs resolve: element e's entry as a hit, with its normal and fracture flag
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

// hit_search.rs AtCentre::back: a hit found at the centre turned back to the ray's time
fn hit_back(hit: Hit, time: f32) -> Hit {
    if (hit.element == NONE) {
        return hit;
    }
    var back = hit;
    back.normal = vector_back(to_centre(hit.element, time), hit.normal);
    return back;
}

// hit_search.rs closest_hit through element_kdtree.rs traverse (short stack, push-down, kd-restart),
// at `time` (frames from the frame's centre)
fn closest_hit(origin: vec3<f32>, direction: vec3<f32>, t_min_ray: f32, time: f32) -> Hit {
    // hit_search.rs AtCentre: the ray in the last group's placement at the centre
    var last_group = NONE;
    var centre_origin = origin;
    var centre_direction = direction;
    let moving = time != 0.0 && params.shutter.x != 0.0;
    // hit_search.rs Nearest: the nearest entry so far, resolved into a hit at the end
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
            if (moving && motion_groups[e] != last_group) {
                last_group = motion_groups[e];
                let map = to_centre(e, time);
                centre_origin = centre_point(map, origin);
                centre_direction = centre_vector(map, direction);
            }
            let entry = element_entry(e, centre_origin, centre_direction, t_min_ray, best.t);
            if (entry.t < best.t || (entry.t == best.t && e < best_element)) {
                best = entry;
                best_element = e;
            }
        }
        if (best.t <= t_max) {
            return hit_back(resolve(best_element, best), time);
        }
        if (stack_len > 0u) {
            stack_len -= 1u;
            node = stack_node[stack_len];
            t_min = stack_min[stack_len];
            t_max = stack_max[stack_len];
            push_down = false;
        } else if (t_max >= scene_max) {
            return hit_back(resolve(best_element, best), time);
        } else {
            t_min = t_max;
            t_max = scene_max;
            node = root;
            push_down = true;
        }
    }
    return hit_back(resolve(best_element, best), time);
}

// hit_search.rs element_at through element_kdtree.rs for_each_at
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

// hit_search.rs next_element
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

// hit_search.rs STALLED_STEPS
const STALLED_STEPS: u32 = 8u;

// hit_search.rs union_exit, at `time`: the walk goes through the centre's placement of the
// element's group
fn union_exit(element: u32, origin: vec3<f32>, direction: vec3<f32>, time: f32) -> Exit {
    let map = to_centre(element, time);
    var exit = union_walk(element, centre_point(map, origin), centre_vector(map, direction));
    exit.normal = vector_back(map, exit.normal);
    return exit;
}

// hit_search.rs union_walk
fn union_walk(element: u32, origin: vec3<f32>, direction: vec3<f32>) -> Exit {
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
