//! The WGSL sources of the simulation kernels (`sim/shaders/`) and their compilation.

use shatter_gpu::{ComputeKernel, GpuContext, GpuError, join_wgsl};

/// Declarations shared by every kernel (no entry point), prepended to each kernel file.
pub const COMMON: &str = include_str!("../../shaders/common.wgsl");

/// What the force kernels share (body forces, the workgroup power sum; no entry point),
/// prepended after [`COMMON`] to them.
pub const FORCE_COMMON: &str = include_str!("../../shaders/force_common.wgsl");

/// The force kernels (they get [`FORCE_COMMON`]).
const FORCE_KERNELS: [&str; 2] = ["spring_forces.wgsl", "family_forces.wgsl"];

/// Every kernel: (file name, source). One `@compute` entry point per file, named like the file.
pub const KERNELS: [(&str, &str); 16] = [
    ("kick_drift.wgsl", include_str!("../../shaders/kick_drift.wgsl")),
    ("kick_floor.wgsl", include_str!("../../shaders/kick_floor.wgsl")),
    ("contact_plan.wgsl", include_str!("../../shaders/contact_plan.wgsl")),
    ("contact_count.wgsl", include_str!("../../shaders/contact_count.wgsl")),
    ("scan_blocks.wgsl", include_str!("../../shaders/scan_blocks.wgsl")),
    ("scan_block_sums.wgsl", include_str!("../../shaders/scan_block_sums.wgsl")),
    ("scan_add.wgsl", include_str!("../../shaders/scan_add.wgsl")),
    ("contact_scatter.wgsl", include_str!("../../shaders/contact_scatter.wgsl")),
    ("contact_rank.wgsl", include_str!("../../shaders/contact_rank.wgsl")),
    ("contact_candidates.wgsl", include_str!("../../shaders/contact_candidates.wgsl")),
    ("collisions.wgsl", include_str!("../../shaders/collisions.wgsl")),
    ("spring_forces.wgsl", include_str!("../../shaders/spring_forces.wgsl")),
    ("power_sum.wgsl", include_str!("../../shaders/power_sum.wgsl")),
    ("bond_energy.wgsl", include_str!("../../shaders/bond_energy.wgsl")),
    ("family_dilatation.wgsl", include_str!("../../shaders/family_dilatation.wgsl")),
    ("family_forces.wgsl", include_str!("../../shaders/family_forces.wgsl")),
];

/// The full source of kernel `name` (common declarations first, then the force kernels' shared
/// code where it is one).
pub fn source(name: &str) -> Option<String> {
    let includes = if FORCE_KERNELS.contains(&name) { FORCE_COMMON } else { "" };
    KERNELS.iter().find(|(file, _)| *file == name).map(|(_, text)| join_wgsl(&[COMMON, includes, text]))
}

/// Compiles kernel `name`.
pub fn compile(ctx: &GpuContext, name: &str) -> Result<ComputeKernel, GpuError> {
    compile_with(ctx, name, &[])
}

/// Compiles kernel `name` with values for its pipeline-overridable constants.
pub fn compile_with(ctx: &GpuContext, name: &str, constants: &[(&str, f64)]) -> Result<ComputeKernel, GpuError> {
    let source = source(name).ok_or_else(|| GpuError::KernelShape {
        shader: name.to_owned(),
        message: "no such simulation kernel".to_owned(),
    })?;
    ComputeKernel::with_constants(ctx, name, &source, constants)
}

/// All kernels, compiled.
#[derive(Debug)]
pub struct Kernels {
    /// `kick_drift.wgsl`.
    pub kick_drift: ComputeKernel,
    /// `kick_floor.wgsl`.
    pub kick_floor: ComputeKernel,
    /// `kick_drift.wgsl` with `LAND_FIRST`: the previous step's velocity update fused in.
    pub kick_floor_drift: ComputeKernel,
    /// `contact_plan.wgsl`.
    pub contact_plan: ComputeKernel,
    /// `contact_count.wgsl`.
    pub contact_count: ComputeKernel,
    /// `scan_blocks.wgsl`.
    pub scan_blocks: ComputeKernel,
    /// `scan_block_sums.wgsl`.
    pub scan_block_sums: ComputeKernel,
    /// `scan_add.wgsl`.
    pub scan_add: ComputeKernel,
    /// `contact_scatter.wgsl`.
    pub contact_scatter: ComputeKernel,
    /// `contact_rank.wgsl`.
    pub contact_rank: ComputeKernel,
    /// `contact_candidates.wgsl`.
    pub contact_candidates: ComputeKernel,
    /// `collisions.wgsl`.
    pub collisions: ComputeKernel,
    /// `spring_forces.wgsl`.
    pub spring_forces: ComputeKernel,
    /// `power_sum.wgsl`.
    pub power_sum: ComputeKernel,
    /// `bond_energy.wgsl`.
    pub bond_energy: ComputeKernel,
    /// `family_dilatation.wgsl` (the elastoplastic model's first pass).
    pub family_dilatation: ComputeKernel,
    /// `family_forces.wgsl` (the elastoplastic model's second pass, with the body forces).
    pub family_forces: ComputeKernel,
}

impl Kernels {
    /// Compiles every kernel.
    pub fn new(ctx: &GpuContext) -> Result<Kernels, GpuError> {
        Ok(Kernels {
            kick_drift: compile(ctx, "kick_drift.wgsl")?,
            kick_floor: compile(ctx, "kick_floor.wgsl")?,
            kick_floor_drift: compile_with(ctx, "kick_drift.wgsl", &[("LAND_FIRST", 1.0)])?,
            contact_plan: compile(ctx, "contact_plan.wgsl")?,
            contact_count: compile(ctx, "contact_count.wgsl")?,
            scan_blocks: compile(ctx, "scan_blocks.wgsl")?,
            scan_block_sums: compile(ctx, "scan_block_sums.wgsl")?,
            scan_add: compile(ctx, "scan_add.wgsl")?,
            contact_scatter: compile(ctx, "contact_scatter.wgsl")?,
            contact_rank: compile(ctx, "contact_rank.wgsl")?,
            contact_candidates: compile(ctx, "contact_candidates.wgsl")?,
            collisions: compile(ctx, "collisions.wgsl")?,
            spring_forces: compile(ctx, "spring_forces.wgsl")?,
            power_sum: compile(ctx, "power_sum.wgsl")?,
            bond_energy: compile(ctx, "bond_energy.wgsl")?,
            family_dilatation: compile(ctx, "family_dilatation.wgsl")?,
            family_forces: compile(ctx, "family_forces.wgsl")?,
        })
    }
}
