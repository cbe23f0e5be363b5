// The external power of a step (one workgroup): sums the spring kernel's per-workgroup partials
// in a fixed order (strided, then a tree) and adds power x dt to the work done, kept as a
// two-float sum (hi + lo, Knuth's TwoSum) since there is no f64 on the GPU.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> power: array<f32>;
@group(0) @binding(2) var<storage, read_write> status: Status;

var<workgroup> partial: array<f32, 256>;

@compute @workgroup_size(256)
fn power_sum(@builtin(local_invocation_index) lid: u32) {
    var sum = 0.0;
    for (var k = lid; k < params.power_count; k = k + 256u) {
        sum = sum + power[k];
    }
    partial[lid] = sum;
    workgroupBarrier();
    for (var stride = 128u; stride > 0u; stride = stride / 2u) {
        if (lid < stride) {
            partial[lid] = partial[lid] + partial[lid + stride];
        }
        workgroupBarrier();
    }
    if (lid == 0u) {
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
}
