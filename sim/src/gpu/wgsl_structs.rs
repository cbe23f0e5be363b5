//! Host mirrors of the WGSL structs in `shaders/common.wgsl` (same field order, 4-byte scalars,
//! sizes multiples of 16 bytes).

use bytemuck::{Pod, Zeroable};

/// Particles per slice of the sliced-ELLPACK bond layout (the shaders' `SLICE`).
pub const SLICE: usize = 32;
/// Invocations per workgroup of the per-particle kernels (the shaders' `WG`).
pub const WG: usize = 64;
/// Counts scanned per workgroup by the prefix sum (the shaders' `SCAN_BLOCK`).
pub const SCAN_BLOCK: usize = 512;

/// `RULE_SIGNED_BOOST`: the boost is -alpha s_min whatever the sign of s_min.
pub const RULE_SIGNED_BOOST: u32 = 1;
/// `RULE_BREAKING_FORCE`: a breaking bond pulls in its breaking step.
pub const RULE_BREAKING_FORCE: u32 = 2;
/// `RULE_LAMMPS_CONTACT`: LAMMPS's short-range contact.
pub const RULE_LAMMPS_CONTACT: u32 = 4;
#[cfg(test)]
/// `NO_STRETCH`: the smallest stretch of a particle with no bond yet seen (signed boost).
pub const NO_STRETCH: f32 = 3.0e38;

/// `Params`: everything constant during a batch of steps.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct Params {
    /// Particles.
    pub n: u32,
    /// The step whose sphere centres sit first in the sphere buffer.
    pub batch_first_step: u32,
    /// Time step, seconds.
    pub dt: f32,
    /// Half the time step.
    pub half_dt: f32,
    /// Compression strengthening alpha.
    pub alpha: f32,
    /// 0: max rule, 1: min rule.
    pub break_rule: u32,
    /// Gravity x, m/s^2.
    pub gravity_x: f32,
    /// Gravity y.
    pub gravity_y: f32,
    /// Gravity z.
    pub gravity_z: f32,
    /// 1 when contact is on.
    pub contact_enabled: u32,
    /// K_c, Pa.
    pub contact_stiffness: f32,
    /// d_c, metres.
    pub contact_distance: f32,
    /// (skin / 2)^2, m^2 (f32::MAX without contact: nothing is ever stale).
    pub skin_limit: f32,
    /// d_c + skin, metres.
    pub reach: f32,
    /// 1 / hash cell size, 1/m.
    pub inverse_cell: f32,
    /// Hash table size - 1.
    pub table_mask: u32,
    /// Candidates stored per particle.
    pub contact_cap: u32,
    /// 1 when there is a floor.
    pub floor_enabled: u32,
    /// Floor height, metres.
    pub floor_height: f32,
    /// Fraction of the normal velocity kept on a bounce.
    pub restitution: f32,
    /// Projectiles (first in the sphere buffer).
    pub projectiles: u32,
    /// Indenters (after the projectiles).
    pub indenters: u32,
    /// Break events the event buffer holds.
    pub event_capacity: u32,
    /// Spring-kernel workgroups over all ranges.
    pub power_count: u32,
    /// Rebuild grid over particles, x.
    pub particle_grid_x: u32,
    /// Rebuild grid over particles, y.
    pub particle_grid_y: u32,
    /// Rebuild grid over the hash table, x.
    pub table_grid_x: u32,
    /// Rebuild grid over the hash table, y.
    pub table_grid_y: u32,
    /// Rebuild grid over scan blocks, x.
    pub block_grid_x: u32,
    /// Rebuild grid over scan blocks, y.
    pub block_grid_y: u32,
    /// Scan blocks.
    pub scan_blocks: u32,
    /// The rules other than Levine's, as bits ([`RULE_SIGNED_BOOST`], [`RULE_BREAKING_FORCE`],
    /// [`RULE_LAMMPS_CONTACT`]).
    pub rules: u32,
}

/// `Range`: one range of particles whose bond arrays share one binding each.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct Range {
    /// First particle.
    pub first: u32,
    /// Particles.
    pub count: u32,
    /// Index of the range's first spring workgroup among all.
    pub first_workgroup: u32,
    /// Spring workgroups of the range.
    pub workgroups: u32,
}

/// `Status`: the clock and counters kept on the GPU.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct Status {
    /// Steps completed.
    pub step: u32,
    /// External work, joules: high part.
    pub work_hi: f32,
    /// External work: low part.
    pub work_lo: f32,
    /// Non-zero: rebuild the contact lists before the next force pass.
    pub rebuild: u32,
    /// Break events recorded since the last read.
    pub events: u32,
    /// Largest candidate count needed at a build, when above the capacity.
    pub contact_needed: u32,
    /// Contact list builds.
    pub builds: u32,
    /// Padding.
    pub pad: u32,
}

impl Status {
    /// The work as one f64.
    pub fn work_j(&self) -> f64 {
        f64::from(self.work_hi) + f64::from(self.work_lo)
    }

    /// Splits `work` into the two-float form.
    pub fn set_work(&mut self, work: f64) {
        self.work_hi = work as f32;
        self.work_lo = (work - f64::from(self.work_hi)) as f32;
    }
}

/// Byte offset of `Status::rebuild` (the host sets it to force a rebuild).
pub const STATUS_REBUILD_OFFSET: u64 = 12;
/// Byte offset of `Status::events`.
pub const STATUS_EVENTS_OFFSET: u64 = 16;

/// `FamilyParams` of `family_forces.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct FamilyParams {
    /// alpha of eq. 18: thresholds grow by (1 + alpha phi).
    pub damage_strengthening: f32,
    /// gamma / |xi|, the cap on the plastic extension (infinite: none).
    pub plastic_cap_ratio: f32,
    /// 1 when some particle is held by a grip.
    pub grips: u32,
    /// Padding to 16 bytes.
    pub pad: u32,
}
