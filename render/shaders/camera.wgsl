// camera.rs: the pinhole camera's rays.

// camera.rs Camera::direction
fn camera_direction(px: f32, py: f32) -> vec3<f32> {
    let sx = 2.0 * px / f32(params.size.x) - 1.0;
    let sy = 1.0 - 2.0 * py / f32(params.size.y);
    let d = params.camera_forward.xyz + sx * params.camera_right.xyz + sy * params.camera_up.xyz;
    return d / sqrt(dot3(d, d));
}

// camera.rs concentric_disk
fn concentric_disk(u: f32, v: f32) -> vec2<f32> {
    let a = 2.0 * u - 1.0;
    let b = 2.0 * v - 1.0;
    if (a == 0.0 && b == 0.0) {
        return vec2<f32>(0.0);
    }
    let quarter = PI / 4.0;
    var r: f32;
    var theta: f32;
    if (abs(a) > abs(b)) {
        r = a;
        theta = quarter * (b / a);
    } else {
        r = b;
        theta = 2.0 * quarter - quarter * (a / b);
    }
    return vec2<f32>(r * cos(theta), r * sin(theta));
}

struct CameraRay {
    origin: vec3<f32>,
    direction: vec3<f32>,
}

// camera.rs Camera::lens_ray (the lens radius in camera_origin.w, 0 for a pinhole; the focus
// distance in camera_forward.w)
fn lens_ray(px: f32, py: f32, disk: vec2<f32>) -> CameraRay {
    let pinhole = camera_direction(px, py);
    let radius = params.camera_origin.w;
    if (radius == 0.0) {
        return CameraRay(params.camera_origin.xyz, pinhole);
    }
    let right = params.camera_right.xyz / sqrt(dot3(params.camera_right.xyz, params.camera_right.xyz));
    let up = params.camera_up.xyz / sqrt(dot3(params.camera_up.xyz, params.camera_up.xyz));
    let along = dot3(pinhole, params.camera_forward.xyz);
    let focus = params.camera_origin.xyz + pinhole * (params.camera_forward.w / along);
    let origin = params.camera_origin.xyz + radius * (disk.x * right + disk.y * up);
    let d = focus - origin;
    return CameraRay(origin, d / sqrt(dot3(d, d)));
}
