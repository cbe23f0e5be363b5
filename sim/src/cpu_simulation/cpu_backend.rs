//! The CPU simulation itself: its state, its construction, what it tells of the state, and
//! what it does as a [`Backend`]. The step is in `verlet_step.rs`, the force evaluation in
//! `force_evaluation.rs`.

use shatter_core::PipelineConfig;
use shatter_core::config::sim::StiffnessCorrection;
use shatter_core::frames::BreakEvent;
use shatter_core::particles::ParticleSet;

use super::bond_index::BondIndex;
use crate::backend::{Backend, DeviceError};
use crate::bond_layouts::EntryValues;
use crate::bond_layouts::layout_choice::{LayoutChoice, SpringTable};
use crate::bond_layouts::row_layout::chunk_size;
use crate::contact::ContactList;
use crate::elastoplastic::FamilyBonds;
use crate::kernels::{ParticleRecord, PassRules};
use crate::material_bonds::MaterialBonds;
use crate::model::{Model, hold_grips};
use crate::simd_path::SimdPath;
use crate::state::{Dynamics, Energy, kinetic_energy_j};
use crate::{SimError, art};

/// A running simulation on the CPU.
#[derive(Debug, Clone)]
pub struct CpuSimulation {
    pub(super) model: Model,
    /// The stable time step of the intact bonds, seconds (computed once, as the step from the
    /// material needs it before the run and the time-step check after).
    pub(super) stable_dt_s: f64,
    pub(super) rest: [Vec<f32>; 3],
    pub(super) mass: Vec<f32>,
    pub(super) inverse_mass: Vec<f32>,
    /// Particle volumes, m^3 (LAMMPS's short-range force).
    pub(super) volume: Vec<f32>,
    /// Bonds per particle in the particle file (for damage).
    pub(super) bond_count: Vec<u32>,
    pub(super) bonds: MaterialBonds,
    /// Particles per chunk of the per-particle passes.
    pub(super) chunk_size: usize,
    pub(super) index: BondIndex,
    pub(super) contacts: Option<ContactList>,
    pub(super) dynamics: Dynamics,
    pub(super) next_boost: Vec<f32>,
    pub(super) broken: Vec<u32>,
    pub(super) events: Vec<BreakEvent>,
    pub(super) position_scratch: [Vec<f32>; 3],
    pub(super) records: Vec<ParticleRecord>,
    pub(super) chunk_power: Vec<f64>,
    /// The spring kernels' instruction set.
    pub(super) simd: SimdPath,
}

impl CpuSimulation {
    /// A body at rest in its reference shape. `factors` are art-direction multipliers of the
    /// thresholds, one per particle-file bond entry.
    pub fn new(
        particles: &ParticleSet,
        model: Model,
        factors: Option<&[f32]>,
        correction: StiffnessCorrection,
    ) -> Result<CpuSimulation, SimError> {
        CpuSimulation::with_layout(particles, model, factors, correction, LayoutChoice::Fastest)
    }

    /// [`CpuSimulation::new`] with a say in the bond layout.
    fn with_layout(
        particles: &ParticleSet,
        mut model: Model,
        factors: Option<&[f32]>,
        correction: StiffnessCorrection,
        layout: LayoutChoice,
    ) -> Result<CpuSimulation, SimError> {
        let n = particles.len();
        let (constant, scale) = (model.bond_constant, model.threshold_scale);
        let values = EntryValues::new(particles, constant, scale, factors, correction, model.rules.partial_volumes);
        let bonds = match model.elastoplastic {
            Some(constants) => {
                let lattice = layout == LayoutChoice::Fastest;
                let table = FamilyBonds::new(particles, constants, chunk_size(n), |k| values.threshold(k), lattice)?;
                MaterialBonds::Elastoplastic(Box::new(table))
            }
            None => {
                // The lattice kernel runs Levine's rules only.
                let layout = if model.pass_rules() == PassRules::default() { layout } else { LayoutChoice::RowsOnly };
                MaterialBonds::Pmb(SpringTable::new(particles, &values, layout))
            }
        };
        // The row kernel's gather records (the lattice kernel fills its own slots).
        let records = match bonds {
            MaterialBonds::Pmb(SpringTable::Rows(_)) => vec![ParticleRecord::default(); n],
            _ => Vec::new(),
        };
        let rest = [0, 1, 2].map(|axis| particles.rest_position_m.iter().map(|p| p[axis]).collect::<Vec<f32>>());
        let mass: Vec<f32> = particles.volume_m3.iter().map(|v| (f64::from(*v) * model.density_kg_m3) as f32).collect();
        let stable_dt_s = bonds.stable_dt_s(&mass, model.density_kg_m3);
        model.take_time_step(stable_dt_s).map_err(SimError::BadInput)?;
        let inverse_mass = mass.iter().map(|m| 1.0 / m).collect();
        let volume = particles.volume_m3.clone();
        let bond_count = (0..n).map(|i| particles.bonds.row(i).len() as u32).collect();
        let contacts = model.has_contact().then(|| ContactList::new(n, model.contact_reach_m()));
        let zeros = || [vec![0.0f32; n], vec![0.0f32; n], vec![0.0f32; n]];
        let mut simulation = CpuSimulation {
            model,
            stable_dt_s,
            rest,
            mass,
            inverse_mass,
            volume,
            bond_count,
            bonds,
            chunk_size: chunk_size(n),
            index: BondIndex::new(&particles.bonds),
            contacts,
            dynamics: Dynamics {
                step: 0,
                disp: zeros(),
                vel: zeros(),
                force: zeros(),
                boost: vec![0.0; n],
                external_work_j: 0.0,
            },
            next_boost: vec![0.0; n],
            broken: vec![0; n],
            events: Vec::new(),
            position_scratch: zeros(),
            records,
            chunk_power: Vec::new(),
            simd: SimdPath::for_process().map_err(SimError::BadInput)?,
        };
        simulation.chunk_power = vec![0.0; n.div_ceil(simulation.chunk_size)];
        simulation.update_positions();
        simulation.compute_forces();
        Ok(simulation)
    }

    /// The simulation a config describes for a particle set: its model, art direction and
    /// stiffness correction.
    pub fn from_config(config: &PipelineConfig, particles: &ParticleSet) -> Result<CpuSimulation, SimError> {
        CpuSimulation::from_config_with_layout(config, particles, LayoutChoice::Fastest)
    }

    /// [`CpuSimulation::from_config`] with a say in the bond layout (tests run both).
    pub fn from_config_with_layout(
        config: &PipelineConfig,
        particles: &ParticleSet,
        layout: LayoutChoice,
    ) -> Result<CpuSimulation, SimError> {
        let model = Model::new(config, particles)?;
        let factors = art::threshold_factors(&config.sim, particles, config.scene.seed)?;
        let correction = config.sim.stiffness_correction;
        CpuSimulation::with_layout(particles, model, factors.as_deref(), correction, layout)
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.mass.len()
    }

    /// True for a simulation without particles.
    pub fn is_empty(&self) -> bool {
        self.mass.is_empty()
    }

    /// Bond entries the force pass computes per step: (internal, stored once and applied to
    /// both ends; external, stored and computed on both sides).
    pub fn bond_entries(&self) -> (usize, usize) {
        match &self.bonds {
            MaterialBonds::Pmb(table) => table.entries(),
            MaterialBonds::Elastoplastic(table) => (0, table.bond_entries()),
        }
    }

    /// True when the force pass runs on the lattice layout ([`crate::bond_layouts::lattice_layout`]),
    /// for either material model.
    pub fn on_lattice(&self) -> bool {
        match &self.bonds {
            MaterialBonds::Pmb(table) => matches!(table, SpringTable::Lattice(_)),
            MaterialBonds::Elastoplastic(table) => table.on_lattice(),
        }
    }

    /// The model.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The mutable state.
    pub fn dynamics(&self) -> &Dynamics {
        &self.dynamics
    }

    /// Simulated time, seconds.
    pub fn time_s(&self) -> f64 {
        self.dynamics.step as f64 * self.model.dt_s
    }

    /// Particle masses, kg.
    pub fn mass(&self) -> &[f32] {
        &self.mass
    }

    /// Rest positions X, metres.
    pub fn rest(&self) -> [&[f32]; 3] {
        [&self.rest[0], &self.rest[1], &self.rest[2]]
    }

    /// Sets velocities (initial conditions; tests); gripped particles keep their grip's.
    pub fn set_velocity(&mut self, velocity: impl Fn(usize, [f32; 3]) -> [f32; 3]) {
        for i in 0..self.len() {
            let x = [0, 1, 2].map(|a| self.rest[a][i]);
            let v = velocity(i, x);
            for (axis, value) in v.into_iter().enumerate() {
                self.dynamics.vel[axis][i] = value;
            }
        }
        hold_grips(&self.model.grips, self.time_s(), &mut self.dynamics.vel);
    }

    /// Sets displacements (initial conditions; tests) and recomputes forces without breaking
    /// bonds' history: a deformed start.
    pub fn set_displacement(&mut self, displacement: impl Fn(usize, [f32; 3]) -> [f32; 3]) {
        for i in 0..self.len() {
            let x = [0, 1, 2].map(|a| self.rest[a][i]);
            let u = displacement(i, x);
            for (axis, value) in u.into_iter().enumerate() {
                self.dynamics.disp[axis][i] = value;
            }
        }
        self.update_positions();
        self.compute_forces();
    }

    /// Replaces the state with a checkpoint's; `broken_bonds` (sorted ids) are marked broken.
    pub fn restore(&mut self, dynamics: Dynamics, broken_bonds: &[u64]) {
        self.bonds.mark_broken(broken_bonds);
        self.broken.fill(0);
        for &id in broken_bonds {
            self.index.record_break(id, &mut self.broken);
        }
        self.dynamics = dynamics;
    }

    /// Takes the bonds broken since the last call, in the order they broke.
    pub fn take_breaks(&mut self) -> Vec<BreakEvent> {
        std::mem::take(&mut self.events)
    }

    /// Fraction of each particle's bonds that are broken.
    pub fn damage(&self) -> Vec<f32> {
        self.broken
            .iter()
            .zip(&self.bond_count)
            .map(|(broken, count)| if *count == 0 { 0.0 } else { *broken as f32 / *count as f32 })
            .collect()
    }

    /// Current positions x = X + u, metres.
    pub fn positions(&self) -> [Vec<f32>; 3] {
        [0, 1, 2].map(|a| self.rest[a].iter().zip(&self.dynamics.disp[a]).map(|(x, u)| x + u).collect())
    }

    /// Kinetic and bond energy, summed per chunk in a fixed order (deterministic).
    pub fn energy(&self) -> Energy {
        let kinetic_j = kinetic_energy_j(&self.mass, &self.dynamics.vel, self.chunk_size);
        Energy { kinetic_j, bond_j: self.bonds.energy_j(&self.dynamics.disp) }
    }

    /// Each particle's share of the stored bond energy (for PMB half of each of its intact
    /// springs' 1/2 k s^2 L), joules.
    pub fn bond_energy_per_particle(&self) -> Vec<f64> {
        self.bonds.energy_per_particle(&self.dynamics.disp)
    }

    /// The largest stable time step of the linearised model (Silling and Askari 2005) with every
    /// bond intact, seconds.
    pub fn stable_dt_s(&self) -> f64 {
        self.stable_dt_s
    }

    /// The spring kernels' instruction set.
    pub fn simd_path(&self) -> SimdPath {
        self.simd
    }

    /// Runs the spring kernels on `path` from the next step on (every path gives the same bits).
    /// Fails, naming the path, when this CPU lacks it.
    pub fn set_simd_path(&mut self, path: SimdPath) -> Result<(), SimError> {
        if !path.supported() {
            return Err(SimError::BadInput(format!("this CPU cannot run the {path} kernels")));
        }
        self.simd = path;
        Ok(())
    }

    /// The material model's per-bond state in the particle file's entry order (plastic
    /// extensions; empty for PMB).
    pub fn bond_state(&self) -> Vec<f32> {
        self.bonds.bond_state()
    }
}

impl Backend for CpuSimulation {
    fn describe(&self) -> String {
        format!("CPU ({} threads)", rayon::current_num_threads())
    }

    fn len(&self) -> usize {
        CpuSimulation::len(self)
    }

    fn model(&self) -> &Model {
        CpuSimulation::model(self)
    }

    fn advance(&mut self, steps: u64) -> Result<(), DeviceError> {
        // On a worker of the pool, so that each step's parallel passes fork and join among the
        // workers rather than each waking this thread at its end (the default shot's sim stage:
        // half the system time, 2% to 6% less wall time).
        rayon::scope(|_| self.advance_steps(steps));
        Ok(())
    }

    fn finish_frame(&mut self) -> Result<Vec<BreakEvent>, DeviceError> {
        Ok(self.take_breaks())
    }

    fn dynamics(&self) -> &Dynamics {
        CpuSimulation::dynamics(self)
    }

    fn energy(&self) -> Energy {
        CpuSimulation::energy(self)
    }

    fn bond_energy_per_particle(&self) -> Vec<f64> {
        CpuSimulation::bond_energy_per_particle(self)
    }

    fn positions(&self) -> [Vec<f32>; 3] {
        CpuSimulation::positions(self)
    }

    fn damage(&self) -> Vec<f32> {
        CpuSimulation::damage(self)
    }

    fn mass(&self) -> &[f32] {
        CpuSimulation::mass(self)
    }

    fn rest(&self) -> [&[f32]; 3] {
        CpuSimulation::rest(self)
    }

    fn time_s(&self) -> f64 {
        CpuSimulation::time_s(self)
    }

    fn stable_dt_s(&self) -> f64 {
        CpuSimulation::stable_dt_s(self)
    }

    fn simd_path(&self) -> Option<SimdPath> {
        Some(self.simd)
    }

    fn restore(&mut self, dynamics: Dynamics, broken_bonds: &[u64]) -> Result<(), DeviceError> {
        CpuSimulation::restore(self, dynamics, broken_bonds);
        Ok(())
    }

    fn bond_state(&self) -> Vec<f32> {
        CpuSimulation::bond_state(self)
    }

    fn set_bond_state(&mut self, state: &[f32]) -> Result<(), String> {
        self.bonds.set_bond_state(state)
    }

    fn set_velocity(&mut self, velocity: &dyn Fn(usize, [f32; 3]) -> [f32; 3]) -> Result<(), DeviceError> {
        CpuSimulation::set_velocity(self, velocity);
        Ok(())
    }

    fn set_displacement(&mut self, displacement: &dyn Fn(usize, [f32; 3]) -> [f32; 3]) -> Result<(), DeviceError> {
        CpuSimulation::set_displacement(self, displacement);
        Ok(())
    }
}
