//! WGSL compilation and the one-entry-point compute kernel wrapper.

use crate::{GpuContext, GpuError};

/// A compiled WGSL module together with naga's parse of it (for introspection).
struct Compiled {
    module: wgpu::ShaderModule,
    naga: wgpu::naga::Module,
}

fn compile(ctx: &GpuContext, name: &str, source: &str) -> Result<Compiled, GpuError> {
    // Parse with naga first: its diagnostics name the shader and show the offending line.
    let naga = wgpu::naga::front::wgsl::parse_str(source).map_err(|e| GpuError::ShaderCompile {
        shader: name.to_owned(),
        message: e.emit_to_string_with_path(source, name),
    })?;
    // wgpu then validates against the device's capabilities; catch its error instead of panicking.
    let module = ctx
        .with_error_scope(
            || format!("compile {name}"),
            || {
                ctx.device.create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(name),
                    source: wgpu::ShaderSource::Wgsl(source.into()),
                })
            },
        )
        .map_err(|e| match e {
            GpuError::Operation { message, .. } => GpuError::ShaderCompile { shader: name.to_owned(), message },
            other => other,
        })?;
    Ok(Compiled { module, naga })
}

/// Compiles WGSL `source` into a shader module. `name` (use the file name, e.g. `"bond_forces.wgsl"`) labels
/// the module and is named in errors.
///
/// # Errors
/// [`GpuError::ShaderCompile`] with the compiler's diagnostics if the source does not parse or validate.
pub fn compile_wgsl(ctx: &GpuContext, name: &str, source: &str) -> Result<wgpu::ShaderModule, GpuError> {
    compile(ctx, name, source).map(|c| c.module)
}

/// How a number of workgroups is laid out as a dispatch: `x * y >= workgroups`, both at most the device's
/// `max_compute_workgroups_per_dimension`, and `x * y - workgroups < y` (little overshoot).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct DispatchGrid {
    /// Workgroups along x.
    pub x: u32,
    /// Workgroups along y (1 unless the count exceeds one dimension's limit).
    pub y: u32,
    /// The workgroup count that was asked for; the shader must ignore the linear workgroup ids at and beyond it.
    pub workgroups: u64,
}

impl DispatchGrid {
    /// Lays out `workgroups` workgroups: one row if they fit in `max_per_dimension`, else the fewest rows that
    /// fit, with the columns spread evenly.
    ///
    /// # Errors
    /// [`GpuError::DispatchTooLarge`] beyond `max_per_dimension²` workgroups.
    pub fn new(workgroups: u64, max_per_dimension: u32) -> Result<DispatchGrid, GpuError> {
        let max = u64::from(max_per_dimension.max(1));
        let too_large = || GpuError::DispatchTooLarge { workgroups, max_per_dimension };
        let y = workgroups.div_ceil(max).max(1);
        if y > max {
            return Err(too_large());
        }
        let x = workgroups.div_ceil(y);
        Ok(DispatchGrid {
            x: u32::try_from(x).map_err(|_| too_large())?,
            y: u32::try_from(y).map_err(|_| too_large())?,
            workgroups,
        })
    }
}

impl GpuContext {
    /// [`DispatchGrid::new`] with this device's `max_compute_workgroups_per_dimension`.
    ///
    /// # Errors
    /// As [`DispatchGrid::new`].
    pub fn dispatch_grid(&self, workgroups: u64) -> Result<DispatchGrid, GpuError> {
        DispatchGrid::new(workgroups, self.limits.max_compute_workgroups_per_dimension)
    }
}

/// One WGSL file with exactly one entry point, a `@compute` one, compiled into a pipeline.
///
/// Dispatches may be split into a 2D grid (see [`DispatchGrid`]) when the workgroup count exceeds
/// `max_compute_workgroups_per_dimension` (65535 on most devices), so kernels compute their linear index as
///
/// ```wgsl
/// @compute @workgroup_size(64)
/// fn main(@builtin(workgroup_id) wid: vec3<u32>,
///         @builtin(num_workgroups) nwg: vec3<u32>,
///         @builtin(local_invocation_index) lid: u32) {
///     let i = (wid.x + wid.y * nwg.x) * 64u + lid;
///     if (i >= arrayLength(&y)) { return; } // or a count from a uniform
///     // ...
/// }
/// ```
///
/// and always bounds-check it: the grid may overshoot by up to `y - 1` workgroups, and the last workgroup is
/// usually partial.
#[derive(Debug)]
pub struct ComputeKernel {
    name: String,
    pipeline: wgpu::ComputePipeline,
    entry_point: String,
    workgroup_size: [u32; 3],
    /// Explicit layouts, when the kernel was built with them; else the pipeline's automatic layouts are used.
    explicit_layouts: Option<Vec<wgpu::BindGroupLayout>>,
}

impl ComputeKernel {
    /// Compiles `source` and builds its pipeline with an automatic layout derived from the shader.
    ///
    /// Automatic layouts contain only the bindings the entry point actually uses (a declared but unused
    /// binding must be left out of the bind group), and their bind group layouts work only with this kernel.
    ///
    /// # Errors
    /// [`GpuError::ShaderCompile`] for WGSL errors, [`GpuError::KernelShape`] unless the module has exactly one
    /// entry point and it is `@compute`, [`GpuError::Operation`] if pipeline creation fails.
    pub fn new(ctx: &GpuContext, name: &str, source: &str) -> Result<ComputeKernel, GpuError> {
        Self::build(ctx, name, source, None, &[])
    }

    /// As [`ComputeKernel::new`], with values for the shader's pipeline-overridable constants
    /// (`override NAME: type = default;`; a bool takes 0.0 or 1.0), so one source serves as
    /// several kernels.
    ///
    /// # Errors
    /// As [`ComputeKernel::new`]; [`GpuError::Operation`] also for a constant the shader lacks.
    pub fn with_constants(
        ctx: &GpuContext,
        name: &str,
        source: &str,
        constants: &[(&str, f64)],
    ) -> Result<ComputeKernel, GpuError> {
        Self::build(ctx, name, source, None, constants)
    }

    /// As [`ComputeKernel::new`], with explicit bind group layouts (group `i` = `layouts[i]`), so bind groups
    /// can be shared between kernels that use the same layouts.
    ///
    /// # Errors
    /// As [`ComputeKernel::new`]; [`GpuError::Operation`] also if the layouts do not match the shader.
    pub fn with_layouts(
        ctx: &GpuContext,
        name: &str,
        source: &str,
        layouts: &[&wgpu::BindGroupLayout],
    ) -> Result<ComputeKernel, GpuError> {
        Self::build(ctx, name, source, Some(layouts), &[])
    }

    fn build(
        ctx: &GpuContext,
        name: &str,
        source: &str,
        layouts: Option<&[&wgpu::BindGroupLayout]>,
        constants: &[(&str, f64)],
    ) -> Result<ComputeKernel, GpuError> {
        let compiled = compile(ctx, name, source)?;
        let shape_error = |message: String| GpuError::KernelShape { shader: name.to_owned(), message };
        let entry = match compiled.naga.entry_points.as_slice() {
            [only] if only.stage == wgpu::naga::ShaderStage::Compute => only,
            [only] => return Err(shape_error(format!("its entry point `{}` is not @compute", only.name))),
            [] => {
                return Err(shape_error("it has no entry point; exactly one @compute entry point is required".into()));
            }
            many => {
                let names: Vec<&str> = many.iter().map(|e| e.name.as_str()).collect();
                return Err(shape_error(format!(
                    "it has {} entry points ({}); exactly one @compute entry point is required (one per file)",
                    many.len(),
                    names.join(", ")
                )));
            }
        };
        if entry.workgroup_size_overrides.is_some() {
            return Err(shape_error("its @workgroup_size uses pipeline-overridable constants; use literals".into()));
        }
        let workgroup_size = entry.workgroup_size;
        let entry_point = entry.name.clone();

        let pipeline = ctx.with_error_scope(
            || format!("create compute pipeline for {name}"),
            || {
                let pipeline_layout = layouts.map(|layouts| {
                    let groups: Vec<Option<&wgpu::BindGroupLayout>> = layouts.iter().map(|l| Some(*l)).collect();
                    ctx.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                        label: Some(name),
                        bind_group_layouts: &groups,
                        immediate_size: 0,
                    })
                });
                ctx.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(name),
                    layout: pipeline_layout.as_ref(),
                    module: &compiled.module,
                    entry_point: Some(&entry_point),
                    compilation_options: wgpu::PipelineCompilationOptions {
                        constants,
                        ..wgpu::PipelineCompilationOptions::default()
                    },
                    cache: None,
                })
            },
        )?;
        Ok(ComputeKernel {
            name: name.to_owned(),
            pipeline,
            entry_point,
            workgroup_size,
            explicit_layouts: layouts.map(|ls| ls.iter().map(|l| (*l).clone()).collect()),
        })
    }

    /// The shader's name as given at creation.
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The name of the shader's entry point.
    #[must_use]
    pub fn entry_point(&self) -> &str {
        &self.entry_point
    }

    /// The compute pipeline.
    #[must_use]
    pub fn pipeline(&self) -> &wgpu::ComputePipeline {
        &self.pipeline
    }

    /// The shader's `@workgroup_size`.
    #[must_use]
    pub fn workgroup_size(&self) -> [u32; 3] {
        self.workgroup_size
    }

    /// Invocations per workgroup: the product of [`ComputeKernel::workgroup_size`].
    #[must_use]
    pub fn invocations_per_workgroup(&self) -> u64 {
        self.workgroup_size.iter().map(|&s| u64::from(s)).product()
    }

    /// Workgroups needed for `invocations` invocations (rounded up).
    #[must_use]
    pub fn workgroups_for(&self, invocations: u64) -> u64 {
        invocations.div_ceil(self.invocations_per_workgroup().max(1))
    }

    /// The layout of bind group `group`: the explicit one, or the pipeline's automatic one (an empty layout for
    /// a group the shader does not use, as WebGPU specifies).
    ///
    /// # Errors
    /// [`GpuError::Operation`] if `group` is not below the device's `max_bind_groups` (or, with explicit
    /// layouts, not below their count).
    pub fn bind_group_layout(&self, ctx: &GpuContext, group: u32) -> Result<wgpu::BindGroupLayout, GpuError> {
        if let Some(layouts) = &self.explicit_layouts {
            return usize::try_from(group).ok().and_then(|g| layouts.get(g)).cloned().ok_or_else(|| {
                GpuError::Operation {
                    operation: format!("get bind group layout {group} of {}", self.name),
                    message: format!("the kernel was built with {} explicit layouts", layouts.len()),
                }
            });
        }
        ctx.with_error_scope(
            || format!("get bind group layout {group} of {}", self.name),
            || self.pipeline.get_bind_group_layout(group),
        )
    }

    /// A bind group for `group` with `resources[i]` at `@binding(i)`.
    ///
    /// # Errors
    /// [`GpuError::Operation`] with wgpu's message if the resources do not match the layout.
    pub fn bind_group(
        &self,
        ctx: &GpuContext,
        group: u32,
        resources: &[wgpu::BindingResource<'_>],
    ) -> Result<wgpu::BindGroup, GpuError> {
        let entries: Vec<wgpu::BindGroupEntry<'_>> = (0u32..)
            .zip(resources)
            .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource: resource.clone() })
            .collect();
        self.bind_group_entries(ctx, group, &entries)
    }

    /// A bind group for `group` with whole `buffers[i]` at `@binding(i)`.
    ///
    /// # Errors
    /// As [`ComputeKernel::bind_group`].
    pub fn bind_buffers(
        &self,
        ctx: &GpuContext,
        group: u32,
        buffers: &[&wgpu::Buffer],
    ) -> Result<wgpu::BindGroup, GpuError> {
        let resources: Vec<wgpu::BindingResource<'_>> = buffers.iter().map(|b| b.as_entire_binding()).collect();
        self.bind_group(ctx, group, &resources)
    }

    /// A bind group for `group` from explicit entries (for sparse binding numbers).
    ///
    /// # Errors
    /// As [`ComputeKernel::bind_group`].
    pub fn bind_group_entries(
        &self,
        ctx: &GpuContext,
        group: u32,
        entries: &[wgpu::BindGroupEntry<'_>],
    ) -> Result<wgpu::BindGroup, GpuError> {
        let layout = self.bind_group_layout(ctx, group)?;
        let label = format!("{} group {group}", self.name);
        ctx.with_error_scope(
            || format!("create bind group {group} of {}", self.name),
            || {
                ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some(&label),
                    layout: &layout,
                    entries,
                })
            },
        )
    }

    /// Records this kernel into an open compute pass: sets the pipeline, `bind_groups[i]` as group `i`, and
    /// dispatches `grid` (nothing for zero workgroups). Use this to put many dispatches in one submission.
    pub fn record(&self, pass: &mut wgpu::ComputePass<'_>, bind_groups: &[&wgpu::BindGroup], grid: DispatchGrid) {
        if grid.workgroups == 0 {
            return;
        }
        pass.set_pipeline(&self.pipeline);
        for (index, group) in (0u32..).zip(bind_groups) {
            pass.set_bind_group(index, *group, &[]);
        }
        pass.dispatch_workgroups(grid.x, grid.y, 1);
    }

    /// Encodes and submits one dispatch of `workgroups` workgroups (laid out by
    /// [`GpuContext::dispatch_grid`]); does not wait. Read results with [`GpuContext::read_buffer`], which
    /// waits.
    ///
    /// # Errors
    /// [`GpuError::DispatchTooLarge`], or [`GpuError::Operation`] with wgpu's validation message (wrong bind
    /// groups, binding too small, ...).
    pub fn dispatch(
        &self,
        ctx: &GpuContext,
        bind_groups: &[&wgpu::BindGroup],
        workgroups: u64,
    ) -> Result<wgpu::SubmissionIndex, GpuError> {
        let grid = ctx.dispatch_grid(workgroups)?;
        ctx.with_error_scope(
            || format!("dispatch {} ({workgroups} workgroups as {} x {})", self.name, grid.x, grid.y),
            || {
                let mut encoder =
                    ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(&self.name) });
                {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some(&self.name),
                        timestamp_writes: None,
                    });
                    self.record(&mut pass, bind_groups, grid);
                }
                ctx.queue.submit([encoder.finish()])
            },
        )
    }

    /// [`ComputeKernel::dispatch`] with enough workgroups for `invocations` invocations.
    ///
    /// # Errors
    /// As [`ComputeKernel::dispatch`].
    pub fn dispatch_invocations(
        &self,
        ctx: &GpuContext,
        bind_groups: &[&wgpu::BindGroup],
        invocations: u64,
    ) -> Result<wgpu::SubmissionIndex, GpuError> {
        self.dispatch(ctx, bind_groups, self.workgroups_for(invocations))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_is_one_row_when_it_fits() {
        let g = DispatchGrid::new(1000, 65_535).expect("fits");
        assert_eq!((g.x, g.y), (1000, 1));
        let g = DispatchGrid::new(0, 65_535).expect("fits");
        assert_eq!((g.x, g.y, g.workgroups), (0, 1, 0));
    }

    #[test]
    fn grid_splits_into_rows_with_small_overshoot() {
        for &max in &[1u32, 2, 7, 100, 65_535] {
            for &w in &[1u64, 2, 3, 99, 100, 101, 65_535, 65_536, 70_000, 1_000_003, 4_000_000_000] {
                match DispatchGrid::new(w, max) {
                    Ok(g) => {
                        let (x, y) = (u64::from(g.x), u64::from(g.y));
                        assert!(x <= u64::from(max) && y <= u64::from(max), "{g:?} exceeds {max}");
                        assert!(x * y >= w, "{g:?} does not cover {w}");
                        assert!(x * y - w < y, "{g:?} overshoots {w} by a row or more");
                    }
                    Err(e) => {
                        assert!(w > u64::from(max) * u64::from(max), "{w} with max {max} should fit: {e}");
                    }
                }
            }
        }
    }
}
