// texture_filter.rs: the floor texture filtered over a ray's footprint (its mip chain follows
// level 0 in floor_texels when look_flags.z is 1; look_flags.w levels).

// texture_filter.rs MAX_TAPS
const MAX_TAPS: u32 = 8u;

struct MipLevel {
    start: u32,
    width: u32,
    height: u32,
}

// texture_filter.rs MipChain::levels
fn mip_level(level: u32) -> MipLevel {
    var start = 0u;
    var width = params.flags.x;
    var height = params.flags.y;
    for (var k = 0u; k < level; k++) {
        start += width * height;
        width = max(width / 2u, 1u);
        height = max(height / 2u, 1u);
    }
    return MipLevel(start, width, height);
}

// texture_filter.rs MipChain::bilinear
fn mip_bilinear(level: u32, u: f32, v: f32) -> vec3<f32> {
    let m = mip_level(level);
    let x = u * f32(m.width) - 0.5;
    let y = v * f32(m.height) - 0.5;
    let fx = x - floor(x);
    let fy = y - floor(y);
    let x0 = u32((i32(floor(x)) % i32(m.width) + i32(m.width)) % i32(m.width));
    let y0 = u32((i32(floor(y)) % i32(m.height) + i32(m.height)) % i32(m.height));
    let x1 = (x0 + 1u) % m.width;
    let y1 = (y0 + 1u) % m.height;
    let a = floor_texels[m.start + y0 * m.width + x0].xyz;
    let b = floor_texels[m.start + y0 * m.width + x1].xyz;
    let c = floor_texels[m.start + y1 * m.width + x0].xyz;
    let d = floor_texels[m.start + y1 * m.width + x1].xyz;
    return (a * (1.0 - fx) + b * fx) * (1.0 - fy) + (c * (1.0 - fx) + d * fx) * fy;
}

// texture_filter.rs MipChain::trilinear
fn mip_trilinear(lod_in: f32, u: f32, v: f32) -> vec3<f32> {
    let top = f32(params.look_flags.w - 1u);
    let lod = clamp(lod_in, 0.0, top);
    let level = floor(lod);
    let blend = lod - level;
    let below = mip_bilinear(u32(level), u, v);
    if (blend == 0.0) {
        return below;
    }
    let above = mip_bilinear(min(u32(level) + 1u, params.look_flags.w - 1u), u, v);
    return below * (1.0 - blend) + above * blend;
}

// texture_filter.rs filtered_albedo
fn filtered_albedo(p: vec3<f32>, direction: vec3<f32>, width_m: f32) -> vec3<f32> {
    let tile = params.floor.y;
    let u = p.x / tile - floor(p.x / tile);
    let v = p.z / tile - floor(p.z / tile);
    let texels_per_metre = f32(max(params.flags.x, params.flags.y)) / tile;
    let sine = max(abs(direction.y), 1e-4);
    let across = sqrt(direction.x * direction.x + direction.z * direction.z);
    var ax = 1.0;
    var az = 0.0;
    if (across > 0.0) {
        ax = direction.x / across;
        az = direction.z / across;
    }
    let minor = max(width_m * texels_per_metre, 1e-6);
    let major = minor / sine;
    let taps = clamp(u32(ceil(major / max(minor, 1.0))), 1u, MAX_TAPS);
    let lod = log2(max(minor, major / f32(taps)));
    let du = ax * width_m / sine / tile;
    let dv = az * width_m / sine / tile;
    var sum = vec3<f32>(0.0);
    for (var i = 0u; i < taps; i++) {
        let s = (f32(i) + 0.5) / f32(taps) - 0.5;
        let tu = u + s * du;
        let tv = v + s * dv;
        sum += mip_trilinear(lod, tu - floor(tu), tv - floor(tv));
    }
    return sum / f32(taps);
}
