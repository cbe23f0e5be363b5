//! The halves of velocity Verlet (the paper's position and velocity updates): the opening kick
//! and drift, the closing kick with the floor's bounce, and the two fused.

use crate::model::Floor;

/// Half a velocity kick: v + dt/2 F/m.
#[inline(always)]
fn half_kick(v: f32, half_dt: f32, force: f32, inverse_mass: f32) -> f32 {
    v + half_dt * force * inverse_mass
}

/// A vertical velocity `v` at `height`: reflected and scaled by the restitution where the
/// particle is below the floor and moves down.
#[inline(always)]
fn bounce(v: f32, height: f32, floor: Option<Floor>) -> f32 {
    match floor {
        Some(floor) if height < floor.height_m && v < 0.0 => v * -floor.restitution,
        _ => v,
    }
}

/// Position update (first half of velocity Verlet): v += dt/2 F/m, then u += dt v.
pub fn kick_drift(dt: f32, inverse_mass: &[f32], force: [&[f32]; 3], velocity: [&mut [f32]; 3], disp: [&mut [f32]; 3]) {
    let half = 0.5 * dt;
    for (axis, (v, u)) in velocity.into_iter().zip(disp).enumerate() {
        for i in 0..v.len() {
            v[i] = half_kick(v[i], half, force[axis][i], inverse_mass[i]);
            u[i] += dt * v[i];
        }
    }
}

/// Velocity update (second half of velocity Verlet): v += dt/2 F/m; a particle below the floor
/// that moves down has its vertical velocity reflected and scaled by the restitution.
pub fn kick_floor(
    dt: f32,
    inverse_mass: &[f32],
    force: [&[f32]; 3],
    height: (&[f32], &[f32]),
    floor: Option<Floor>,
    velocity: [&mut [f32]; 3],
) {
    let half = 0.5 * dt;
    for (axis, v) in velocity.into_iter().enumerate() {
        for i in 0..v.len() {
            v[i] = half_kick(v[i], half, force[axis][i], inverse_mass[i]);
            if axis == 1 {
                v[i] = bounce(v[i], height.0[i] + height.1[i], floor);
            }
        }
    }
}

/// [`kick_floor`] of one step, then [`kick_drift`] of the next (the forces are the same), in
/// one pass over the particles: the two passes' operations in their order, particle by particle.
/// The floor test reads the height before the drift, as `kick_floor` does; `rest_y` is the rest
/// height.
pub fn kick_floor_drift(
    dt: f32,
    inverse_mass: &[f32],
    force: [&[f32]; 3],
    rest_y: &[f32],
    floor: Option<Floor>,
    velocity: [&mut [f32]; 3],
    disp: [&mut [f32]; 3],
) {
    let half = 0.5 * dt;
    for (axis, (v, u)) in velocity.into_iter().zip(disp).enumerate() {
        for i in 0..v.len() {
            let mut kicked = half_kick(v[i], half, force[axis][i], inverse_mass[i]);
            if axis == 1 {
                kicked = bounce(kicked, rest_y[i] + u[i], floor);
            }
            v[i] = half_kick(kicked, half, force[axis][i], inverse_mass[i]);
            u[i] += dt * v[i];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fused_kick_is_the_closing_kick_then_the_opening_one_to_the_bit() {
        let mut rng = shatter_core::random::SplitMix64::new(11);
        let n = 257;
        let mut values = |scale: f64| -> Vec<f32> { (0..n).map(|_| ((rng.next_f64() - 0.5) * scale) as f32).collect() };
        let inverse_mass: Vec<f32> = values(2.0).iter().map(|m| 1e3 * (1.5 + m)).collect();
        let force = [values(1e-2), values(1e-2), values(1e-2)];
        let rest_y = values(2e-3);
        let (velocity, disp) = ([values(4.0), values(4.0), values(4.0)], [values(1e-3), values(1e-3), values(1e-3)]);
        let force = [&force[0][..], &force[1][..], &force[2][..]];
        for floor in [None, Some(Floor { height_m: 0.0, restitution: 0.5 })] {
            let dt = 1e-4;
            let (mut v, mut u) = (velocity.clone(), disp.clone());
            let [vx, vy, vz] = &mut v;
            let [ux, uy, uz] = &mut u;
            kick_floor(dt, &inverse_mass, force, (&rest_y, uy), floor, [vx, vy, vz]);
            kick_drift(dt, &inverse_mass, force, [vx, vy, vz], [ux, uy, uz]);
            let (mut fused_v, mut fused_u) = (velocity.clone(), disp.clone());
            let [fvx, fvy, fvz] = &mut fused_v;
            let [fux, fuy, fuz] = &mut fused_u;
            kick_floor_drift(dt, &inverse_mass, force, &rest_y, floor, [fvx, fvy, fvz], [fux, fuy, fuz]);
            for axis in 0..3 {
                let bits = |values: &[f32]| values.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
                assert_eq!(bits(&fused_v[axis]), bits(&v[axis]), "velocity, axis {axis}, floor {floor:?}");
                assert_eq!(bits(&fused_u[axis]), bits(&u[axis]), "displacement, axis {axis}, floor {floor:?}");
            }
        }
        // some particles bounced
        let below = (0..n).filter(|&i| rest_y[i] + disp[1][i] < 0.0 && velocity[1][i] < 0.0).count();
        assert!(below > 10, "{below}");
    }
}
