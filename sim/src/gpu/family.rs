//! The elastoplastic model on the GPU: its bonds in the sliced layout of the PMB springs (the
//! same rows, partners and broken bits, so contact, break events, restore and the snapshot work
//! alike for both models), its per-entry and per-particle arrays, and the host's copy of its
//! state. The host keeps the CPU model's [`FamilyTable`] (built the same way, from the same
//! thresholds): it supplies the arrays, the stable time step, and at each frame boundary, with
//! the broken bonds and plastic extensions read back, the stored energy and the checkpoint's
//! per-bond state.

use shatter_gpu::{GpuContext, GpuError, wgpu};

use super::wgsl_structs::{FamilyParams, SLICE};
use crate::elastoplastic::FamilyTable;
use crate::elastoplastic::passes::FamilyView;
use crate::model::Grip;

/// The model's buffers (see `family_dilatation.wgsl` and `family_forces.wgsl`).
#[derive(Debug)]
pub(super) struct FamilyBuffers {
    pub(super) params: wgpu::Buffer,
    pub(super) entry: wgpu::Buffer,
    pub(super) particle: wgpu::Buffer,
    pub(super) weighted_volume: wgpu::Buffer,
    pub(super) reverse: wgpu::Buffer,
    pub(super) threshold: wgpu::Buffer,
    pub(super) plastic: wgpu::Buffer,
    pub(super) plastic_snapshot: wgpu::Buffer,
    pub(super) extension: wgpu::Buffer,
    pub(super) record: wgpu::Buffer,
    pub(super) damage: wgpu::Buffer,
    pub(super) hold: wgpu::Buffer,
}

/// The elastoplastic model of a GPU simulation: its buffers and the host's copy of its state.
#[derive(Debug)]
pub(super) struct GpuFamily {
    /// The host's copy: geometry, constants, and the broken bonds and plastic extensions as of
    /// the last frame boundary.
    pub(super) table: FamilyTable,
    pub(super) buffers: FamilyBuffers,
}

/// The sliced-layout entry of the host table's entry `e` (a table of `stride` entries per
/// particle).
fn sliced(rows: &[[u32; 4]], stride: usize, e: usize) -> usize {
    let (i, k) = FamilyView::place_of(stride, e);
    rows[i][0] as usize + k * SLICE
}

/// The first step at which time step * dt_s reaches `release_s` (u32::MAX: never).
pub(super) fn release_step(release_s: f64, dt_s: f64) -> u32 {
    if !release_s.is_finite() {
        return u32::MAX;
    }
    let mut step = (release_s / dt_s).ceil().clamp(0.0, f64::from(u32::MAX)) as u32;
    while step < u32::MAX && (f64::from(step) * dt_s) < release_s {
        step += 1;
    }
    while step > 0 && f64::from(step - 1) * dt_s >= release_s {
        step -= 1;
    }
    step
}

/// The per-entry arrays of a family table in the sliced layout (padding entries: zeros, an
/// infinite threshold).
pub(super) struct FamilyArrays {
    /// omega_ij, omega_ji, |xi|, 1 / (omega_mean |xi|).
    pub(super) entry: Vec<[f32; 4]>,
    /// The sliced entry of the same bond in the partner's row.
    pub(super) reverse: Vec<u32>,
    /// The critical weighted elastic stretch.
    pub(super) threshold: Vec<f32>,
}

impl FamilyArrays {
    /// The arrays of `table` in the sliced layout of `rows` (`entries` entries).
    pub(super) fn new(table: &FamilyTable, rows: &[[u32; 4]], entries: usize) -> FamilyArrays {
        let stride = table.stride;
        let mut arrays = FamilyArrays {
            entry: vec![[0.0; 4]; entries],
            reverse: vec![0; entries],
            threshold: vec![f32::INFINITY; entries],
        };
        for (i, row) in rows.iter().enumerate() {
            for k in 0..row[2] as usize {
                let e = table.entry(i, k);
                let g = sliced(rows, stride, e);
                arrays.entry[g] =
                    [table.influence[e], table.reverse_influence[e], table.rest_length_m[e], table.break_scale[e]];
                arrays.reverse[g] = sliced(rows, stride, table.reverse[e] as usize) as u32;
                arrays.threshold[g] = table.threshold[e];
            }
        }
        arrays
    }
}

impl GpuFamily {
    /// Uploads `table` into the sliced layout of `rows` (one range of `entries` entries), with
    /// the particles `grips` hold.
    pub(super) fn new(
        ctx: &GpuContext,
        table: FamilyTable,
        rows: &[[u32; 4]],
        entries: usize,
        grips: &[Grip],
        dt_s: f64,
    ) -> Result<GpuFamily, GpuError> {
        let n = table.len();
        let arrays = FamilyArrays::new(&table, rows, entries);
        let mut hold = vec![[0.0f32; 4]; if grips.is_empty() { 1 } else { n }];
        for grip in grips {
            let release = f32::from_bits(release_step(grip.release_s, dt_s));
            for &i in &grip.particles {
                let [vx, vy, vz] = grip.velocity_m_s;
                hold[i as usize] = [vx, vy, vz, release];
            }
        }
        let constants = &table.constants;
        let params = FamilyParams {
            damage_strengthening: constants.damage_strengthening as f32,
            plastic_cap_ratio: constants.plastic_cap_ratio as f32,
            grips: u32::from(!grips.is_empty()),
            pad: 0,
        };
        let zeros = |label: &str, bytes: u64| ctx.create_zeroed_storage_buffer(label, bytes.max(4));
        let buffers = FamilyBuffers {
            params: ctx.create_uniform_buffer("family params", &params)?,
            entry: ctx.create_storage_buffer("family entry", &arrays.entry)?,
            particle: ctx.create_storage_buffer("family particle", &table.particle)?,
            weighted_volume: ctx.create_storage_buffer("weighted volume", &table.weighted_volume)?,
            reverse: ctx.create_storage_buffer("family reverse", &arrays.reverse)?,
            threshold: ctx.create_storage_buffer("family threshold", &arrays.threshold)?,
            plastic: zeros("plastic", 8 * entries as u64)?,
            plastic_snapshot: zeros("snapshot plastic", 8 * entries as u64)?,
            extension: zeros("extension", 4 * entries as u64)?,
            record: zeros("family record", 16 * n as u64)?,
            damage: zeros("damage", 4 * n as u64)?,
            hold: ctx.create_storage_buffer("hold", &hold)?,
        };
        Ok(GpuFamily { table, buffers })
    }

    /// Bytes of the model's arrays per stored entry and per particle (for the bandwidth model).
    pub(super) fn bytes_per_entry_and_particle() -> (u64, u64) {
        // entry 16, reverse 4, threshold 4, plastic 8 (read and written), extension 4 (written,
        // read); per particle: record 16 written and read, damage 4, constants 16, m 4.
        (16 + 4 + 4 + 8 + 8 + 4 + 4, 16 + 16 + 4 + 4 + 16 + 4)
    }

    /// Writes the host table's plastic extensions to the GPU (both halves of each entry).
    pub(super) fn upload_plastic(&self, ctx: &GpuContext, rows: &[[u32; 4]], entries: usize) -> Result<(), GpuError> {
        let stride = self.table.stride;
        let mut plastic = vec![[0.0f32; 2]; entries];
        for (i, row) in rows.iter().enumerate() {
            for k in 0..row[2] as usize {
                let e = self.table.entry(i, k);
                plastic[sliced(rows, stride, e)] = [self.table.plastic_m[e]; 2];
            }
        }
        ctx.write_buffer(&self.buffers.plastic, 0, &plastic)
    }

    /// Reads the plastic extensions of the last force pass into the host table, and marks the
    /// bonds `broken` (ids) broken there.
    pub(super) fn read_back(
        &mut self,
        ctx: &GpuContext,
        rows: &[[u32; 4]],
        entries: usize,
        broken: &[u64],
    ) -> Result<(), GpuError> {
        let plastic: Vec<[f32; 2]> = ctx.read_buffer(&self.buffers.plastic, entries)?;
        let stride = self.table.stride;
        for (i, row) in rows.iter().enumerate() {
            for k in 0..row[2] as usize {
                let e = self.table.entry(i, k);
                self.table.plastic_m[e] = plastic[sliced(rows, stride, e)][1];
            }
        }
        self.table.mark_broken(broken);
        Ok(())
    }

    /// The stored energy per particle at displacements `disp`, joules (the CPU model's sum).
    pub(super) fn energy_per_particle(&self, disp: &[Vec<f32>; 3]) -> Vec<f64> {
        self.table.energy_per_particle([&disp[0], &disp[1], &disp[2]])
    }
}

#[cfg(test)]
mod tests {
    use super::release_step;

    #[test]
    fn a_grip_lets_go_at_the_first_step_whose_time_reaches_its_release() {
        for (release, dt) in [(1e-5, 1e-7), (3.3e-6, 1e-7), (0.0, 1e-7), (2.5e-7, 1e-7), (1e-3, 3e-8)] {
            let step = release_step(release, dt);
            assert!(f64::from(step) * dt >= release, "{release} {dt} {step}");
            assert!(step == 0 || f64::from(step - 1) * dt < release, "{release} {dt} {step}");
        }
        assert_eq!(release_step(f64::INFINITY, 1e-7), u32::MAX);
    }
}
