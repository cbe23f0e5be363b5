// Declarations shared by every simulation kernel. This file has no entry point: the host prepends
// it to each kernel file (one @compute entry point per file) before compiling.
//
// Index convention: kernels run one invocation per item on a possibly 2D grid of workgroups
// (see shatter-gpu's DispatchGrid); the linear index is (wid.x + wid.y * nwg.x) * WG + lid and
// every kernel bounds-checks it.

// Invocations per workgroup of every kernel except the single-workgroup ones.
const WG: u32 = 64u;
// Particles per slice of the sliced-ELLPACK bond layout: entry k of particle i sits at
// row.x + k * SLICE, so the 32 particles of a slice read consecutive words for the same k.
const SLICE: u32 = 32u;
// Counts scanned per workgroup by the prefix sum (256 invocations, 2 counts each).
const SCAN_BLOCK: u32 = 512u;

// Everything constant during a batch of steps (written by the host before each submission).
struct Params {
    // Particles.
    n: u32,
    // The step whose sphere centres sit first in the sphere buffer.
    batch_first_step: u32,
    // Time step and its half, seconds.
    dt: f32,
    half_dt: f32,
    // Compression strengthening alpha.
    alpha: f32,
    // 0: the larger boost of the two particles decides (the paper); 1: the smaller.
    break_rule: u32,
    // Gravity, m/s^2.
    gravity_x: f32,
    gravity_y: f32,
    gravity_z: f32,
    // 1 when contact is on (K_c > 0).
    contact_enabled: u32,
    // K_c, Pa, and d_c, metres.
    contact_stiffness: f32,
    contact_distance: f32,
    // (skin / 2)^2: a particle that moved farther than skin / 2 since the build makes the
    // contact lists stale.
    skin_limit: f32,
    // d_c + skin: the candidate radius of the contact lists.
    reach: f32,
    // 1 / cell size of the spatial hash (cells of 2 reach).
    inverse_cell: f32,
    // Hash table size - 1 (a power of two minus one).
    table_mask: u32,
    // Candidates stored per particle.
    contact_cap: u32,
    // 1 when there is a floor.
    floor_enabled: u32,
    floor_height: f32,
    restitution: f32,
    // Projectiles, then indenters, in the sphere buffer.
    projectiles: u32,
    indenters: u32,
    // Break events the event buffer holds.
    event_capacity: u32,
    // Workgroups of the spring kernel over all ranges (power partials).
    power_count: u32,
    // Dispatch grids (x, y) of the contact rebuild: over particles, over the hash table, over
    // scan blocks.
    particle_grid_x: u32,
    particle_grid_y: u32,
    table_grid_x: u32,
    table_grid_y: u32,
    block_grid_x: u32,
    block_grid_y: u32,
    // Scan blocks (table / SCAN_BLOCK, at least 1).
    scan_blocks: u32,
    // The rules other than Levine's, as bits: RULE_SIGNED_BOOST, RULE_BREAKING_FORCE,
    // RULE_LAMMPS_CONTACT.
    rules: u32,
}

// The smallest stretch may be positive: the boost is -alpha s_min whatever its sign.
const RULE_SIGNED_BOOST: u32 = 1u;
// A breaking bond pulls in its breaking step, and its stretch counts towards the smallest.
const RULE_BREAKING_FORCE: u32 = 2u;
// LAMMPS's short-range contact: every pair closer than min(0.9 |xi|, contact_distance), bonded
// or not, repels with contact_stiffness m_i m_j (d_ij - r).
const RULE_LAMMPS_CONTACT: u32 = 4u;
// The smallest stretch of a particle with no bond yet seen, under RULE_SIGNED_BOOST.
const NO_STRETCH: f32 = 3.0e38;

// One range of particles whose bond arrays share one binding each.
struct Range {
    // First particle and particle count.
    first: u32,
    count: u32,
    // Index of the range's first workgroup among all spring workgroups (power partials).
    first_workgroup: u32,
    // Workgroups of this range.
    workgroups: u32,
}

// The run's clock and counters, on the GPU.
struct Status {
    // Steps completed (advanced by the position update).
    step: u32,
    // Work of the external forces, joules, as an unevaluated sum hi + lo (two-float).
    work_hi: f32,
    work_lo: f32,
    // Non-zero: the contact lists must be rebuilt before the next force pass.
    rebuild: atomic<u32>,
    // Break events recorded since the host last read them.
    events: atomic<u32>,
    // The largest candidate count any particle needed at a build.
    contact_needed: atomic<u32>,
    // Contact list builds (diagnostic).
    builds: u32,
    _pad: u32,
}

fn linear_index(wid: vec3<u32>, nwg: vec3<u32>, lid: u32) -> u32 {
    return (wid.x + wid.y * nwg.x) * WG + lid;
}

// x.x^2 + x.y^2 + x.z^2, summed left to right (the CPU twins do the same).
fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

// The hash cell of a position: floor(x / cell), saturating.
fn cell_of(p: vec3<f32>, inverse_cell: f32) -> vec3<i32> {
    let scaled = floor(p * inverse_cell);
    let lo = vec3<f32>(-2147483648.0);
    let hi = vec3<f32>(2147483520.0);
    return vec3<i32>(clamp(scaled, lo, hi));
}

// The hash bucket of a cell (the CPU's constants).
fn bucket_of(c: vec3<i32>, mask: u32) -> u32 {
    let h = (bitcast<u32>(c.x) * 73856093u) ^ (bitcast<u32>(c.y) * 19349663u) ^ (bitcast<u32>(c.z) * 83492791u);
    return h & mask;
}

// Velocity half kick v += dt/2 F / m (w of the velocity holds 1/m).
fn half_kick(v: vec4<f32>, f: vec4<f32>, half_dt: f32) -> vec4<f32> {
    return vec4<f32>(v.xyz + half_dt * f.xyz * v.w, v.w);
}

// The floor: a particle below it that moves down has its vertical velocity reflected and scaled.
fn floor_bounce(v: vec4<f32>, rest_y: f32, disp_y: f32, enabled: u32, height: f32, restitution: f32) -> vec4<f32> {
    var out = v;
    if (enabled != 0u && rest_y + disp_y < height && out.y < 0.0) {
        out.y = out.y * -restitution;
    }
    return out;
}
