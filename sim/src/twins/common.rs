//! Twins of the helpers `common.wgsl` declares for every kernel, and the WGSL vector types as
//! arrays. The structs and constants of `common.wgsl` are [`crate::gpu::wgsl_structs`].

/// A `vec4<f32>`.
pub type V4 = [f32; 4];
/// A `vec4<u32>`.
pub type U4 = [u32; 4];
/// A `vec4<i32>`.
pub type I4 = [i32; 4];

/// `v.xyz`.
pub(super) fn xyz(v: V4) -> [f32; 3] {
    [v[0], v[1], v[2]]
}

/// `a + b` of two `vec3<f32>`.
pub(super) fn add(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `a - b` of two `vec3<f32>`.
pub(super) fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `a * s`, a `vec3<f32>` times a scalar.
pub(super) fn scale(a: [f32; 3], s: f32) -> [f32; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// `dot3`: summed left to right.
pub fn dot3(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `cell_of`: the hash cell of a position, floor(x / cell), saturating.
pub fn cell_of(p: [f32; 3], inverse_cell: f32) -> [i32; 3] {
    p.map(|x| (x * inverse_cell).floor().clamp(-2_147_483_648.0, 2_147_483_520.0) as i32)
}

/// `bucket_of`: the hash bucket of a cell.
pub fn bucket_of(c: [i32; 3], mask: u32) -> u32 {
    let h = (c[0] as u32).wrapping_mul(73_856_093)
        ^ (c[1] as u32).wrapping_mul(19_349_663)
        ^ (c[2] as u32).wrapping_mul(83_492_791);
    h & mask
}

/// `half_kick`: v += dt/2 F / m (w holds 1/m).
pub(super) fn half_kick(v: V4, f: V4, half_dt: f32) -> V4 {
    [v[0] + half_dt * f[0] * v[3], v[1] + half_dt * f[1] * v[3], v[2] + half_dt * f[2] * v[3], v[3]]
}

/// `floor_bounce`.
pub(super) fn floor_bounce(v: V4, rest_y: f32, disp_y: f32, enabled: u32, height: f32, restitution: f32) -> V4 {
    let mut out = v;
    if enabled != 0 && rest_y + disp_y < height && out[1] < 0.0 {
        out[1] *= -restitution;
    }
    out
}
