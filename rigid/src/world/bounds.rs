//! The shot's region (`rigid.bounds_m`): which pieces have left it and are retired.

use super::{DUST, RigidWorld};

impl RigidWorld {
    /// A piece flung out of the shot's region (a single element shot off the crushed base of a
    /// vase at 40 m/s skids for hundreds of metres before friction stops it) is retired: its
    /// body is disabled where it is, so it neither moves nor keeps the shot from settling. Past
    /// the region's top or bottom it is retired at once; past its sides once it touches
    /// something (lands): a piece retired in flight would hang in the air, in view. In flight
    /// it is retired once it is farther past a side than the region is wide (a tumbling
    /// piece can hop away with no contact at any frame's end), and dust (a speck beyond the
    /// region, which lies beyond what the camera resolves) once it flies on away from a side:
    /// nothing turns it back, and dust struck off at 48 m/s lands tens of metres away seconds
    /// after the shot ends.
    pub(super) fn retire_outside_bounds(&mut self, touching: &[bool]) {
        let Some([low, high]) = self.bounds_m else { return };
        for ((watch, &handle), &touches) in self.watch.iter_mut().zip(&self.pieces).zip(touching) {
            let body = &self.world.bodies[handle];
            let (centre, v) = (body.center_of_mass().to_array(), body.linvel().to_array());
            let dust = body.colliders().iter().any(|&c| self.world.colliders[c].collision_groups().memberships == DUST);
            let outside = |axis: usize| centre[axis] < low[axis] || centre[axis] > high[axis];
            // flying on away from a side: in flight nothing turns it back
            let leaving = |axis: usize| {
                (centre[axis] < low[axis] && v[axis] < 0.0) || (centre[axis] > high[axis] && v[axis] > 0.0)
            };
            // past a side by more than the region's width
            let far = |axis: usize| {
                let width = high[axis] - low[axis];
                centre[axis] < low[axis] - width || centre[axis] > high[axis] + width
            };
            let past_side =
                (touches && (outside(0) || outside(2))) || (dust && (leaving(0) || leaving(2))) || far(0) || far(2);
            if !watch.retired && (outside(1) || past_side) {
                watch.retired = true;
                self.world.bodies[handle].set_enabled(false);
            }
        }
    }
}
