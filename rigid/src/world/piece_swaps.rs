//! Pieces leaving and joining the world mid-shot: a piece that goes back to the simulation is
//! withdrawn (held where it is, out of the simulation), and the pieces it breaks into come back
//! in its place and after the last piece.

use rapier3d_f64::prelude::RigidBodyHandle;

use super::{PieceBody, RestWatch, RigidWorld, WorldSettings, insert_piece};

impl RigidWorld {
    /// Takes `piece` out of the simulation: its body is held where it is until
    /// [`RigidWorld::replace_piece`] puts what it became in its place.
    pub fn withdraw_piece(&mut self, piece: usize) {
        self.world.bodies[self.pieces[piece]].set_enabled(false);
        self.watch[piece].retired = true;
    }

    /// Puts `body` in the place of piece `piece` (a withdrawn one), as a new body.
    pub fn replace_piece(&mut self, settings: &WorldSettings, piece: usize, body: &PieceBody) {
        self.world.remove_body(self.pieces[piece]);
        let handle = self.insert_now(settings, body);
        self.pieces[piece] = handle;
        self.watch[piece] = RestWatch::new(&self.world.bodies[handle], body);
        // the pieces come back as neighbours a moment ago one body: their overlaps at the next
        // step become allowances, as at the handoff
        self.rules.at_handoff = true;
    }

    /// Adds `body` as a new piece after the last; returns its index.
    pub fn add_piece(&mut self, settings: &WorldSettings, body: &PieceBody) -> usize {
        let handle = self.insert_now(settings, body);
        self.pieces.push(handle);
        self.watch.push(RestWatch::new(&self.world.bodies[handle], body));
        self.rules.at_handoff = true;
        self.pieces.len() - 1
    }

    /// Inserts `body` with its mass properties in force at once: rapier otherwise computes a new
    /// body's centre of mass in the world at its next step, and a piece that goes back to the
    /// simulation before one would leave with its pose's origin for its centre (and a velocity
    /// field about the wrong point).
    fn insert_now(&mut self, settings: &WorldSettings, body: &PieceBody) -> RigidBodyHandle {
        let handle = insert_piece(&mut self.world, settings, body);
        let colliders = &self.world.colliders;
        self.world.bodies[handle].recompute_mass_properties_from_colliders(colliders);
        handle
    }

    /// How many pieces the world holds (withdrawn and retired ones too).
    pub fn piece_count(&self) -> usize {
        self.pieces.len()
    }
}

#[cfg(test)]
mod tests {
    use rapier3d_f64::prelude::*;

    use shatter_core::config::RigidConfig;

    use super::*;
    use crate::mass::MassProps;

    fn settings() -> WorldSettings {
        WorldSettings::of(&RigidConfig::default(), [0.0, -9.81, 0.0], 0.01)
    }

    /// A 2 cm cube piece whose centre of mass is `centre_m` in its rest frame, posed at `pose`.
    fn cube(centre_m: Vector, rotation: Rotation, translation_m: Vector) -> PieceBody {
        let second = Matrix::from_diagonal(Vector::splat(0.1 * 0.01 * 0.01 / 3.0));
        PieceBody {
            mass: MassProps { mass_kg: 0.1, centre_m, second_moment: second },
            rotation,
            translation_m,
            linear_m_s: Vector::new(0.0, -2.0, 0.0),
            angular_rad_s: Vector::new(0.0, 0.0, 5.0),
            shape: Some(SharedShape::cuboid(0.01, 0.01, 0.01)),
            dust: false,
        }
    }

    #[test]
    fn a_piece_put_back_has_its_centre_of_mass_before_any_step() {
        let settings = settings();
        let first = cube(Vector::new(0.0, 0.3, 0.0), Rotation::IDENTITY, Vector::ZERO);
        let mut world = RigidWorld::new(&settings, Some(0.0), &[], &[first]);
        world.advance(0.01, 1.0 / 960.0);
        world.withdraw_piece(0);
        let rotation = Rotation::from_rotation_z(0.5);
        let (centre, translation) = (Vector::new(0.05, 0.2, 0.0), Vector::new(0.1, 0.05, 0.0));
        world.replace_piece(&settings, 0, &cube(centre, rotation, translation));
        let added = world.add_piece(&settings, &cube(centre, rotation, translation + Vector::X));
        assert_eq!(added, 1);
        let centres = world.centres();
        assert!((centres[0] - (rotation * centre + translation)).length() < 1e-12, "{:?}", centres[0]);
        assert!((centres[1] - (rotation * centre + translation + Vector::X)).length() < 1e-12);
        assert_eq!(world.piece_count(), 2);
    }
}
