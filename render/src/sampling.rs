//! The tracers' random numbers and pixel samples: a 32-bit hash of (pixel, sample, event), the
//! same on the CPU and the GPU, and each sample's stratified offset in its pixel. The twin of
//! `shaders/sampling.wgsl`.

/// A 32-bit integer hash (the PCG output permutation): WGSL has no 64-bit integers, so the
/// tracer's randomness is 32-bit on both sides.
pub fn hash32(x: u32) -> u32 {
    let state = x.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// A deterministic uniform number in [0, 1) for (pixel, sample, event).
pub fn random(pixel: u32, sample: u32, event: u32) -> f32 {
    let bits = hash32(pixel ^ hash32(sample.wrapping_mul(0x9e37_79b9) ^ hash32(event)));
    (bits >> 8) as f32 / (1u32 << 24) as f32
}

/// Where sample `sample` of `samples` goes in pixel `pixel`, as an offset from its corner in
/// [0, 1)^2: sample 0 through the centre; the others stratified, one in each cell of the largest
/// square grid they fill (jittered in it), any left over anywhere at random.
pub fn sample_offset(pixel: u32, sample: u32, samples: u32) -> (f32, f32) {
    if sample == 0 {
        return (0.5, 0.5);
    }
    let (jx, jy) = (random(pixel, sample, 1000), random(pixel, sample, 1001));
    let others = samples - 1;
    let mut n = (others as f32).sqrt() as u32;
    while (n + 1) * (n + 1) <= others {
        n += 1;
    }
    while n * n > others {
        n -= 1;
    }
    let k = sample - 1;
    if k >= n * n {
        return (jx, jy);
    }
    (((k % n) as f32 + jx) / n as f32, ((k / n) as f32 + jy) / n as f32)
}

/// The time of sample `sample` in pixel `pixel` under a shutter open `shutter` frames, in frames
/// from the frame's centre: the samples' base-2 radical inverses (stratified for any count),
/// turned by one random shift per pixel, spread over the open interval.
pub fn sample_time(pixel: u32, sample: u32, shutter: f32) -> f32 {
    let base = sample.reverse_bits() as f32 * (1.0 / 4_294_967_296.0);
    let mut u = base + random(pixel, 0, 1002);
    if u >= 1.0 {
        u -= 1.0;
    }
    shutter * (u - 0.5)
}

/// The radical inverse of `index` in base `base`: its digits mirrored about the point.
fn radical_inverse(mut index: u32, base: u32) -> f32 {
    let (mut value, mut scale) = (0.0f32, 1.0f32);
    let inverse = 1.0 / base as f32;
    while index > 0 {
        scale *= inverse;
        value += (index % base) as f32 * scale;
        index /= base;
    }
    value
}

/// Where sample `sample` in pixel `pixel` passes through the lens, as a point of [0, 1)^2 for
/// [`crate::camera::concentric_disk`]: the sample's base-5 and base-3 radical inverses (a Halton
/// set, apart from the pixel's strata and the times' base 2), turned by one random shift per
/// pixel.
pub fn lens_sample(pixel: u32, sample: u32) -> (f32, f32) {
    let turn = |value: f32, event: u32| {
        let u = value + random(pixel, 0, event);
        if u >= 1.0 { u - 1.0 } else { u }
    };
    (turn(radical_inverse(sample, 5), 1003), turn(radical_inverse(sample, 3), 1004))
}
