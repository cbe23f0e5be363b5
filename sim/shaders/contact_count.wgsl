// Collection, step 1 (the paper's hashing): each particle finds its cell and bucket and counts
// itself into the bucket (the counts start at zero: contact_scatter of the last build cleared
// them). The atomic increment's return value (the particle's arrival order in its bucket) varies
// from run to run; it is used only to scatter particles into their bucket's range, and
// contact_rank then orders each bucket by particle index: the table that results is the same
// every run.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> body: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> cell: array<vec4<i32>>;
@group(0) @binding(3) var<storage, read_write> arrival: array<u32>;
@group(0) @binding(4) var<storage, read_write> bucket_count: array<atomic<u32>>;

@compute @workgroup_size(64)
fn contact_count(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_index(wid, nwg, lid);
    if (i >= params.n) {
        return;
    }
    let p = body[2u * i].xyz + body[2u * i + 1u].xyz;
    let c = cell_of(p, params.inverse_cell);
    let b = bucket_of(c, params.table_mask);
    cell[i] = vec4<i32>(c, bitcast<i32>(b));
    arrival[i] = atomicAdd(&bucket_count[b], 1u);
}
