// The tracer's constants, its parameters and outputs as the host lays them out (gpu_trace.rs's
// Params, PixelOut and the matte counts it reads back), and its bindings. Every other file in this
// folder is the twin of the CPU module of its name in render/src/; gpu_trace.rs joins them.

const NONE: u32 = 0xffffffffu;
const PI: f32 = 3.14159265358979;
const WG: u32 = 8u;
struct Params {
    // eye; w = the lens's radius (0: a pinhole)
    camera_origin: vec4<f32>,
    // unit view direction; w = the lens's focus distance
    camera_forward: vec4<f32>,
    camera_right: vec4<f32>,
    camera_up: vec4<f32>,
    // width, height, samples per pixel, max bounces
    size: vec4<u32>,
    // elements, element type (0 cube, 1 tet, 2 trimtope), environment width, environment height
    counts: vec4<u32>,
    // floor texture width, height, has floor, show environment
    flags: vec4<u32>,
    // k-d tree bounds; min.w = slack, max.w = index of refraction
    scene_min: vec4<f32>,
    scene_max: vec4<f32>,
    // glass absorption per metre; w = highlight strength
    absorption: vec4<f32>,
    // opaque albedo; w = highlight exponent
    albedo: vec4<f32>,
    // floor height, tile size, first pixel of this dispatch, pixels in this dispatch (bits)
    floor: vec4<f32>,
    key_direction: vec4<f32>,
    key_irradiance: vec4<f32>,
    sh: array<vec4<f32>, 9>,
    // opaque albedo of fracture faces; w unused
    fracture_albedo: vec4<f32>,
    // glass split events, opaque cubes (1) or glass (0), floor texture filtered (1) or point
    // sampled (0), its mip levels
    look_flags: vec4<u32>,
    // the shutter's open time in frames where the scene moves over it (else 0); a pixel's spread,
    // radians; z, w unused
    shutter: vec4<f32>,
}

struct PixelOut {
    color: vec4<f32>,   // rgb, alpha
    normal: vec4<f32>,  // xyz, w = depth
    ids: vec4<u32>,     // fragment + 1, element, surface kind, 0
    denoising_albedo: vec4<f32>,  // rgb, 0
    denoising_normal: vec4<f32>,  // xyz, 0
}

// mattes.rs MatteCounts
struct MatteOut {
    fragments: array<vec2<u32>, 8>,  // (fragment + 1, samples), in order of first appearance
    surfaces: vec4<u32>,             // outer, fracture, floor, samples
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> nodes: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read> items: array<u32>;
@group(0) @binding(3) var<storage, read> plane_offsets: array<u32>;
@group(0) @binding(4) var<storage, read> planes: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> triangle_offsets: array<u32>;
@group(0) @binding(6) var<storage, read> triangles: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> sites: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read> fragments: array<u32>;
@group(0) @binding(9) var<storage, read> environment: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read> floor_texels: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read_write> pixels: array<PixelOut>;
@group(0) @binding(12) var<storage, read> triangle_group_offsets: array<u32>;
// per group of TRIANGLE_GROUP triangles (a constant the host prepends): min, then max corner
@group(0) @binding(13) var<storage, read> triangle_groups: array<vec4<f32>>;
// face_seams.rs interior_faces: per element, bit k set when plane k rested against another element
@group(0) @binding(14) var<storage, read> interior_faces: array<u32>;
@group(0) @binding(15) var<storage, read_write> mattes: array<MatteOut>;
// face_seams.rs face_neighbours: parallel to planes, the element that rested against each plane, or NONE
@group(0) @binding(16) var<storage, read> face_neighbours: array<u32>;
// shutter.rs SceneMotion: each element's group, and each group's GroupMotion as five vec4
@group(0) @binding(17) var<storage, read> motion_groups: array<u32>;
@group(0) @binding(18) var<storage, read> group_motions: array<vec4<f32>>;
// per trimtope: min, then max corner of the part of its cell inside the surface (one zero for
// other elements)
@group(0) @binding(19) var<storage, read> element_bounds: array<vec4<f32>>;

fn infinity() -> f32 {
    return bitcast<f32>(0x7f800000u);
}
