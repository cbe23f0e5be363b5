//! Benchmark: the follow-through of the paper-scale vase's pieces (issue #18: the shot's 4 s in
//! under a minute on two cores).
//!
//! The paper-scale simulation of `vase_drop_paper` (323,000 tetrahedra, 31 million bonds) takes
//! hours on a CPU, so its pieces are cut here by the small shot's cracks: every particle of the
//! paper-scale vase takes the fragment, the pose and the velocity of the nearest particle of
//! `vase_drop_small` at its handoff, and what is a single element there (the dust of the
//! crushed base) is single elements here too. The rigid world is then built exactly as
//! `shatter rigid` builds it (mass properties, shapes, velocity fit) with the paper preset's
//! `[rigid]` settings, and stepped for 3.5 s of frames at 24 fps (the vase's follow-through
//! lasts about 3.4 s of its 4 s).
//!
//! Needs both outputs first:
//!
//! ```text
//! shatter run --config assets/scenes/vase_drop_small.toml --until rigid
//! shatter preprocess --config assets/scenes/vase_drop_paper.toml
//! cargo bench -p shatter-rigid --bench follow_through
//! ```

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::DVec3;
use rapier3d_f64::math::{Rotation, Vector};
use shatter_core::fragments::{FragmentFrame, FragmentMeta};
use shatter_core::frames::PointFrame;
use shatter_core::particles::ParticleSet;
use shatter_core::rigid_checkpoint::RigidCheckpoint;
use shatter_core::{OutputLayout, PipelineConfig};
use shatter_geometry::PointKdTree;
use shatter_rigid::hand_over;
use shatter_rigid::shapes::ElementGeometry;

const FRAME_S: f64 = 1.0 / 24.0;
const FOLLOW_THROUGH_FRAMES: u32 = 84;

fn main() {
    let scenes = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes");
    let small = PipelineConfig::load(&scenes.join("vase_drop_small.toml")).expect("vase_drop_small.toml");
    let paper = PipelineConfig::load(&scenes.join("vase_drop_paper.toml")).expect("vase_drop_paper.toml");
    let (small_layout, paper_layout) = (OutputLayout::of(&small), OutputLayout::of(&paper));
    let need = |path: &Path, command: &str| {
        if !path.is_file() {
            eprintln!("{} is missing: run `{command}` first (see the bench's header)", path.display());
            std::process::exit(2);
        }
    };
    need(&small_layout.rigid_checkpoint(), "shatter run --config assets/scenes/vase_drop_small.toml --until rigid");
    need(&paper_layout.particles(), "shatter preprocess --config assets/scenes/vase_drop_paper.toml");

    let started = Instant::now();
    let handoff_frame = RigidCheckpoint::read(&small_layout.rigid_checkpoint()).expect("checkpoint").meta.handoff_frame;
    let small_particles = ParticleSet::read(&small_layout.particles()).expect("small particles");
    let small_fragments = FragmentFrame::read(&small_layout.fragments(handoff_frame)).expect("small fragments");
    let small_points = PointFrame::read(&small_layout.frame_points(handoff_frame)).expect("small points");
    let particles = ParticleSet::read(&paper_layout.particles()).expect("paper particles");
    let read_s = started.elapsed().as_secs_f64();

    // FOLLOW_THROUGH_VERBOSE=1: the pieces' hulls, and each frame's awake pieces and time
    let verbose = std::env::var_os("FOLLOW_THROUGH_VERBOSE").is_some();
    // FOLLOW_THROUGH_DUST=grains: the small shot's dust stays in grains of its size
    let split_dust = std::env::var("FOLLOW_THROUGH_DUST").map_or(true, |dust| dust != "grains");
    let started = Instant::now();
    let source = nearest(&small_particles.rest_position_m, &particles.rest_position_m, small_particles.meta.lambda_m);
    let (handoff, points) = cut(&small_fragments, &small_points, &particles, &source, split_dust);
    let cut_s = started.elapsed().as_secs_f64();

    let rigid = paper.rigid.as_ref().expect("[rigid]");
    if verbose {
        print_shapes(&particles, &handoff, rigid.hull_volume_factor, rigid.dust_max_elements as usize);
    }
    let started = Instant::now();
    let (mut world, conservation) = hand_over(&paper, rigid, &particles, &handoff, &points);
    let build_s = started.elapsed().as_secs_f64();

    let started = Instant::now();
    let mut steps = 0;
    let mut asleep_from = None;
    for frame in 1..=FOLLOW_THROUGH_FRAMES {
        let frame_started = Instant::now();
        steps += world.advance(FRAME_S, rigid.max_step_s);
        if verbose {
            println!(
                "  frame {frame}: {} awake, {:.2} s",
                world.awake_pieces().len(),
                frame_started.elapsed().as_secs_f64()
            );
        }
        if world.all_asleep() {
            asleep_from = Some(frame);
            break;
        }
    }
    let step_s = started.elapsed().as_secs_f64();
    if verbose {
        let velocities = world.velocities();
        for piece in world.awake_pieces() {
            let (v, w) = velocities[piece];
            println!(
                "  awake at the end: piece {piece} of {} elements, {:.4} m/s, {:.4} rad/s",
                handoff.elements[piece],
                v.length(),
                w.length()
            );
        }
    }

    let pieces = handoff.fragment_count();
    let dust = handoff.elements.iter().filter(|&&n| n <= rigid.dust_max_elements).count();
    println!(
        "paper-scale vase follow-through ({} threads): {} elements, {pieces} pieces ({dust} \
         of them dust of at most {} elements)",
        rayon::current_num_threads(),
        particles.len(),
        rigid.dust_max_elements
    );
    println!(
        "  handoff: momentum kept to {:.1e}, angular momentum to {:.1e}; {:.3} J in the bodies of {:.3} J",
        conservation.momentum_error,
        conservation.angular_momentum_error,
        conservation.body_energy_j,
        conservation.particle_energy_j
    );
    let simulated = asleep_from.unwrap_or(FOLLOW_THROUGH_FRAMES);
    println!(
        "  {simulated} frames ({:.2} s) in {steps} steps; {}; {} retired, {} awake at the end; \
         deepest overlap {:.2} mm",
        f64::from(simulated) * FRAME_S,
        asleep_from.map_or("not every piece asleep".to_string(), |f| format!("every piece asleep from frame {f}")),
        world.retired_pieces(),
        world.awake_pieces().len(),
        world.deepest_penetration_m() * 1e3
    );
    println!(
        "  read {read_s:.1} s, cut {cut_s:.1} s, build (mass, shapes, fit) {build_s:.1} s, step {step_s:.1} s: \
         follow-through {:.1} s",
        build_s + step_s
    );
}

/// How many hulls (and their points) the pieces that are not dust collide as.
fn print_shapes(particles: &ParticleSet, handoff: &FragmentFrame, hull_volume_factor: f64, dust_max_elements: usize) {
    let geometry = ElementGeometry::of(particles);
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); handoff.fragment_count()];
    for (element, &piece) in handoff.fragment_of.iter().enumerate() {
        members[piece as usize].push(element as u32);
    }
    let shapes: Vec<_> = members
        .iter()
        .filter(|members| members.len() > dust_max_elements)
        .map(|members| geometry.piece_shape(members, hull_volume_factor))
        .collect();
    let hulls: usize = shapes.iter().map(|shape| shape.hulls.len()).sum();
    let most = shapes.iter().map(|shape| shape.hulls.len()).max().unwrap_or(0);
    let points: usize = shapes.iter().flat_map(|shape| shape.hulls.iter().map(Vec::len)).sum();
    println!(
        "  {} pieces that are not dust collide as {hulls} hulls (at most {most} a piece) of {points} points \
         (hull_volume_factor {hull_volume_factor})",
        shapes.len()
    );
}

/// The paper-scale handoff: each element in the fragment of its source particle (a fragment of
/// one element there: an element of its own), posed as that fragment, moving as that particle.
fn cut(
    small: &FragmentFrame,
    small_points: &PointFrame,
    particles: &ParticleSet,
    source: &[usize],
    split_dust: bool,
) -> (FragmentFrame, PointFrame) {
    let mut piece_of_fragment: HashMap<u32, u32> = HashMap::new();
    let mut fragment_of = Vec::with_capacity(source.len());
    let mut small_fragment = Vec::new();
    for &s in source {
        let f = small.fragment_of[s];
        let piece =
            if split_dust && small.elements[f as usize] == 1 { None } else { piece_of_fragment.get(&f).copied() };
        let piece = piece.unwrap_or_else(|| {
            let id = small_fragment.len() as u32;
            small_fragment.push(f);
            if !split_dust || small.elements[f as usize] > 1 {
                piece_of_fragment.insert(f, id);
            }
            id
        });
        fragment_of.push(piece);
    }
    let mut elements = vec![0u32; small_fragment.len()];
    for &piece in &fragment_of {
        elements[piece as usize] += 1;
    }
    let rotation: Vec<[f32; 4]> = small_fragment.iter().map(|&f| small.rotation[f as usize]).collect();
    let translation_m: Vec<[f64; 3]> = small_fragment.iter().map(|&f| small.translation_m[f as usize]).collect();
    let n = particles.len();
    let mut position = [vec![0f32; n], vec![0f32; n], vec![0f32; n]];
    let mut velocity = [vec![0f32; n], vec![0f32; n], vec![0f32; n]];
    for i in 0..n {
        let piece = fragment_of[i] as usize;
        let [x, y, z, w] = rotation[piece].map(f64::from);
        let rest = Vector::from_array(particles.rest_position_m[i].map(f64::from));
        let at = Rotation::from_xyzw(x, y, z, w).normalize() * rest + Vector::from_array(translation_m[piece]);
        for axis in 0..3 {
            position[axis][i] = at[axis] as f32;
            velocity[axis][i] = small_points.velocity[axis][source[i]];
        }
    }
    let meta = FragmentMeta { inputs: None, ..small.meta.clone() };
    let handoff = FragmentFrame {
        meta,
        fragment_of,
        rotation,
        translation_m,
        elements,
        mass_kg: vec![0.0; small_fragment.len()],
        element_affine: None,
    };
    let points = PointFrame {
        frame: small_points.frame,
        step: small_points.step,
        time_s: small_points.time_s,
        position,
        velocity,
        damage: vec![0.0; n],
        inputs: None,
    };
    (handoff, points)
}

/// For each of `queries`, the index of the nearest of `points` (ties to the lower index),
/// searched within a radius of `spacing_m` that doubles until a point is found.
fn nearest(points: &[[f32; 3]], queries: &[[f32; 3]], spacing_m: f64) -> Vec<usize> {
    let vector = |p: &[f32; 3]| DVec3::from_array(p.map(f64::from));
    let points: Vec<DVec3> = points.iter().map(vector).collect();
    let tree = PointKdTree::new(&points);
    let mut found = Vec::new();
    queries
        .iter()
        .map(|query| {
            let query = vector(query);
            let mut radius = spacing_m;
            loop {
                found.clear();
                tree.within(query, radius * radius, &mut found);
                let distance = |j: &u32| (points[*j as usize].distance_squared(query), *j);
                if let Some(j) = found.iter().min_by(|a, b| distance(a).partial_cmp(&distance(b)).expect("finite")) {
                    return *j as usize;
                }
                radius *= 2.0;
            }
        })
        .collect()
}
