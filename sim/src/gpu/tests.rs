//! Every kernel against its CPU twin on the same random inputs.

use std::path::Path;

use bytemuck::Pod;
use shatter_core::NoProgress;
use shatter_core::config::PipelineConfig;
use shatter_core::config::sim::{PartialVolumes, StiffnessCorrection};
use shatter_core::random::SplitMix64;
use shatter_gpu::{GpuContext, wgpu};

use super::shaders;
use super::wgsl_structs::{
    Params, RULE_BREAKING_FORCE, RULE_LAMMPS_CONTACT, RULE_SIGNED_BOOST, SCAN_BLOCK, SLICE, Status, WG,
};
use crate::bond_layouts::gpu_layout::GpuBondLayout;
use crate::twins::{
    self, BondEnergyBindings, CollisionsBindings, ContactCandidatesBindings, ContactCountBindings, ContactPlanBindings,
    ContactRankBindings, ContactScatterBindings, FamilyDilatationBindings, FamilyForcesBindings, I4, KickDriftBindings,
    KickFloorBindings, PowerSumBindings, ScanAddBindings, ScanBlockSumsBindings, ScanBlocksBindings,
    SpringForcesBindings, U4, V4,
};

fn gpu() -> &'static GpuContext {
    GpuContext::shared_for_tests().unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"))
}

fn upload<T: Pod>(data: &[T]) -> wgpu::Buffer {
    gpu().create_storage_buffer("test input", data).expect("buffer")
}

fn uniform<T: Pod>(value: &T) -> wgpu::Buffer {
    gpu().create_uniform_buffer("test uniform", value).expect("uniform")
}

fn read<T: Pod>(buffer: &wgpu::Buffer, len: usize) -> Vec<T> {
    gpu().read_buffer(buffer, len).expect("readback")
}

/// Runs kernel `name` once over `workgroups` workgroups with `buffers` at bindings 0, 1, ...
fn dispatch(name: &str, buffers: &[&wgpu::Buffer], workgroups: u64) {
    dispatch_with(name, &[], buffers, workgroups);
}

/// As `dispatch`, with values for the kernel's pipeline-overridable constants.
fn dispatch_with(name: &str, constants: &[(&str, f64)], buffers: &[&wgpu::Buffer], workgroups: u64) {
    let ctx = gpu();
    let kernel = shaders::compile_with(ctx, name, constants).unwrap_or_else(|e| panic!("{e}"));
    let group = kernel.bind_buffers(ctx, 0, buffers).unwrap_or_else(|e| panic!("{e}"));
    kernel.dispatch(ctx, &[&group], workgroups).unwrap_or_else(|e| panic!("{e}"));
}

fn groups(n: usize) -> u64 {
    n.div_ceil(WG) as u64
}

/// Largest |a - b| over the largest |b| (0 when both are all zero).
fn relative_error(a: &[f32], b: &[f32]) -> f64 {
    let scale = b.iter().map(|x| f64::from(x.abs())).fold(0.0, f64::max);
    let worst = a.iter().zip(b).map(|(x, y)| f64::from((x - y).abs())).fold(0.0, f64::max);
    if scale == 0.0 { worst } else { worst / scale }
}

fn flat(v: &[V4]) -> Vec<f32> {
    v.iter().flat_map(|x| x.iter().copied()).collect()
}

/// The parity scenes' bond network: a jittered 9 x 8 x 7 block of 1 mm at N = 3.
fn block_particles() -> shatter_core::particles::ParticleSet {
    let text = r#"
[scene]
name = "parity"
output_dir = "out"
seed = 3
[geometry]
source = "box"
box_size_m = [0.009, 0.008, 0.007]
sampler = "grid"
spacing_m = 0.001
horizon_factor = 3.0
[material]
density_kg_m3 = 2200.0
bulk_modulus_pa = 14.9e9
"#;
    let config = PipelineConfig::from_toml_str(text, Path::new("/nonexistent/pipeline.toml")).expect("config");
    shatter_preprocess::preprocess(&config, &NoProgress).expect("preprocess").particles
}

/// A small random state on a real bond network: a jittered 9 x 8 x 7 block at N = 3, some
/// bonds broken, thresholds placed so that about a third of the intact bonds break, contact on.
struct Scene {
    n: usize,
    params: Params,
    layout: GpuBondLayout,
    body: Vec<V4>,
    vel: Vec<V4>,
    force: Vec<V4>,
    boost_next: Vec<f32>,
    built_at: Vec<V4>,
    rows: Vec<U4>,
    bits: Vec<Vec<u32>>,
    spheres: Vec<V4>,
    status: Status,
}

impl Scene {
    fn new(seed: u64, max_binding_bytes: u64) -> Scene {
        let particles = block_particles();
        let n = particles.len();
        let mut rng = SplitMix64::new(seed);
        let mut uniform = |lo: f64, hi: f64| (lo + (hi - lo) * rng.next_f64()) as f32;
        let c = 18.0 * 14.9e9 / (std::f64::consts::PI * 0.003f64.powi(4));
        let mut layout = GpuBondLayout::new(
            &particles,
            c,
            1.0,
            None,
            StiffnessCorrection::Energy,
            PartialVolumes::None,
            max_binding_bytes,
        )
        .expect("layout");
        let mass = 2.2e-6f32;
        let body: Vec<V4> = (0..n)
            .flat_map(|i| {
                let x = particles.rest_position_m[i];
                [[x[0], x[1], x[2], mass], [0.0; 4]]
            })
            .collect();
        let mut body = body;
        for i in 0..n {
            // Displacements up to 0.35 lambda (some unbonded pairs come within contact), boosts.
            body[2 * i + 1] = [
                uniform(-3.5e-4, 3.5e-4),
                uniform(-3.5e-4, 3.5e-4),
                uniform(-3.5e-4, 3.5e-4),
                if i % 3 == 0 { uniform(0.0, 0.01) } else { 0.0 },
            ];
        }
        let vel: Vec<V4> =
            (0..n).map(|_| [uniform(-2.0, 2.0), uniform(-2.0, 2.0), uniform(-2.0, 2.0), 1.0 / mass]).collect();
        let force: Vec<V4> =
            (0..n).map(|_| [uniform(-50.0, 50.0), uniform(-50.0, 50.0), uniform(-50.0, 50.0), 0.0]).collect();
        let boost_next: Vec<f32> = (0..n).map(|_| uniform(0.0, 0.01)).collect();
        let built_at: Vec<V4> = (0..n)
            .map(|i| {
                let x = particles.rest_position_m[i];
                [x[0], x[1], x[2], 0.0]
            })
            .collect();
        // Thresholds: the same for both directions of a bond, away from its stretch, so that both
        // sides decide the same clearly; half the bonds broken beforehand.
        let bonds = &particles.bonds;
        let mut bits: Vec<Vec<u32>> = layout.ranges.iter().map(|r| vec![0u32; r.words]).collect();
        let disp = |i: usize| [body[2 * i + 1][0], body[2 * i + 1][1], body[2 * i + 1][2]];
        for i in 0..n {
            for (k, entry) in bonds.row(i).enumerate() {
                let j = bonds.neighbor[entry] as usize;
                let (lo, hi) = (i.min(j), i.max(j));
                let key = shatter_core::random::splitmix64(((lo as u64) << 32 | hi as u64) ^ seed);
                let xi: [f32; 3] =
                    [0, 1, 2].map(|a| particles.rest_position_m[hi][a] - particles.rest_position_m[lo][a]);
                let eta: [f32; 3] = [0, 1, 2].map(|a| disp(hi)[a] - disp(lo)[a]);
                let (s, _, _) = crate::kernels::stretch(xi, eta, bonds.rest_length_m[entry]);
                let boost = body[2 * i + 1][3].max(body[2 * j + 1][3]);
                let factor = if key.is_multiple_of(3) { 0.7 } else { 1.5 };
                let threshold = (s - boost).abs() * factor + 1e-5;
                let (range, word, bit) = layout.bit_of(i, k);
                let row = layout.rows[i];
                let e = row[0] as usize + k * SLICE;
                layout.ranges[range].threshold[e] =
                    if key.is_multiple_of(3) { (s - boost) * factor } else { threshold };
                if key % 2 == 1 {
                    bits[range][word] |= 1 << bit;
                }
            }
        }
        let distance = 8e-4f32;
        let skin = 0.5 * distance;
        let table = (2 * n).next_power_of_two().max(16);
        let spheres = vec![
            [0.0, 0.0, -1.0, 0.003],
            [3e7, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 0.002],
            [1e9, 0.0, 0.0, 0.0],
            // centres for step 7: the projectile over the top face, the indenter in a corner
            [0.0, 0.0, 0.0055, 0.0],
            [-0.0045, -0.004, -0.0035, 0.0],
        ];
        let params = Params {
            n: n as u32,
            batch_first_step: 7,
            dt: 1.2e-7,
            half_dt: 0.6e-7,
            alpha: 0.25,
            break_rule: 0,
            gravity_x: 0.5,
            gravity_y: -9.81,
            gravity_z: 0.25,
            contact_enabled: 1,
            contact_stiffness: 1e8,
            contact_distance: distance,
            skin_limit: 0.25 * skin * skin,
            reach: distance + skin,
            inverse_cell: 1.0 / (2.0 * (distance + skin)),
            table_mask: (table - 1) as u32,
            contact_cap: 8,
            floor_enabled: 1,
            floor_height: 0.0,
            restitution: 0.99,
            projectiles: 1,
            indenters: 1,
            event_capacity: 1 << 16,
            power_count: layout.workgroups(),
            scan_blocks: table.div_ceil(SCAN_BLOCK) as u32,
            ..Params::default()
        };
        let status = Status { step: 7, work_hi: 1.5, work_lo: 1e-9, ..Status::default() };
        Scene {
            n,
            params,
            rows: layout.rows.clone(),
            layout,
            body,
            vel,
            force,
            boost_next,
            built_at,
            bits,
            spheres,
            status,
        }
    }
}

#[test]
fn kick_kernels_match_their_twins() {
    let scene = Scene::new(1, 1 << 30);
    let n = scene.n;
    for (name, land_first) in [("kick_drift.wgsl", false), ("kick_floor.wgsl", false), ("kick_drift.wgsl", true)] {
        let mut body = scene.body.clone();
        let mut vel = scene.vel.clone();
        let mut status = scene.status;
        // Half the particles below the floor.
        for i in 0..n {
            if i % 2 == 0 {
                body[2 * i][1] = -1e-3;
            }
        }
        let (pb, bb, vb, fb) = (uniform(&scene.params), upload(&body), upload(&vel), upload(&scene.force));
        let (boost, built, sb) = (upload(&scene.boost_next), upload(&scene.built_at), upload(&[status]));
        match name {
            "kick_floor.wgsl" => {
                twins::kick_floor(KickFloorBindings {
                    params: &scene.params,
                    body: &body,
                    vel: &mut vel,
                    force: &scene.force,
                });
                dispatch(name, &[&pb, &bb, &vb, &fb], groups(n));
            }
            _ => {
                twins::kick_drift(
                    land_first,
                    KickDriftBindings {
                        params: &scene.params,
                        body: &mut body,
                        vel: &mut vel,
                        force: &scene.force,
                        boost_next: &scene.boost_next,
                        built_at: &scene.built_at,
                        status: &mut status,
                    },
                );
                let constants = [("LAND_FIRST", f64::from(u8::from(land_first)))];
                dispatch_with(name, &constants, &[&pb, &bb, &vb, &fb, &boost, &built, &sb], groups(n));
            }
        }
        let gpu_body: Vec<V4> = read(&bb, 2 * n);
        let gpu_vel: Vec<V4> = read(&vb, n);
        let gpu_status: Vec<Status> = read(&sb, 1);
        let body_error = relative_error(&flat(&gpu_body), &flat(&body));
        let vel_error = relative_error(&flat(&gpu_vel), &flat(&vel));
        let name = if land_first { format!("{name} with LAND_FIRST") } else { name.to_owned() };
        eprintln!("{name}: relative error of records {body_error:e}, of velocities {vel_error:e}");
        assert!(body_error <= 1e-6 && vel_error <= 1e-6, "{name}");
        assert_eq!(gpu_status[0], status, "{name}");
        if name != "kick_floor.wgsl" {
            assert_eq!(status.step, 8);
            assert_eq!(status.rebuild, 1, "displacements of 0.3 lambda make the lists stale");
        }
    }
}

/// The contact rebuild, kernel by kernel, each GPU kernel fed the twin's previous outputs.
#[test]
fn contact_kernels_match_their_twins() {
    let scene = Scene::new(2, 1 << 30);
    let (n, p) = (scene.n, scene.params);
    let table = p.table_mask as usize + 1;
    let blocks = p.scan_blocks as usize;
    let pb = uniform(&p);

    // contact_plan, both ways.
    for rebuild in [0u32, 1] {
        let mut status = Status { rebuild, builds: 3, ..scene.status };
        let mut indirect = vec![7u32; 12];
        let mut params = p;
        (params.particle_grid_x, params.particle_grid_y, params.table_grid_x) = (5, 1, 9);
        (params.table_grid_y, params.block_grid_x, params.block_grid_y) = (2, 1, 1);
        let (qb, sb, ib) = (uniform(&params), upload(&[status]), upload(&indirect));
        twins::contact_plan(ContactPlanBindings { params: &params, status: &mut status, indirect: &mut indirect });
        dispatch("contact_plan.wgsl", &[&qb, &sb, &ib], 1);
        assert_eq!(read::<u32>(&ib, 12), indirect);
        assert_eq!(read::<Status>(&sb, 1)[0], status);
    }

    // The counts start at zero (contact_scatter of the last build cleared them).
    let mut counts = vec![0u32; table];
    let cb = upload(&counts);

    // contact_count: cells exact; arrival slots a permutation per bucket (atomic order).
    let mut cell = vec![[0i32; 4]; n];
    let mut arrival = vec![0u32; n];
    let bodyb = upload(&scene.body);
    let (cellb, arrb) = (upload(&cell), upload(&arrival));
    twins::contact_count(ContactCountBindings {
        params: &p,
        body: &scene.body,
        cell: &mut cell,
        arrival: &mut arrival,
        bucket_count: &mut counts,
    });
    dispatch("contact_count.wgsl", &[&pb, &bodyb, &cellb, &arrb, &cb], groups(n));
    let gpu_cell: Vec<I4> = read(&cellb, n);
    assert_eq!(gpu_cell, cell);
    assert_eq!(read::<u32>(&cb, table), counts);
    let gpu_arrival: Vec<u32> = read(&arrb, n);
    let mut slots: Vec<(i32, u32)> = (0..n).map(|i| (cell[i][3], gpu_arrival[i])).collect();
    slots.sort_unstable();
    slots.dedup();
    assert_eq!(slots.len(), n, "arrival slots are distinct within a bucket");
    assert!(gpu_arrival.iter().zip(&cell).all(|(a, c)| *a < counts[c[3] as usize]));

    // scan_blocks, scan_block_sums, scan_add
    let mut start = vec![0u32; table + 1];
    let mut sums = vec![0u32; blocks];
    let (startb, sumsb) = (upload(&start), upload(&sums));
    twins::scan_blocks(ScanBlocksBindings {
        params: &p,
        bucket_count: &counts,
        bucket_start: &mut start,
        block_sums: &mut sums,
    });
    dispatch("scan_blocks.wgsl", &[&pb, &cb, &startb, &sumsb], blocks as u64);
    assert_eq!(read::<u32>(&startb, table + 1), start);
    assert_eq!(read::<u32>(&sumsb, blocks), sums);
    twins::scan_block_sums(ScanBlockSumsBindings { params: &p, bucket_start: &mut start, block_sums: &mut sums });
    dispatch("scan_block_sums.wgsl", &[&pb, &startb, &sumsb], 1);
    assert_eq!(read::<u32>(&startb, table + 1), start);
    assert_eq!(read::<u32>(&sumsb, blocks), sums);
    twins::scan_add(ScanAddBindings { params: &p, bucket_start: &mut start, block_sums: &sums });
    dispatch("scan_add.wgsl", &[&pb, &startb, &sumsb], groups(table));
    assert_eq!(read::<u32>(&startb, table + 1), start);
    assert_eq!(start[table] as usize, n);

    // contact_scatter (fed the twin's arrival slots), contact_rank
    let arrb = upload(&arrival);
    let mut unsorted = vec![0u32; n];
    let unsortedb = upload(&unsorted);
    let mut cleared = counts.clone();
    twins::contact_scatter(ContactScatterBindings {
        params: &p,
        cell: &cell,
        arrival: &arrival,
        bucket_start: &start,
        unsorted: &mut unsorted,
        bucket_count: &mut cleared,
    });
    dispatch("contact_scatter.wgsl", &[&pb, &cellb, &arrb, &startb, &unsortedb, &cb], groups(n));
    assert_eq!(read::<u32>(&unsortedb, n), unsorted);
    assert_eq!(read::<u32>(&cb, table), cleared);
    assert!(cleared.iter().all(|c| *c == 0), "the counts are clear for the next build");
    // Scramble each bucket (any arrival order) before ranking: the result must not change.
    let mut scrambled = unsorted.clone();
    for b in 0..table {
        scrambled[start[b] as usize..start[b + 1] as usize].reverse();
    }
    let mut sorted = vec![0u32; n];
    let (scrambledb, sortedb) = (upload(&scrambled), upload(&sorted));
    twins::contact_rank(ContactRankBindings {
        params: &p,
        cell: &cell,
        bucket_start: &start,
        unsorted: &unsorted,
        sorted: &mut sorted,
    });
    dispatch("contact_rank.wgsl", &[&pb, &cellb, &startb, &scrambledb, &sortedb], groups(n));
    assert_eq!(read::<u32>(&sortedb, n), sorted);
    for b in 0..table {
        assert!(sorted[start[b] as usize..start[b + 1] as usize].is_sorted(), "bucket {b} in index order");
    }

    // contact_candidates, twice: a list that fits, and one that overflows.
    for cap in [64u32, 2] {
        let params = Params { contact_cap: cap, ..p };
        let qb = uniform(&params);
        let mut count = vec![0u32; n];
        let mut list = vec![0u32; n * cap as usize];
        let mut built = scene.built_at.clone();
        let mut status = scene.status;
        let (countb, listb, builtb, sb) = (upload(&count), upload(&list), upload(&built), upload(&[status]));
        twins::contact_candidates(ContactCandidatesBindings {
            params: &params,
            body: &scene.body,
            cell: &cell,
            bucket_start: &start,
            sorted: &sorted,
            contact_count: &mut count,
            contact_list: &mut list,
            built_at: &mut built,
            status: &mut status,
        });
        dispatch(
            "contact_candidates.wgsl",
            &[&qb, &bodyb, &cellb, &startb, &sortedb, &countb, &listb, &builtb, &sb],
            groups(n),
        );
        assert_eq!(read::<u32>(&countb, n), count);
        assert_eq!(read::<u32>(&listb, list.len()), list);
        assert_eq!(read::<V4>(&builtb, n), built);
        assert_eq!(read::<Status>(&sb, 1)[0], status);
        let listed: usize = count.iter().map(|c| *c as usize).sum();
        eprintln!("contact_candidates, cap {cap}: {listed} candidates, largest need {}", status.contact_needed);
        assert!(listed > 0, "the scene has candidates");
        assert_eq!(status.contact_needed > cap, cap == 2, "overflow reported exactly when it happens");
    }
}

/// The contact lists of the scene, from the twins.
fn contact_lists(scene: &Scene) -> (Vec<u32>, Vec<u32>) {
    let (n, p) = (scene.n, scene.params);
    let table = p.table_mask as usize + 1;
    let mut counts = vec![0u32; table];
    let mut cell = vec![[0i32; 4]; n];
    let mut arrival = vec![0u32; n];
    twins::contact_count(ContactCountBindings {
        params: &p,
        body: &scene.body,
        cell: &mut cell,
        arrival: &mut arrival,
        bucket_count: &mut counts,
    });
    let mut start = vec![0u32; table + 1];
    let mut sums = vec![0u32; p.scan_blocks as usize];
    twins::scan_blocks(ScanBlocksBindings {
        params: &p,
        bucket_count: &counts,
        bucket_start: &mut start,
        block_sums: &mut sums,
    });
    twins::scan_block_sums(ScanBlockSumsBindings { params: &p, bucket_start: &mut start, block_sums: &mut sums });
    twins::scan_add(ScanAddBindings { params: &p, bucket_start: &mut start, block_sums: &sums });
    let mut unsorted = vec![0u32; n];
    twins::contact_scatter(ContactScatterBindings {
        params: &p,
        cell: &cell,
        arrival: &arrival,
        bucket_start: &start,
        unsorted: &mut unsorted,
        bucket_count: &mut counts,
    });
    let mut sorted = vec![0u32; n];
    twins::contact_rank(ContactRankBindings {
        params: &p,
        cell: &cell,
        bucket_start: &start,
        unsorted: &unsorted,
        sorted: &mut sorted,
    });
    let mut count = vec![0u32; n];
    let mut list = vec![0u32; n * p.contact_cap as usize];
    let mut built = scene.built_at.clone();
    let mut status = scene.status;
    twins::contact_candidates(ContactCandidatesBindings {
        params: &p,
        body: &scene.body,
        cell: &cell,
        bucket_start: &start,
        sorted: &sorted,
        contact_count: &mut count,
        contact_list: &mut list,
        built_at: &mut built,
        status: &mut status,
    });
    (count, list)
}

#[test]
fn force_kernels_match_their_twins() {
    force_kernels_match_their_twins_under(false);
}

#[test]
fn force_kernels_match_their_twins_under_the_lammps_rules() {
    force_kernels_match_their_twins_under(true);
}

/// The force kernels against their twins, under Levine's rules or LAMMPS's (signed boost, the
/// breaking step's force, short-range contact within 1.35 lambda).
fn force_kernels_match_their_twins_under(lammps: bool) {
    // A small binding limit: the bonds fall into several ranges, each its own dispatch.
    let mut scene = Scene::new(3, 64 * 1024);
    if lammps {
        let (distance, skin) = (1.35e-3f32, 0.5 * 1.35e-3f32);
        let c = 18.0 * 14.9e9 / (std::f64::consts::PI * 0.003f64.powi(4));
        scene.params = Params {
            rules: RULE_SIGNED_BOOST | RULE_BREAKING_FORCE | RULE_LAMMPS_CONTACT,
            contact_distance: distance,
            reach: distance + skin,
            skin_limit: 0.25 * skin * skin,
            inverse_cell: 1.0 / (2.0 * (distance + skin)),
            contact_cap: 64,
            contact_stiffness: (15.0 * c / (0.003 * 2200.0 * 2200.0)) as f32,
            ..scene.params
        };
    }
    let scene = scene;
    assert!(scene.layout.ranges.len() >= 3, "{} ranges", scene.layout.ranges.len());
    let (n, p) = (scene.n, scene.params);
    let pb = uniform(&p);
    let (count, list) = contact_lists(&scene);
    let (bodyb, rowsb, countb, listb) = (upload(&scene.body), upload(&scene.rows), upload(&count), upload(&list));
    let velb = upload(&scene.vel);

    // collisions
    let mut contact = vec![[0.0f32; 4]; n];
    let contactb = upload(&contact);
    for (part, bits) in scene.layout.ranges.iter().zip(&scene.bits) {
        let (rb, nb, bb) = (uniform(&part.range), upload(&part.neighbor), upload(bits));
        twins::collisions(CollisionsBindings {
            params: &p,
            range: &part.range,
            body: &scene.body,
            rows: &scene.rows,
            contact_count: &count,
            contact_list: &list,
            contact_force: &mut contact,
            neighbor: &part.neighbor,
            bits,
        });
        dispatch(
            "collisions.wgsl",
            &[&pb, &rb, &bodyb, &rowsb, &countb, &listb, &contactb, &nb, &bb],
            u64::from(part.range.workgroups),
        );
    }
    let gpu_contact: Vec<V4> = read(&contactb, n);
    let pushed = contact.iter().filter(|f| f[..3].iter().any(|c| *c != 0.0)).count();
    let error = relative_error(&flat(&gpu_contact), &flat(&contact));
    eprintln!("collisions: {pushed} particles pushed, relative force error {error:e}");
    assert!(pushed > 10);
    assert!(error <= 1e-5);

    // spring_forces
    let mut force = vec![[0.0f32; 4]; n];
    let mut boost = vec![0.0f32; n];
    let mut broken = vec![1u32; n];
    let mut power = vec![0.0f32; p.power_count as usize];
    let mut status = scene.status;
    let mut events = vec![[0u32; 2]; p.event_capacity as usize];
    let (forceb, boostb, brokenb, powerb) = (upload(&force), upload(&boost), upload(&broken), upload(&power));
    let (statusb, spheresb, eventsb) = (upload(&[status]), upload(&scene.spheres), upload(&events));
    let contactb = upload(&contact);
    let mut bits_after = Vec::new();
    for (part, bits) in scene.layout.ranges.iter().zip(&scene.bits) {
        let mut twin_bits = bits.clone();
        let (rb, nb, sb, tb, bb) = (
            uniform(&part.range),
            upload(&part.neighbor),
            upload(&part.stiffness),
            upload(&part.threshold),
            upload(bits),
        );
        twins::spring_forces(SpringForcesBindings {
            params: &p,
            range: &part.range,
            body: &scene.body,
            vel: &scene.vel,
            force: &mut force,
            boost_next: &mut boost,
            rows: &scene.rows,
            broken_count: &mut broken,
            contact_count: &count,
            contact_force: &contact,
            neighbor: &part.neighbor,
            stiffness: &part.stiffness,
            threshold: &part.threshold,
            bits: &mut twin_bits,
            power: &mut power,
            status: &mut status,
            spheres: &scene.spheres,
            events: &mut events,
        });
        dispatch(
            "spring_forces.wgsl",
            &[
                &pb, &rb, &bodyb, &velb, &forceb, &boostb, &rowsb, &brokenb, &countb, &contactb, &nb, &sb, &tb, &bb,
                &powerb, &statusb, &spheresb, &eventsb,
            ],
            u64::from(part.range.workgroups),
        );
        bits_after.push((read::<u32>(&bb, twin_bits.len()), twin_bits));
    }
    let gpu_force: Vec<V4> = read(&forceb, n);
    let force_error = relative_error(&flat(&gpu_force), &flat(&force));
    let boost_error = relative_error(&read::<f32>(&boostb, n), &boost);
    let power_error = relative_error(&read::<f32>(&powerb, power.len()), &power);
    let gpu_status = read::<Status>(&statusb, 1)[0];
    let breaks = status.events as usize;
    eprintln!(
        "spring_forces: {breaks} bonds broke, relative error of forces {force_error:e}, boosts {boost_error:e}, power \
         {power_error:e}"
    );
    assert!(breaks > 100, "the scene breaks bonds");
    assert!(force_error <= 1e-5);
    assert!(boost_error <= 1e-5);
    assert!(power_error <= 1e-5);
    for (gpu_bits, twin_bits) in &bits_after {
        assert_eq!(gpu_bits, twin_bits, "the same bonds broke");
    }
    assert_eq!(read::<u32>(&brokenb, n), broken);
    assert_eq!(gpu_status, status);
    let mut gpu_events: Vec<[u32; 2]> = read(&eventsb, breaks);
    let mut twin_events = events[..breaks].to_vec();
    gpu_events.sort_unstable();
    twin_events.sort_unstable();
    assert_eq!(gpu_events, twin_events);
    assert!(twin_events.iter().all(|e| e[0] == 7));
    // Both ends of every bond that broke agree: each broken entry's reverse entry (the same bond
    // seen from its other end) is broken.
    let bit = |i: usize, k: usize| {
        let (range, word, bit) = scene.layout.bit_of(i, k);
        bits_after[range].1[word] & (1 << bit) != 0
    };
    for i in 0..n {
        let row = scene.rows[i];
        for k in 0..row[2] as usize {
            let j = scene.layout.ranges[scene.layout.range_of(i)].neighbor[row[0] as usize + k * SLICE] as usize;
            let back = (0..scene.rows[j][2] as usize)
                .find(|&m| {
                    scene.layout.ranges[scene.layout.range_of(j)].neighbor[scene.rows[j][0] as usize + m * SLICE]
                        == i as u32
                })
                .expect("symmetric");
            assert_eq!(bit(i, k), bit(j, back), "bond {i}-{j}: both ends agree");
        }
    }

    // power_sum
    let mut status = scene.status;
    let sb = upload(&[status]);
    let powerb = upload(&power);
    twins::power_sum(PowerSumBindings { params: &p, power: &power, status: &mut status });
    dispatch("power_sum.wgsl", &[&pb, &powerb, &sb], 1);
    let gpu_status = read::<Status>(&sb, 1)[0];
    let error = (gpu_status.work_j() - status.work_j()).abs() / status.work_j().abs();
    eprintln!("power_sum: work {:e} J, relative error {error:e}", status.work_j());
    assert!(error <= 1e-6);

    // bond_energy
    let mut energy = vec![0.0f32; n];
    let energyb = upload(&energy);
    for (part, bits) in scene.layout.ranges.iter().zip(&scene.bits) {
        let (rb, nb, sb, bb) = (uniform(&part.range), upload(&part.neighbor), upload(&part.stiffness), upload(bits));
        twins::bond_energy(BondEnergyBindings {
            range: &part.range,
            body: &scene.body,
            rows: &scene.rows,
            neighbor: &part.neighbor,
            stiffness: &part.stiffness,
            bits,
            energy: &mut energy,
        });
        dispatch("bond_energy.wgsl", &[&rb, &bodyb, &rowsb, &nb, &sb, &bb, &energyb], u64::from(part.range.workgroups));
    }
    let error = relative_error(&read::<f32>(&energyb, n), &energy);
    eprintln!("bond_energy: relative error {error:e}");
    assert!(error <= 1e-5);
}

#[test]
fn every_shader_file_has_one_entry_point_named_like_the_file() {
    for (file, _) in shaders::KERNELS {
        let kernel = shaders::compile(gpu(), file).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(format!("{}.wgsl", kernel.entry_point()), file);
    }
}

/// The elastoplastic passes against their twins on the parity scene's block and displacements,
/// with random plastic extensions, broken bonds, damage, thresholds (about a third of the intact
/// bonds break), yield forces (some bonds yield), a cap, contact, body forces and grips.
#[test]
fn elastoplastic_kernels_match_their_twins() {
    use super::family::FamilyArrays;
    use super::wgsl_structs::FamilyParams;
    use crate::elastoplastic::{FamilyTable, StateBasedConstants};
    use shatter_core::config::material::Normalisation;

    let scene = Scene::new(5, u64::MAX);
    assert_eq!(scene.layout.ranges.len(), 1);
    let (n, p) = (scene.n, scene.params);
    let particles = block_particles();
    let constants = StateBasedConstants {
        bulk_modulus_pa: 14.9e9,
        shear_modulus_pa: 8.0e9,
        yield_force_n_m6: 0.0,
        plastic_cap_ratio: 0.05,
        damage_strengthening: 1.5,
        normalisation: Normalisation::WeightedVolume,
        anisotropy: None,
    };
    let mut rng = SplitMix64::new(11);
    let mut random = |lo: f64, hi: f64| (lo + (hi - lo) * rng.next_f64()) as f32;
    let table = FamilyTable::new(&particles, constants, 1024, |_| 0.0).expect("table");
    let part = &scene.layout.ranges[0];
    let entries = part.neighbor.len();
    let mut arrays = FamilyArrays::new(&table, &scene.rows, entries);
    for t in &mut arrays.threshold {
        *t = random(0.02, 0.6);
    }
    let mut particle_constants = table.particle.clone();
    for c in &mut particle_constants {
        // a yield force about that of a tenth of the bonds' deviatoric scalars
        c[3] = c[1] * random(1e-7, 2e-5) / 3e-3;
    }
    let plastic: Vec<[f32; 2]> = (0..entries).map(|_| [random(-1e-5, 1e-5), random(-2e-5, 2e-5)]).collect();
    let broken: Vec<u32> = (0..n).map(|i| scene.rows[i][2] / 2 - (i as u32 % 5)).collect();
    let hold: Vec<V4> = (0..n)
        .map(|i| match i % 7 {
            0 => [0.5, -1.0, 0.25, f32::from_bits(9)],
            1 => [1.0, 0.0, 0.0, f32::from_bits(3)],
            _ => [0.0; 4],
        })
        .collect();
    let family = FamilyParams { damage_strengthening: 1.5, plastic_cap_ratio: 0.05, grips: 1, pad: 0 };
    let bits = &scene.bits[0];

    // family_dilatation
    let mut twin_plastic = plastic.clone();
    let mut extension = vec![0.0f32; entries];
    let mut record = vec![[0.0f32; 4]; n];
    let mut damage = vec![0.0f32; n];
    twins::family_dilatation(FamilyDilatationBindings {
        params: &p,
        body: &scene.body,
        rows: &scene.rows,
        broken_count: &broken,
        neighbor: &part.neighbor,
        bits,
        family_entry: &arrays.entry,
        family_particle: &particle_constants,
        weighted_volume: &table.weighted_volume,
        plastic: &mut twin_plastic,
        extension: &mut extension,
        family_record: &mut record,
        damage: &mut damage,
    });
    let pb = uniform(&p);
    let (bodyb, rowsb, brokenb, nb, bb) =
        (upload(&scene.body), upload(&scene.rows), upload(&broken), upload(&part.neighbor), upload(bits));
    let (entryb, particleb, weightb) =
        (upload(&arrays.entry), upload(&particle_constants), upload(&table.weighted_volume));
    let (plasticb, extensionb, recordb, damageb) =
        (upload(&plastic), upload(&vec![0.0f32; entries]), upload(&vec![[0.0f32; 4]; n]), upload(&vec![0.0f32; n]));
    dispatch(
        "family_dilatation.wgsl",
        &[
            &pb,
            &bodyb,
            &rowsb,
            &brokenb,
            &nb,
            &bb,
            &entryb,
            &particleb,
            &weightb,
            &plasticb,
            &extensionb,
            &recordb,
            &damageb,
        ],
        groups(n),
    );
    let gpu_record: Vec<V4> = read(&recordb, n);
    let theta = |r: &[V4]| r.iter().map(|x| x[3]).collect::<Vec<f32>>();
    let theta_error = relative_error(&theta(&gpu_record), &theta(&record));
    let extension_error = relative_error(&read::<f32>(&extensionb, entries), &extension);
    eprintln!("family_dilatation: relative error of theta {theta_error:e}, of extensions {extension_error:e}");
    assert!(theta_error <= 1e-5 && extension_error <= 1e-5);
    assert_eq!(read::<f32>(&damageb, n), damage);
    assert_eq!(read::<[f32; 2]>(&plasticb, entries), twin_plastic);
    assert!(damage.iter().any(|d| *d > 0.3));

    // family_forces, from the twin's first-pass outputs
    let (count, list) = contact_lists(&scene);
    let mut contact = vec![[0.0f32; 4]; n];
    twins::collisions(CollisionsBindings {
        params: &p,
        range: &part.range,
        body: &scene.body,
        rows: &scene.rows,
        contact_count: &count,
        contact_list: &list,
        contact_force: &mut contact,
        neighbor: &part.neighbor,
        bits,
    });
    let mut vel = scene.vel.clone();
    let mut force = vec![[0.0f32; 4]; n];
    let mut broken_after = broken.clone();
    let mut twin_bits = bits.clone();
    let mut plastic_after = twin_plastic.clone();
    let mut power = vec![0.0f32; p.power_count as usize];
    let mut status = scene.status;
    let mut events = vec![[0u32; 2]; p.event_capacity as usize];
    let family_b = uniform(&family);
    let (velb, forceb, brokenb, countb, contactb) =
        (upload(&vel), upload(&force), upload(&broken), upload(&count), upload(&contact));
    let (reverseb, thresholdb, plasticb, extensionb, recordb, damageb) = (
        upload(&arrays.reverse),
        upload(&arrays.threshold),
        upload(&twin_plastic),
        upload(&extension),
        upload(&record),
        upload(&damage),
    );
    let (powerb, statusb, spheresb, eventsb, holdb) =
        (upload(&power), upload(&[status]), upload(&scene.spheres), upload(&events), upload(&hold));
    let bb = upload(bits);
    twins::family_forces(FamilyForcesBindings {
        params: &p,
        family: &family,
        body: &scene.body,
        vel: &mut vel,
        force: &mut force,
        rows: &scene.rows,
        broken_count: &mut broken_after,
        contact_count: &count,
        contact_force: &contact,
        neighbor: &part.neighbor,
        bits: &mut twin_bits,
        family_entry: &arrays.entry,
        family_particle: &particle_constants,
        family_reverse: &arrays.reverse,
        threshold: &arrays.threshold,
        plastic: &mut plastic_after,
        extension: &extension,
        family_record: &record,
        damage: &damage,
        power: &mut power,
        status: &mut status,
        spheres: &scene.spheres,
        events: &mut events,
        hold: &hold,
    });
    dispatch(
        "family_forces.wgsl",
        &[
            &pb,
            &family_b,
            &bodyb,
            &velb,
            &forceb,
            &rowsb,
            &brokenb,
            &countb,
            &contactb,
            &nb,
            &bb,
            &entryb,
            &particleb,
            &reverseb,
            &thresholdb,
            &plasticb,
            &extensionb,
            &recordb,
            &damageb,
            &powerb,
            &statusb,
            &spheresb,
            &eventsb,
            &holdb,
        ],
        groups(n),
    );
    let force_error = relative_error(&flat(&read::<V4>(&forceb, n)), &flat(&force));
    let velocity_error = relative_error(&flat(&read::<V4>(&velb, n)), &flat(&vel));
    let power_error = relative_error(&read::<f32>(&powerb, power.len()), &power);
    let gpu_plastic: Vec<[f32; 2]> = read(&plasticb, entries);
    let plastic_error = relative_error(
        &gpu_plastic.iter().map(|x| x[1]).collect::<Vec<_>>(),
        &plastic_after.iter().map(|x| x[1]).collect::<Vec<_>>(),
    );
    let yielded = plastic_after.iter().zip(&twin_plastic).filter(|(a, b)| a[1] != b[0]).count();
    let capped = plastic_after.iter().filter(|x| x[1].abs() >= 0.05 * 1e-3 * 0.999).count();
    let breaks = status.events as usize;
    eprintln!(
        "family_forces: {breaks} bonds broke, {yielded} entries flowed ({capped} at the cap), relative error of \
         forces {force_error:e}, velocities {velocity_error:e}, power {power_error:e}, plastic {plastic_error:e}"
    );
    assert!(breaks > 100, "the scene breaks bonds");
    assert!(yielded > 100, "bonds flow");
    assert!(force_error <= 1e-5 && velocity_error == 0.0 && power_error <= 1e-5 && plastic_error <= 1e-5);
    assert_eq!(read::<u32>(&bb, twin_bits.len()), twin_bits, "the same bonds broke");
    assert_eq!(read::<u32>(&brokenb, n), broken_after);
    assert_eq!(read::<Status>(&statusb, 1)[0], status);
    let mut gpu_events: Vec<[u32; 2]> = read(&eventsb, breaks);
    let mut twin_events = events[..breaks].to_vec();
    gpu_events.sort_unstable();
    twin_events.sort_unstable();
    assert_eq!(gpu_events, twin_events);
}
