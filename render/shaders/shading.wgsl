// shading.rs: reflection, refraction, Fresnel, opaque surfaces and the floor.

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

// shading.rs shade_opaque
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

// shading.rs floor_albedo: filtered over the ray's footprint (direction, cone width in metres)
// where the texture is, else materials.rs FloorLook::albedo
fn floor_albedo(p: vec3<f32>, direction: vec3<f32>, width_m: f32) -> vec3<f32> {
    if (params.look_flags.z != 0u) {
        return filtered_albedo(p, direction, width_m);
    }
    let tile = params.floor.y;
    let u = p.x / tile - floor(p.x / tile);
    let v = p.z / tile - floor(p.z / tile);
    let width = params.flags.x;
    let height = params.flags.y;
    let x = min(u32(u * f32(width)), width - 1u);
    let y = min(u32(v * f32(height)), height - 1u);
    return floor_texels[y * width + x].xyz;
}

// shading.rs floor_t
fn floor_t(o: vec3<f32>, d: vec3<f32>) -> f32 {
    if (params.flags.z != 0u && d.y < 0.0 && o.y > params.floor.x) {
        return (params.floor.x - o.y) / d.y;
    }
    return infinity();
}

// shading.rs floor_radiance, of the floor's albedo where it is seen
fn floor_radiance(albedo: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    return shade_opaque(albedo, vec3<f32>(0.0, 1.0, 0.0), d, 0.0);
}
