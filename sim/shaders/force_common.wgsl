// What the force kernels (`spring_forces`, `family_forces`) share: the body forces on a particle
// (the paper's bodyforces: gravity, projectiles (eq. 7) and spherical indenters at the current
// step) and the workgroup's sum of the external power. No entry point: the host prepends this
// file to those kernels, which declare `params` and `spheres`.

var<workgroup> partial: array<f32, 64>;

// The sum of `p` over the workgroup's invocations, in a fixed tree order (every invocation gets
// it; call from uniform control flow).
fn workgroup_sum(lid: u32, p: f32) -> f32 {
    partial[lid] = p;
    workgroupBarrier();
    for (var stride = 32u; stride > 0u; stride = stride / 2u) {
        if (lid < stride) {
            partial[lid] = partial[lid] + partial[lid + stride];
        }
        workgroupBarrier();
    }
    return partial[0];
}

// The cube root of x >= 0: pow, then one Newton step (WGSL has no cbrt).
fn cube_root(x: f32) -> f32 {
    if (x <= 0.0) {
        return 0.0;
    }
    let c = pow(x, 1.0 / 3.0);
    return c - (c * c * c - x) / (3.0 * c * c);
}

// The paper's eq. 7 on a particle at p from sphere s (centre c).
fn projectile_force(s: u32, c: vec3<f32>, p: vec3<f32>) -> vec3<f32> {
    let heading = spheres[2u * s];
    let radius = heading.w;
    let stiffness_s = spheres[2u * s + 1u].x;
    let d = p - c;
    let r = sqrt(dot3(d, d));
    if (!(r >= 0.75 * radius && r <= 1.5 * radius)) {
        return vec3<f32>(0.0);
    }
    let shape = 16.0 * (r - 0.75 * radius) * (r - 1.5 * radius) * (r - 1.5 * radius);
    let root = cube_root(shape);
    let magnitude = stiffness_s * root * root;
    let away = d / r;
    var direction = away + heading.xyz;
    let norm = sqrt(dot3(direction, direction));
    if (norm > 1e-6) {
        direction = direction / norm;
    } else {
        direction = away;
    }
    return direction * magnitude;
}

// A spherical indenter's K (R - r)^2 outwards.
fn indenter_force(s: u32, c: vec3<f32>, p: vec3<f32>) -> vec3<f32> {
    let radius = spheres[2u * s].w;
    let stiffness_s = spheres[2u * s + 1u].x;
    let d = p - c;
    let r = sqrt(dot3(d, d));
    if (r >= radius || r == 0.0) {
        return vec3<f32>(0.0);
    }
    let gap = radius - r;
    let scale = stiffness_s * gap * gap / r;
    return d * scale;
}

// Gravity, then each projectile, then each indenter on a particle of mass `mass` at `p`, at
// step `step` (whose sphere centres are in the batch's part of the sphere buffer).
fn body_force(mass: f32, p: vec3<f32>, step: u32) -> vec3<f32> {
    var applied = vec3<f32>(params.gravity_x, params.gravity_y, params.gravity_z) * mass;
    let spheres_now = params.projectiles + params.indenters;
    let centres = 2u * spheres_now + (step - params.batch_first_step) * spheres_now;
    for (var s = 0u; s < params.projectiles; s = s + 1u) {
        applied = applied + projectile_force(s, spheres[centres + s].xyz, p);
    }
    for (var s = params.projectiles; s < spheres_now; s = s + 1u) {
        applied = applied + indenter_force(s, spheres[centres + s].xyz, p);
    }
    return applied;
}
