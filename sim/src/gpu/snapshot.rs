//! Snapshot and replay: at a frame boundary the host-side state is read back; if a capacity (break
//! events of the frame, contact candidates per particle) overflowed since, the buffers grow and
//! the frame is replayed from a GPU-side snapshot of its start, so the result is the same as
//! with large enough buffers from the start.

use shatter_core::frames::BreakEvent;
use shatter_gpu::{GpuError, wgpu};

use super::bind_groups::BindGroups;
use super::gpu_simulation::GpuSimulation;
use super::wgsl_structs::{STATUS_EVENTS_OFFSET, STATUS_REBUILD_OFFSET, Status};

/// Work since the snapshot, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Replay {
    /// `advance(steps)`.
    Steps(u64),
    /// A force pass without moving.
    ForcePass,
}

impl GpuSimulation {
    /// The GPU's clock and counters.
    fn read_status(&self) -> Result<Status, GpuError> {
        Ok(self.ctx.read_buffer::<Status>(&self.buffers.status, 1)?[0])
    }

    /// Copies the live state into the snapshot (or back, `restore`).
    pub(super) fn copy_snapshot(&self, restore: bool) -> Result<(), GpuError> {
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
        if let Some(family) = &self.family {
            pairs.push((&family.buffers.plastic, &family.buffers.plastic_snapshot));
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
        self.groups = BindGroups::new(
            ctx,
            &self.kernels,
            &self.buffers,
            &self.ranges,
            self.params.contact_enabled != 0,
            self.family.as_ref().map(|f| &f.buffers),
        )?;
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
    pub(super) fn sync(&mut self) -> Result<(), GpuError> {
        let mut status = self.read_status()?;
        while status.events > self.params.event_capacity || status.contact_needed > self.params.contact_cap {
            self.replay(status)?;
            status = self.read_status()?;
        }
        let ctx = &self.ctx;
        let n = self.len();
        // Bond energies (the elastoplastic model's are summed on the host below).
        if self.family.is_none() {
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
        }
        let mut events: Vec<[u32; 2]> = ctx.read_buffer(&self.buffers.events, status.events as usize)?;
        events.sort_unstable();
        self.events.extend(events.iter().map(|e| BreakEvent { step: u64::from(e[0]), bond: u64::from(e[1]) }));
        let body: Vec<[f32; 4]> = ctx.read_buffer(&self.buffers.body, 2 * n)?;
        let vel: Vec<[f32; 4]> = ctx.read_buffer(&self.buffers.vel, n)?;
        let force: Vec<[f32; 4]> = ctx.read_buffer(&self.buffers.force, n)?;
        let boost: Vec<f32> = ctx.read_buffer(&self.buffers.boost_next, n)?;
        let broken: Vec<u32> = ctx.read_buffer(&self.buffers.broken_count, n)?;
        let energy: Vec<f32> =
            if self.family.is_none() { ctx.read_buffer(&self.buffers.energy, n)? } else { Vec::new() };
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
        if let Some(family) = &mut self.family {
            let broken: Vec<u64> = events.iter().map(|e| u64::from(e[1])).collect();
            family.read_back(ctx, &self.rows, self.stored_entries, &broken)?;
            self.bond_energy = family.energy_per_particle(&self.dynamics.disp);
        }
        debug_assert_eq!(u64::from(status.step), self.step);
        // Events consumed; the snapshot starts here.
        ctx.write_buffer(&self.buffers.status, STATUS_EVENTS_OFFSET, &[0u32])?;
        self.copy_snapshot(false)?;
        self.history.clear();
        Ok(())
    }
}
