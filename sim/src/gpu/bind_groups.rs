//! The GPU simulation's bind groups: which buffers each kernel sees, in binding order.

use shatter_gpu::{GpuContext, GpuError, wgpu};

use super::family::FamilyBuffers;
use super::shaders::Kernels;
use super::sim_buffers::{Buffers, RangeBuffers};

/// The bind groups of every kernel, made once for the buffers they bind (and again when a buffer
/// grows).
#[derive(Debug)]
pub(super) struct BindGroups {
    pub(super) kick_drift: wgpu::BindGroup,
    pub(super) kick_floor: wgpu::BindGroup,
    pub(super) kick_floor_drift: wgpu::BindGroup,
    pub(super) contact: Option<ContactGroups>,
    pub(super) spring_forces: Vec<wgpu::BindGroup>,
    pub(super) bond_energy: Vec<wgpu::BindGroup>,
    pub(super) power_sum: wgpu::BindGroup,
    pub(super) family: Option<FamilyGroups>,
}

/// The bind groups of the elastoplastic model's passes (only with that model).
#[derive(Debug)]
pub(super) struct FamilyGroups {
    pub(super) dilatation: wgpu::BindGroup,
    pub(super) forces: wgpu::BindGroup,
}

/// The bind groups of the contact kernels (only when contact is on).
#[derive(Debug)]
pub(super) struct ContactGroups {
    pub(super) plan: wgpu::BindGroup,
    pub(super) count: wgpu::BindGroup,
    pub(super) scan_blocks: wgpu::BindGroup,
    pub(super) scan_block_sums: wgpu::BindGroup,
    pub(super) scan_add: wgpu::BindGroup,
    pub(super) scatter: wgpu::BindGroup,
    pub(super) rank: wgpu::BindGroup,
    pub(super) candidates: wgpu::BindGroup,
    pub(super) collisions: Vec<wgpu::BindGroup>,
}

impl BindGroups {
    /// Binds `b` and the bond ranges' buffers to each kernel of `kernels` (the contact kernels
    /// only when `contact`, the elastoplastic passes only with `family`), in the order of the
    /// kernels' bindings.
    pub(super) fn new(
        ctx: &GpuContext,
        kernels: &Kernels,
        b: &Buffers,
        ranges: &[RangeBuffers],
        contact: bool,
        family: Option<&FamilyBuffers>,
    ) -> Result<BindGroups, GpuError> {
        let family_groups = match family {
            Some(f) => Some(FamilyGroups::new(ctx, kernels, b, ranges, f)?),
            None => None,
        };
        let contact_groups = if contact { Some(ContactGroups::new(ctx, kernels, b, ranges)?) } else { None };
        let kick = [&b.params, &b.body, &b.vel, &b.force, &b.boost_next, &b.built_at, &b.status];
        Ok(BindGroups {
            kick_drift: kernels.kick_drift.bind_buffers(ctx, 0, &kick)?,
            kick_floor_drift: kernels.kick_floor_drift.bind_buffers(ctx, 0, &kick)?,
            kick_floor: kernels.kick_floor.bind_buffers(ctx, 0, &[&b.params, &b.body, &b.vel, &b.force])?,
            contact: contact_groups,
            spring_forces: per_range(ranges, |r| {
                kernels.spring_forces.bind_buffers(
                    ctx,
                    0,
                    &[
                        &b.params,
                        &r.uniform,
                        &b.body,
                        &b.vel,
                        &b.force,
                        &b.boost_next,
                        &b.rows,
                        &b.broken_count,
                        &b.contact_count,
                        &b.contact_force,
                        &r.neighbor,
                        &r.stiffness,
                        &r.threshold,
                        &r.bits,
                        &b.power,
                        &b.status,
                        &b.spheres,
                        &b.events,
                    ],
                )
            })?,
            bond_energy: per_range(ranges, |r| {
                kernels.bond_energy.bind_buffers(
                    ctx,
                    0,
                    &[&r.uniform, &b.body, &b.rows, &r.neighbor, &r.stiffness, &r.bits, &b.energy],
                )
            })?,
            power_sum: kernels.power_sum.bind_buffers(ctx, 0, &[&b.params, &b.power, &b.status])?,
            family: family_groups,
        })
    }
}

/// One bind group per bond range, `bind` making each.
fn per_range(
    ranges: &[RangeBuffers],
    bind: impl FnMut(&RangeBuffers) -> Result<wgpu::BindGroup, GpuError>,
) -> Result<Vec<wgpu::BindGroup>, GpuError> {
    ranges.iter().map(bind).collect()
}

impl FamilyGroups {
    /// Binds `b`, the one bond range's buffers and the model's `f` to the elastoplastic passes;
    /// an error when the bonds take more than one range.
    fn new(
        ctx: &GpuContext,
        kernels: &Kernels,
        b: &Buffers,
        ranges: &[RangeBuffers],
        f: &FamilyBuffers,
    ) -> Result<FamilyGroups, GpuError> {
        let [r] = ranges else {
            return Err(GpuError::Split {
                message: format!(
                    "the elastoplastic model keeps its bonds in one range on the GPU; this scene's need {}",
                    ranges.len()
                ),
            });
        };
        Ok(FamilyGroups {
            dilatation: kernels.family_dilatation.bind_buffers(
                ctx,
                0,
                &[
                    &b.params,
                    &b.body,
                    &b.rows,
                    &b.broken_count,
                    &r.neighbor,
                    &r.bits,
                    &f.entry,
                    &f.particle,
                    &f.weighted_volume,
                    &f.plastic,
                    &f.extension,
                    &f.record,
                    &f.damage,
                ],
            )?,
            forces: kernels.family_forces.bind_buffers(
                ctx,
                0,
                &[
                    &b.params,
                    &f.params,
                    &b.body,
                    &b.vel,
                    &b.force,
                    &b.rows,
                    &b.broken_count,
                    &b.contact_count,
                    &b.contact_force,
                    &r.neighbor,
                    &r.bits,
                    &f.entry,
                    &f.particle,
                    &f.reverse,
                    &f.threshold,
                    &f.plastic,
                    &f.extension,
                    &f.record,
                    &f.damage,
                    &b.power,
                    &b.status,
                    &b.spheres,
                    &b.events,
                    &f.hold,
                ],
            )?,
        })
    }
}

impl ContactGroups {
    /// Binds `b` and the bond ranges' buffers to the contact kernels.
    fn new(
        ctx: &GpuContext,
        kernels: &Kernels,
        b: &Buffers,
        ranges: &[RangeBuffers],
    ) -> Result<ContactGroups, GpuError> {
        Ok(ContactGroups {
            plan: kernels.contact_plan.bind_buffers(ctx, 0, &[&b.params, &b.status, &b.indirect])?,
            count: kernels.contact_count.bind_buffers(
                ctx,
                0,
                &[&b.params, &b.body, &b.cell, &b.arrival, &b.bucket_count],
            )?,
            scan_blocks: kernels.scan_blocks.bind_buffers(
                ctx,
                0,
                &[&b.params, &b.bucket_count, &b.bucket_start, &b.block_sums],
            )?,
            scan_block_sums: kernels.scan_block_sums.bind_buffers(
                ctx,
                0,
                &[&b.params, &b.bucket_start, &b.block_sums],
            )?,
            scan_add: kernels.scan_add.bind_buffers(ctx, 0, &[&b.params, &b.bucket_start, &b.block_sums])?,
            scatter: kernels.contact_scatter.bind_buffers(
                ctx,
                0,
                &[&b.params, &b.cell, &b.arrival, &b.bucket_start, &b.unsorted, &b.bucket_count],
            )?,
            rank: kernels.contact_rank.bind_buffers(
                ctx,
                0,
                &[&b.params, &b.cell, &b.bucket_start, &b.unsorted, &b.sorted],
            )?,
            candidates: kernels.contact_candidates.bind_buffers(
                ctx,
                0,
                &[
                    &b.params,
                    &b.body,
                    &b.cell,
                    &b.bucket_start,
                    &b.sorted,
                    &b.contact_count,
                    &b.contact_list,
                    &b.built_at,
                    &b.status,
                ],
            )?,
            collisions: per_range(ranges, |r| {
                kernels.collisions.bind_buffers(
                    ctx,
                    0,
                    &[
                        &b.params,
                        &r.uniform,
                        &b.body,
                        &b.rows,
                        &b.contact_count,
                        &b.contact_list,
                        &b.contact_force,
                        &r.neighbor,
                        &r.bits,
                    ],
                )
            })?,
        })
    }
}
