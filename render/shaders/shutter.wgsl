// shutter.rs: a ray at its time carried to the frame's centre's placement of an element's group.

// shutter.rs ToCentre: x -> rows (x - pivot_at_time) + pivot_at_centre; identity when !moved
struct ToCentre {
    moved: bool,
    r0: vec3<f32>,
    r1: vec3<f32>,
    r2: vec3<f32>,
    pivot_at_time: vec3<f32>,
    pivot_at_centre: vec3<f32>,
}

// shutter.rs rotation_rows, as ToCentre's rows
fn rotation_rows(phi: vec3<f32>, map: ptr<function, ToCentre>) {
    let angle = sqrt(dot3(phi, phi));
    if (angle == 0.0) {
        (*map).r0 = vec3<f32>(1.0, 0.0, 0.0);
        (*map).r1 = vec3<f32>(0.0, 1.0, 0.0);
        (*map).r2 = vec3<f32>(0.0, 0.0, 1.0);
        return;
    }
    let k = phi / angle;
    let s = sin(angle);
    let c = cos(angle);
    let t = 1.0 - c;
    (*map).r0 = vec3<f32>(c + t * k.x * k.x, t * k.x * k.y - s * k.z, t * k.x * k.z + s * k.y);
    (*map).r1 = vec3<f32>(t * k.y * k.x + s * k.z, c + t * k.y * k.y, t * k.y * k.z - s * k.x);
    (*map).r2 = vec3<f32>(t * k.z * k.x - s * k.y, t * k.z * k.y + s * k.x, c + t * k.z * k.z);
}

// shutter.rs SceneMotion::to_centre (GroupMotion: centre, then velocity and rotation before the
// centre, then after it: five vec4 per group)
fn to_centre(e: u32, time: f32) -> ToCentre {
    var map: ToCentre;
    map.moved = false;
    if (time == 0.0 || params.shutter.x == 0.0) {
        return map;
    }
    let base = 5u * motion_groups[e];
    let segment = base + select(1u, 3u, time > 0.0);
    let velocity = group_motions[segment].xyz;
    let rotation = group_motions[segment + 1u].xyz;
    if (all(velocity == vec3<f32>(0.0)) && all(rotation == vec3<f32>(0.0))) {
        return map;
    }
    map.moved = true;
    map.pivot_at_centre = group_motions[base].xyz;
    map.pivot_at_time = map.pivot_at_centre + time * velocity;
    rotation_rows(-time * rotation, &map);
    return map;
}

// shutter.rs ToCentre::vector
fn centre_vector(map: ToCentre, d: vec3<f32>) -> vec3<f32> {
    if (!map.moved) {
        return d;
    }
    return vec3<f32>(dot3(map.r0, d), dot3(map.r1, d), dot3(map.r2, d));
}

// shutter.rs ToCentre::point
fn centre_point(map: ToCentre, p: vec3<f32>) -> vec3<f32> {
    if (!map.moved) {
        return p;
    }
    return centre_vector(map, p - map.pivot_at_time) + map.pivot_at_centre;
}

// shutter.rs ToCentre::vector_back
fn vector_back(map: ToCentre, n: vec3<f32>) -> vec3<f32> {
    if (!map.moved) {
        return n;
    }
    return map.r0 * n.x + map.r1 * n.y + map.r2 * n.z;
}
