// out[i] = hash((first + i) ^ seed) for i < n: fills one chunk of a larger array, bound at the chunk's offset.
// Test kernel for shatter-gpu.
struct Params {
    first: u32,
    n: u32,
    seed: u32,
    _pad: u32,
}

const WG: u32 = 64u;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn hash(v: u32) -> u32 {
    var x = v * 747796405u + 2891336453u;
    x = ((x >> ((x >> 28u) + 4u)) ^ x) * 277803737u;
    return (x >> 22u) ^ x;
}

@compute @workgroup_size(WG)
fn index_hash(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = (wid.x + wid.y * nwg.x) * WG + lid;
    if (i >= params.n) {
        return;
    }
    out[i] = hash((params.first + i) ^ params.seed);
}
