// Collection, step 0 (one invocation): decides whether the contact lists are rebuilt this step.
// When some particle has moved more than half the skin (or the host asked), it writes the
// dispatch grids of the rebuild kernels into the indirect-dispatch buffer; else zero grids, so
// the rebuild kernels that follow are dispatched with no workgroups and cost nothing. No
// readback: the decision stays on the GPU.
//
// Indirect buffer layout (x, y, z triples): 0 particles, 1 hash table, 2 scan blocks, 3 one
// workgroup.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> status: Status;
@group(0) @binding(2) var<storage, read_write> indirect: array<u32>;

fn set_grid(slot: u32, x: u32, y: u32, on: bool) {
    indirect[3u * slot] = select(0u, x, on);
    indirect[3u * slot + 1u] = select(0u, y, on);
    indirect[3u * slot + 2u] = select(0u, 1u, on);
}

@compute @workgroup_size(1)
fn contact_plan() {
    let rebuild = atomicLoad(&status.rebuild) != 0u;
    set_grid(0u, params.particle_grid_x, params.particle_grid_y, rebuild);
    set_grid(1u, params.table_grid_x, params.table_grid_y, rebuild);
    set_grid(2u, params.block_grid_x, params.block_grid_y, rebuild);
    set_grid(3u, 1u, 1u, rebuild);
    if (rebuild) {
        status.builds = status.builds + 1u;
        atomicStore(&status.rebuild, 0u);
    }
}
