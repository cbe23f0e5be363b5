// y[i] = clamp(x[i] * scale, lo, hi) for i < n, parameters in a uniform. Test kernel for shatter-gpu.
struct Params {
    scale: f32,
    lo: f32,
    hi: f32,
    n: u32,
}

const WG: u32 = 64u;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> x: array<f32>;
@group(0) @binding(2) var<storage, read_write> y: array<f32>;

@compute @workgroup_size(WG)
fn scale_clamp(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = (wid.x + wid.y * nwg.x) * WG + lid;
    if (i >= params.n) {
        return;
    }
    y[i] = clamp(x[i] * params.scale, params.lo, params.hi);
}
