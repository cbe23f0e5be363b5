//! Stepping on the GPU: batches of steps recorded into one submission each, the force pass as a
//! sequence of dispatches (the contact rebuild through indirect dispatches), and a force pass
//! without moving.

use shatter_gpu::{ComputeKernel, DispatchGrid, GpuError, wgpu};

use super::family::GpuFamily;
use super::gpu_simulation::GpuSimulation;
use super::snapshot::Replay;
use super::wgsl_structs::STATUS_REBUILD_OFFSET;

/// Steps recorded into one submission.
pub const BATCH: u64 = 64;

// Indirect-dispatch slots written by `contact_plan.wgsl`.
/// The slot of a dispatch over the particles.
const SLOT_PARTICLES: u64 = 0;
/// The slot of a dispatch over the hash table.
const SLOT_TABLE: u64 = 1;
/// The slot of a dispatch over the scan blocks.
const SLOT_BLOCKS: u64 = 2;
/// The slot of a one-workgroup dispatch.
const SLOT_ONE: u64 = 3;

impl GpuSimulation {
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
        if self.family.is_some() {
            // the neighbour and bit streams, the model's own arrays; the passes read the body
            // records (32) and write velocity and force besides the kick's 116
            let (per_entry, per_particle) = GpuFamily::bytes_per_entry_and_particle();
            let bonds = (4 + per_entry) * entries + 4 * words;
            return (bonds, n * (116 + 32 + 32 + per_particle + contact));
        }
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
        if let Some(family) = &self.groups.family {
            k.family_dilatation.record(pass, &[&family.dilatation], self.particle_grid);
            k.family_forces.record(pass, &[&family.forces], self.particle_grid);
            return;
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
    pub(super) fn advance_steps(&mut self, steps: u64) -> Result<(), GpuError> {
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
    pub(super) fn force_pass(&mut self) -> Result<(), GpuError> {
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
    pub(super) fn standalone_force_pass(&mut self) -> Result<(), GpuError> {
        self.copy_snapshot(false)?;
        self.history = vec![Replay::ForcePass];
        self.force_pass()?;
        self.sync()
    }
}
