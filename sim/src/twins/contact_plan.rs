//! Twin of `contact_plan.wgsl`: whether the contact lists are rebuilt this step, as the indirect
//! dispatch sizes of the rebuild kernels.

use crate::gpu::wgsl_structs::{Params, Status};

/// The bindings of `contact_plan.wgsl`, in binding order.
pub struct ContactPlanBindings<'a> {
    /// The batch's constants.
    pub params: &'a Params,
    /// The run's clock and counters (the rebuild flag, the builds).
    pub status: &'a mut Status,
    /// The rebuild kernels' indirect dispatch sizes, three words each.
    pub indirect: &'a mut [u32],
}

/// Twin of `contact_plan.wgsl`.
pub fn contact_plan(b: ContactPlanBindings) {
    let ContactPlanBindings { params, status, indirect } = b;
    let rebuild = status.rebuild != 0;
    let mut set_grid = |slot: usize, x: u32, y: u32| {
        indirect[3 * slot] = if rebuild { x } else { 0 };
        indirect[3 * slot + 1] = if rebuild { y } else { 0 };
        indirect[3 * slot + 2] = if rebuild { 1 } else { 0 };
    };
    set_grid(0, params.particle_grid_x, params.particle_grid_y);
    set_grid(1, params.table_grid_x, params.table_grid_y);
    set_grid(2, params.block_grid_x, params.block_grid_y);
    set_grid(3, 1, 1);
    if rebuild {
        status.builds += 1;
        status.rebuild = 0;
    }
}
