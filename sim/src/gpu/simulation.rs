//! The GPU simulation: buffers, the step as a sequence of dispatches, readback at frame
//! boundaries, and the replay that makes capacities exact.

use std::ops::Deref;

use glam::DVec3;
use rayon::prelude::*;
use shatter_core::config::sim::{BreakRule, StiffnessCorrection};
use shatter_core::particles::ParticleSet;
use shatter_gpu::{ComputeKernel, DispatchGrid, GpuContext, GpuError, wgpu};

use super::layout::{BondLayout, LayoutError};
use super::shaders::Kernels;
use super::types::{Params, SCAN_BLOCK, STATUS_EVENTS_OFFSET, STATUS_REBUILD_OFFSET, Status, WG};
use crate::backend::Backend;
use crate::contact::SKIN_FRACTION;
use crate::model::{Model, MovingSphere};
use shatter_core::frames::BreakEvent;

use crate::simulation::{Dynamics, Energy};

/// Steps recorded into one submission.
pub const BATCH: u64 = 64;

/// The GPU context a simulation runs on: its own, or one shared for the life of the process
/// (tests).
#[derive(Debug)]
pub enum GpuHandle {
    /// A context owned by the simulation.
    Owned(Box<GpuContext>),
    /// A context that outlives it.
    Shared(&'static GpuContext),
}

impl Deref for GpuHandle {
    type Target = GpuContext;

    fn deref(&self) -> &GpuContext {
        match self {
            GpuHandle::Owned(ctx) => ctx,
            GpuHandle::Shared(ctx) => ctx,
        }
    }
}

impl From<GpuContext> for GpuHandle {
    fn from(ctx: GpuContext) -> GpuHandle {
        GpuHandle::Owned(Box::new(ctx))
    }
}

impl From<&'static GpuContext> for GpuHandle {
    fn from(ctx: &'static GpuContext) -> GpuHandle {
        GpuHandle::Shared(ctx)
    }
}

/// Tuning of the GPU backend; the defaults suit production runs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GpuOptions {
    /// Cap on the bytes of one storage binding of a bond array (default: the adapter's limit).
    /// Tests lower it to exercise the splitting of bond arrays across bindings.
    pub max_binding_bytes: Option<u64>,
    /// Contact candidates stored per particle at the start (grown, with a replay of the frame,
    /// when a particle needs more).
    pub contact_cap: u32,
    /// Break events one frame may hold at the start (grown, with a replay of the frame, when
    /// more break); default min(bonds, 2^20).
    pub event_capacity: Option<u32>,
}

impl Default for GpuOptions {
    fn default() -> GpuOptions {
        GpuOptions { max_binding_bytes: None, contact_cap: 16, event_capacity: None }
    }
}

/// One bond range's buffers.
#[derive(Debug)]
struct RangeBuffers {
    uniform: wgpu::Buffer,
    neighbor: wgpu::Buffer,
    stiffness: wgpu::Buffer,
    threshold: wgpu::Buffer,
    bits: wgpu::Buffer,
    bits_snapshot: wgpu::Buffer,
    words: usize,
    grid: DispatchGrid,
}

/// Per-particle and global buffers (see `shaders/common.wgsl` for their contents).
#[derive(Debug)]
struct Buffers {
    params: wgpu::Buffer,
    status: wgpu::Buffer,
    body: wgpu::Buffer,
    vel: wgpu::Buffer,
    force: wgpu::Buffer,
    boost_next: wgpu::Buffer,
    built_at: wgpu::Buffer,
    rows: wgpu::Buffer,
    broken_count: wgpu::Buffer,
    contact_force: wgpu::Buffer,
    contact_count: wgpu::Buffer,
    contact_list: wgpu::Buffer,
    cell: wgpu::Buffer,
    arrival: wgpu::Buffer,
    bucket_count: wgpu::Buffer,
    bucket_start: wgpu::Buffer,
    block_sums: wgpu::Buffer,
    unsorted: wgpu::Buffer,
    sorted: wgpu::Buffer,
    indirect: wgpu::Buffer,
    power: wgpu::Buffer,
    spheres: wgpu::Buffer,
    events: wgpu::Buffer,
    energy: wgpu::Buffer,
    /// Copies of the state at the last frame boundary, for the replay.
    snapshot: Snapshot,
}

#[derive(Debug)]
struct Snapshot {
    status: wgpu::Buffer,
    body: wgpu::Buffer,
    vel: wgpu::Buffer,
    force: wgpu::Buffer,
    boost_next: wgpu::Buffer,
    broken_count: wgpu::Buffer,
}

#[derive(Debug)]
struct BindGroups {
    kick_drift: wgpu::BindGroup,
    kick_floor: wgpu::BindGroup,
    kick_floor_drift: wgpu::BindGroup,
    contact: Option<ContactGroups>,
    spring_forces: Vec<wgpu::BindGroup>,
    bond_energy: Vec<wgpu::BindGroup>,
    power_sum: wgpu::BindGroup,
}

#[derive(Debug)]
struct ContactGroups {
    plan: wgpu::BindGroup,
    count: wgpu::BindGroup,
    scan_blocks: wgpu::BindGroup,
    scan_block_sums: wgpu::BindGroup,
    scan_add: wgpu::BindGroup,
    scatter: wgpu::BindGroup,
    rank: wgpu::BindGroup,
    candidates: wgpu::BindGroup,
    collisions: Vec<wgpu::BindGroup>,
}

/// Work since the snapshot, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Replay {
    /// `advance(steps)`.
    Steps(u64),
    /// A force pass without moving.
    ForcePass,
}

/// Indirect-dispatch slots written by `contact_plan.wgsl`.
const SLOT_PARTICLES: u64 = 0;
const SLOT_TABLE: u64 = 1;
const SLOT_BLOCKS: u64 = 2;
const SLOT_ONE: u64 = 3;

/// A running simulation on the GPU: the same model and results (to f32 rounding) as the CPU
/// [`crate::Simulation`], one particle per invocation. See the module docs of [`crate::gpu`].
#[derive(Debug)]
pub struct GpuSimulation {
    ctx: GpuHandle,
    model: Model,
    kernels: Kernels,
    buffers: Buffers,
    ranges: Vec<RangeBuffers>,
    groups: BindGroups,
    params: Params,
    particle_grid: DispatchGrid,
    /// Static sphere data (heading and radius; stiffness), projectiles then indenters.
    spheres: Vec<MovingSphere>,
    rest: [Vec<f32>; 3],
    mass: Vec<f32>,
    inverse_mass: Vec<f32>,
    bond_count: Vec<u32>,
    rows: Vec<[u32; 4]>,
    offsets: Vec<u64>,
    neighbor: Vec<u32>,
    range_words: Vec<usize>,
    range_of_group: Vec<u32>,
    stored_entries: usize,
    stable_dt_s: f64,
    /// Host-side state as of the last frame boundary.
    dynamics: Dynamics,
    broken: Vec<u32>,
    bond_energy: Vec<f64>,
    events: Vec<BreakEvent>,
    /// What ran since the snapshot (replayed after an overflow).
    history: Vec<Replay>,
    /// Steps taken (the GPU clock mirrors it).
    step: u64,
}

fn layout_error(error: LayoutError) -> GpuError {
    GpuError::Split { message: error.to_string() }
}

impl GpuSimulation {
    /// A body at rest in its reference shape, on the GPU. `factors` are art-direction multipliers
    /// of the thresholds, one per particle-file bond entry.
    pub fn new(
        ctx: GpuHandle,
        particles: &ParticleSet,
        model: Model,
        factors: Option<&[f32]>,
        correction: StiffnessCorrection,
        options: &GpuOptions,
    ) -> Result<GpuSimulation, GpuError> {
        let n = particles.len();
        if n == 0 {
            return Err(GpuError::Split { message: "the particle set is empty".into() });
        }
        let binding = ctx.max_storage_binding_bytes();
        let max_binding = options.max_binding_bytes.map_or(binding, |limit| limit.min(binding));
        let layout =
            BondLayout::new(particles, model.bond_constant, model.threshold_scale, factors, correction, max_binding)
                .map_err(layout_error)?;
        if 32 * n as u64 > binding {
            return Err(GpuError::Split {
                message: format!(
                    "{n} particles need {} bytes of particle records, more than one storage binding of {} holds \
                     ({binding} bytes)",
                    32 * n,
                    ctx.describe()
                ),
            });
        }
        let rest = [0, 1, 2].map(|axis| particles.rest_position_m.iter().map(|p| p[axis]).collect::<Vec<f32>>());
        let mass: Vec<f32> = particles.volume_m3.iter().map(|v| (f64::from(*v) * model.density_kg_m3) as f32).collect();
        let inverse_mass: Vec<f32> = mass.iter().map(|m| 1.0 / m).collect();
        let bond_count: Vec<u32> = (0..n).map(|i| particles.bonds.row(i).len() as u32).collect();
        let stable_dt_s = stable_dt(&layout, &particles.bonds.rest_length_m, &mass);
        let spheres: Vec<MovingSphere> = model.projectiles.iter().chain(&model.indenters).copied().collect();

        let contact = model.contact_stiffness_pa > 0.0;
        let table = (2 * n).next_power_of_two().max(16);
        let scan_blocks = table.div_ceil(SCAN_BLOCK);
        let particle_grid = ctx.dispatch_grid(n.div_ceil(WG) as u64)?;
        let table_grid = ctx.dispatch_grid(table.div_ceil(WG) as u64)?;
        let block_grid = ctx.dispatch_grid(scan_blocks as u64)?;
        let distance = model.contact_distance_m;
        let skin = SKIN_FRACTION * distance;
        let unique = particles.bonds.unique_count();
        let event_capacity = options.event_capacity.unwrap_or(unique.clamp(16, 1 << 20) as u32).max(1);
        let params = Params {
            n: n as u32,
            batch_first_step: 0,
            dt: model.dt_s as f32,
            half_dt: 0.5 * model.dt_s as f32,
            alpha: model.alpha,
            break_rule: match model.break_rule {
                BreakRule::Max => 0,
                BreakRule::Min => 1,
            },
            gravity_x: model.gravity_m_s2[0],
            gravity_y: model.gravity_m_s2[1],
            gravity_z: model.gravity_m_s2[2],
            contact_enabled: u32::from(contact),
            contact_stiffness: model.contact_stiffness_pa,
            contact_distance: distance,
            skin_limit: if contact { 0.25 * skin * skin } else { f32::MAX },
            reach: distance + skin,
            inverse_cell: 1.0 / (2.0 * (distance + skin)),
            table_mask: (table - 1) as u32,
            contact_cap: options.contact_cap.max(1),
            floor_enabled: u32::from(model.floor.is_some()),
            floor_height: model.floor.map_or(0.0, |f| f.height_m),
            restitution: model.floor.map_or(0.0, |f| f.restitution),
            projectiles: model.projectiles.len() as u32,
            indenters: model.indenters.len() as u32,
            event_capacity,
            power_count: layout.workgroups(),
            particle_grid_x: particle_grid.x,
            particle_grid_y: particle_grid.y,
            table_grid_x: table_grid.x,
            table_grid_y: table_grid.y,
            block_grid_x: block_grid.x,
            block_grid_y: block_grid.y,
            scan_blocks: scan_blocks as u32,
            pad: 0,
        };

        let kernels = Kernels::new(&ctx)?;
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
        let buffers = Buffers {
            params: ctx.create_uniform_buffer("params", &params)?,
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
            bucket_count: zeros("bucket_count", 4 * if contact { table as u64 } else { 1 })?,
            bucket_start: zeros("bucket_start", 4 * if contact { table as u64 + 1 } else { 1 })?,
            block_sums: zeros("block_sums", 4 * scan_blocks as u64)?,
            unsorted: zeros("unsorted", 4 * contact_n)?,
            sorted: zeros("sorted", 4 * contact_n)?,
            indirect: ctx.create_storage_buffer_with_usage("indirect", &[0u32; 12], wgpu::BufferUsages::INDIRECT)?,
            power: zeros("power", 4 * u64::from(layout.workgroups()))?,
            spheres: ctx.create_storage_buffer("spheres", &sphere_data)?,
            events: zeros("events", 8 * u64::from(event_capacity))?,
            energy: zeros("energy", 4 * n64)?,
            snapshot: Snapshot {
                status: zeros("snapshot status", size_of::<Status>() as u64)?,
                body: zeros("snapshot body", 32 * n64)?,
                vel: zeros("snapshot vel", 16 * n64)?,
                force: zeros("snapshot force", 16 * n64)?,
                boost_next: zeros("snapshot boost_next", 4 * n64)?,
                broken_count: zeros("snapshot broken_count", 4 * n64)?,
            },
        };
        let mut ranges = Vec::with_capacity(layout.ranges.len());
        for part in &layout.ranges {
            ranges.push(RangeBuffers {
                uniform: ctx.create_uniform_buffer("range", &part.range)?,
                neighbor: ctx.create_storage_buffer("neighbor", &part.neighbor)?,
                stiffness: ctx.create_storage_buffer("stiffness", &part.stiffness)?,
                threshold: ctx.create_storage_buffer("threshold", &part.threshold)?,
                bits: zeros("bits", 4 * part.words as u64)?,
                bits_snapshot: zeros("snapshot bits", 4 * part.words as u64)?,
                words: part.words,
                grid: ctx.dispatch_grid(u64::from(part.range.workgroups))?,
            });
        }
        let range_words = ranges.iter().map(|r| r.words).collect();
        let stored_entries = layout.stored_entries();
        let zero3 = || [vec![0.0f32; n], vec![0.0f32; n], vec![0.0f32; n]];
        let groups = bind_groups(&ctx, &kernels, &buffers, &ranges, contact)?;
        let mut simulation = GpuSimulation {
            model,
            kernels,
            buffers,
            ranges,
            groups,
            params,
            particle_grid,
            spheres,
            rest,
            mass,
            inverse_mass,
            bond_count,
            rows: layout.rows,
            offsets: particles.bonds.offsets.clone(),
            neighbor: particles.bonds.neighbor.clone(),
            range_words,
            range_of_group: layout.range_of_group,
            stored_entries,
            stable_dt_s,
            dynamics: Dynamics {
                step: 0,
                disp: zero3(),
                vel: zero3(),
                force: zero3(),
                boost: vec![0.0; n],
                external_work_j: 0.0,
            },
            broken: vec![0; n],
            bond_energy: vec![0.0; n],
            events: Vec::new(),
            history: Vec::new(),
            step: 0,
            ctx,
        };
        simulation.standalone_force_pass()?;
        Ok(simulation)
    }

    /// The adapter.
    pub fn describe(&self) -> String {
        self.ctx.describe()
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.mass.len()
    }

    /// True without particles (never: construction refuses an empty set).
    pub fn is_empty(&self) -> bool {
        self.mass.is_empty()
    }

    /// Bond ranges (one binding each per bond array).
    pub fn ranges(&self) -> usize {
        self.ranges.len()
    }

    /// Bond entries stored (both directions, padding of the sliced layout included).
    pub fn stored_entries(&self) -> usize {
        self.stored_entries
    }

    /// Contact candidates stored per particle now.
    pub fn contact_cap(&self) -> u32 {
        self.params.contact_cap
    }

    /// Break events one frame may hold now.
    pub fn event_capacity(&self) -> u32 {
        self.params.event_capacity
    }

    /// Bytes the step moves through memory, by a simple model: every stream read or written once
    /// (bond arrays, bit words, per-particle records), gathers of partners' records from cache.
    /// Returns (bond streams, per-particle streams).
    pub fn bytes_per_step(&self) -> (u64, u64) {
        let entries = self.stored_entries as u64;
        let words: u64 = self.range_words.iter().map(|w| *w as u64).sum();
        let bonds = 12 * entries + 4 * words;
        let n = self.len() as u64;
        // kick_floor_drift: record r/w 32, rest 16, velocity r/w 32, force 16, boost 4, built_at 16;
        // spring_forces: rest and record 32, row 16, velocity 16, force 16, boost 4;
        // with contact, the candidate count in collisions and spring_forces, 4 + 4.
        let contact = if self.params.contact_enabled != 0 { 8 } else { 0 };
        let particles = n * (116 + 84 + contact);
        (bonds, particles)
    }

    /// Writes the params and the sphere centres for steps `first .. first + count`.
    fn write_batch(&mut self, first: u64, count: u64) -> Result<(), GpuError> {
        self.params.batch_first_step = first as u32;
        self.ctx.write_buffer(&self.buffers.params, 0, &[self.params])?;
        if !self.spheres.is_empty() {
            let centres: Vec<[f32; 4]> = (first..first + count)
                .flat_map(|step| {
                    let t = step as f64 * self.model.dt_s;
                    self.spheres.iter().map(move |s| {
                        let c = s.center_at(t).as_vec3();
                        [c.x, c.y, c.z, 0.0]
                    })
                })
                .collect();
            self.ctx.write_buffer(&self.buffers.spheres, 32 * self.spheres.len() as u64, &centres)?;
        }
        Ok(())
    }

    /// Records the force pass: contact (rebuild if stale, collisions), springs and body forces.
    fn record_forces(&self, pass: &mut wgpu::ComputePass<'_>) {
        let k = &self.kernels;
        let indirect = &self.buffers.indirect;
        if let Some(contact) = &self.groups.contact {
            let one = DispatchGrid { x: 1, y: 1, workgroups: 1 };
            k.contact_plan.record(pass, &[&contact.plan], one);
            let steps: [(&ComputeKernel, &wgpu::BindGroup, u64); 7] = [
                (&k.contact_count, &contact.count, SLOT_PARTICLES),
                (&k.scan_blocks, &contact.scan_blocks, SLOT_BLOCKS),
                (&k.scan_block_sums, &contact.scan_block_sums, SLOT_ONE),
                (&k.scan_add, &contact.scan_add, SLOT_TABLE),
                (&k.contact_scatter, &contact.scatter, SLOT_PARTICLES),
                (&k.contact_rank, &contact.rank, SLOT_PARTICLES),
                (&k.contact_candidates, &contact.candidates, SLOT_PARTICLES),
            ];
            for (kernel, group, slot) in steps {
                pass.set_pipeline(kernel.pipeline());
                pass.set_bind_group(0, group, &[]);
                pass.dispatch_workgroups_indirect(indirect, 12 * slot);
            }
            for (range, group) in self.ranges.iter().zip(&contact.collisions) {
                k.collisions.record(pass, &[group], range.grid);
            }
        }
        for (range, group) in self.ranges.iter().zip(&self.groups.spring_forces) {
            k.spring_forces.record(pass, &[group], range.grid);
        }
    }

    /// Records and submits steps `self.step + 1 ..= self.step + count` (count <= BATCH).
    fn submit_steps(&mut self, count: u64) -> Result<(), GpuError> {
        self.write_batch(self.step + 1, count)?;
        let ctx = &self.ctx;
        let one = DispatchGrid { x: 1, y: 1, workgroups: 1 };
        ctx.with_error_scope(
            || format!("simulate steps {}..{}", self.step + 1, self.step + count),
            || {
                let mut encoder =
                    ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("steps") });
                {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("steps"),
                        timestamp_writes: None,
                    });
                    for s in 0..count {
                        if s == 0 {
                            self.kernels.kick_drift.record(&mut pass, &[&self.groups.kick_drift], self.particle_grid);
                        } else {
                            self.kernels.kick_floor_drift.record(
                                &mut pass,
                                &[&self.groups.kick_floor_drift],
                                self.particle_grid,
                            );
                        }
                        self.record_forces(&mut pass);
                        self.kernels.power_sum.record(&mut pass, &[&self.groups.power_sum], one);
                    }
                    self.kernels.kick_floor.record(&mut pass, &[&self.groups.kick_floor], self.particle_grid);
                }
                ctx.queue.submit([encoder.finish()]);
            },
        )?;
        self.step += count;
        Ok(())
    }

    /// Advances `steps` steps (no readback).
    fn advance_steps(&mut self, steps: u64) -> Result<(), GpuError> {
        let mut left = steps;
        while left > 0 {
            let count = left.min(BATCH);
            self.submit_steps(count)?;
            left -= count;
        }
        Ok(())
    }

    /// A force pass at the current step without moving (construction, `set_displacement`): the
    /// contact lists are rebuilt, bonds may break.
    fn force_pass(&mut self) -> Result<(), GpuError> {
        self.write_batch(self.step, 1)?;
        if self.params.contact_enabled != 0 {
            self.ctx.write_buffer(&self.buffers.status, STATUS_REBUILD_OFFSET, &[1u32])?;
        }
        let ctx = &self.ctx;
        ctx.with_error_scope(
            || "force pass".to_string(),
            || {
                let mut encoder =
                    ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("forces") });
                {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("forces"),
                        timestamp_writes: None,
                    });
                    self.record_forces(&mut pass);
                }
                ctx.queue.submit([encoder.finish()]);
            },
        )?;
        Ok(())
    }

    /// The state on the GPU is the snapshot's plus new host data: snapshot it, run a force
    /// pass, sync.
    fn standalone_force_pass(&mut self) -> Result<(), GpuError> {
        self.copy_snapshot(false)?;
        self.history = vec![Replay::ForcePass];
        self.force_pass()?;
        self.sync()
    }

    fn read_status(&self) -> Result<Status, GpuError> {
        Ok(self.ctx.read_buffer::<Status>(&self.buffers.status, 1)?[0])
    }

    /// Copies the live state into the snapshot (or back, `restore`).
    fn copy_snapshot(&self, restore: bool) -> Result<(), GpuError> {
        let b = &self.buffers;
        let s = &b.snapshot;
        let mut pairs = vec![
            (&b.status, &s.status),
            (&b.body, &s.body),
            (&b.vel, &s.vel),
            (&b.force, &s.force),
            (&b.boost_next, &s.boost_next),
            (&b.broken_count, &s.broken_count),
        ];
        for range in &self.ranges {
            pairs.push((&range.bits, &range.bits_snapshot));
        }
        let ctx = &self.ctx;
        ctx.with_error_scope(
            || "copy the snapshot".to_string(),
            || {
                let mut encoder =
                    ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("snapshot") });
                for (live, copy) in pairs {
                    let (from, to) = if restore { (copy, live) } else { (live, copy) };
                    encoder.copy_buffer_to_buffer(from, 0, to, 0, live.size());
                }
                ctx.queue.submit([encoder.finish()]);
            },
        )
    }

    /// Grows what overflowed since the snapshot and replays the steps since.
    fn replay(&mut self, status: Status) -> Result<(), GpuError> {
        let ctx = &self.ctx;
        if status.events > self.params.event_capacity {
            let capacity = status.events.checked_next_power_of_two().unwrap_or(u32::MAX);
            self.buffers.events = ctx.create_zeroed_storage_buffer("events", 8 * u64::from(capacity))?;
            self.params.event_capacity = capacity;
        }
        if status.contact_needed > self.params.contact_cap {
            let cap = status.contact_needed.next_multiple_of(8);
            let bytes = 4 * self.len() as u64 * u64::from(cap);
            if bytes > ctx.max_storage_binding_bytes() {
                return Err(GpuError::Split {
                    message: format!(
                        "the contact lists need {cap} candidates per particle ({bytes} bytes), more than one storage \
                         binding holds"
                    ),
                });
            }
            self.buffers.contact_list = ctx.create_zeroed_storage_buffer("contact_list", bytes)?;
            self.params.contact_cap = cap;
        }
        self.groups = bind_groups(ctx, &self.kernels, &self.buffers, &self.ranges, self.params.contact_enabled != 0)?;
        self.copy_snapshot(true)?;
        // The lists were built for states after the snapshot: rebuild. (Forces do not depend on
        // when the lists were built.)
        self.ctx.write_buffer(&self.buffers.status, STATUS_REBUILD_OFFSET, &[1u32])?;
        self.step = self.dynamics.step;
        for work in self.history.clone() {
            match work {
                Replay::Steps(count) => self.advance_steps(count)?,
                Replay::ForcePass => self.force_pass()?,
            }
        }
        Ok(())
    }

    /// Brings the host-side state up to date (a frame boundary): replays the frame if a capacity
    /// overflowed, reads the break events, state and bond energies back, and takes a snapshot.
    fn sync(&mut self) -> Result<(), GpuError> {
        let mut status = self.read_status()?;
        while status.events > self.params.event_capacity || status.contact_needed > self.params.contact_cap {
            self.replay(status)?;
            status = self.read_status()?;
        }
        let ctx = &self.ctx;
        let n = self.len();
        // Bond energies.
        ctx.with_error_scope(
            || "bond energy".to_string(),
            || {
                let mut encoder =
                    ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("energy") });
                {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("energy"),
                        timestamp_writes: None,
                    });
                    for (range, group) in self.ranges.iter().zip(&self.groups.bond_energy) {
                        self.kernels.bond_energy.record(&mut pass, &[group], range.grid);
                    }
                }
                ctx.queue.submit([encoder.finish()]);
            },
        )?;
        let mut events: Vec<[u32; 2]> = ctx.read_buffer(&self.buffers.events, status.events as usize)?;
        events.sort_unstable();
        self.events.extend(events.iter().map(|e| BreakEvent { step: u64::from(e[0]), bond: u64::from(e[1]) }));
        let body: Vec<[f32; 4]> = ctx.read_buffer(&self.buffers.body, 2 * n)?;
        let vel: Vec<[f32; 4]> = ctx.read_buffer(&self.buffers.vel, n)?;
        let force: Vec<[f32; 4]> = ctx.read_buffer(&self.buffers.force, n)?;
        let boost: Vec<f32> = ctx.read_buffer(&self.buffers.boost_next, n)?;
        let broken: Vec<u32> = ctx.read_buffer(&self.buffers.broken_count, n)?;
        let energy: Vec<f32> = ctx.read_buffer(&self.buffers.energy, n)?;
        for axis in 0..3 {
            for i in 0..n {
                self.dynamics.disp[axis][i] = body[2 * i + 1][axis];
                self.dynamics.vel[axis][i] = vel[i][axis];
                self.dynamics.force[axis][i] = force[i][axis];
            }
        }
        self.dynamics.boost = boost;
        self.dynamics.step = self.step;
        self.dynamics.external_work_j = status.work_j();
        self.broken = broken;
        self.bond_energy = energy.iter().map(|e| f64::from(*e)).collect();
        debug_assert_eq!(u64::from(status.step), self.step);
        // Events consumed; the snapshot starts here.
        ctx.write_buffer(&self.buffers.status, STATUS_EVENTS_OFFSET, &[0u32])?;
        self.copy_snapshot(false)?;
        self.history.clear();
        Ok(())
    }

    /// Uploads the host-side state (displacements, velocities, forces, boosts) and the broken
    /// bonds `broken_bonds` (sorted ids).
    fn upload(&mut self, broken_bonds: Option<&[u64]>) -> Result<(), GpuError> {
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

/// min over particles of sqrt(2 m_i / sum_j k_ij / L_ij), as the CPU's `stable_dt_s`.
fn stable_dt(layout: &BondLayout, rest_length: &[f32], mass: &[f32]) -> f64 {
    let n = mass.len();
    (0..n)
        .into_par_iter()
        .map(|i| {
            let row = layout.rows[i];
            let part = &layout.ranges[layout.range_of(i)];
            let stiffness: f64 = (0..row[2] as usize)
                .map(|k| {
                    let e = row[0] as usize + k * super::types::SLICE;
                    f64::from(part.stiffness[e]) / f64::from(rest_length[row[3] as usize + k])
                })
                .sum();
            if stiffness > 0.0 { (2.0 * f64::from(mass[i]) / stiffness).sqrt() } else { f64::INFINITY }
        })
        .reduce(|| f64::INFINITY, f64::min)
}

fn bind_groups(
    ctx: &GpuContext,
    kernels: &Kernels,
    b: &Buffers,
    ranges: &[RangeBuffers],
    contact: bool,
) -> Result<BindGroups, GpuError> {
    let contact_groups = if contact {
        Some(ContactGroups {
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
            collisions: ranges
                .iter()
                .map(|r| {
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
                })
                .collect::<Result<_, _>>()?,
        })
    } else {
        None
    };
    let kick = [&b.params, &b.body, &b.vel, &b.force, &b.boost_next, &b.built_at, &b.status];
    Ok(BindGroups {
        kick_drift: kernels.kick_drift.bind_buffers(ctx, 0, &kick)?,
        kick_floor_drift: kernels.kick_floor_drift.bind_buffers(ctx, 0, &kick)?,
        kick_floor: kernels.kick_floor.bind_buffers(ctx, 0, &[&b.params, &b.body, &b.vel, &b.force])?,
        contact: contact_groups,
        spring_forces: ranges
            .iter()
            .map(|r| {
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
            })
            .collect::<Result<_, _>>()?,
        bond_energy: ranges
            .iter()
            .map(|r| {
                kernels.bond_energy.bind_buffers(
                    ctx,
                    0,
                    &[&r.uniform, &b.body, &b.rows, &r.neighbor, &r.stiffness, &r.bits, &b.energy],
                )
            })
            .collect::<Result<_, _>>()?,
        power_sum: kernels.power_sum.bind_buffers(ctx, 0, &[&b.params, &b.power, &b.status])?,
    })
}

impl Backend for GpuSimulation {
    fn describe(&self) -> String {
        format!("GPU: {}", self.ctx.describe())
    }

    fn len(&self) -> usize {
        self.mass.len()
    }

    fn model(&self) -> &Model {
        &self.model
    }

    fn advance(&mut self, steps: u64) -> Result<(), GpuError> {
        self.advance_steps(steps)?;
        self.history.push(Replay::Steps(steps));
        Ok(())
    }

    fn finish_frame(&mut self) -> Result<Vec<BreakEvent>, GpuError> {
        self.sync()?;
        Ok(std::mem::take(&mut self.events))
    }

    fn dynamics(&self) -> &Dynamics {
        &self.dynamics
    }

    fn energy(&self) -> Energy {
        let size = crate::bond_table::chunk_size(self.len());
        let kinetic_j = crate::simulation::kinetic_energy_j(&self.mass, &self.dynamics.vel, size);
        Energy { kinetic_j, bond_j: self.bond_energy.iter().sum() }
    }

    fn bond_energy_per_particle(&self) -> Vec<f64> {
        self.bond_energy.clone()
    }

    fn positions(&self) -> [Vec<f32>; 3] {
        [0, 1, 2].map(|a| self.rest[a].iter().zip(&self.dynamics.disp[a]).map(|(x, u)| x + u).collect())
    }

    fn damage(&self) -> Vec<f32> {
        self.broken
            .iter()
            .zip(&self.bond_count)
            .map(|(broken, count)| if *count == 0 { 0.0 } else { *broken as f32 / *count as f32 })
            .collect()
    }

    fn mass(&self) -> &[f32] {
        &self.mass
    }

    fn rest(&self) -> [&[f32]; 3] {
        [&self.rest[0], &self.rest[1], &self.rest[2]]
    }

    fn stable_dt_s(&self) -> f64 {
        self.stable_dt_s
    }

    fn restore(&mut self, dynamics: Dynamics, broken_bonds: &[u64]) -> Result<(), GpuError> {
        self.dynamics = dynamics;
        self.events.clear();
        self.upload(Some(broken_bonds))?;
        self.sync()
    }

    fn set_velocity(&mut self, velocity: &dyn Fn(usize, [f32; 3]) -> [f32; 3]) -> Result<(), GpuError> {
        self.sync()?;
        for i in 0..self.len() {
            let v = velocity(i, [0, 1, 2].map(|a| self.rest[a][i]));
            for (axis, value) in v.into_iter().enumerate() {
                self.dynamics.vel[axis][i] = value;
            }
        }
        self.upload(None)?;
        self.sync()
    }

    fn set_displacement(&mut self, displacement: &dyn Fn(usize, [f32; 3]) -> [f32; 3]) -> Result<(), GpuError> {
        self.sync()?;
        for i in 0..self.len() {
            let u = displacement(i, [0, 1, 2].map(|a| self.rest[a][i]));
            for (axis, value) in u.into_iter().enumerate() {
                self.dynamics.disp[axis][i] = value;
            }
        }
        self.upload(None)?;
        self.standalone_force_pass()
    }
}
