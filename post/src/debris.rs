//! Debris emitters: the break log's events of each frame as points an FX artist emits dust or
//! debris from. One point per particle that lost bonds during the frame, at the particle's
//! position and velocity at the frame's end, with when it first broke, how many of its bonds
//! broke, its fragment and the fragment across its first broken bond (the same on both sides of
//! a bond that has not yet split the body). Both ends of a broken bond get a point, so a crack
//! emits from both faces.

use std::collections::BTreeMap;

use shatter_core::debris_points::DebrisFrame;
use shatter_core::frames::{BreakEvent, PointFrame};
use shatter_core::particles::Bonds;

/// The debris of `frame`: its break `events` (bond ids of `bonds`, in the order they broke), the
/// frame's `points` and the `fragment_of` each particle at its end, `dt_s` the time step.
pub fn debris_frame(
    frame: u32,
    events: &[BreakEvent],
    bonds: &Bonds,
    points: &PointFrame,
    fragment_of: &[u32],
    dt_s: f64,
) -> DebrisFrame {
    // particle -> (its first event's step, bonds broken, the partner across the first)
    let mut broken: BTreeMap<usize, (u64, i32, usize)> = BTreeMap::new();
    for event in events {
        let entry = event.bond as usize;
        let i = bonds.offsets.partition_point(|&start| start as usize <= entry) - 1;
        let j = bonds.neighbor[entry] as usize;
        for (particle, partner) in [(i, j), (j, i)] {
            broken.entry(particle).or_insert((event.step, 0, partner)).1 += 1;
        }
    }
    let mut debris = DebrisFrame { frame, ..DebrisFrame::default() };
    for (&particle, &(step, count, partner)) in &broken {
        debris.position.push([0, 1, 2].map(|axis| points.position[axis][particle]));
        debris.velocity.push([0, 1, 2].map(|axis| points.velocity[axis][particle]));
        debris.time_s.push((step as f64 * dt_s) as f32);
        debris.broken_bonds.push(count);
        debris.fragment.push(fragment_of[particle] as i32);
        debris.other_fragment.push(fragment_of[partner] as i32);
    }
    debris
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_end_of_each_broken_bond_emits_once_per_frame() {
        // particles 0-1-2 in a row, bonds 0-1 (entries 0 and 1 of row 0: 0->1, 0->2), 1-2
        let bonds = Bonds {
            offsets: vec![0, 2, 4, 6],
            neighbor: vec![1, 2, 0, 2, 0, 1],
            rest_length_m: vec![1.0; 6],
            threshold: vec![1.0; 6],
        };
        let points = PointFrame {
            frame: 3,
            step: 300,
            time_s: 3e-4,
            inputs: None,
            position: [vec![0.0, 1.0, 2.0], vec![0.0; 3], vec![0.0; 3]],
            velocity: [vec![0.5, 0.0, -0.5], vec![0.0; 3], vec![0.0; 3]],
            damage: vec![0.5, 1.0, 0.5],
        };
        // the bond 0-1 (entry 0) breaks at step 210, then 1-2 (entry 3) at step 250
        let events = [BreakEvent { step: 210, bond: 0 }, BreakEvent { step: 250, bond: 3 }];
        let debris = debris_frame(3, &events, &bonds, &points, &[0, 1, 2], 1e-6);
        assert_eq!(debris.broken_bonds, vec![1, 2, 1], "particle 1 lost both its bonds");
        assert_eq!(debris.position, vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]);
        assert_eq!(debris.fragment, vec![0, 1, 2]);
        assert_eq!(debris.other_fragment, vec![1, 0, 1], "across each particle's first broken bond");
        assert!((debris.time_s[1] - 210e-6).abs() < 1e-9 && (debris.time_s[2] - 250e-6).abs() < 1e-9);
        assert_eq!(debris.velocity[2], [-0.5, 0.0, 0.0]);
        assert_eq!(debris_frame(3, &[], &bonds, &points, &[0, 0, 0], 1e-6).position.len(), 0);
    }
}
