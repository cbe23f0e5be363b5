//! shatter-gpu on a real adapter (lavapipe in CI): kernels against their CPU twins, readback, binding
//! splitting, 2D dispatch, adapter choice and error reporting.

use bytemuck::{Pod, Zeroable};
use shatter_gpu::{AdapterChoice, ComputeKernel, GpuContext, GpuError};

const SAXPY: &str = include_str!("shaders/saxpy.wgsl");
const SCALE_CLAMP: &str = include_str!("shaders/scale_clamp.wgsl");
const INDEX_HASH: &str = include_str!("shaders/index_hash.wgsl");

fn gpu() -> &'static GpuContext {
    GpuContext::shared_for_tests().unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"))
}

/// splitmix64: a tiny deterministic generator for test inputs.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [-1000, 1000): normal numbers (and zero), far from the denormal range, whose products and
    /// sums stay normal, so flush-to-zero modes cannot matter.
    fn f32(&mut self) -> f32 {
        let unit = (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32;
        unit * 2000.0 - 1000.0
    }
}

fn random_f32s(seed: u64, n: usize) -> Vec<f32> {
    let mut rng = Rng(seed);
    (0..n).map(|_| rng.f32()).collect()
}

// ---- CPU twins -------------------------------------------------------------------------------------------

const SAXPY_A: f32 = 1.7;

/// CPU twin of saxpy.wgsl, unfused: `a * x + y` rounds twice.
fn saxpy_cpu(x: &[f32], y: &mut [f32]) {
    for (yi, &xi) in y.iter_mut().zip(x) {
        *yi += SAXPY_A * xi; // = a * x + y: IEEE addition commutes
    }
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ScaleClampParams {
    scale: f32,
    lo: f32,
    hi: f32,
    n: u32,
}

/// CPU twin of scale_clamp.wgsl.
fn scale_clamp_cpu(p: &ScaleClampParams, x: &[f32], y: &mut [f32]) {
    for (yi, &xi) in y.iter_mut().zip(x).take(p.n as usize) {
        *yi = (xi * p.scale).clamp(p.lo, p.hi);
    }
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct IndexHashParams {
    first: u32,
    n: u32,
    seed: u32,
    pad: u32,
}

/// CPU twin of index_hash.wgsl's `hash`.
fn hash(v: u32) -> u32 {
    let mut x = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    x = ((x >> ((x >> 28) + 4)) ^ x).wrapping_mul(277_803_737);
    (x >> 22) ^ x
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|f| f.to_bits()).collect()
}

fn run_saxpy(ctx: &GpuContext, kernel: &ComputeKernel, x: &[f32], y: &[f32]) -> Vec<f32> {
    let xb = ctx.create_storage_buffer("x", x).expect("x buffer");
    let yb = ctx.create_storage_buffer("y", y).expect("y buffer");
    let group = kernel.bind_buffers(ctx, 0, &[&xb, &yb]).expect("bind group");
    kernel.dispatch_invocations(ctx, &[&group], y.len() as u64).expect("dispatch");
    ctx.read_buffer(&yb, y.len()).expect("readback")
}

// ---- kernels vs. CPU twins ----------------------------------------------------------------------------------

#[test]
fn saxpy_matches_cpu_twin_bitwise() {
    let ctx = gpu();
    let kernel = ComputeKernel::new(ctx, "saxpy.wgsl", SAXPY).expect("saxpy compiles");
    assert_eq!(kernel.workgroup_size(), [64, 1, 1]);
    assert_eq!(kernel.entry_point(), "saxpy");

    let n = 100_003; // not a multiple of the workgroup size
    let x = random_f32s(1, n);
    let y = random_f32s(2, n);
    let gpu_y = run_saxpy(ctx, &kernel, &x, &y);

    let mut cpu_y = y.clone();
    saxpy_cpu(&x, &mut cpu_y);
    // The WGSL is `A * x + y`. Vulkan drivers may contract it into one fused multiply-add, which rounds once;
    // so each element must equal, bit for bit, either the unfused CPU result or the fused one.
    let mut fused = 0usize;
    for i in 0..n {
        let g = gpu_y[i].to_bits();
        if g == cpu_y[i].to_bits() {
            continue;
        }
        assert_eq!(g, SAXPY_A.mul_add(x[i], y[i]).to_bits(), "element {i}: x {} y {} gpu {}", x[i], y[i], gpu_y[i]);
        fused += 1;
    }
    eprintln!("saxpy on {}: {fused} of {n} elements matched only the fused (FMA) CPU result", ctx.describe());
}

#[test]
fn uniform_kernel_matches_cpu_twin_bitwise_and_respects_n() {
    let ctx = gpu();
    let kernel = ComputeKernel::new(ctx, "scale_clamp.wgsl", SCALE_CLAMP).expect("scale_clamp compiles");
    let len = 50_000;
    let params = ScaleClampParams { scale: -0.37, lo: -150.0, hi: 200.5, n: 49_990 };
    let x = random_f32s(3, len);
    let sentinel = vec![f32::from_bits(0x7F7F_0001); len];

    let pb = ctx.create_uniform_buffer("params", &params).expect("uniform");
    let xb = ctx.create_storage_buffer("x", &x).expect("x");
    let yb = ctx.create_storage_buffer("y", &sentinel).expect("y");
    let group = kernel.bind_buffers(ctx, 0, &[&pb, &xb, &yb]).expect("bind group");
    kernel.dispatch_invocations(ctx, &[&group], u64::from(params.n)).expect("dispatch");
    let gpu_y: Vec<f32> = ctx.read_buffer(&yb, len).expect("readback");

    let mut cpu_y = sentinel.clone();
    scale_clamp_cpu(&params, &x, &mut cpu_y);
    // One rounding (the product) and exact min/max: identical on any IEEE-754 implementation.
    assert_eq!(bits(&gpu_y), bits(&cpu_y));

    // Update the uniform in place and run again.
    let params2 = ScaleClampParams { scale: 3.25, lo: -10.0, hi: 10.0, n: len as u32 };
    ctx.write_buffer(&pb, 0, &[params2]).expect("write uniform");
    kernel.dispatch_invocations(ctx, &[&group], u64::from(params2.n)).expect("dispatch");
    let gpu_y: Vec<f32> = ctx.read_buffer(&yb, len).expect("readback");
    scale_clamp_cpu(&params2, &x, &mut cpu_y);
    assert_eq!(bits(&gpu_y), bits(&cpu_y));
}

#[test]
fn readback_is_deterministic_run_to_run() {
    let ctx = gpu();
    let kernel = ComputeKernel::new(ctx, "saxpy.wgsl", SAXPY).expect("saxpy compiles");
    let x = random_f32s(4, 20_000);
    let y = random_f32s(5, 20_000);
    let first = bits(&run_saxpy(ctx, &kernel, &x, &y));
    for _ in 0..3 {
        assert_eq!(bits(&run_saxpy(ctx, &kernel, &x, &y)), first);
    }
}

// ---- dispatch grid ------------------------------------------------------------------------------------------

#[test]
fn dispatch_beyond_one_dimension_uses_a_2d_grid() {
    let ctx = gpu();
    // One invocation per workgroup, so the workgroup count exceeds the per-dimension limit cheaply.
    let source = INDEX_HASH.replace("const WG: u32 = 64u;", "const WG: u32 = 1u;");
    let kernel = ComputeKernel::new(ctx, "index_hash_wg1.wgsl", &source).expect("compiles");
    assert_eq!(kernel.invocations_per_workgroup(), 1);

    let max = ctx.limits.max_compute_workgroups_per_dimension;
    let n = max as usize + 1234;
    let grid = ctx.dispatch_grid(n as u64).expect("fits in 2D");
    assert!(grid.y >= 2, "{grid:?} should need a second row");

    let sentinel = 0xDEAD_BEEFu32;
    let out = ctx.create_storage_buffer("out", &vec![sentinel; n + 100]).expect("out");
    let params = IndexHashParams { first: 0, n: n as u32, seed: 77, pad: 0 };
    let pb = ctx.create_uniform_buffer("params", &params).expect("uniform");
    let group = kernel.bind_buffers(ctx, 0, &[&pb, &out]).expect("bind group");
    kernel.dispatch(ctx, &[&group], n as u64).expect("dispatch");

    let got: Vec<u32> = ctx.read_buffer(&out, n + 100).expect("readback");
    for (i, &g) in got.iter().enumerate().take(n) {
        assert_eq!(g, hash(i as u32 ^ 77), "element {i}");
    }
    assert!(got[n..].iter().all(|&g| g == sentinel), "the grid's overshoot must not write past n");
}

// ---- binding splitting and chunked readback ---------------------------------------------------------------

/// Fills `len` u32s of `out` with `hash(i ^ seed)`, one dispatch per binding chunk of at most `max_binding`
/// bytes, each chunk bound at its own offset of the one buffer.
fn fill_by_chunks(
    ctx: &GpuContext,
    kernel: &ComputeKernel,
    out: &wgpu::Buffer,
    len: usize,
    max_binding: u64,
    seed: u32,
) -> usize {
    let align = u64::from(ctx.limits.min_storage_buffer_offset_alignment);
    let chunks = shatter_gpu::split_for_binding(len, 4, max_binding, align).expect("split");
    for chunk in &chunks {
        assert_eq!(chunk.byte_offset % align, 0);
        assert!(chunk.binding_size() <= max_binding);
        let params = IndexHashParams { first: chunk.first as u32, n: chunk.len as u32, seed, pad: 0 };
        let pb = ctx.create_uniform_buffer("params", &params).expect("uniform");
        let group = kernel.bind_group(ctx, 0, &[pb.as_entire_binding(), chunk.binding(out)]).expect("bind group");
        kernel.dispatch_invocations(ctx, &[&group], chunk.len as u64).expect("dispatch");
    }
    chunks.len()
}

use shatter_gpu::wgpu;

#[test]
fn chunked_bindings_and_chunked_readback_cover_a_buffer_exactly() {
    let ctx = gpu();
    let kernel = ComputeKernel::new(ctx, "index_hash.wgsl", INDEX_HASH).expect("compiles");
    let len = 300_001;
    let out = ctx.create_zeroed_storage_buffer("out", len as u64 * 4).expect("out");

    // A fake binding limit far below the device's, not a multiple of the alignment.
    let fake_limit = 64 * 1024 + 100;
    let n_chunks = fill_by_chunks(ctx, &kernel, &out, len, fake_limit, 9);
    assert!(n_chunks >= 18, "{n_chunks} chunks");

    let expected: Vec<u32> = (0..len as u32).map(|i| hash(i ^ 9)).collect();
    // Staging chunk that divides nothing evenly: many rounds, a partial last one.
    let got: Vec<u32> = ctx.read_buffer_range_chunked(&out, 0, len, 40_004).expect("chunked readback");
    assert_eq!(got, expected);
    // The default path and an offset sub-range agree.
    assert_eq!(ctx.read_buffer::<u32>(&out, len).expect("readback"), expected);
    let mid: Vec<u32> = ctx.read_buffer_range_chunked(&out, 4 * 123_457, 50_000, 4096).expect("range");
    assert_eq!(mid, expected[123_457..173_457]);
}

#[test]
fn device_binding_limit_is_respected_for_a_buffer_larger_than_one_binding() {
    let ctx = gpu();
    let max_binding = ctx.max_storage_binding_bytes();
    // Only where a buffer past the binding limit is cheap (lavapipe: 128 MiB); real GPUs allow GiBs.
    let bytes = max_binding + 4 * 1024 * 1024;
    if max_binding > 256 * 1024 * 1024 || bytes > ctx.limits.max_buffer_size {
        eprintln!("skipped: binding limit {max_binding} B is too large to exceed cheaply on {}", ctx.describe());
        return;
    }
    let len = (bytes / 4) as usize;
    let kernel = ComputeKernel::new(ctx, "index_hash.wgsl", INDEX_HASH).expect("compiles");
    let out = ctx.create_zeroed_storage_buffer("big out", bytes).expect("big buffer");
    let chunks = ctx.binding_chunks::<u32>(len).expect("split");
    assert_eq!(chunks.len(), 2);
    assert_eq!(fill_by_chunks(ctx, &kernel, &out, len, max_binding, 5), 2);

    let got: Vec<u32> = ctx.read_buffer(&out, len).expect("readback");
    let bad = got.iter().enumerate().find(|&(i, &g)| g != hash(i as u32 ^ 5));
    assert!(bad.is_none(), "first mismatch {bad:?}");
}

// ---- adapter choice -----------------------------------------------------------------------------------------

#[test]
fn hardware_only_fails_helpfully_without_a_hardware_gpu() {
    let adapters = shatter_gpu::enumerate_adapters();
    for a in &adapters {
        eprintln!("adapter: {}", shatter_gpu::describe_adapter(a));
    }
    let has_hardware = adapters.iter().any(|a| !shatter_gpu::is_software_adapter(a));
    match GpuContext::new(AdapterChoice::HardwareOnly) {
        Ok(ctx) => {
            assert!(has_hardware, "got {} although no hardware adapter was enumerated", ctx.describe());
            assert!(!ctx.is_software());
        }
        Err(e) => {
            let msg = e.to_string();
            eprintln!("{msg}");
            assert!(
                matches!(&e, GpuError::NoAdapter { choice: AdapterChoice::HardwareOnly, .. }),
                "unexpected error: {msg}"
            );
            assert!(!has_hardware || std::env::var_os(shatter_gpu::ENV_ADAPTER_NAME).is_some(), "{msg}");
            assert!(msg.contains("no hardware GPU adapter found"), "{msg}");
            assert!(msg.contains(shatter_gpu::ENV_ALLOW_SOFTWARE), "{msg}");
            assert!(msg.contains("--backend cpu"), "{msg}");
            // Every software adapter that was seen is named, with why it was not taken.
            for a in adapters.iter().filter(|a| shatter_gpu::is_software_adapter(a)) {
                assert!(msg.contains(&a.name), "{msg} should name {}", a.name);
            }
        }
    }
}

#[test]
fn the_test_context_is_software_here_or_hardware_elsewhere() {
    let ctx = gpu();
    eprintln!(
        "{} limits: max storage binding {} B, max buffer {} B, storage offset alignment {} B, max workgroups/dim {}",
        ctx.describe(),
        ctx.limits.max_storage_buffer_binding_size,
        ctx.limits.max_buffer_size,
        ctx.limits.min_storage_buffer_offset_alignment,
        ctx.limits.max_compute_workgroups_per_dimension
    );
    eprintln!("adapter features: {:?}", ctx.adapter.features());
    // The device gets the adapter's own limits, not wgpu's defaults.
    assert_eq!(ctx.limits.max_storage_buffer_binding_size, ctx.adapter.limits().max_storage_buffer_binding_size);
    assert_eq!(ctx.limits.max_buffer_size, ctx.adapter.limits().max_buffer_size);
    assert_eq!(ctx.is_software(), shatter_gpu::is_software_adapter(&ctx.info));
}

#[test]
fn many_contexts_can_be_created_in_parallel() {
    let threads: Vec<_> = (0..4)
        .map(|t| {
            std::thread::spawn(move || {
                let ctx = GpuContext::for_tests().unwrap_or_else(|e| panic!("{e}"));
                let kernel = ComputeKernel::new(&ctx, "saxpy.wgsl", SAXPY).expect("compiles");
                let x = random_f32s(10 + t, 1000);
                let y = vec![0.0f32; 1000];
                let got = run_saxpy(&ctx, &kernel, &x, &y);
                let mut want = y.clone();
                saxpy_cpu(&x, &mut want);
                assert_eq!(bits(&got), bits(&want)); // 1.7 * x + 0 has one rounding either way
            })
        })
        .collect();
    for t in threads {
        t.join().expect("thread");
    }
}

// ---- errors -------------------------------------------------------------------------------------------------

#[test]
fn wgsl_syntax_error_names_the_shader_and_line() {
    let ctx = gpu();
    let source = "@compute @workgroup_size(1)\nfn main() {\n    let x = ;\n}\n";
    let err = ComputeKernel::new(ctx, "broken_syntax.wgsl", source).expect_err("must not compile");
    let msg = err.to_string();
    eprintln!("{msg}");
    assert!(matches!(&err, GpuError::ShaderCompile { shader, .. } if shader == "broken_syntax.wgsl"));
    assert!(msg.contains("broken_syntax.wgsl"), "{msg}");
    assert!(msg.contains("let x = ;"), "the offending line should be quoted: {msg}");
}

#[test]
fn wgsl_type_error_names_the_shader() {
    let ctx = gpu();
    let source = "@group(0) @binding(0) var<storage, read_write> y: array<f32>;\n\
                  @compute @workgroup_size(1)\nfn main() {\n    y[0] = 1u;\n}\n";
    let err = shatter_gpu::compile_wgsl(ctx, "broken_types.wgsl", source).expect_err("must not compile");
    let msg = err.to_string();
    eprintln!("{msg}");
    assert!(matches!(&err, GpuError::ShaderCompile { .. }), "{msg}");
    assert!(msg.contains("broken_types.wgsl"), "{msg}");
}

#[test]
fn kernel_needs_exactly_one_compute_entry_point() {
    let ctx = gpu();
    let two = "@compute @workgroup_size(1) fn a() {}\n@compute @workgroup_size(1) fn b() {}\n";
    let err = ComputeKernel::new(ctx, "two.wgsl", two).expect_err("two entry points");
    assert!(matches!(&err, GpuError::KernelShape { .. }), "{err}");
    assert!(err.to_string().contains("a, b"), "{err}");

    let none = "fn helper() -> f32 { return 1.0; }\n";
    let err = ComputeKernel::new(ctx, "none.wgsl", none).expect_err("no entry point");
    assert!(matches!(&err, GpuError::KernelShape { .. }), "{err}");
}

#[test]
fn misuse_is_an_error_not_a_panic() {
    let ctx = gpu();
    let kernel = ComputeKernel::new(ctx, "saxpy.wgsl", SAXPY).expect("compiles");
    let xb = ctx.create_storage_buffer("x", &[1.0f32; 4]).expect("x");
    // Binding 1 missing.
    let err = kernel.bind_buffers(ctx, 0, &[&xb]).expect_err("incomplete bind group");
    assert!(matches!(&err, GpuError::Operation { .. }), "{err}");
    eprintln!("{err}");
    // Group indices past the shader's groups give empty layouts (WebGPU rule); past max_bind_groups, an error.
    assert!(kernel.bind_group_layout(ctx, 3).is_ok());
    assert!(kernel.bind_group_layout(ctx, ctx.limits.max_bind_groups).is_err());
    // Reading past the end.
    assert!(matches!(ctx.read_buffer::<f32>(&xb, 5), Err(GpuError::Readback { .. })));
    // Too large for the device.
    let too_big = ctx.limits.max_buffer_size.saturating_add(4);
    assert!(matches!(ctx.create_zeroed_storage_buffer("huge", too_big), Err(GpuError::BufferTooLarge { .. })));
}
