//! The GPU simulation's buffers: what each holds, their creation with the initial state, and
//! the upload of host-side state (a restore, new velocities or displacements).

use glam::DVec3;
use shatter_core::particles::ParticleSet;
use shatter_gpu::{DispatchGrid, GpuContext, GpuError, wgpu};

use super::gpu_simulation::GpuSimulation;
use super::stepping::BATCH;
use super::wgsl_structs::{Params, Status, WG};
use crate::bond_layouts::gpu_layout::{GpuBondLayout, RangeLayout};
use crate::model::MovingSphere;

/// One bond range's buffers.
#[derive(Debug)]
pub(super) struct RangeBuffers {
    pub(super) uniform: wgpu::Buffer,
    pub(super) neighbor: wgpu::Buffer,
    pub(super) stiffness: wgpu::Buffer,
    pub(super) threshold: wgpu::Buffer,
    pub(super) bits: wgpu::Buffer,
    pub(super) bits_snapshot: wgpu::Buffer,
    pub(super) words: usize,
    pub(super) grid: DispatchGrid,
}

/// Per-particle and global buffers (see `shaders/common.wgsl` for their contents).
#[derive(Debug)]
pub(super) struct Buffers {
    pub(super) params: wgpu::Buffer,
    pub(super) status: wgpu::Buffer,
    pub(super) body: wgpu::Buffer,
    pub(super) vel: wgpu::Buffer,
    pub(super) force: wgpu::Buffer,
    pub(super) boost_next: wgpu::Buffer,
    pub(super) built_at: wgpu::Buffer,
    pub(super) rows: wgpu::Buffer,
    pub(super) broken_count: wgpu::Buffer,
    pub(super) contact_force: wgpu::Buffer,
    pub(super) contact_count: wgpu::Buffer,
    pub(super) contact_list: wgpu::Buffer,
    pub(super) cell: wgpu::Buffer,
    pub(super) arrival: wgpu::Buffer,
    pub(super) bucket_count: wgpu::Buffer,
    pub(super) bucket_start: wgpu::Buffer,
    pub(super) block_sums: wgpu::Buffer,
    pub(super) unsorted: wgpu::Buffer,
    pub(super) sorted: wgpu::Buffer,
    pub(super) indirect: wgpu::Buffer,
    pub(super) power: wgpu::Buffer,
    pub(super) spheres: wgpu::Buffer,
    pub(super) events: wgpu::Buffer,
    pub(super) energy: wgpu::Buffer,
    /// Copies of the state at the last frame boundary, for the replay.
    pub(super) snapshot: SnapshotBuffers,
}

/// The copies [`Buffers::snapshot`] holds.
#[derive(Debug)]
pub(super) struct SnapshotBuffers {
    pub(super) status: wgpu::Buffer,
    pub(super) body: wgpu::Buffer,
    pub(super) vel: wgpu::Buffer,
    pub(super) force: wgpu::Buffer,
    pub(super) boost_next: wgpu::Buffer,
    pub(super) broken_count: wgpu::Buffer,
}

impl Buffers {
    /// The buffers of a body at rest in its reference shape: the particles' records and
    /// velocities from `particles`, `mass` and `inverse_mass`, the static data of `spheres`, and
    /// zeroed working buffers sized by `params` and `layout`.
    pub(super) fn new(
        ctx: &GpuContext,
        particles: &ParticleSet,
        mass: &[f32],
        inverse_mass: &[f32],
        spheres: &[MovingSphere],
        params: &Params,
        layout: &GpuBondLayout,
    ) -> Result<Buffers, GpuError> {
        let n = particles.len();
        let contact = params.contact_enabled != 0;
        let table = u64::from(params.table_mask) + 1;
        let zeros = |label: &str, bytes: u64| ctx.create_zeroed_storage_buffer(label, bytes.max(4));
        let n64 = n as u64;
        let contact_n = if contact { n64 } else { 1 };
        let body: Vec<[f32; 4]> = (0..n)
            .flat_map(|i| {
                let x = particles.rest_position_m[i];
                [[x[0], x[1], x[2], mass[i]], [0.0; 4]]
            })
            .collect();
        let vel: Vec<[f32; 4]> = inverse_mass.iter().map(|im| [0.0, 0.0, 0.0, *im]).collect();
        let mut status = Status { rebuild: 1, ..Status::default() };
        status.set_work(0.0);
        let sphere_data: Vec<[f32; 4]> = spheres
            .iter()
            .flat_map(|s| {
                let speed = s.velocity_m_s.length();
                let heading = if speed > 0.0 { s.velocity_m_s / speed } else { DVec3::ZERO }.as_vec3();
                [[heading.x, heading.y, heading.z, s.radius_m as f32], [s.stiffness as f32, 0.0, 0.0, 0.0]]
            })
            .chain(std::iter::repeat_n([0.0; 4], spheres.len() * BATCH as usize))
            .chain(std::iter::once([0.0; 4]))
            .collect();
        Ok(Buffers {
            params: ctx.create_uniform_buffer("params", params)?,
            status: ctx.create_storage_buffer("status", &[status])?,
            body: ctx.create_storage_buffer("body", &body)?,
            vel: ctx.create_storage_buffer("vel", &vel)?,
            force: zeros("force", 16 * n64)?,
            boost_next: zeros("boost_next", 4 * n64)?,
            built_at: zeros("built_at", 16 * n64)?,
            rows: ctx.create_storage_buffer("rows", &layout.rows)?,
            broken_count: zeros("broken_count", 4 * n64)?,
            contact_force: zeros("contact_force", 16 * contact_n)?,
            contact_count: zeros("contact_count", 4 * contact_n)?,
            contact_list: zeros("contact_list", 4 * contact_n * u64::from(params.contact_cap))?,
            cell: zeros("cell", 16 * contact_n)?,
            arrival: zeros("arrival", 4 * contact_n)?,
            bucket_count: zeros("bucket_count", 4 * if contact { table } else { 1 })?,
            bucket_start: zeros("bucket_start", 4 * if contact { table + 1 } else { 1 })?,
            block_sums: zeros("block_sums", 4 * u64::from(params.scan_blocks))?,
            unsorted: zeros("unsorted", 4 * contact_n)?,
            sorted: zeros("sorted", 4 * contact_n)?,
            indirect: ctx.create_storage_buffer_with_usage("indirect", &[0u32; 12], wgpu::BufferUsages::INDIRECT)?,
            power: zeros("power", 4 * u64::from(layout.workgroups()))?,
            spheres: ctx.create_storage_buffer("spheres", &sphere_data)?,
            events: zeros("events", 8 * u64::from(params.event_capacity))?,
            energy: zeros("energy", 4 * n64)?,
            snapshot: SnapshotBuffers {
                status: zeros("snapshot status", size_of::<Status>() as u64)?,
                body: zeros("snapshot body", 32 * n64)?,
                vel: zeros("snapshot vel", 16 * n64)?,
                force: zeros("snapshot force", 16 * n64)?,
                boost_next: zeros("snapshot boost_next", 4 * n64)?,
                broken_count: zeros("snapshot broken_count", 4 * n64)?,
            },
        })
    }
}

impl RangeBuffers {
    /// The buffers of the bond range `part`, its broken bits all clear.
    pub(super) fn new(ctx: &GpuContext, part: &RangeLayout) -> Result<RangeBuffers, GpuError> {
        let zeros = |label: &str, bytes: u64| ctx.create_zeroed_storage_buffer(label, bytes.max(4));
        Ok(RangeBuffers {
            uniform: ctx.create_uniform_buffer("range", &part.range)?,
            neighbor: ctx.create_storage_buffer("neighbor", &part.neighbor)?,
            stiffness: ctx.create_storage_buffer("stiffness", &part.stiffness)?,
            threshold: ctx.create_storage_buffer("threshold", &part.threshold)?,
            bits: zeros("bits", 4 * part.words as u64)?,
            bits_snapshot: zeros("snapshot bits", 4 * part.words as u64)?,
            words: part.words,
            grid: ctx.dispatch_grid(u64::from(part.range.workgroups))?,
        })
    }
}

impl GpuSimulation {
    /// Uploads the host-side state (displacements, velocities, forces, boosts) and the broken
    /// bonds `broken_bonds` (sorted ids).
    pub(super) fn upload(&mut self, broken_bonds: Option<&[u64]>) -> Result<(), GpuError> {
        let n = self.len();
        let d = &self.dynamics;
        let body: Vec<[f32; 4]> = (0..n)
            .flat_map(|i| {
                [
                    [self.rest[0][i], self.rest[1][i], self.rest[2][i], self.mass[i]],
                    [d.disp[0][i], d.disp[1][i], d.disp[2][i], d.boost[i]],
                ]
            })
            .collect();
        let vel: Vec<[f32; 4]> =
            (0..n).map(|i| [d.vel[0][i], d.vel[1][i], d.vel[2][i], self.inverse_mass[i]]).collect();
        let force: Vec<[f32; 4]> = (0..n).map(|i| [d.force[0][i], d.force[1][i], d.force[2][i], 0.0]).collect();
        let ctx = &self.ctx;
        ctx.write_buffer(&self.buffers.body, 0, &body)?;
        ctx.write_buffer(&self.buffers.vel, 0, &vel)?;
        ctx.write_buffer(&self.buffers.force, 0, &force)?;
        ctx.write_buffer(&self.buffers.boost_next, 0, &d.boost)?;
        if let Some(ids) = broken_bonds {
            let mut words: Vec<Vec<u32>> = self.range_words.iter().map(|w| vec![0u32; *w]).collect();
            let mut broken = vec![0u32; n];
            let mut mark = |i: usize, k: usize| {
                let row = self.rows[i];
                let range = self.range_of_group[i / WG] as usize;
                words[range][row[1] as usize + (k / 32) * 32] |= 1 << (k % 32);
                broken[i] += 1;
            };
            for &id in ids {
                let i = self.offsets.partition_point(|offset| *offset <= id) - 1;
                let j = self.neighbor[id as usize] as usize;
                mark(i, (id - self.offsets[i]) as usize);
                let row_j = self.offsets[j] as usize..self.offsets[j + 1] as usize;
                if let Ok(k) = self.neighbor[row_j].binary_search(&(i as u32)) {
                    mark(j, k);
                }
            }
            for (range, words) in self.ranges.iter().zip(&words) {
                ctx.write_buffer(&range.bits, 0, words)?;
            }
            ctx.write_buffer(&self.buffers.broken_count, 0, &broken)?;
            let mut status = Status { step: self.dynamics.step as u32, rebuild: 1, ..Status::default() };
            status.set_work(self.dynamics.external_work_j);
            ctx.write_buffer(&self.buffers.status, 0, &[status])?;
            self.step = self.dynamics.step;
        }
        Ok(())
    }
}
