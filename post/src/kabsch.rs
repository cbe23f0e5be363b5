//! The rigid motion of a fragment: the mass-weighted least-squares rotation and translation
//! taking its rest positions to its current ones (Kabsch / Procrustes), always a proper rotation.
//!
//! We use Horn's quaternion form (1987): the best rotation is the eigenvector of the largest
//! eigenvalue of a symmetric 4 x 4 matrix built from the weighted cross-covariance, found here by
//! Jacobi rotations. It yields a unit quaternion directly (no reflection case, no SVD). When the
//! best rotation is not unique (one particle, two particles, a straight line of particles), the
//! top eigenvalue repeats; we then pick, within its eigenspace, the rotation closest to a given
//! previous one, so a fragment does not spin arbitrarily from frame to frame.

// Matrix code indexes rows and columns explicitly.
#![allow(clippy::needless_range_loop)]

use glam::{DQuat, DVec3};

/// A rigid motion x = R X + t.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidMotion {
    /// Rotation.
    pub rotation: DQuat,
    /// Translation.
    pub translation: DVec3,
}

/// Accumulates weighted point pairs (rest X, current x) of one fragment.
#[derive(Debug, Clone, Copy, Default)]
pub struct Accumulator {
    weight: f64,
    rest_sum: DVec3,
    current_sum: DVec3,
    /// Sum of w X x^T, row-major.
    cross: [[f64; 3]; 3],
}

impl Accumulator {
    /// Adds a pair with weight `w`. The caller should pass positions relative to a reference
    /// point near the fragment (e.g. one of its particles) to keep the sums well conditioned.
    pub fn add(&mut self, w: f64, rest: DVec3, current: DVec3) {
        self.weight += w;
        self.rest_sum += w * rest;
        self.current_sum += w * current;
        for (a, row) in self.cross.iter_mut().enumerate() {
            for (b, value) in row.iter_mut().enumerate() {
                *value += w * rest[a] * current[b];
            }
        }
    }

    /// The best rigid motion (in the coordinates the pairs were given in), preferring `previous`
    /// among equally good rotations.
    pub fn solve(&self, previous: DQuat) -> RigidMotion {
        let w = self.weight;
        let rest_centre = self.rest_sum / w;
        let current_centre = self.current_sum / w;
        // Centred cross-covariance S = sum w (X - Xc)(x - xc)^T = sum w X x^T - w Xc xc^T.
        let mut s = [[0.0f64; 3]; 3];
        for a in 0..3 {
            for b in 0..3 {
                s[a][b] = self.cross[a][b] - w * rest_centre[a] * current_centre[b];
            }
        }
        let rotation = best_rotation(&s, previous);
        RigidMotion { rotation, translation: current_centre - rotation * rest_centre }
    }
}

/// The unit quaternion maximising sum w (x - xc) . R (X - Xc) for cross-covariance `s`.
fn best_rotation(s: &[[f64; 3]; 3], previous: DQuat) -> DQuat {
    let [[sxx, sxy, sxz], [syx, syy, syz], [szx, szy, szz]] = *s;
    // Horn's matrix, quaternion order (w, x, y, z).
    let n = [
        [sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
        [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
        [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
        [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz],
    ];
    let (values, vectors) = symmetric_eigen4(n);
    let top = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let scale = values.iter().map(|v| v.abs()).fold(0.0, f64::max);
    let tolerance = 1e-9 * scale + 1e-300;
    // Project the previous rotation (sign chosen to be nearest) onto the top eigenspace.
    let prev = [previous.w, previous.x, previous.y, previous.z];
    let mut projected = [0.0f64; 4];
    let mut any = None;
    for k in 0..4 {
        if values[k] >= top - tolerance {
            let v = [vectors[0][k], vectors[1][k], vectors[2][k], vectors[3][k]];
            any.get_or_insert(v);
            let dot: f64 = (0..4).map(|c| v[c] * prev[c]).sum();
            for c in 0..4 {
                projected[c] += dot * v[c];
            }
        }
    }
    let norm = projected.iter().map(|c| c * c).sum::<f64>().sqrt();
    let q = if norm > 1e-6 { projected.map(|c| c / norm) } else { any.unwrap_or([1.0, 0.0, 0.0, 0.0]) };
    let rotation = DQuat::from_xyzw(q[1], q[2], q[3], q[0]).normalize();
    // q and -q are the same rotation: keep the one nearest the previous for smooth sampling.
    if rotation.dot(previous) < 0.0 { -rotation } else { rotation }
}

/// Eigenvalues and eigenvectors (columns) of a symmetric 4 x 4 matrix by cyclic Jacobi rotations.
fn symmetric_eigen4(mut a: [[f64; 4]; 4]) -> ([f64; 4], [[f64; 4]; 4]) {
    let mut v = [[0.0f64; 4]; 4];
    for (k, row) in v.iter_mut().enumerate() {
        row[k] = 1.0;
    }
    for _sweep in 0..64 {
        let off: f64 = (0..4).flat_map(|p| (p + 1..4).map(move |q| (p, q))).map(|(p, q)| a[p][q] * a[p][q]).sum();
        let diagonal: f64 = (0..4).map(|p| a[p][p] * a[p][p]).sum();
        if off <= 1e-30 * diagonal || off == 0.0 {
            break;
        }
        for p in 0..4 {
            for q in p + 1..4 {
                if a[p][q] == 0.0 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..4 {
                    let (akp, akq) = (a[k][p], a[k][q]);
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for k in 0..4 {
                    let (apk, aqk) = (a[p][k], a[q][k]);
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
                for row in v.iter_mut() {
                    let (vkp, vkq) = (row[p], row[q]);
                    row[p] = c * vkp - s * vkq;
                    row[q] = s * vkp + c * vkq;
                }
            }
        }
    }
    ([a[0][0], a[1][1], a[2][2], a[3][3]], v)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn random(seed: u64) -> impl FnMut() -> f64 {
        let mut rng = shatter_core::random::SplitMix64::new(seed);
        move || 2.0 * rng.next_f64() - 1.0
    }

    fn recover(points: &[DVec3], weights: &[f64], motion: RigidMotion, previous: DQuat) -> RigidMotion {
        let mut acc = Accumulator::default();
        for (p, w) in points.iter().zip(weights) {
            acc.add(*w, *p, motion.rotation * *p + motion.translation);
        }
        acc.solve(previous)
    }

    #[test]
    fn random_rigid_motions_are_recovered() {
        let mut r = random(3);
        for trial in 0..200 {
            let count = 3 + trial % 40;
            let points: Vec<DVec3> = (0..count).map(|_| DVec3::new(r(), r(), r())).collect();
            let weights: Vec<f64> = (0..count).map(|_| 1.0 + r().abs()).collect();
            let axis = DVec3::new(r(), r(), r()).normalize();
            let rotation = DQuat::from_axis_angle(axis, 3.0 * r());
            let motion = RigidMotion { rotation, translation: DVec3::new(r(), r(), r()) * 10.0 };
            let found = recover(&points, &weights, motion, DQuat::IDENTITY);
            assert!(found.rotation.dot(rotation).abs() > 1.0 - 1e-12, "trial {trial}");
            assert!((found.translation - motion.translation).length() < 1e-9, "trial {trial}");
        }
    }

    #[test]
    fn a_half_turn_is_found() {
        let points = [DVec3::X, DVec3::Y, DVec3::Z, DVec3::ONE];
        let rotation = DQuat::from_rotation_z(std::f64::consts::PI);
        let motion = RigidMotion { rotation, translation: DVec3::ZERO };
        let found = recover(&points, &[1.0; 4], motion, DQuat::IDENTITY);
        assert!(found.rotation.dot(rotation).abs() > 1.0 - 1e-12);
    }

    #[test]
    fn one_and_two_particles_keep_the_previous_rotation_where_free() {
        let previous = DQuat::from_rotation_x(0.3);
        // one particle: any rotation fits; the previous one is kept, the translation follows
        let lone = recover(
            &[DVec3::new(1.0, 2.0, 3.0)],
            &[2.0],
            RigidMotion { rotation: DQuat::IDENTITY, translation: DVec3::X },
            previous,
        );
        assert!(lone.rotation.dot(previous).abs() > 1.0 - 1e-12);
        assert!(
            (lone.rotation * DVec3::new(1.0, 2.0, 3.0) + lone.translation - DVec3::new(2.0, 2.0, 3.0)).length() < 1e-12
        );
        // two particles along x, rotated about z: the pair's direction is matched exactly, and the
        // spin about the pair's axis is the one nearest the previous rotation
        let pair = [DVec3::ZERO, DVec3::X];
        let rotation = DQuat::from_rotation_z(0.7);
        let found = recover(&pair, &[1.0, 1.0], RigidMotion { rotation, translation: DVec3::Y }, DQuat::IDENTITY);
        assert!((found.rotation * DVec3::X - rotation * DVec3::X).length() < 1e-12);
        assert!(found.rotation.dot(rotation).abs() > 1.0 - 1e-12, "no spurious spin about the axis");
    }
}
