//! The GPU simulation itself: its handle on the device, its options, its state and its
//! construction, and what it does as a [`Backend`]. The other files of this module hold its
//! buffers, bind groups, stepping, and snapshot and replay.

use std::ops::Deref;

use rayon::prelude::*;
use shatter_core::config::sim::{BreakRule, ContactModel, StiffnessCorrection};
use shatter_core::frames::BreakEvent;
use shatter_core::particles::ParticleSet;
use shatter_gpu::{DispatchGrid, GpuContext, GpuError};

use super::bind_groups::BindGroups;
use super::family::GpuFamily;
use super::shaders::Kernels;
use super::sim_buffers::{Buffers, RangeBuffers};
use super::snapshot::Replay;
use super::wgsl_structs::{Params, RULE_BREAKING_FORCE, RULE_LAMMPS_CONTACT, RULE_SIGNED_BOOST, SCAN_BLOCK, SLICE, WG};
use crate::backend::{Backend, DeviceError};
use crate::bond_layouts::EntryValues;
use crate::bond_layouts::gpu_layout::{GpuBondLayout, GpuLayoutError};
use crate::bond_layouts::row_layout::chunk_size;
use crate::contact::SKIN_FRACTION;
use crate::elastoplastic::FamilyTable;
use crate::model::{Model, MovingSphere, hold_grips};
use crate::state::{Dynamics, Energy, kinetic_energy_j};

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

/// A running simulation on the GPU: the same model and results (to f32 rounding) as the CPU
/// [`crate::CpuSimulation`], one particle per invocation. See the module docs of [`crate::gpu`].
#[derive(Debug)]
pub struct GpuSimulation {
    pub(super) ctx: GpuHandle,
    pub(super) model: Model,
    pub(super) kernels: Kernels,
    pub(super) buffers: Buffers,
    pub(super) ranges: Vec<RangeBuffers>,
    pub(super) groups: BindGroups,
    pub(super) params: Params,
    /// The elastoplastic model (None: PMB springs).
    pub(super) family: Option<GpuFamily>,
    pub(super) particle_grid: DispatchGrid,
    /// Static sphere data (heading and radius; stiffness), projectiles then indenters.
    pub(super) spheres: Vec<MovingSphere>,
    pub(super) rest: [Vec<f32>; 3],
    pub(super) mass: Vec<f32>,
    pub(super) inverse_mass: Vec<f32>,
    bond_count: Vec<u32>,
    pub(super) rows: Vec<[u32; 4]>,
    pub(super) offsets: Vec<u64>,
    pub(super) neighbor: Vec<u32>,
    pub(super) range_words: Vec<usize>,
    pub(super) range_of_group: Vec<u32>,
    pub(super) stored_entries: usize,
    stable_dt_s: f64,
    /// Host-side state as of the last frame boundary.
    pub(super) dynamics: Dynamics,
    pub(super) broken: Vec<u32>,
    pub(super) bond_energy: Vec<f64>,
    pub(super) events: Vec<BreakEvent>,
    /// What ran since the snapshot (replayed after an overflow).
    pub(super) history: Vec<Replay>,
    /// Steps taken (the GPU clock mirrors it).
    pub(super) step: u64,
}

fn layout_error(error: GpuLayoutError) -> GpuError {
    GpuError::Split { message: error.to_string() }
}

/// What a simulation's bonds are made from: the particles, the model, the art direction's
/// threshold factors (one per particle-file bond entry) and the stiffness correction.
struct BondInputs<'a> {
    particles: &'a ParticleSet,
    model: &'a Model,
    factors: Option<&'a [f32]>,
    correction: StiffnessCorrection,
}

impl BondInputs<'_> {
    /// The sliced bond layout, each range's arrays within `limit` bytes (a quarter of it for the
    /// elastoplastic model); an error also when the particle records exceed one binding of
    /// `binding` bytes.
    fn layout(&self, ctx: &GpuContext, binding: u64, limit: u64) -> Result<GpuBondLayout, GpuError> {
        let (particles, model, n) = (self.particles, self.model, self.particles.len());
        // the layout sizes ranges by its 4-byte arrays; the elastoplastic model's widest is 16 bytes
        // an entry
        let max_binding = if model.elastoplastic.is_some() { limit / 4 } else { limit };
        let layout = GpuBondLayout::new(
            particles,
            model.bond_constant,
            model.threshold_scale,
            self.factors,
            self.correction,
            model.rules.partial_volumes,
            max_binding,
        )
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
        Ok(layout)
    }

    /// The elastoplastic model's family table (None for PMB springs), whose bonds must fit the
    /// one range of `layout` (bindings of `limit` bytes); an error also for grips without it.
    fn family_table(
        &self,
        ctx: &GpuContext,
        layout: &GpuBondLayout,
        limit: u64,
    ) -> Result<Option<FamilyTable>, GpuError> {
        let (particles, model) = (self.particles, self.model);
        let family_table = match model.elastoplastic {
            Some(constants) => {
                if layout.ranges.len() != 1 {
                    return Err(GpuError::Split {
                        message: format!(
                            "the elastoplastic model keeps its bonds in one storage binding on the GPU, and this \
                             scene's need {} (its 16-byte entry records are larger than one binding of {} holds: \
                             {} bytes)",
                            layout.ranges.len(),
                            ctx.describe(),
                            limit
                        ),
                    });
                }
                let values = EntryValues::new(
                    particles,
                    model.bond_constant,
                    model.threshold_scale,
                    self.factors,
                    self.correction,
                    model.rules.partial_volumes,
                );
                let table =
                    FamilyTable::new(particles, constants, chunk_size(particles.len()), |k| values.threshold(k))
                        .map_err(|error| GpuError::Split { message: error.to_string() })?;
                Some(table)
            }
            None => None,
        };
        if !model.grips.is_empty() && family_table.is_none() {
            return Err(GpuError::Split {
                message: "grips ([[sim.grip]]) hold particles on the GPU with the elastoplastic model only".into(),
            });
        }
        Ok(family_table)
    }
}

/// The rules other than Levine's that `model` follows, as the bits of [`Params::rules`].
fn rule_bits(model: &Model) -> u32 {
    let pass = model.pass_rules();
    u32::from(pass.signed_boost) * RULE_SIGNED_BOOST
        + u32::from(pass.breaking_step_force) * RULE_BREAKING_FORCE
        + u32::from(model.rules.contact == ContactModel::Lammps) * RULE_LAMMPS_CONTACT
}

/// The kernels' constants for a run of `model` on `particles` with `layout`, and the dispatch
/// grid over the particles.
fn step_params(
    ctx: &GpuContext,
    particles: &ParticleSet,
    model: &Model,
    options: &GpuOptions,
    layout: &GpuBondLayout,
) -> Result<(Params, DispatchGrid), GpuError> {
    let n = particles.len();
    let contact = model.has_contact();
    let lammps_contact = model.rules.contact == ContactModel::Lammps;
    // LAMMPS's 15 c V_i V_j / delta, on masses m = rho V
    let contact_stiffness = if lammps_contact {
        (15.0 * model.bond_constant / (model.delta_m * model.density_kg_m3 * model.density_kg_m3)) as f32
    } else {
        model.contact_stiffness_pa
    };
    let table = (2 * n).next_power_of_two().max(16);
    let scan_blocks = table.div_ceil(SCAN_BLOCK);
    let particle_grid = ctx.dispatch_grid(n.div_ceil(WG) as u64)?;
    let table_grid = ctx.dispatch_grid(table.div_ceil(WG) as u64)?;
    let block_grid = ctx.dispatch_grid(scan_blocks as u64)?;
    let distance = model.contact_reach_m();
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
        contact_stiffness,
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
        rules: rule_bits(model),
    };
    Ok((params, particle_grid))
}

impl GpuSimulation {
    /// A body at rest in its reference shape, on the GPU. `factors` are art-direction multipliers
    /// of the thresholds, one per particle-file bond entry.
    pub fn new(
        ctx: GpuHandle,
        particles: &ParticleSet,
        mut model: Model,
        factors: Option<&[f32]>,
        correction: StiffnessCorrection,
        options: &GpuOptions,
    ) -> Result<GpuSimulation, GpuError> {
        let n = particles.len();
        if n == 0 {
            return Err(GpuError::Split { message: "the particle set is empty".into() });
        }
        let binding = ctx.max_storage_binding_bytes();
        let limit = options.max_binding_bytes.map_or(binding, |limit| limit.min(binding));
        let bond_inputs = BondInputs { particles, model: &model, factors, correction };
        let layout = bond_inputs.layout(&ctx, binding, limit)?;
        let rest = [0, 1, 2].map(|axis| particles.rest_position_m.iter().map(|p| p[axis]).collect::<Vec<f32>>());
        let mass: Vec<f32> = particles.volume_m3.iter().map(|v| (f64::from(*v) * model.density_kg_m3) as f32).collect();
        let inverse_mass: Vec<f32> = mass.iter().map(|m| 1.0 / m).collect();
        let bond_count: Vec<u32> = (0..n).map(|i| particles.bonds.row(i).len() as u32).collect();
        let family_table = bond_inputs.family_table(&ctx, &layout, limit)?;
        let stable_dt_s = match &family_table {
            Some(table) => table.stable_dt_s(model.density_kg_m3),
            None => stable_dt(&layout, &particles.bonds.rest_length_m, &mass),
        };
        model.take_time_step(stable_dt_s).map_err(|message| GpuError::Split { message })?;
        let spheres: Vec<MovingSphere> = model.projectiles.iter().chain(&model.indenters).copied().collect();
        let (params, particle_grid) = step_params(&ctx, particles, &model, options, &layout)?;

        let kernels = Kernels::new(&ctx)?;
        let buffers = Buffers::new(&ctx, particles, &mass, &inverse_mass, &spheres, &params, &layout)?;
        let mut ranges = Vec::with_capacity(layout.ranges.len());
        for part in &layout.ranges {
            ranges.push(RangeBuffers::new(&ctx, part)?);
        }
        let range_words = ranges.iter().map(|r| r.words).collect();
        let stored_entries = layout.stored_entries();
        let zero3 = || [vec![0.0f32; n], vec![0.0f32; n], vec![0.0f32; n]];
        let family = match family_table {
            Some(table) => Some(GpuFamily::new(&ctx, table, &layout.rows, stored_entries, &model.grips, model.dt_s)?),
            None => None,
        };
        let contact = model.has_contact();
        let groups = BindGroups::new(&ctx, &kernels, &buffers, &ranges, contact, family.as_ref().map(|f| &f.buffers))?;
        let mut simulation = GpuSimulation {
            model,
            kernels,
            buffers,
            ranges,
            groups,
            params,
            family,
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
}

/// min over particles of sqrt(2 m_i / sum_j k_ij / L_ij), as the CPU's `stable_dt_s`.
fn stable_dt(layout: &GpuBondLayout, rest_length: &[f32], mass: &[f32]) -> f64 {
    let n = mass.len();
    (0..n)
        .into_par_iter()
        .map(|i| {
            let row = layout.rows[i];
            let part = &layout.ranges[layout.range_of(i)];
            let stiffness: f64 = (0..row[2] as usize)
                .map(|k| {
                    let e = row[0] as usize + k * SLICE;
                    f64::from(part.stiffness[e]) / f64::from(rest_length[row[3] as usize + k])
                })
                .sum();
            if stiffness > 0.0 { (2.0 * f64::from(mass[i]) / stiffness).sqrt() } else { f64::INFINITY }
        })
        .reduce(|| f64::INFINITY, f64::min)
}

/// A GPU error met while running, as the backend-neutral error of [`Backend`].
impl From<GpuError> for DeviceError {
    fn from(error: GpuError) -> DeviceError {
        DeviceError::new(error)
    }
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

    fn advance(&mut self, steps: u64) -> Result<(), DeviceError> {
        self.advance_steps(steps)?;
        self.history.push(Replay::Steps(steps));
        Ok(())
    }

    fn finish_frame(&mut self) -> Result<Vec<BreakEvent>, DeviceError> {
        self.sync()?;
        Ok(std::mem::take(&mut self.events))
    }

    fn dynamics(&self) -> &Dynamics {
        &self.dynamics
    }

    fn energy(&self) -> Energy {
        let size = chunk_size(self.len());
        let kinetic_j = kinetic_energy_j(&self.mass, &self.dynamics.vel, size);
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

    fn restore(&mut self, dynamics: Dynamics, broken_bonds: &[u64]) -> Result<(), DeviceError> {
        self.dynamics = dynamics;
        self.events.clear();
        if let Some(family) = &mut self.family {
            family.table.mark_broken(broken_bonds);
        }
        self.upload(Some(broken_bonds))?;
        Ok(self.sync()?)
    }

    fn bond_state(&self) -> Vec<f32> {
        self.family.as_ref().map_or_else(Vec::new, |family| family.table.plastic_in_file_order())
    }

    fn set_bond_state(&mut self, state: &[f32]) -> Result<(), String> {
        let Some(family) = &mut self.family else {
            return if state.is_empty() {
                Ok(())
            } else {
                Err(format!("{} per-bond values for the PMB model, which keeps none", state.len()))
            };
        };
        family.table.set_plastic_from_file_order(state)?;
        let uploaded =
            family.upload_plastic(&self.ctx, &self.rows, self.stored_entries).and_then(|()| self.copy_snapshot(false));
        uploaded.map_err(|error| error.to_string())?;
        if let Some(family) = &self.family {
            self.bond_energy = family.energy_per_particle(&self.dynamics.disp);
        }
        Ok(())
    }

    fn set_velocity(&mut self, velocity: &dyn Fn(usize, [f32; 3]) -> [f32; 3]) -> Result<(), DeviceError> {
        self.sync()?;
        for i in 0..self.len() {
            let v = velocity(i, [0, 1, 2].map(|a| self.rest[a][i]));
            for (axis, value) in v.into_iter().enumerate() {
                self.dynamics.vel[axis][i] = value;
            }
        }
        hold_grips(&self.model.grips, self.dynamics.step as f64 * self.model.dt_s, &mut self.dynamics.vel);
        self.upload(None)?;
        Ok(self.sync()?)
    }

    fn set_displacement(&mut self, displacement: &dyn Fn(usize, [f32; 3]) -> [f32; 3]) -> Result<(), DeviceError> {
        self.sync()?;
        for i in 0..self.len() {
            let u = displacement(i, [0, 1, 2].map(|a| self.rest[a][i]));
            for (axis, value) in u.into_iter().enumerate() {
                self.dynamics.disp[axis][i] = value;
            }
        }
        self.upload(None)?;
        Ok(self.standalone_force_pass()?)
    }
}
