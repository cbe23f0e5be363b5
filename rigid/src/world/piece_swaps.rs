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
