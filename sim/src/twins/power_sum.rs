//! Twin of `power_sum.wgsl`: the step's external power into the work done (a two-float sum).

use crate::gpu::wgsl_structs::{Params, Status};

/// The bindings of `power_sum.wgsl`, in binding order.
pub struct PowerSumBindings<'a> {
    /// The batch's constants.
    pub params: &'a Params,
    /// Per force workgroup: the external power it delivers, watts.
    pub power: &'a [f32],
    /// The run's clock and counters (the work done, joules, as two floats).
    pub status: &'a mut Status,
}

/// Twin of `power_sum.wgsl`.
pub fn power_sum(b: PowerSumBindings) {
    let PowerSumBindings { params, power, status } = b;
    let mut partial = [0.0f32; 256];
    for lid in 0..256 {
        let mut k = lid;
        while k < params.power_count as usize {
            partial[lid] += power[k];
            k += 256;
        }
    }
    let mut stride = 128;
    while stride > 0 {
        for lid in 0..stride {
            partial[lid] += partial[lid + stride];
        }
        stride /= 2;
    }
    let add = partial[0] * params.dt;
    let hi = status.work_hi;
    let s = hi + add;
    let b = s - hi;
    let error = (hi - (s - b)) + (add - b);
    let lo = status.work_lo + error;
    let total = s + lo;
    status.work_lo = lo - (total - s);
    status.work_hi = total;
}
