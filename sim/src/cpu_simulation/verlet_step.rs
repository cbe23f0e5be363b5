//! The CPU simulation's step: velocity Verlet's kick passes (the position update, the velocity
//! update, and the two fused between steps) around the force evaluation.

use rayon::prelude::*;

use super::CpuSimulation;
use crate::kernels;
use crate::state::Dynamics;

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

impl CpuSimulation {
    /// Advances one step of velocity Verlet.
    pub fn step(&mut self) {
        self.advance_steps(1);
    }

    /// Advances `steps` steps of velocity Verlet. A step's closing velocity kick and the next
    /// step's opening kick and drift, which read the same forces, run as one pass.
    pub(super) fn advance_steps(&mut self, steps: u64) {
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
    pub(super) fn update_positions(&mut self) {
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
}

/// Positions of a chunk of particles: rest plus displacement, axis by axis.
fn place(rest: [&[f32]; 3], disp: [&[f32]; 3], position: [&mut [f32]; 3]) {
    for ((rest, disp), position) in rest.into_iter().zip(disp).zip(position) {
        for ((x, r), u) in position.iter_mut().zip(rest).zip(disp) {
            *x = r + u;
        }
    }
}
