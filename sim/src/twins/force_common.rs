//! Twin of `force_common.wgsl`, what the force kernels (`spring_forces`, `family_forces`) share:
//! the body forces (gravity, projectiles (the paper's eq. 7) and spherical indenters) and the
//! workgroup power sum.

use super::common::{V4, add, dot3, scale, sub, xyz};
use crate::gpu::wgsl_structs::{Params, WG};

/// `cube_root` of `force_common.wgsl`: pow, then one Newton step.
pub fn cube_root(x: f32) -> f32 {
    if x <= 0.0 {
        return 0.0;
    }
    let c = x.powf(1.0 / 3.0);
    c - (c * c * c - x) / (3.0 * c * c)
}

/// `projectile_force` of `force_common.wgsl`.
fn projectile_force(spheres: &[V4], s: usize, c: [f32; 3], p: [f32; 3]) -> [f32; 3] {
    let heading = spheres[2 * s];
    let radius = heading[3];
    let stiffness = spheres[2 * s + 1][0];
    let d = sub(p, c);
    let r = dot3(d, d).sqrt();
    if !(r >= 0.75 * radius && r <= 1.5 * radius) {
        return [0.0; 3];
    }
    let shape = 16.0 * (r - 0.75 * radius) * (r - 1.5 * radius) * (r - 1.5 * radius);
    let root = cube_root(shape);
    let magnitude = stiffness * root * root;
    let away = d.map(|x| x / r);
    let mut direction = add(away, xyz(heading));
    let norm = dot3(direction, direction).sqrt();
    if norm > 1e-6 {
        direction = direction.map(|x| x / norm);
    } else {
        direction = away;
    }
    scale(direction, magnitude)
}

/// `indenter_force` of `force_common.wgsl`.
fn indenter_force(spheres: &[V4], s: usize, c: [f32; 3], p: [f32; 3]) -> [f32; 3] {
    let radius = spheres[2 * s][3];
    let stiffness = spheres[2 * s + 1][0];
    let d = sub(p, c);
    let r = dot3(d, d).sqrt();
    if r >= radius || r == 0.0 {
        return [0.0; 3];
    }
    let gap = radius - r;
    scale(d, stiffness * gap * gap / r)
}

/// `body_force` of `force_common.wgsl`: gravity, then each projectile, then each indenter on a
/// particle of mass `mass` at `p`, at step `step`.
pub(super) fn body_force(params: &Params, spheres: &[V4], mass: f32, p: [f32; 3], step: u32) -> [f32; 3] {
    let mut external = scale([params.gravity_x, params.gravity_y, params.gravity_z], mass);
    let spheres_now = (params.projectiles + params.indenters) as usize;
    let centres = 2 * spheres_now + (step - params.batch_first_step) as usize * spheres_now;
    for s in 0..params.projectiles as usize {
        external = add(external, projectile_force(spheres, s, xyz(spheres[centres + s]), p));
    }
    for s in params.projectiles as usize..spheres_now {
        external = add(external, indenter_force(spheres, s, xyz(spheres[centres + s]), p));
    }
    external
}

/// `workgroup_sum` of `force_common.wgsl`: the sum of a workgroup's `partial` values in the
/// shader's tree order.
pub(super) fn workgroup_sum(mut partial: [f32; WG]) -> f32 {
    let mut stride = WG / 2;
    while stride > 0 {
        for lid in 0..stride {
            partial[lid] += partial[lid + stride];
        }
        stride /= 2;
    }
    partial[0]
}
