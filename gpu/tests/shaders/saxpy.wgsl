// y[i] = A * x[i] + y[i], with A a shader constant. Test kernel for shatter-gpu.
const A: f32 = 1.7;
const WG: u32 = 64u;

@group(0) @binding(0) var<storage, read> x: array<f32>;
@group(0) @binding(1) var<storage, read_write> y: array<f32>;

@compute @workgroup_size(WG)
fn saxpy(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = (wid.x + wid.y * nwg.x) * WG + lid;
    if (i >= arrayLength(&y)) {
        return;
    }
    y[i] = A * x[i] + y[i];
}
