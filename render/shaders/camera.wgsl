// camera.rs: the pinhole camera's rays.

// camera.rs Camera::direction
fn camera_direction(px: f32, py: f32) -> vec3<f32> {
    let sx = 2.0 * px / f32(params.size.x) - 1.0;
    let sy = 1.0 - 2.0 * py / f32(params.size.y);
    let d = params.camera_forward.xyz + sx * params.camera_right.xyz + sy * params.camera_up.xyz;
    return d / sqrt(dot3(d, d));
}
