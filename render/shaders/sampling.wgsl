// sampling.rs: the tracers' random numbers and pixel samples.

// sampling.rs hash32 and random
fn hash32(x: u32) -> u32 {
    let state = x * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn random(pixel: u32, sample: u32, event: u32) -> f32 {
    let bits = hash32(pixel ^ hash32((sample * 0x9e3779b9u) ^ hash32(event)));
    return f32(bits >> 8u) / 16777216.0;
}

// sampling.rs sample_offset
fn sample_offset(pixel: u32, sample: u32, samples: u32) -> vec2<f32> {
    if (sample == 0u) {
        return vec2<f32>(0.5, 0.5);
    }
    let jx = random(pixel, sample, 1000u);
    let jy = random(pixel, sample, 1001u);
    let others = samples - 1u;
    var n = u32(sqrt(f32(others)));
    while ((n + 1u) * (n + 1u) <= others) {
        n += 1u;
    }
    while (n * n > others) {
        n -= 1u;
    }
    let k = sample - 1u;
    if (k >= n * n) {
        return vec2<f32>(jx, jy);
    }
    return vec2<f32>((f32(k % n) + jx) / f32(n), (f32(k / n) + jy) / f32(n));
}

// sampling.rs sample_time
fn sample_time(pixel: u32, sample: u32, shutter: f32) -> f32 {
    let base = f32(reverseBits(sample)) * (1.0 / 4294967296.0);
    var u = base + random(pixel, 0u, 1002u);
    if (u >= 1.0) {
        u -= 1.0;
    }
    return shutter * (u - 0.5);
}

// sampling.rs radical_inverse
fn radical_inverse(index: u32, base: u32) -> f32 {
    var i = index;
    var value = 0.0;
    var scale = 1.0;
    let inverse = 1.0 / f32(base);
    while (i > 0u) {
        scale *= inverse;
        value += f32(i % base) * scale;
        i /= base;
    }
    return value;
}

// sampling.rs lens_sample
fn lens_sample(pixel: u32, sample: u32) -> vec2<f32> {
    var u = radical_inverse(sample, 5u) + random(pixel, 0u, 1003u);
    var v = radical_inverse(sample, 3u) + random(pixel, 0u, 1004u);
    if (u >= 1.0) {
        u -= 1.0;
    }
    if (v >= 1.0) {
        v -= 1.0;
    }
    return vec2<f32>(u, v);
}
