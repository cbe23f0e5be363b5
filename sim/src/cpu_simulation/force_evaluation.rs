//! The CPU simulation's force evaluation, once a step: the bonds' forces by material model and
//! layout, beside the contact lists' update; then, chunk by chunk, the lattice kernel's totals in
//! particle order, the next compression boosts, the contact forces and the body forces; then the
//! grips and the breaks.

use glam::DVec3;
use rayon::prelude::*;
use shatter_core::config::sim::{BreakRule, ContactModel};
use shatter_core::frames::BreakEvent;

use super::CpuSimulation;
use crate::bond_layouts::lattice_layout::{LatticeTable, PmbSlot, SlotInputs, SlotViews};
use crate::bond_layouts::layout_choice::SpringTable;
use crate::bond_layouts::row_layout::BondTable;
use crate::kernels::{self, BodyForces, ChunkForces, ContactChunk, Gathers, ParticleRecord, SphereNow};
use crate::material_bonds::MaterialBonds;
use crate::model::{MovingSphere, hold_grips};
use crate::simd_path::SimdPath;
use crate::state::Dynamics;

impl CpuSimulation {
    /// Forces at the current displacements: springs (breaking bonds), collisions, body forces.
    /// Also sets the next step's compression boosts and records breaks. Returns the power the
    /// external forces deliver at the current velocities, watts.
    pub(super) fn compute_forces(&mut self) -> f64 {
        let t = self.dynamics.step as f64 * self.model.dt_s;
        let projectiles: Vec<SphereNow> = self.model.projectiles.iter().map(|sphere| sphere_now(sphere, t)).collect();
        let indenters: Vec<SphereNow> = self.model.indenters.iter().map(|sphere| sphere_now(sphere, t)).collect();
        let body = BodyForces { gravity: self.model.gravity_m_s2, projectiles: &projectiles, indenters: &indenters };
        // The contact lists read the current positions (set by the last drift), the spring pass
        // the displacements: they run side by side, so that the lists' serial parts take a core
        // that the spring pass's chunks, too few to share out evenly, leave idle.
        let CpuSimulation { model, bonds, chunk_size, dynamics, next_boost, records, simd, .. } = self;
        let springs = SpringPass { model, bonds, chunk_size: *chunk_size, dynamics, next_boost, records, simd: *simd };
        let (contacts, [px, py, pz], index) = (&mut self.contacts, &self.position_scratch, &self.index);
        rayon::join(
            || {
                if let Some(contacts) = contacts.as_mut() {
                    contacts.update([&px[..], &py[..], &pz[..]], index);
                }
            },
            || springs.run(),
        );
        self.chunk_forces(&body);
        std::mem::swap(&mut self.dynamics.boost, &mut self.next_boost);
        let grip_power = self.grip_forces(t);
        hold_grips(&self.model.grips, t, &mut self.dynamics.vel);
        self.record_breaks();
        self.chunk_power.iter().sum::<f64>() + grip_power
    }

    /// Chunk by chunk: the lattice kernel's totals into particle order, the next compression
    /// boosts from the smallest stretches, the contact forces, and the body forces `body`, whose
    /// power goes into `chunk_power`.
    fn chunk_forces(&mut self, body: &BodyForces) {
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
            position_scratch,
            chunk_power,
            ..
        } = self;
        let size = *chunk_size;
        let position = [&position_scratch[0][..], &position_scratch[1][..], &position_scratch[2][..]];
        let Dynamics { vel, force, .. } = dynamics;
        let velocity = [&vel[0][..], &vel[1][..], &vel[2][..]];
        let (alpha, signed_boost) = (model.alpha, model.pass_rules().signed_boost);
        let (contact_stiffness, contact_distance) = (model.contact_stiffness_pa, model.contact_distance_m);
        // LAMMPS's short-range force: its stiffness 15 c / delta and lambda
        let short_range = (model.rules.contact == ContactModel::Lammps)
            .then(|| ((15.0 * model.bond_constant / model.delta_m) as f32, model.lambda_m as f32));
        let (mass, volume, contacts, lookup) = (&mass[..], &volume[..], contacts.as_ref(), &*index);
        let rest_position = [&rest[0][..], &rest[1][..], &rest[2][..]];
        let lattice_totals = match &*bonds {
            MaterialBonds::Pmb(SpringTable::Lattice(lattice)) => Some((&lattice.slot_of, &lattice.slots)),
            _ => None,
        };
        let [fx, fy, fz] = force;
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
                boosts_from_stretches(min_stretch, alpha, signed_boost);
                let mut force = [fx, fy, fz];
                if let Some(contacts) = contacts {
                    let chunk = ContactChunk { first, position, rest: rest_position, contacts };
                    match short_range {
                        Some((stiffness, lambda)) => {
                            kernels::short_range(&chunk, volume, stiffness, lambda, &mut force)
                        }
                        None => kernels::collisions(&chunk, lookup, contact_stiffness, contact_distance, &mut force),
                    }
                }
                *power = if body.is_empty() {
                    0.0
                } else {
                    kernels::body_forces(first, position, velocity, mass, body, &mut force)
                };
            });
    }

    /// Grips: their particles keep their velocity; the grip takes up the force on them, and its
    /// work, -F . v, counts as external work. Returns the grips' power at time `t`, watts.
    fn grip_forces(&mut self, t: f64) -> f64 {
        let [fx, fy, fz] = &mut self.dynamics.force;
        let mut grip_power = 0.0f64;
        for grip in self.model.grips.iter().filter(|grip| t < grip.release_s) {
            for &i in &grip.particles {
                let i = i as usize;
                for (axis, v) in grip.velocity_m_s.into_iter().enumerate() {
                    let f = [&mut fx[i], &mut fy[i], &mut fz[i]];
                    grip_power -= f64::from(*f[axis]) * f64::from(v);
                    *f[axis] = 0.0;
                }
            }
        }
        grip_power
    }

    /// Records the bonds the force pass broke: their events, and the broken counts of both
    /// their particles (both kernels log each broken bond once, so the counts are kept here).
    fn record_breaks(&mut self) {
        let CpuSimulation { bonds, index, broken, events, dynamics, .. } = self;
        bonds.for_each_break(|bond| {
            index.record_break(bond, broken);
            events.push(BreakEvent { step: dynamics.step, bond });
        });
    }
}

/// What the spring pass reads and writes of a [`CpuSimulation`].
struct SpringPass<'a> {
    model: &'a crate::model::Model,
    bonds: &'a mut MaterialBonds,
    chunk_size: usize,
    dynamics: &'a mut Dynamics,
    next_boost: &'a mut [f32],
    records: &'a mut [ParticleRecord],
    simd: SimdPath,
}

impl SpringPass<'_> {
    /// The bonds' forces into the force arrays, by material model and layout (the row kernel's
    /// smallest stretches into `next_boost`; the lattice kernel's totals stay in its slots).
    fn run(self) {
        let SpringPass { model, bonds, chunk_size: size, dynamics, next_boost, records, simd } = self;
        let Dynamics { disp, force, boost, .. } = dynamics;
        let (rule, pass_rules) = (model.break_rule, model.pass_rules());
        let [fx, fy, fz] = force;
        match bonds {
            MaterialBonds::Elastoplastic(table) => {
                table.evaluate([&disp[0][..], &disp[1][..], &disp[2][..]], [&mut fx[..], &mut fy[..], &mut fz[..]]);
                next_boost.fill(0.0);
            }
            MaterialBonds::Pmb(SpringTable::Rows(BondTable { chunks, rest_position, .. })) => {
                // The row kernel's gather records.
                records.par_chunks_mut(size).enumerate().for_each(|(c, records)| {
                    for (i, record) in (c * size..).zip(records) {
                        *record = ParticleRecord { disp: [disp[0][i], disp[1][i], disp[2][i]], boost: boost[i] };
                    }
                });
                let gathers = Gathers { records, rest_positions: rest_position };
                (
                    chunks.par_iter_mut(),
                    fx.par_chunks_mut(size),
                    fy.par_chunks_mut(size),
                    fz.par_chunks_mut(size),
                    next_boost.par_chunks_mut(size),
                )
                    .into_par_iter()
                    .for_each(|(chunk, fx, fy, fz, min_stretch)| {
                        let mut out = ChunkForces { force: [fx, fy, fz], min_stretch };
                        kernels::spring_forces(chunk, gathers, rule, pass_rules, simd, &mut out);
                    });
            }
            MaterialBonds::Pmb(SpringTable::Lattice(lattice)) => {
                lattice_forces(lattice, [&disp[0][..], &disp[1][..], &disp[2][..]], boost, rule, simd);
            }
        }
    }
}

/// A kinematic sphere's state at time `t`.
fn sphere_now(sphere: &MovingSphere, t: f64) -> SphereNow {
    let speed = sphere.velocity_m_s.length();
    let heading = if speed > 0.0 { sphere.velocity_m_s / speed } else { DVec3::ZERO };
    SphereNow {
        center: sphere.center_at(t).as_vec3().to_array(),
        heading: heading.as_vec3().to_array(),
        radius: sphere.radius_m as f32,
        stiffness: sphere.stiffness as f32,
    }
}

/// The next compression boosts -alpha s_min from a chunk's smallest stretches `min_stretch`, in
/// place; with `signed_boost` whatever the stretch's sign.
fn boosts_from_stretches(min_stretch: &mut [f32], alpha: f32, signed_boost: bool) {
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
}

/// The lattice layout's spring pass: the slots' inputs from the particles' displacements and
/// boosts, then the kernel over all chunks, into the table's slot totals.
fn lattice_forces(lattice: &mut LatticeTable, disp: [&[f32]; 3], boost: &[f32], rule: BreakRule, simd: SimdPath) {
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
            kernels::lattice_spring_forces(chunk, &inputs, particle_of, rule, simd, &mut out);
        });
}
