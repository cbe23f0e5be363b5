//! The GPU ray tracer: uploads a frame's scene and look, runs the WGSL twins in `shaders/` (one pixel per
//! invocation, in batches of pixels so no single dispatch runs long), reads the pixels back.
//! The twin of [`crate::image_loop::render`].

use bytemuck::{Pod, Zeroable};
use shatter_core::particles::ElementType;
use shatter_gpu::{ComputeKernel, GpuContext, GpuError, join_wgsl, wgpu};

use crate::camera::Camera;
use crate::element_kdtree::KdTree;
use crate::image_loop::Rendered;
use crate::integrator::Pixel;
use crate::materials::{FloorLook, Look};
use crate::mattes::MatteCounts;
use crate::primitives::TRIANGLE_GROUP;
use crate::scene_geometry::SceneGeometry;
use crate::shutter::GroupMotion;

/// The tracer's WGSL parts (`render/shaders/`): the bindings, then each the twin of the CPU module
/// of its name, joined into one program whose entry point is the image loop's.
const PARTS: [&str; 14] = [
    include_str!("../shaders/bindings.wgsl"),
    include_str!("../shaders/primitives.wgsl"),
    include_str!("../shaders/scene_geometry.wgsl"),
    include_str!("../shaders/element_kdtree.wgsl"),
    include_str!("../shaders/shutter.wgsl"),
    include_str!("../shaders/hit_search.wgsl"),
    include_str!("../shaders/sampling.wgsl"),
    include_str!("../shaders/camera.wgsl"),
    include_str!("../shaders/lighting.wgsl"),
    include_str!("../shaders/texture_filter.wgsl"),
    include_str!("../shaders/shading.wgsl"),
    include_str!("../shaders/mattes.wgsl"),
    include_str!("../shaders/integrator.wgsl"),
    include_str!("../shaders/image_loop.wgsl"),
];
/// Pixels per dispatch: a multiple of 16 so every batch's output starts at a bindable offset.
const BATCH_PIXELS: u32 = 1 << 16;

/// The shader's `Params` (see shaders/bindings.wgsl for the meaning of each lane).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct Params {
    camera_origin: [f32; 4],
    camera_forward: [f32; 4],
    camera_right: [f32; 4],
    camera_up: [f32; 4],
    size: [u32; 4],
    counts: [u32; 4],
    flags: [u32; 4],
    scene_min: [f32; 4],
    scene_max: [f32; 4],
    absorption: [f32; 4],
    albedo: [f32; 4],
    floor: [f32; 4],
    key_direction: [f32; 4],
    key_irradiance: [f32; 4],
    sh: [[f32; 4]; 9],
    fracture_albedo: [f32; 4],
    look_flags: [u32; 4],
    shutter: [f32; 4],
}

/// The shader's `PixelOut`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct PixelOut {
    color: [f32; 4],
    normal: [f32; 4],
    ids: [u32; 4],
    denoising_albedo: [f32; 4],
    denoising_normal: [f32; 4],
}

fn vec4(v: [f32; 3], w: f32) -> [f32; 4] {
    [v[0], v[1], v[2], w]
}

/// `v`, or one zero where it is empty (a binding cannot be empty).
fn non_empty_u32(v: &[u32]) -> &[u32] {
    if v.is_empty() { &[0] } else { v }
}

/// A compiled tracer on one GPU.
pub struct GpuTracer {
    kernel: ComputeKernel,
}

impl GpuTracer {
    /// Compiles the tracer for `ctx`.
    pub fn new(ctx: &GpuContext) -> Result<GpuTracer, GpuError> {
        let triangle_group = format!("const TRIANGLE_GROUP: u32 = {TRIANGLE_GROUP}u;");
        let source = join_wgsl(&[&[triangle_group.as_str()], &PARTS[..]].concat());
        Ok(GpuTracer { kernel: ComputeKernel::new(ctx, "render/shaders (the tracer)", &source)? })
    }

    /// Traces every pixel of `camera`'s image with `samples` samples each, like
    /// [`crate::image_loop::render`].
    pub fn render(
        &self,
        ctx: &GpuContext,
        scene: &SceneGeometry,
        look: &Look,
        camera: &Camera,
        samples: u32,
    ) -> Result<Rendered, GpuError> {
        // The shaders walk one world tree (the CPU's index of a frame's fragments is not theirs).
        let built;
        let tree = match scene.index.world_tree() {
            Some(tree) => tree,
            None => {
                built = KdTree::build(&scene.element_bounds);
                &built
            }
        };
        let total = camera.width * camera.height;
        let mut params = Params::new(scene, look, camera, samples, tree);
        let buffers = TraceBuffers::upload(ctx, scene, look, tree, &params, total)?;
        let mut first = 0u32;
        while first < total {
            let count = BATCH_PIXELS.min(total - first);
            params.floor[2] = f32::from_bits(first);
            params.floor[3] = f32::from_bits(count);
            ctx.write_buffer(&buffers.params, 0, std::slice::from_ref(&params))?;
            let group = self.kernel.bind_group(ctx, 0, &buffers.batch_bindings(first, count))?;
            self.kernel.dispatch_invocations(ctx, &[&group], u64::from(count))?;
            first += count;
        }
        buffers.read_pixels(ctx, total)
    }
}

impl Params {
    /// The parameters of a render of `scene` (walking `tree`) in `look` through `camera`, with
    /// `samples` samples a pixel; the batch's pixels (`floor`'s last two lanes) still unset.
    fn new(scene: &SceneGeometry, look: &Look, camera: &Camera, samples: u32, tree: &KdTree) -> Params {
        let floor_size = look.floor.as_ref().map_or([1, 1], |floor| floor.size);
        let mips = look.floor.as_ref().and_then(|floor| floor.mips.as_ref());
        let element_type = match scene.element_type {
            ElementType::Cube => 0,
            ElementType::Tet => 1,
            ElementType::Trimtope => 2,
        };
        Params {
            camera_origin: vec4(camera.origin, camera.lens.map_or(0.0, |lens| lens.radius_m)),
            camera_forward: vec4(camera.forward, camera.lens.map_or(0.0, |lens| lens.focus_distance_m)),
            camera_right: vec4(camera.right, 0.0),
            camera_up: vec4(camera.up, 0.0),
            size: [camera.width, camera.height, samples, look.max_bounces],
            counts: [scene.len() as u32, element_type, look.environment.width as u32, look.environment.height as u32],
            flags: [
                floor_size[0] as u32,
                floor_size[1] as u32,
                u32::from(look.floor.is_some()),
                u32::from(look.show_environment),
            ],
            scene_min: vec4(tree.bounds.min, scene.slack),
            scene_max: vec4(tree.bounds.max, look.ior),
            absorption: vec4(look.absorption, look.specular),
            albedo: vec4(look.albedo, look.shininess),
            floor: [
                look.floor.as_ref().map_or(0.0, |f| f.height),
                look.floor.as_ref().map_or(1.0, |f| f.tile),
                0.0,
                0.0,
            ],
            key_direction: vec4(look.key.direction, 0.0),
            key_irradiance: vec4(look.key.irradiance, 0.0),
            sh: look.sh.map(|c| vec4(c, 0.0)),
            fracture_albedo: vec4(look.fracture_albedo, 0.0),
            look_flags: [
                look.glass_split_events,
                u32::from(look.opaque_cubes),
                u32::from(mips.is_some()),
                mips.map_or(0, |mips| mips.levels.len() as u32),
            ],
            shutter: [scene.motion.as_ref().map_or(0.0, |motion| motion.shutter), camera.pixel_spread_rad(), 0.0, 0.0],
        }
    }
}

/// A render's buffers on the GPU: the parameters, the scene and look uploaded, and the pixels'
/// outputs.
struct TraceBuffers {
    params: wgpu::Buffer,
    nodes: wgpu::Buffer,
    items: wgpu::Buffer,
    plane_offsets: wgpu::Buffer,
    planes: wgpu::Buffer,
    triangle_offsets: wgpu::Buffer,
    triangles: wgpu::Buffer,
    triangle_group_offsets: wgpu::Buffer,
    triangle_groups: wgpu::Buffer,
    sites: wgpu::Buffer,
    /// A trimtope's bounds (min, max: [`SceneGeometry::element_bounds`]); one zero for other elements.
    element_bounds: wgpu::Buffer,
    interior_faces: wgpu::Buffer,
    face_neighbours: wgpu::Buffer,
    /// [`crate::shutter::SceneMotion`]'s groups of the elements, and the groups' motions.
    motion_groups: wgpu::Buffer,
    group_motions: wgpu::Buffer,
    fragments: wgpu::Buffer,
    environment: wgpu::Buffer,
    floor_texels: wgpu::Buffer,
    /// `PixelOut` per pixel.
    pixels: wgpu::Buffer,
    /// `MatteCounts` per pixel.
    mattes: wgpu::Buffer,
}

/// Bytes of one pixel's output.
const PIXEL_BYTES: u64 = std::mem::size_of::<PixelOut>() as u64;
/// Bytes of one pixel's matte counts.
const MATTE_BYTES: u64 = std::mem::size_of::<MatteCounts>() as u64;

impl TraceBuffers {
    /// Uploads `scene` (walking `tree`), `look` and `params`, and makes room for `total` pixels.
    fn upload(
        ctx: &GpuContext,
        scene: &SceneGeometry,
        look: &Look,
        tree: &KdTree,
        params: &Params,
        total: u32,
    ) -> Result<TraceBuffers, GpuError> {
        // an empty array as one zero element (a binding cannot be empty)
        let non_empty = |v: Vec<[f32; 4]>| if v.is_empty() { vec![[0.0; 4]] } else { v };
        let nodes = ctx.create_storage_buffer("kd nodes", &tree.nodes)?;
        let items = ctx.create_storage_buffer("kd items", non_empty_u32(&tree.items))?;
        let plane_offsets = ctx.create_storage_buffer("plane offsets", &scene.plane_offsets)?;
        let planes = ctx.create_storage_buffer("planes", &non_empty(scene.planes.clone()))?;
        let triangle_offsets = ctx.create_storage_buffer("triangle offsets", &scene.triangle_offsets)?;
        let triangles: Vec<[f32; 4]> = scene.triangles.iter().flat_map(|t| t.map(|v| vec4(v, 0.0))).collect();
        let triangles = ctx.create_storage_buffer("triangles", &non_empty(triangles))?;
        let triangle_group_offsets =
            ctx.create_storage_buffer("triangle group offsets", &scene.triangle_group_offsets)?;
        let triangle_groups: Vec<[f32; 4]> =
            scene.triangle_groups.iter().flat_map(|b| [vec4(b.min, 0.0), vec4(b.max, 0.0)]).collect();
        let triangle_groups = ctx.create_storage_buffer("triangle groups", &non_empty(triangle_groups))?;
        let sites: Vec<[f32; 4]> = scene.sites.iter().map(|s| vec4(*s, 0.0)).collect();
        let sites = ctx.create_storage_buffer("sites", &non_empty(sites))?;
        let element_bounds: Vec<[f32; 4]> = match scene.element_type {
            ElementType::Trimtope => {
                scene.element_bounds.iter().flat_map(|b| [vec4(b.min, 0.0), vec4(b.max, 0.0)]).collect()
            }
            _ => Vec::new(),
        };
        let element_bounds = ctx.create_storage_buffer("element bounds", &non_empty(element_bounds))?;
        let interior_faces = ctx.create_storage_buffer("interior faces", non_empty_u32(&scene.interior_faces))?;
        let face_neighbours = ctx.create_storage_buffer("face neighbours", non_empty_u32(&scene.face_neighbours))?;
        let fragments = ctx.create_storage_buffer("fragments", non_empty_u32(&scene.fragment))?;
        let (motion_groups, group_motions) = match &scene.motion {
            Some(motion) => (
                ctx.create_storage_buffer("motion groups", non_empty_u32(&motion.group_of))?,
                ctx.create_storage_buffer("group motions", &motion.groups)?,
            ),
            None => (
                ctx.create_storage_buffer("motion groups", &[0u32])?,
                ctx.create_storage_buffer("group motions", &[GroupMotion::zeroed()])?,
            ),
        };
        let environment: Vec<[f32; 4]> = look.environment.texels.iter().map(|t| vec4(*t, 0.0)).collect();
        let environment = ctx.create_storage_buffer("environment", &environment)?;
        let floor_texels = match &look.floor {
            Some(FloorLook { mips: Some(mips), .. }) => mips.texels.iter().map(|t| vec4(*t, 0.0)).collect(),
            Some(floor) => (0..floor.texels.len()).map(|i| vec4(floor.texels.linear_at(i), 0.0)).collect(),
            None => vec![[0.0; 4]],
        };
        let floor_texels = ctx.create_storage_buffer("floor texture", &floor_texels)?;
        let params = ctx.create_uniform_buffer("trace params", params)?;
        let pixels = ctx.create_zeroed_storage_buffer("pixels", u64::from(total.max(1)) * PIXEL_BYTES)?;
        let mattes = ctx.create_zeroed_storage_buffer("mattes", u64::from(total.max(1)) * MATTE_BYTES)?;
        Ok(TraceBuffers {
            params,
            nodes,
            items,
            plane_offsets,
            planes,
            triangle_offsets,
            triangles,
            triangle_group_offsets,
            triangle_groups,
            sites,
            element_bounds,
            interior_faces,
            face_neighbours,
            motion_groups,
            group_motions,
            fragments,
            environment,
            floor_texels,
            pixels,
            mattes,
        })
    }

    /// The bindings of the batch of `count` pixels from pixel `first`, in the order of
    /// shaders/bindings.wgsl: the outputs are the batch's slices.
    fn batch_bindings(&self, first: u32, count: u32) -> [wgpu::BindingResource<'_>; 20] {
        let slice = |buffer, bytes: u64| {
            wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer,
                offset: u64::from(first) * bytes,
                size: wgpu::BufferSize::new(u64::from(count) * bytes),
            })
        };
        [
            self.params.as_entire_binding(),
            self.nodes.as_entire_binding(),
            self.items.as_entire_binding(),
            self.plane_offsets.as_entire_binding(),
            self.planes.as_entire_binding(),
            self.triangle_offsets.as_entire_binding(),
            self.triangles.as_entire_binding(),
            self.sites.as_entire_binding(),
            self.fragments.as_entire_binding(),
            self.environment.as_entire_binding(),
            self.floor_texels.as_entire_binding(),
            slice(&self.pixels, PIXEL_BYTES),
            self.triangle_group_offsets.as_entire_binding(),
            self.triangle_groups.as_entire_binding(),
            self.interior_faces.as_entire_binding(),
            slice(&self.mattes, MATTE_BYTES),
            self.face_neighbours.as_entire_binding(),
            self.motion_groups.as_entire_binding(),
            self.group_motions.as_entire_binding(),
            self.element_bounds.as_entire_binding(),
        ]
    }

    /// Reads back the `total` pixels and their matte counts.
    fn read_pixels(&self, ctx: &GpuContext, total: u32) -> Result<Rendered, GpuError> {
        let out: Vec<PixelOut> = ctx.read_buffer(&self.pixels, total as usize)?;
        let mattes: Vec<MatteCounts> = ctx.read_buffer(&self.mattes, total as usize)?;
        let pixels = out
            .iter()
            .map(|p| Pixel {
                color: [p.color[0], p.color[1], p.color[2]],
                alpha: p.color[3],
                depth: p.normal[3],
                normal: [p.normal[0], p.normal[1], p.normal[2]],
                fragment: p.ids[0],
                element: p.ids[1],
                surface: p.ids[2],
                denoising_albedo: [p.denoising_albedo[0], p.denoising_albedo[1], p.denoising_albedo[2]],
                denoising_normal: [p.denoising_normal[0], p.denoising_normal[1], p.denoising_normal[2]],
            })
            .collect();
        Ok(Rendered { pixels, mattes })
    }
}
