//! The CPU simulation: state in structure-of-arrays form, advanced by velocity Verlet; the
//! production backend and the reference for the GPU one.

use glam::DVec3;
use rayon::prelude::*;
use shatter_core::PipelineConfig;
use shatter_core::config::sim::{BreakRule, ContactModel, StiffnessCorrection};
use shatter_core::frames::BreakEvent;
use shatter_core::particles::{Bonds, ParticleSet};

use crate::backend::{Backend, DeviceError};
use crate::bond_layouts::EntryValues;
use crate::bond_layouts::lattice_layout::{LatticeTable, PmbSlot, SlotInputs, SlotViews};
use crate::bond_layouts::layout_choice::{LayoutChoice, SpringTable};
use crate::bond_layouts::row_layout::chunk_size;
use crate::contact::{BondLookup, ContactList, NO_BOND};
use crate::elastoplastic::FamilyBonds;
use crate::kernels::{self, BodyForces, ChunkForces, ParticleRecord, PassRules, SphereNow};
use crate::material_bonds::MaterialBonds;
use crate::model::{Model, MovingSphere, hold_grips};
use crate::state::{Dynamics, Energy, kinetic_energy_j};
use crate::{SimError, art};

/// Bond lookups for contact: "are i and j bonded and intact?", from the particle file's CSR and
/// a bitset of broken bond ids.
#[derive(Debug, Clone)]
struct BondIndex {
    offsets: Vec<u64>,
    neighbor: Vec<u32>,
    broken: Vec<u64>,
}

impl BondIndex {
    fn new(bonds: &Bonds) -> BondIndex {
        BondIndex {
            offsets: bonds.offsets.clone(),
            neighbor: bonds.neighbor.clone(),
            broken: vec![0; bonds.neighbor.len().div_ceil(64)],
        }
    }

    /// Marks bond `id` broken and counts it in both its particles' `broken` counts.
    fn record_break(&mut self, id: u64, broken: &mut [u32]) {
        self.broken[(id / 64) as usize] |= 1 << (id % 64);
        let i = self.offsets.partition_point(|offset| *offset <= id) - 1;
        broken[i] += 1;
        broken[self.neighbor[id as usize] as usize] += 1;
    }
}

impl BondLookup for BondIndex {
    fn bond_between(&self, i: usize, j: usize) -> u64 {
        let (lo, hi) = (i.min(j), i.max(j) as u32);
        let row = self.offsets[lo] as usize..self.offsets[lo + 1] as usize;
        match self.neighbor[row.clone()].binary_search(&hi) {
            Ok(k) => (row.start + k) as u64,
            Err(_) => NO_BOND,
        }
    }

    fn intact(&self, bond: u64) -> bool {
        bond != NO_BOND && self.broken[(bond / 64) as usize] & (1 << (bond % 64)) == 0
    }
}

/// Which velocity-Verlet kick pass to run ([`kernels::kick_drift`] and its kin).
#[derive(Debug, Clone, Copy)]
enum Kick {
    /// A step's opening kick and drift.
    Drift,
    /// A step's closing kick (and floor bounce).
    Floor,
    /// A step's closing kick, then the next one's opening kick and drift.
    FloorThenDrift,
}

/// A running simulation on the CPU.
#[derive(Debug, Clone)]
pub struct CpuSimulation {
    model: Model,
    rest: [Vec<f32>; 3],
    mass: Vec<f32>,
    inverse_mass: Vec<f32>,
    /// Particle volumes, m^3 (LAMMPS's short-range force).
    volume: Vec<f32>,
    /// Bonds per particle in the particle file (for damage).
    bond_count: Vec<u32>,
    bonds: MaterialBonds,
    /// Particles per chunk of the per-particle passes.
    chunk_size: usize,
    index: BondIndex,
    contacts: Option<ContactList>,
    dynamics: Dynamics,
    next_boost: Vec<f32>,
    broken: Vec<u32>,
    events: Vec<BreakEvent>,
    position_scratch: [Vec<f32>; 3],
    records: Vec<ParticleRecord>,
    chunk_power: Vec<f64>,
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
        model: Model,
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
        let inverse_mass = mass.iter().map(|m| 1.0 / m).collect();
        let volume = particles.volume_m3.clone();
        let bond_count = (0..n).map(|i| particles.bonds.row(i).len() as u32).collect();
        let contacts = model.has_contact().then(|| ContactList::new(n, model.contact_reach_m()));
        let zeros = || [vec![0.0f32; n], vec![0.0f32; n], vec![0.0f32; n]];
        let mut simulation = CpuSimulation {
            model,
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

    /// The largest stable time step of the linearised model (Silling and Askari 2005), seconds.
    pub fn stable_dt_s(&self) -> f64 {
        self.bonds.stable_dt_s(&self.mass, self.model.density_kg_m3)
    }

    /// The material model's per-bond state in the particle file's entry order (plastic
    /// extensions; empty for PMB).
    pub fn bond_state(&self) -> Vec<f32> {
        self.bonds.bond_state()
    }

    /// Advances one step of velocity Verlet.
    pub fn step(&mut self) {
        self.advance_steps(1);
    }

    /// Advances `steps` steps of velocity Verlet. A step's closing velocity kick and the next
    /// step's opening kick and drift, which read the same forces, run as one pass.
    fn advance_steps(&mut self, steps: u64) {
        if steps == 0 {
            return;
        }
        self.kick_pass(Kick::Drift);
        for k in 0..steps {
            self.dynamics.step += 1;
            let power = self.compute_forces();
            self.dynamics.external_work_j += power * self.model.dt_s;
            self.kick_pass(if k + 1 < steps { Kick::FloorThenDrift } else { Kick::Floor });
        }
    }

    /// One velocity-Verlet kick pass over all particles. A pass that drifts also sets the
    /// current positions (rest plus displacement), which the next force pass reads.
    fn kick_pass(&mut self, kick: Kick) {
        let (dt, size, floor) = (self.model.dt_s as f32, self.chunk_size, self.model.floor);
        let (inverse_mass, [rest_x, rest_y, rest_z]) = (&self.inverse_mass, &self.rest);
        let Dynamics { disp, vel, force, .. } = &mut self.dynamics;
        let ([vx, vy, vz], [ux, uy, uz], [fx, fy, fz]) = (vel, disp, &*force);
        let [px, py, pz] = &mut self.position_scratch;
        (
            (inverse_mass.par_chunks(size), fx.par_chunks(size), fy.par_chunks(size), fz.par_chunks(size)),
            (rest_x.par_chunks(size), rest_y.par_chunks(size), rest_z.par_chunks(size)),
            (vx.par_chunks_mut(size), vy.par_chunks_mut(size), vz.par_chunks_mut(size)),
            (ux.par_chunks_mut(size), uy.par_chunks_mut(size), uz.par_chunks_mut(size)),
            (px.par_chunks_mut(size), py.par_chunks_mut(size), pz.par_chunks_mut(size)),
        )
            .into_par_iter()
            .for_each(|((m, fx, fy, fz), rest, (vx, vy, vz), (ux, uy, uz), (px, py, pz))| {
                let (force, velocity) = ([fx, fy, fz], [vx, vy, vz]);
                match kick {
                    Kick::Drift => kernels::kick_drift(dt, m, force, velocity, [ux, uy, uz]),
                    Kick::Floor => kernels::kick_floor(dt, m, force, (rest.1, uy), floor, velocity),
                    Kick::FloorThenDrift => {
                        kernels::kick_floor_drift(dt, m, force, rest.1, floor, velocity, [ux, uy, uz])
                    }
                }
                if !matches!(kick, Kick::Floor) {
                    place([rest.0, rest.1, rest.2], [ux, uy, uz], [px, py, pz]);
                }
            });
    }

    /// Sets the current positions (rest plus displacement) of all particles.
    fn update_positions(&mut self) {
        let size = self.chunk_size;
        let [rx, ry, rz] = &self.rest;
        let [ux, uy, uz] = &self.dynamics.disp;
        let [px, py, pz] = &mut self.position_scratch;
        (
            (rx.par_chunks(size), ry.par_chunks(size), rz.par_chunks(size)),
            (ux.par_chunks(size), uy.par_chunks(size), uz.par_chunks(size)),
            (px.par_chunks_mut(size), py.par_chunks_mut(size), pz.par_chunks_mut(size)),
        )
            .into_par_iter()
            .for_each(|((rx, ry, rz), (ux, uy, uz), (px, py, pz))| place([rx, ry, rz], [ux, uy, uz], [px, py, pz]));
    }

    /// Forces at the current displacements: springs (breaking bonds), collisions, body forces.
    /// Also sets the next step's compression boosts and records breaks. Returns the power the
    /// external forces deliver at the current velocities, watts.
    fn compute_forces(&mut self) -> f64 {
        let CpuSimulation {
            model,
            rest,
            mass,
            volume,
            bonds,
            chunk_size,
            index,
            contacts,
            dynamics,
            next_boost,
            broken,
            events,
            position_scratch,
            records,
            chunk_power,
            ..
        } = self;
        let size = *chunk_size;
        let t = dynamics.step as f64 * model.dt_s;
        let sphere_now = |sphere: &MovingSphere| {
            let speed = sphere.velocity_m_s.length();
            let heading = if speed > 0.0 { sphere.velocity_m_s / speed } else { DVec3::ZERO };
            SphereNow {
                center: sphere.center_at(t).as_vec3().to_array(),
                heading: heading.as_vec3().to_array(),
                radius: sphere.radius_m as f32,
                stiffness: sphere.stiffness as f32,
            }
        };
        let projectiles: Vec<SphereNow> = model.projectiles.iter().map(sphere_now).collect();
        let indenters: Vec<SphereNow> = model.indenters.iter().map(sphere_now).collect();
        let body = BodyForces { gravity: model.gravity_m_s2, projectiles: &projectiles, indenters: &indenters };

        let Dynamics { disp, vel, force, boost, step, .. } = dynamics;
        // Current positions, for collisions and body forces (set by the last drift).
        let position = [&position_scratch[0][..], &position_scratch[1][..], &position_scratch[2][..]];
        if let Some(contacts) = contacts.as_mut() {
            contacts.update(position, &*index);
        }
        let rule = model.break_rule;
        let pass_rules = model.pass_rules();
        let [fx, fy, fz] = force;
        match bonds {
            MaterialBonds::Elastoplastic(table) => {
                table.evaluate([&disp[0][..], &disp[1][..], &disp[2][..]], [&mut fx[..], &mut fy[..], &mut fz[..]]);
                next_boost.fill(0.0);
            }
            MaterialBonds::Pmb(SpringTable::Rows(table)) => {
                // The row kernel's gather records.
                records.par_chunks_mut(size).enumerate().for_each(|(c, records)| {
                    for (i, record) in (c * size..).zip(records) {
                        *record = ParticleRecord { disp: [disp[0][i], disp[1][i], disp[2][i]], boost: boost[i] };
                    }
                });
                let records = &*records;
                (
                    table.chunks.par_iter_mut(),
                    fx.par_chunks_mut(size),
                    fy.par_chunks_mut(size),
                    fz.par_chunks_mut(size),
                    next_boost.par_chunks_mut(size),
                )
                    .into_par_iter()
                    .for_each(|(chunk, fx, fy, fz, min_stretch)| {
                        let mut out = ChunkForces { force: [fx, fy, fz], min_stretch };
                        kernels::spring_forces(chunk, records, rule, pass_rules, &mut out);
                    });
            }
            MaterialBonds::Pmb(SpringTable::Lattice(lattice)) => {
                lattice_forces(lattice, [&disp[0][..], &disp[1][..], &disp[2][..]], boost, rule);
            }
        }
        let velocity = [&vel[0][..], &vel[1][..], &vel[2][..]];
        let (alpha, signed_boost) = (model.alpha, pass_rules.signed_boost);
        let (contact_stiffness, contact_distance) = (model.contact_stiffness_pa, model.contact_distance_m);
        // LAMMPS's short-range force: its stiffness 15 c / delta and lambda
        let short_range = (model.rules.contact == ContactModel::Lammps)
            .then(|| ((15.0 * model.bond_constant / model.delta_m) as f32, model.lambda_m as f32));
        let volume = &volume[..];
        let contacts = contacts.as_ref();
        let rest_position = [&rest[0][..], &rest[1][..], &rest[2][..]];
        let lookup = &*index;
        let lattice_totals = match &*bonds {
            MaterialBonds::Pmb(SpringTable::Lattice(lattice)) => Some((&lattice.slot_of, &lattice.slots)),
            _ => None,
        };
        (
            chunk_power.par_iter_mut(),
            fx.par_chunks_mut(size),
            fy.par_chunks_mut(size),
            fz.par_chunks_mut(size),
            next_boost.par_chunks_mut(size),
        )
            .into_par_iter()
            .enumerate()
            .for_each(|(c, (power, fx, fy, fz, min_stretch))| {
                let first = c * size;
                if let Some((slot_of, slots)) = lattice_totals {
                    // The lattice kernel's outputs, from slot to particle order.
                    let [sx, sy, sz, smallest] = [0, 1, 2, 3].map(|k| slots.array(PmbSlot::FORCE + k));
                    // All sources one length: one bounds check covers the four loads.
                    let m = smallest.len();
                    let [sx, sy, sz] = [&sx[..m], &sy[..m], &sz[..m]];
                    let targets = fx.iter_mut().zip(fy.iter_mut()).zip(fz.iter_mut()).zip(min_stretch.iter_mut());
                    for ((((x, y), z), s), &slot) in targets.zip(&slot_of[first..]) {
                        let slot = slot as usize;
                        (*x, *y, *z, *s) = (sx[slot], sy[slot], sz[slot], smallest[slot]);
                    }
                }
                if signed_boost {
                    for value in min_stretch.iter_mut() {
                        // no intact bond: no boost either
                        *value = if value.is_finite() { -alpha * *value } else { 0.0 };
                    }
                } else {
                    for value in min_stretch.iter_mut() {
                        *value *= -alpha;
                    }
                }
                let mut force = [fx, fy, fz];
                match (contacts, short_range) {
                    (Some(contacts), Some((stiffness, lambda))) => kernels::short_range(
                        first,
                        position,
                        rest_position,
                        contacts,
                        volume,
                        stiffness,
                        lambda,
                        &mut force,
                    ),
                    (Some(contacts), None) => kernels::collisions(
                        first,
                        position,
                        rest_position,
                        contacts,
                        lookup,
                        contact_stiffness,
                        contact_distance,
                        &mut force,
                    ),
                    (None, _) => {}
                }
                *power = if body.is_empty() {
                    0.0
                } else {
                    kernels::body_forces(first, position, velocity, mass, &body, &mut force)
                };
            });
        std::mem::swap(boost, next_boost);
        // Grips: their particles keep their velocity; the grip takes up the force on them, and
        // its work, -F . v, counts as external work.
        let mut grip_power = 0.0f64;
        for grip in model.grips.iter().filter(|grip| t < grip.release_s) {
            for &i in &grip.particles {
                let i = i as usize;
                for (axis, v) in grip.velocity_m_s.into_iter().enumerate() {
                    let f = [&mut fx[i], &mut fy[i], &mut fz[i]];
                    grip_power -= f64::from(*f[axis]) * f64::from(v);
                    *f[axis] = 0.0;
                }
            }
        }
        hold_grips(&model.grips, t, vel);
        // Both kernels log each broken bond once, so the counts per particle are kept here.
        bonds.for_each_break(|bond| {
            index.record_break(bond, broken);
            events.push(BreakEvent { step: *step, bond });
        });
        chunk_power.iter().sum::<f64>() + grip_power
    }
}

/// The lattice layout's spring pass: the slots' inputs from the particles' displacements and
/// boosts, then the kernel over all chunks, into the table's slot totals.
fn lattice_forces(lattice: &mut LatticeTable, disp: [&[f32]; 3], boost: &[f32], rule: BreakRule) {
    let LatticeTable { chunk_slots, chunks, particle_of, slots, .. } = lattice;
    let (size, particle_of) = (*chunk_slots, &*particle_of);
    let SlotViews { inputs: [ux, uy, uz, slot_boost], outputs: [fx, fy, fz, min_stretch] } = slots.split_mut();
    (ux.par_chunks_mut(size), uy.par_chunks_mut(size), uz.par_chunks_mut(size), slot_boost.par_chunks_mut(size))
        .into_par_iter()
        .enumerate()
        .zip(chunks.par_iter())
        .for_each(|((c, (ux, uy, uz, slot_boost)), chunk)| {
            // All sources one length, so that one test of a slot's particle covers all four
            // loads (an empty slot's NO_PARTICLE fails it).
            let n = boost.len();
            let [dx, dy, dz] = disp.map(|axis| &axis[..n]);
            let slots = chunk.shape.slots;
            let owners = &particle_of[c * size..c * size + slots];
            let targets =
                ux[..slots].iter_mut().zip(&mut uy[..slots]).zip(&mut uz[..slots]).zip(&mut slot_boost[..slots]);
            for ((((x, y), z), b), &p) in targets.zip(owners) {
                let p = p as usize;
                if p < n {
                    (*x, *y, *z, *b) = (dx[p], dy[p], dz[p], boost[p]);
                }
            }
        });
    let inputs = SlotInputs { disp: [ux, uy, uz], boost: slot_boost };
    (
        chunks.par_iter_mut(),
        fx.par_chunks_mut(size),
        fy.par_chunks_mut(size),
        fz.par_chunks_mut(size),
        min_stretch.par_chunks_mut(size),
    )
        .into_par_iter()
        .for_each(|(chunk, fx, fy, fz, min_stretch)| {
            let mut out = ChunkForces { force: [fx, fy, fz], min_stretch };
            kernels::lattice_spring_forces(chunk, &inputs, particle_of, rule, &mut out);
        });
}

/// Positions of a chunk of particles: rest plus displacement, axis by axis.
fn place(rest: [&[f32]; 3], disp: [&[f32]; 3], position: [&mut [f32]; 3]) {
    for ((rest, disp), position) in rest.into_iter().zip(disp).zip(position) {
        for ((x, r), u) in position.iter_mut().zip(rest).zip(disp) {
            *x = r + u;
        }
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
