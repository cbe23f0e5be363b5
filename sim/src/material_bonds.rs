//! The material-model seam of the CPU backend: the bonds of the run's material model, what each
//! model keeps per bond, and the operations the step and the reports need of them. The PMB
//! model's bonds are its spring tables ([`crate::bond_layouts`], force pass in
//! [`crate::kernels`]); the elastoplastic model's are its family table ([`crate::elastoplastic`]).
//! A new model adds one arm here and a folder of its own; the integrator, contact, body forces,
//! art direction and frame loop do not change.

use crate::bond_layouts::layout_choice::{SpringNow, SpringTable, StoredBond};
use crate::elastoplastic::FamilyBonds;

/// The bonds of a run, by material model.
#[derive(Debug, Clone)]
pub enum MaterialBonds {
    /// Bond-based PMB: one spring per bond, broken by stretch.
    Pmb(SpringTable),
    /// State-based elastoplastic: families with dilatation and plastic extensions.
    Elastoplastic(Box<FamilyBonds>),
}

impl MaterialBonds {
    /// Marks bonds broken by id (sorted).
    pub fn mark_broken(&mut self, sorted_ids: &[u64]) {
        match self {
            MaterialBonds::Pmb(table) => table.mark_broken(sorted_ids),
            MaterialBonds::Elastoplastic(table) => table.mark_broken(sorted_ids),
        }
    }

    /// Calls `f` with each bond broken in the last force evaluation, in a fixed order.
    pub fn for_each_break(&self, f: impl FnMut(u64)) {
        match self {
            MaterialBonds::Pmb(table) => table.for_each_break(f),
            MaterialBonds::Elastoplastic(table) => table.for_each_break(f),
        }
    }

    /// The stored elastic energy, joules, summed in a fixed order.
    pub fn energy_j(&self, disp: &[Vec<f32>; 3]) -> f64 {
        match self {
            MaterialBonds::Pmb(table) => table.sum_springs(disp, |spring| {
                // stored once: the partner's half too
                let ends = if spring.bond.internal { 2.0 } else { 1.0 };
                ends * half_spring_energy_j(&spring.bond, spring.stretch)
            }),
            MaterialBonds::Elastoplastic(table) => {
                table.energy_per_particle([&disp[0], &disp[1], &disp[2]]).iter().sum()
            }
        }
    }

    /// Each particle's share of the stored energy, joules.
    pub fn energy_per_particle(&self, disp: &[Vec<f32>; 3]) -> Vec<f64> {
        match self {
            MaterialBonds::Pmb(table) => {
                let mut energy = vec![0.0f64; disp[0].len()];
                table.for_each_entry(|bond| {
                    let half = half_spring_energy_j(bond, SpringNow::at(bond, disp).stretch);
                    energy[bond.i] += half;
                    if bond.internal {
                        // stored once: the partner's half too
                        energy[bond.j] += half;
                    }
                });
                energy
            }
            MaterialBonds::Elastoplastic(table) => table.energy_per_particle([&disp[0], &disp[1], &disp[2]]),
        }
    }

    /// The largest stable time step, seconds, for particle masses `mass` (kg).
    pub fn stable_dt_s(&self, mass: &[f32], density_kg_m3: f64) -> f64 {
        match self {
            MaterialBonds::Pmb(table) => {
                // Silling and Askari (2005): min over particles of sqrt(2 m_i / sum_j k_ij / L_ij)
                let mut stiffness = vec![0.0f64; mass.len()];
                table.for_each_entry(|bond| {
                    let spring = f64::from(bond.stiffness) / f64::from(bond.rest_length_m);
                    stiffness[bond.i] += spring;
                    if bond.internal {
                        stiffness[bond.j] += spring;
                    }
                });
                stiffness
                    .iter()
                    .zip(mass)
                    .filter(|(k, _)| **k > 0.0)
                    .map(|(k, m)| (2.0 * f64::from(*m) / k).sqrt())
                    .fold(f64::INFINITY, f64::min)
            }
            MaterialBonds::Elastoplastic(table) => table.stable_dt_s(density_kg_m3),
        }
    }

    /// The model's per-bond state in the particle file's entry order (the elastoplastic
    /// model's plastic extensions, metres); empty for PMB, which keeps none.
    pub fn bond_state(&self) -> Vec<f32> {
        match self {
            MaterialBonds::Pmb(_) => Vec::new(),
            MaterialBonds::Elastoplastic(table) => table.plastic_in_file_order(),
        }
    }

    /// Sets the per-bond state from [`MaterialBonds::bond_state`]'s order. Fails when it does not
    /// fit the model.
    pub fn set_bond_state(&mut self, state: &[f32]) -> Result<(), String> {
        match self {
            MaterialBonds::Pmb(_) if state.is_empty() => Ok(()),
            MaterialBonds::Pmb(_) => {
                Err(format!("{} per-bond values for the PMB model, which keeps none", state.len()))
            }
            MaterialBonds::Elastoplastic(table) => table.set_plastic_from_file_order(state),
        }
    }
}

/// Half the energy 1/2 k s^2 L of a spring (0 once broken, and for padding) at stretch `s`,
/// joules.
fn half_spring_energy_j(bond: &StoredBond, s: f32) -> f64 {
    if bond.stiffness == 0.0 {
        return 0.0;
    }
    0.25 * f64::from(bond.stiffness) * f64::from(s).powi(2) * f64::from(bond.rest_length_m)
}
