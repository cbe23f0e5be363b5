// image_loop.rs: every pixel of this dispatch, one per invocation, with its samples.

// image_loop.rs render, for the pixels of this dispatch
@compute @workgroup_size(64)
fn trace(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let local = (wid.x + wid.y * nwg.x) * 64u + lid;
    let first_pixel = bitcast<u32>(params.floor.z);
    let count = bitcast<u32>(params.floor.w);
    if (local >= count) {
        return;
    }
    let pixel = first_pixel + local;
    let width = params.size.x;
    let x = pixel % width;
    let y = pixel / width;
    let samples = params.size.z;
    var sum = vec3<f32>(0.0);
    var alpha = 0.0;
    var out: PixelOut;
    var matte: MatteOut;
    for (var sample = 0u; sample < samples; sample++) {
        let offset = sample_offset(pixel, sample, samples);
        let d = camera_direction(f32(x) + offset.x, f32(y) + offset.y);
        let traced = trace_ray(params.camera_origin.xyz, d, pixel, sample);
        if (sample == 0u) {
            out.normal = vec4<f32>(traced.normal, traced.depth);
            out.ids = vec4<u32>(traced.fragment, traced.element, traced.surface, 0u);
        }
        add_matte_sample(&matte, traced.fragment, traced.surface);
        sum += traced.color;
        alpha += traced.alpha;
    }
    out.color = vec4<f32>(sum / f32(samples), alpha / f32(samples));
    pixels[local] = out;
    mattes[local] = matte;
}
