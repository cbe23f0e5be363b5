// lighting.rs: the environment map and the SH irradiance.

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
