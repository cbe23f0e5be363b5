//! The rigid world on cases with known answers: free fall, a box settling on the floor, a
//! pile coming to rest without interpenetration, overlapping pieces at the handoff left
//! where they are, and a snapshot continuing bit for bit.

use rapier3d_f64::math::{Rotation, Vector};
use shatter_rigid::mass::{MassProps, solid_of_triangles};
use shatter_rigid::shapes::PieceShape;
use shatter_rigid::world::{PieceBody, RigidWorld, WorldSettings};

fn settings() -> WorldSettings {
    WorldSettings {
        gravity_m_s2: [0.0, -9.81, 0.0],
        length_unit_m: 0.05,
        solver_iterations: 4,
        floor_friction: 0.6,
        floor_restitution: 0.2,
        piece_friction: 0.5,
        piece_restitution: 0.1,
        sleep_speed_m_s: 0.005,
        sleep_after_s: 0.5,
        max_mass_ratio: 500.0,
        bounds_m: None,
        rolling_damping_per_s: 0.0,
        rolling_resistance_m_s2: 0.0,
    }
}

fn box_corners(centre: Vector, half: Vector) -> Vec<Vector> {
    (0..8)
        .map(|i| {
            let s = |bit: usize, h: f64| if i & bit != 0 { h } else { -h };
            centre + Vector::new(s(1, half.x), s(2, half.y), s(4, half.z))
        })
        .collect()
}

/// A box piece whose rest frame has it at `rest_centre`, placed at `centre` (no rotation).
fn box_piece(rest_centre: Vector, half: Vector, centre: Vector, velocity: Vector, density: f64) -> PieceBody {
    let corners = box_corners(rest_centre, half);
    const FACES: [[usize; 4]; 6] = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
    let triangles: Vec<[Vector; 3]> = FACES
        .iter()
        .flat_map(|[a, b, c, d]| [[corners[*a], corners[*b], corners[*c]], [corners[*a], corners[*c], corners[*d]]])
        .collect();
    let (volume, c, second) = solid_of_triangles(&triangles, rest_centre).expect("box");
    PieceBody {
        mass: MassProps { mass_kg: volume * density, centre_m: c, second_moment: second * density },
        rotation: Rotation::IDENTITY,
        translation_m: centre - rest_centre,
        linear_m_s: velocity,
        angular_rad_s: Vector::ZERO,
        shape: PieceShape { hulls: vec![corners] }.shared_shape(),
        dust: false,
    }
}

/// The mass properties of the convex hull of `points`, of ceramic (2,200 kg/m^3).
fn hull_mass(points: &[Vector]) -> MassProps {
    let (vertices, faces) = rapier3d_f64::parry::transformation::convex_hull(points);
    let triangles: Vec<[Vector; 3]> = faces.iter().map(|f| f.map(|i| vertices[i as usize])).collect();
    let (volume, centre, second) = solid_of_triangles(&triangles, Vector::ZERO).expect("a hull with a volume");
    MassProps { mass_kg: volume * 2200.0, centre_m: centre, second_moment: second * 2200.0 }
}

/// The hull of `points` (a body of revolution about z, of `radius`) on the floor, rolling
/// along x at `speed_m_s`.
fn rolling_on_the_floor(points: &[Vector], radius: f64, speed_m_s: f64) -> PieceBody {
    PieceBody {
        mass: hull_mass(points),
        rotation: Rotation::IDENTITY,
        translation_m: Vector::new(0.0, radius, 0.0),
        linear_m_s: Vector::new(speed_m_s, 0.0, 0.0),
        angular_rad_s: Vector::new(0.0, 0.0, -speed_m_s / radius),
        shape: PieceShape { hulls: vec![points.to_vec()] }.shared_shape(),
        dust: false,
    }
}

fn run_until(world: &mut RigidWorld, seconds: f64) {
    let frames = (seconds * 24.0).round() as u32;
    for _ in 0..frames {
        world.advance(1.0 / 24.0, 1.0 / 960.0);
    }
}

#[test]
fn free_fall_follows_the_parabola() {
    // rapier's update is semi-implicit Euler over `solver_iterations` substeps; with one
    // substep, started half a step back in velocity, it is the leapfrog scheme: exact for
    // uniform gravity (the lead-in runs so)
    let half = Vector::splat(0.01);
    let start = Vector::new(0.0, 1.0, 0.0);
    let v0 = Vector::new(0.5, 2.0, -0.25);
    let g = Vector::new(0.0, -9.81, 0.0);
    let dt = 1.0 / 960.0;
    let flying = WorldSettings { solver_iterations: 1, sleep_speed_m_s: -1.0, ..settings() };
    let piece = box_piece(Vector::new(0.3, 0.1, 0.2), half, start, v0 - g * (0.5 * dt), 2200.0);
    let mut world = RigidWorld::new(&flying, None, &[], &[piece]);
    let t = 0.5;
    for _ in 0..480 {
        world.advance(dt, dt);
    }
    let expected = start + v0 * t + g * (0.5 * t * t);
    let centre = world.centres()[0];
    let error = (centre - expected).length() / (expected - start).length();
    assert!(error < 1e-9, "{centre:?} vs {expected:?}: {error:e}");
    let (v, w) = world.velocities()[0];
    assert!((v + g * (0.5 * dt) - (v0 + g * t)).length() < 1e-9, "{v:?}");
    assert_eq!(w, Vector::ZERO);
    // with rapier's four substeps and no offset it trails the parabola by g t dt / 8
    let mut world = RigidWorld::new(&settings(), None, &[], &[box_piece(Vector::ZERO, half, start, v0, 2200.0)]);
    for _ in 0..480 {
        world.advance(dt, dt);
    }
    let trail = (world.centres()[0] - expected).y;
    assert!((trail - g.y * t * dt / 8.0).abs() < 1e-9, "{trail} vs {}", g.y * t * dt / 8.0);
    // fast: no speed limit (rapier's default would hold it at 400 length units a second, 20 m/s)
    let fast = Vector::new(0.0, -30.0, 0.0);
    let piece = box_piece(Vector::ZERO, half, Vector::new(0.0, 100.0, 0.0), fast - g * (0.5 * dt), 2200.0);
    let mut world = RigidWorld::new(&flying, None, &[], &[piece]);
    for _ in 0..480 {
        world.advance(dt, dt);
    }
    let (v, _) = world.velocities()[0];
    assert!((v + g * (0.5 * dt) - (fast + g * t)).length() < 1e-9, "{v:?}");
}

#[test]
fn a_box_settles_on_the_floor_at_its_height() {
    // as a piece and as dust (which meets only the floor's plane and the spheres), on a floor
    // at 0 and at -0.3 m
    for (dust, floor) in [(false, 0.0), (true, 0.0), (false, -0.3), (true, -0.3)] {
        let half = Vector::new(0.02, 0.01, 0.015);
        let start = Vector::new(0.0, floor + 0.1, 0.0);
        let mut piece = box_piece(Vector::ZERO, half, start, Vector::new(0.3, 0.0, 0.0), 2200.0);
        piece.dust = dust;
        let mut world = RigidWorld::new(&settings(), Some(floor), &[], &[piece]);
        run_until(&mut world, 2.0);
        let centre = world.centres()[0];
        let height = centre.y - floor;
        assert!((height - half.y).abs() < 5e-4, "dust {dust}: rests {height} above the floor, not {}", half.y);
        assert!(centre.x > 0.01, "dust {dust}: slid to {} only", centre.x);
        let (v, w) = world.velocities()[0];
        assert!(v.length() < 1e-3 && w.length() * half.length() < 1e-3, "dust {dust}: still moving: {v:?} {w:?}");
        assert!(world.all_asleep(), "dust {dust}: the box should sleep");
    }
}

fn pile() -> Vec<PieceBody> {
    // a column of small boxes dropped onto each other
    (0..6)
        .map(|i| {
            let half = Vector::new(0.01 + 0.002 * (i % 3) as f64, 0.006, 0.012 - 0.001 * i as f64);
            let centre = Vector::new(0.003 * i as f64, 0.03 + 0.02 * i as f64, -0.002 * i as f64);
            box_piece(Vector::new(i as f64, 0.0, 0.0), half, centre, Vector::new(0.0, -0.5, 0.1), 2400.0)
        })
        .collect()
}

#[test]
fn a_plate_of_two_hulls_lands_flat_on_the_floor() {
    // a compound piece lands on the floor slab and rests at its half-thickness
    let half = Vector::new(0.01, 0.0025, 0.02);
    let parts = vec![box_corners(Vector::new(-0.01, 0.0, 0.0), half), box_corners(Vector::new(0.01, 0.0, 0.0), half)];
    let whole = Vector::new(0.02, 0.0025, 0.02);
    let mut piece = box_piece(Vector::ZERO, whole, Vector::new(0.0, 0.03, 0.0), Vector::ZERO, 2200.0);
    piece.shape = PieceShape { hulls: parts }.shared_shape();
    let mut world = RigidWorld::new(&settings(), Some(0.0), &[], &[piece]);
    run_until(&mut world, 1.0);
    let height = world.centres()[0].y;
    assert!((height - whole.y).abs() < 5e-4, "rests at {height} instead of {}", whole.y);
}

#[test]
fn a_pile_comes_to_rest_without_interpenetration() {
    let mut world = RigidWorld::new(&settings(), Some(0.0), &[], &pile());
    let mut deepest: f64 = 0.0;
    for _ in 0..(4 * 24) {
        world.advance(1.0 / 24.0, 1.0 / 960.0);
        deepest = deepest.max(world.deepest_penetration_m());
    }
    // soft contacts give a little while the pile lands (measured 1.03 mm), less at rest (0.24)
    assert!(deepest <= 2e-3, "pieces overlapped by {deepest} m while landing");
    let resting = world.deepest_penetration_m();
    assert!(resting <= 1e-3, "pieces rest {resting} m inside each other or the floor");
    for (centre, piece) in world.centres().iter().zip(pile()) {
        assert!(
            centre.y > 0.0 && centre.y.is_finite(),
            "a piece fell through the floor: {centre:?} ({:?})",
            piece.mass
        );
    }
    assert!(world.all_asleep(), "every piece should sleep after 4 s");
}

#[test]
fn pieces_overlapping_at_the_handoff_are_not_pushed_apart() {
    // two boxes, 1 mm into each other, floating without gravity
    let half = Vector::splat(0.01);
    let a = box_piece(Vector::ZERO, half, Vector::ZERO, Vector::ZERO, 2200.0);
    let b = box_piece(Vector::ZERO, half, Vector::new(0.019, 0.0, 0.0), Vector::ZERO, 2200.0);
    let still = WorldSettings { gravity_m_s2: [0.0; 3], ..settings() };
    let mut world = RigidWorld::new(&still, None, &[], &[a, b]);
    world.advance(1e-3, 1e-3);
    assert_eq!(world.allowances(), 1, "the overlap is recorded");
    run_until(&mut world, 0.5);
    assert!(world.kinetic_energy_j() < 1e-12, "kinetic energy {} J from nothing", world.kinetic_energy_j());
    // yet they do not sink into each other either: pushed together, they stop
    let a = box_piece(Vector::ZERO, half, Vector::ZERO, Vector::new(0.1, 0.0, 0.0), 2200.0);
    let b = box_piece(Vector::ZERO, half, Vector::new(0.019, 0.0, 0.0), Vector::ZERO, 2200.0);
    let mut world = RigidWorld::new(&still, None, &[], &[a, b]);
    run_until(&mut world, 0.5);
    let [ca, cb] = [world.centres()[0], world.centres()[1]];
    assert!(cb.x - ca.x > 0.0185, "sank into each other: {}", cb.x - ca.x);
}

#[test]
fn a_snapshot_continues_bit_for_bit() {
    // the pile and a grain of dust, which rests on the floor's plane (the contacts of a plane
    // are our own code, which the restored world must use too)
    let mut pieces = pile();
    let mut grain = box_piece(Vector::ZERO, Vector::splat(0.003), Vector::new(0.1, 0.05, 0.0), Vector::X, 2200.0);
    grain.dust = true;
    pieces.push(grain);
    let mut whole = RigidWorld::new(&settings(), Some(0.0), &[], &pieces);
    run_until(&mut whole, 0.25);
    let bytes = whole.snapshot().expect("snapshot");
    let mut resumed = RigidWorld::restore(&bytes).expect("restore");
    run_until(&mut whole, 0.5);
    run_until(&mut resumed, 0.5);
    let bits = |w: &RigidWorld| {
        w.poses().iter().flat_map(|(r, t)| [r.x, r.y, r.z, r.w, t.x, t.y, t.z].map(f64::to_bits)).collect::<Vec<u64>>()
    };
    assert_eq!(bits(&whole), bits(&resumed));
}

#[test]
fn light_pieces_under_a_heavy_shard_hold_it_up() {
    // two 6 mm grains on the floor carry a flat shard 230 times heavier than each (5 mm thick,
    // 10 cm square): soft contacts carry a mass ratio this large only if they are stiff enough
    // (at 120 / 60 Hz the grains were pressed 5.4 mm into the floor; at 240 / 480 Hz the shard
    // sank 0.50 mm into them; at 480 / 960 Hz 0.125 mm, the soft contact's F / (m w^2))
    let grain_half = Vector::splat(0.003);
    let grain = |x: f64| box_piece(Vector::ZERO, grain_half, Vector::new(x, 0.003, 0.0), Vector::ZERO, 2200.0);
    let shard_half = Vector::new(0.05, 0.0025, 0.05);
    let shard = box_piece(Vector::ZERO, shard_half, Vector::new(0.0, 0.0085, 0.0), Vector::ZERO, 2200.0);
    let mut world = RigidWorld::new(&settings(), Some(0.0), &[], &[grain(-0.04), grain(0.04), shard]);
    run_until(&mut world, 2.0);
    let overlaps = world.overlaps();
    assert!(overlaps.iter().all(|o| o.2 <= 3e-4), "overlaps at rest {overlaps:?}");
    for grain in &world.centres()[..2] {
        assert!((grain.y - grain_half.y).abs() < 2e-4, "a grain sits at {} not {}", grain.y, grain_half.y);
    }
    assert!(world.all_asleep(), "every piece should sleep: {:?}", world.velocities());
}

#[test]
fn a_piece_far_lighter_than_another_passes_through_it() {
    // a 2 mm grain 6,250 times lighter than the shard falling on it (over max_mass_ratio):
    // contacts could not hold the shard up on it, so the two do not collide; the shard lands
    // flat on the floor over the grain, and both sleep
    let grain_half = Vector::splat(0.001);
    let grain = box_piece(Vector::ZERO, grain_half, Vector::new(0.02, 0.001, 0.0), Vector::ZERO, 2200.0);
    let shard_half = Vector::new(0.05, 0.0025, 0.05);
    let shard = box_piece(Vector::ZERO, shard_half, Vector::new(0.0, 0.02, 0.0), Vector::ZERO, 2200.0);
    let mut world = RigidWorld::new(&settings(), Some(0.0), &[], &[grain.clone(), shard.clone()]);
    run_until(&mut world, 1.0);
    let [grain_at, shard_at] = [world.centres()[0], world.centres()[1]];
    assert!((shard_at.y - shard_half.y).abs() < 1e-4, "the shard rests at {} not on the floor", shard_at.y);
    assert!((grain_at - Vector::new(0.02, 0.001, 0.0)).length() < 1e-4, "the grain moved to {grain_at:?}");
    assert!(world.overlaps().iter().all(|o| o.2 < 1e-4), "{:?}", world.overlaps());
    assert!(world.all_asleep());
    // with the rule off they collide, and the soft contacts let the shard swallow the grain
    let mut world =
        RigidWorld::new(&WorldSettings { max_mass_ratio: 1e9, ..settings() }, Some(0.0), &[], &[grain, shard]);
    run_until(&mut world, 1.0);
    let deepest = world.overlaps().first().map_or(0.0, |o| o.2);
    assert!(deepest > 1e-3, "the grain held the shard up ({deepest} m): the rule is no longer needed");
}

#[test]
fn a_piece_flung_out_of_the_shot_is_retired_where_it_left() {
    // a grain skidding off at 30 m/s (friction alone would stop it 76 m away, after 5 s)
    // leaves the 1 m region within a frame or two and is held there; the box beside it settles
    // as without the region, and the shot counts as at rest
    let half = Vector::splat(0.003);
    let flung = box_piece(Vector::ZERO, half, Vector::new(0.0, 0.003, 0.0), Vector::new(30.0, 0.0, 0.0), 2200.0);
    let block_half = Vector::new(0.02, 0.01, 0.015);
    let block = box_piece(Vector::ZERO, block_half, Vector::new(0.0, 0.1, 0.2), Vector::new(0.3, 0.0, 0.0), 2200.0);
    let bounds = Some([[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]]);
    let mut world = RigidWorld::new(
        &WorldSettings { bounds_m: bounds, ..settings() },
        Some(0.0),
        &[],
        &[flung.clone(), block.clone()],
    );
    run_until(&mut world, 0.1);
    assert_eq!(world.retired_pieces(), 1);
    let left_at = world.centres()[0];
    assert!(left_at.x > 1.0 && left_at.x < 1.0 + 30.0 / 24.0, "retired at {left_at:?}");
    let bytes = world.snapshot().expect("snapshot");
    let mut resumed = RigidWorld::restore(&bytes).expect("restore");
    run_until(&mut world, 2.0);
    run_until(&mut resumed, 2.0);
    assert_eq!(world.centres()[0], left_at, "a retired piece stays where it left");
    assert!(world.all_asleep() && world.awake_pieces().is_empty());
    assert_eq!(world.poses(), resumed.poses(), "retirement survives a snapshot");
    let mut unbounded = RigidWorld::new(&settings(), Some(0.0), &[], &[flung, block]);
    run_until(&mut unbounded, 2.1);
    assert!(!unbounded.all_asleep(), "the grain should still be skidding without a region");
    assert_eq!(unbounded.poses()[1], world.poses()[1], "the region changed the box's motion");
}

/// A curved shard: a 120 degree arc of a 5 cm cylinder shell, 4 mm thick and 4 cm long, lying
/// on its back on the floor, tilted by `tilt_rad` about the cylinder's axis; as one hull, or as
/// a compound of `parts` hulls along the arc.
fn curved_shard(tilt_rad: f64, parts: usize) -> PieceBody {
    let (radius, thickness, half_length) = (0.05, 0.004, 0.02);
    let arc = |from: f64, to: f64, steps: usize| {
        let mut points = Vec::new();
        for k in 0..=steps {
            let angle = (from + (to - from) * k as f64 / steps as f64).to_radians();
            for r in [radius, radius - thickness] {
                for z in [-half_length, half_length] {
                    points.push(Vector::new(r * angle.sin(), radius - r * angle.cos(), z));
                }
            }
        }
        points
    };
    let whole = arc(-60.0, 60.0, 48);
    let mass = hull_mass(&whole);
    let hulls = if parts == 1 {
        vec![whole]
    } else {
        let step = 120.0 / parts as f64;
        (0..parts).map(|p| arc(-60.0 + step * p as f64, -60.0 + step * (p + 1) as f64, 2)).collect()
    };
    let rotation = Rotation::from_rotation_z(tilt_rad);
    let contact = Vector::new(radius * tilt_rad.sin(), radius - radius * tilt_rad.cos(), 0.0);
    PieceBody {
        mass,
        rotation,
        translation_m: -(rotation * contact) + Vector::new(0.0, 1e-5, 0.0),
        linear_m_s: Vector::ZERO,
        angular_rad_s: Vector::ZERO,
        shape: PieceShape { hulls }.shared_shape(),
        dust: false,
    }
}

#[test]
fn a_curved_shard_on_a_compound_of_hulls_comes_to_rest() {
    // tipped by 6 degrees, a shard drawn as 24 hulls along its arc settles on its back; with
    // rapier's contact clustering (now off) the four points it kept jumped from hull to hull
    // and fed the rocking: still 1.3 rad/s after 3 s
    let settings =
        WorldSettings { rolling_damping_per_s: 4.0, sleep_speed_m_s: 0.02, sleep_after_s: 0.2, ..settings() };
    let mut world = RigidWorld::new(&settings, Some(0.0), &[], &[curved_shard(0.1, 24)]);
    run_until(&mut world, 1.0);
    assert!(world.all_asleep(), "the shard should rest: {:?}", world.velocities());
    let tilt = world.poses()[0].0.angle_between(Rotation::IDENTITY);
    assert!(tilt < 0.11, "rests tipped by {tilt} rad");
}

#[test]
fn rolling_resistance_damps_spin_on_contact_only() {
    // a shard spinning in free fall keeps its spin; a cylinder rolling on the floor slows
    // down with rolling resistance and hardly without
    let spin = Vector::new(0.0, 0.0, 3.0);
    let mut flying = curved_shard(0.0, 1);
    flying.angular_rad_s = spin;
    flying.translation_m += Vector::new(0.0, 1.0, 0.0);
    let damped = WorldSettings { rolling_damping_per_s: 4.0, ..settings() };
    let mut world = RigidWorld::new(&damped, Some(0.0), &[], &[flying]);
    world.advance(0.25, 1.0 / 960.0);
    let kept = world.velocities()[0].1.length() / spin.length();
    assert!((kept - 1.0).abs() < 1e-3, "in flight the spin changed by a factor {kept}");
    // a 64-sided cylinder rolling along the floor at 0.5 m/s
    let rolled = |damping: f64| {
        let (radius, half_length) = (0.02, 0.02);
        let points: Vec<Vector> = (0..64)
            .flat_map(|k| {
                let angle = std::f64::consts::TAU * k as f64 / 64.0;
                [-half_length, half_length].map(|z| Vector::new(radius * angle.cos(), radius * angle.sin(), z))
            })
            .collect();
        let cylinder = rolling_on_the_floor(&points, radius, 0.5);
        let settings = WorldSettings { rolling_damping_per_s: damping, sleep_speed_m_s: -1.0, ..settings() };
        let mut world = RigidWorld::new(&settings, Some(0.0), &[], &[cylinder]);
        run_until(&mut world, 0.5);
        world.velocities()[0].0.length()
    };
    let (free, resisted) = (rolled(0.0), rolled(4.0));
    // a rolling cylinder's spin damped at 4/s slows it at 4 I / (I + m r^2) = 4/3 per second:
    // e^(-0.6) = 0.55 of the free roll's speed (which facets slow to 0.36 m/s) after 0.46 s
    assert!(
        free > 0.3 && resisted < 0.6 * free && resisted > 0.45 * free,
        "rolling at {resisted} m/s with rolling resistance, {free} m/s without"
    );
}

#[test]
fn a_piece_flung_out_through_the_side_is_retired_where_it_lands() {
    // a flat chip thrown out of the 1 m region's side at 5 m/s, 0.3 m up: it flies on (a piece
    // retired in flight would hang in the air, in view) and is retired once it lands, 1.85 m out
    let half = Vector::new(0.02, 0.003, 0.02);
    let thrown = box_piece(Vector::ZERO, half, Vector::new(0.0, 0.3, 0.0), Vector::new(5.0, 1.0, 0.0), 2200.0);
    let bounds = Some([[-1.0, -1.0, -1.0], [1.0, 3.0, 1.0]]);
    let mut world = RigidWorld::new(&WorldSettings { bounds_m: bounds, ..settings() }, Some(0.0), &[], &[thrown]);
    run_until(&mut world, 0.25);
    assert_eq!(world.retired_pieces(), 0, "retired in flight at {:?}", world.centres()[0]);
    assert!(world.centres()[0].x > 1.0);
    run_until(&mut world, 0.75);
    assert_eq!(world.retired_pieces(), 1, "not retired at {:?}", world.centres()[0]);
    let at = world.centres()[0];
    assert!(at.y < 0.01 && at.x > 1.8 && at.x < 3.0, "retired at {at:?}, not on the floor where it landed");
}

#[test]
fn dust_flying_out_and_a_piece_far_out_are_retired_in_flight() {
    // thrown up and out of the 2 m wide region at 30 m/s: a grain of dust is retired once it
    // flies out through the side, a chip once it is farther beyond it than the region is wide
    let bounds = Some([[-1.0, -1.0, -1.0], [1.0, 3.0, 1.0]]);
    let settings = WorldSettings { bounds_m: bounds, ..settings() };
    let throw = |half: Vector, dust: bool| {
        let mut piece = box_piece(Vector::ZERO, half, Vector::new(0.0, 0.01, 0.0), Vector::new(30.0, 8.0, 0.0), 2200.0);
        piece.dust = dust;
        RigidWorld::new(&settings, Some(0.0), &[], &[piece])
    };
    let mut grain = throw(Vector::splat(0.001), true);
    run_until(&mut grain, 1.0 / 24.0);
    assert_eq!(grain.retired_pieces(), 1, "{:?}", grain.centres()[0]);
    let mut chip = throw(Vector::new(0.02, 0.003, 0.02), false);
    run_until(&mut chip, 1.0 / 24.0);
    assert_eq!(chip.retired_pieces(), 0, "a chip just past the side flies on: {:?}", chip.centres()[0]);
    run_until(&mut chip, 3.0 / 24.0);
    let at = chip.centres()[0];
    assert_eq!(chip.retired_pieces(), 1, "{at:?}");
    assert!(at.x > 3.0 && at.x < 3.0 + 30.0 / 24.0 && at.y > 0.1, "retired at {at:?}");
}

#[test]
fn a_fast_grain_does_not_sink_into_the_floor() {
    // a 4 mm grain flung at the floor at 6 m/s, as dust and as a piece: it rests on the floor,
    // not in it
    for dust in [false, true] {
        let half = Vector::splat(0.002);
        let velocity = Vector::new(1.0, -6.0, 0.5);
        let mut piece = box_piece(Vector::ZERO, half, Vector::new(0.0, 0.05, 0.0), velocity, 2500.0);
        piece.dust = dust;
        let mut world = RigidWorld::new(&settings(), Some(0.0), &[], &[piece]);
        let mut deepest: f64 = 0.0;
        for _ in 0..48 {
            world.advance(1.0 / 24.0, 1.0 / 960.0);
            deepest = deepest.max(world.deepest_penetration_m());
        }
        let centre = world.centres()[0];
        assert!(deepest < 5e-4, "dust {dust}: {deepest} m into the floor");
        assert!(centre.y > half.y - 5e-4, "dust {dust}: rests at {} m", centre.y);
    }
}

/// A prism over a regular `sides`-gon (a Voronoi cell's faces have up to eight corners), its
/// rest frame centred on it, dropped from `height_m` tilted by `tilt_rad` about x and z.
fn prism(sides: usize, height_m: f64, tilt_rad: f64) -> (PieceBody, Vec<Vector>) {
    let (radius, half_height) = (0.006, 0.003);
    let corners: Vec<Vector> = (0..sides)
        .flat_map(|k| {
            let angle = std::f64::consts::TAU * k as f64 / sides as f64;
            [-half_height, half_height].map(|y| Vector::new(radius * angle.cos(), y, radius * angle.sin()))
        })
        .collect();
    let mass = hull_mass(&corners);
    let piece = PieceBody {
        mass,
        rotation: Rotation::from_rotation_x(tilt_rad) * Rotation::from_rotation_z(0.5 * tilt_rad),
        translation_m: Vector::new(0.0, height_m, 0.0),
        linear_m_s: Vector::new(0.2, 0.0, 0.0),
        angular_rad_s: Vector::ZERO,
        shape: PieceShape { hulls: vec![corners.clone()] }.shared_shape(),
        dust: false,
    };
    (piece, corners)
}

#[test]
fn an_octagonal_cell_rests_on_the_floor_not_in_it() {
    // parry's own plane contact takes at most four corners of the face most facing the plane:
    // Voronoi cells of dust sank 1.7 mm into the floor. Ours takes every corner near the plane.
    for (dust, tilt) in [(true, 0.0), (true, 0.3), (true, 1.2), (false, 0.3)] {
        let (mut piece, corners) = prism(8, 0.02, tilt);
        piece.dust = dust;
        let mut world = RigidWorld::new(&settings(), Some(0.0), &[], &[piece]);
        let mut deepest: f64 = 0.0;
        for _ in 0..48 {
            world.advance(1.0 / 24.0, 1.0 / 960.0);
            let (rotation, translation) = world.poses()[0];
            let lowest = corners.iter().map(|&c| (rotation * c + translation).y).fold(f64::INFINITY, f64::min);
            deepest = deepest.max(-lowest);
        }
        assert!(deepest < 2e-4, "dust {dust}, tilt {tilt}: a corner went {deepest} m into the floor");
        let (rotation, translation) = world.poses()[0];
        let lowest = corners.iter().map(|&c| (rotation * c + translation).y).fold(f64::INFINITY, f64::min);
        assert!(lowest < 2e-4, "dust {dust}, tilt {tilt}: floats {lowest} m above the floor");
        assert!(world.all_asleep(), "dust {dust}, tilt {tilt}: still moving {:?}", world.velocities());
    }
}

#[test]
fn rolling_resistance_stops_a_roll_in_finite_time() {
    // a ball of 400 corners rolling at 0.1 m/s: without resistance it rolls on; with the
    // constant part alone (no rate) its rim slows by 0.2 m/s^2, and the ball's speed by 2/7 of
    // that (I / (I + m r^2)): it stops after about 1.75 s, in finite time, where a rate alone
    // would only slow it by a constant factor per second
    let radius = 0.02;
    let points: Vec<Vector> = (0..400)
        .map(|k| {
            let y = 1.0 - 2.0 * (k as f64 + 0.5) / 400.0;
            let angle = k as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
            let r = (1.0 - y * y).sqrt();
            radius * Vector::new(r * angle.cos(), y, r * angle.sin())
        })
        .collect();
    let speeds = |resistance: f64| {
        let ball = rolling_on_the_floor(&points, radius, 0.1);
        let settings = WorldSettings { rolling_resistance_m_s2: resistance, sleep_speed_m_s: -1.0, ..settings() };
        let mut world = RigidWorld::new(&settings, Some(0.0), &[], &[ball]);
        // its speed every quarter second for 2.5 s
        (0..10)
            .map(|_| {
                run_until(&mut world, 0.25);
                world.velocities()[0].0.length()
            })
            .collect::<Vec<f64>>()
    };
    let (free, resisted) = (speeds(0.0), speeds(0.2));
    // the facets slow the free roll too, to 0.023 m/s after 2.5 s
    assert!(free[9] > 0.015, "without resistance the ball should roll on: {free:?}");
    assert!(resisted[7..].iter().all(|&v| v < 1e-6), "with resistance the ball should stop by 2 s: {resisted:?}");
}
