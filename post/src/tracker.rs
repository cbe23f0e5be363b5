//! The fragments of each frame and their rigid motions: components of the intact element
//! adjacency, stable ids through splits, mass-weighted Kabsch per fragment, optional smoothing.

use glam::{DQuat, DVec3};
use shatter_core::particles::ParticleSet;

use crate::components::FragmentIds;
use crate::kabsch::{Accumulator, RigidMotion};
use crate::smoothing::SmoothState;

/// The fragments of one frame with their rigid motions, computed from the intact adjacency and
/// the current positions. Keeps the state that carries over between frames.
#[derive(Debug, Clone)]
pub struct FragmentTracker {
    ids: FragmentIds,
    /// The fragment each id split from (itself for the first frame's fragments).
    parent: Vec<u32>,
    rotation: Vec<DQuat>,
    smoothed: Vec<SmoothState>,
    rest: Vec<DVec3>,
    mass: Vec<f64>,
}

/// One frame's result.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackedFrame {
    /// The fragment of each element.
    pub fragment_of: Vec<u32>,
    /// The motion of each fragment (smoothed if asked).
    pub motion: Vec<RigidMotion>,
    /// Elements per fragment.
    pub elements: Vec<u32>,
    /// Mass per fragment, kg.
    pub mass_kg: Vec<f64>,
}

impl FragmentTracker {
    /// A tracker for `particles` with element masses `mass_kg`.
    pub fn new(particles: &ParticleSet, mass_kg: Vec<f64>) -> FragmentTracker {
        FragmentTracker {
            ids: FragmentIds::new(particles),
            parent: Vec::new(),
            rotation: Vec::new(),
            smoothed: Vec::new(),
            rest: particles.rest_position_m.iter().map(|p| DVec3::from_array(p.map(f64::from))).collect(),
            mass: mass_kg,
        }
    }

    /// Marks the adjacency edges resting on `bond` broken.
    pub fn break_bond(&mut self, bond: u64) {
        self.ids.break_bond(bond);
    }

    /// The id chain: the fragment that piece id `id` belonged to when there were `count` fragments.
    pub fn ancestor(&self, mut id: u32, count: usize) -> u32 {
        while id as usize >= count {
            id = self.parent[id as usize];
        }
        id
    }

    /// Fragments and motions for current positions `position` (x, y, z arrays);
    /// `smoothing_frames` > 0 smooths the motions.
    pub fn track(&mut self, position: [&[f32]; 3], smoothing_frames: f64) -> TrackedFrame {
        let first_frame = self.parent.is_empty();
        let parents = self.ids.next_frame();
        let count = self.ids.count();
        if first_frame {
            self.parent = (0..count as u32).collect();
            self.rotation = vec![DQuat::IDENTITY; count];
        } else {
            for &p in &parents {
                self.parent.push(p);
                self.rotation.push(self.rotation[p as usize]);
            }
        }
        let fragment_of = self.ids.fragment_of().to_vec();
        let current =
            |i: usize| DVec3::new(f64::from(position[0][i]), f64::from(position[1][i]), f64::from(position[2][i]));
        // Kabsch per fragment, about each fragment's first element to keep the sums small.
        let mut reference = vec![usize::MAX; count];
        let mut accumulators = vec![Accumulator::default(); count];
        let mut elements = vec![0u32; count];
        let mut mass_kg = vec![0.0f64; count];
        for (i, &f) in fragment_of.iter().enumerate() {
            let f = f as usize;
            if reference[f] == usize::MAX {
                reference[f] = i;
            }
            let r = reference[f];
            accumulators[f].add(self.mass[i], self.rest[i] - self.rest[r], current(i) - current(r));
            elements[f] += 1;
            mass_kg[f] += self.mass[i];
        }
        let mut motion: Vec<RigidMotion> = (0..count)
            .map(|f| {
                let local = accumulators[f].solve(self.rotation[f]);
                let r = reference[f];
                // x - x_r = R (X - X_r) + t'  =>  x = R X + (t' + x_r - R X_r)
                let translation = local.translation + current(r) - local.rotation * self.rest[r];
                RigidMotion { rotation: local.rotation, translation }
            })
            .collect();
        for (f, m) in motion.iter().enumerate() {
            self.rotation[f] = m.rotation;
        }
        if smoothing_frames > 0.0 {
            let rest_centre = fragment_centres(&fragment_of, &self.rest, &self.mass, &mass_kg);
            if self.smoothed.is_empty() {
                self.smoothed = (0..count)
                    .map(|f| {
                        SmoothState::at(motion[f].rotation * rest_centre[f] + motion[f].translation, motion[f].rotation)
                    })
                    .collect();
            } else {
                for f in self.smoothed.len()..count {
                    let parent = &self.smoothed[self.parent[f] as usize];
                    let smoothed_centre = parent.rotation * rest_centre[f]
                        + (parent.centre - parent.rotation * rest_centre[self.parent[f] as usize]);
                    self.smoothed.push(parent.part_at(smoothed_centre));
                }
                for f in 0..count {
                    let target = motion[f].rotation * rest_centre[f] + motion[f].translation;
                    self.smoothed[f].follow(target, motion[f].rotation, smoothing_frames);
                }
            }
            for f in 0..count {
                let state = &self.smoothed[f];
                motion[f] = RigidMotion {
                    rotation: state.rotation,
                    translation: state.centre - state.rotation * rest_centre[f],
                };
            }
        }
        TrackedFrame { fragment_of, motion, elements, mass_kg }
    }
}

/// Mass-weighted rest centres of the fragments.
fn fragment_centres(fragment_of: &[u32], rest: &[DVec3], mass: &[f64], fragment_mass: &[f64]) -> Vec<DVec3> {
    let mut centres = vec![DVec3::ZERO; fragment_mass.len()];
    for (i, &f) in fragment_of.iter().enumerate() {
        centres[f as usize] += mass[i] * rest[i];
    }
    for (centre, m) in centres.iter_mut().zip(fragment_mass) {
        *centre /= *m;
    }
    centres
}
