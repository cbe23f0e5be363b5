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
    var albedo = vec3<f32>(0.0);
    var guide_normal = vec3<f32>(0.0);
    var out: PixelOut;
    var matte: MatteOut;
    for (var sample = 0u; sample < samples; sample++) {
        let offset = sample_offset(pixel, sample, samples);
        // through a lens each sample from its own point of it; the pinhole's ray otherwise
        let has_lens = params.camera_origin.w != 0.0;
        let lens = lens_sample(pixel, sample);
        let ray = lens_ray(f32(x) + offset.x, f32(y) + offset.y, concentric_disk(lens.x, lens.y));
        let origin = ray.origin;
        let d = ray.direction;
        // with motion over the shutter, the colour at the sample's time and the layers at the centre's
        let moving = params.shutter.x != 0.0;
        let time = select(0.0, sample_time(pixel, sample, params.shutter.x), moving);
        let traced = trace_ray(origin, d, pixel, sample, time);
        var layers = traced;
        if (moving) {
            layers = first_layers(origin, d, closest_hit(origin, d, 0.0, 0.0));
        }
        if (sample == 0u) {
            // through a lens, the layers are the pinhole's through the pixel centre
            var first = layers;
            if (has_lens) {
                let o = params.camera_origin.xyz;
                let pinhole = camera_direction(f32(x) + 0.5, f32(y) + 0.5);
                first = first_layers(o, pinhole, closest_hit(o, pinhole, 0.0, 0.0));
            }
            out.normal = vec4<f32>(first.normal, first.depth);
            out.ids = vec4<u32>(first.fragment, first.element, first.surface, 0u);
        }
        add_matte_sample(&matte, layers.fragment, layers.surface);
        sum += traced.color;
        alpha += traced.alpha;
        albedo += traced.denoising_albedo;
        guide_normal += traced.denoising_normal;
    }
    out.color = vec4<f32>(sum / f32(samples), alpha / f32(samples));
    out.denoising_albedo = vec4<f32>(albedo / f32(samples), 0.0);
    out.denoising_normal = vec4<f32>(guide_normal / f32(samples), 0.0);
    pixels[local] = out;
    mattes[local] = matte;
}
