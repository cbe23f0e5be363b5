//! The USD of a shot with a follow-through, `rigid/shot.usda`: every frame of the shot, from
//! the lead-in's first to the follow-through's last, one mesh per piece of the follow-through
//! (its rigid bodies: the handoff's, or the parts a re-entry broke them into), each with the
//! transform of the fragment that holds it in each frame's fragments file (so a part moves with
//! the piece it broke from until it breaks off), so a DCC reads the follow-through exactly as the simulated
//! frames; with post's debris points at the simulated frames (and a re-entry's at the frame its
//! pieces come back by) and each frame's physical time. A piece that broke again is drawn whole
//! in the follow-through's frames before it broke, its parts hidden then.

use std::collections::BTreeMap;
use std::ops::Range;

use shatter_core::debris_points::{DebrisFrame, read_point_cache};
use shatter_core::fragments::FragmentFrame;
use shatter_core::layout::missing_input;
use shatter_core::shot::{Shot, Source};
use shatter_core::sim_frames::SimFrames;
use shatter_core::surfaces::piece_surfaces;
use shatter_core::usd::{PieceTransform, UsdShot, WholeMesh, element_of_pieces, write_usda};
use shatter_core::{OutputLayout, ParticleSet, PipelineConfig};

use crate::reentries::Reentries;
use crate::rigid_driver::RigidError;

/// Writes `layout.rigid_usd()` for the finished follow-through whose pieces at its end are
/// `last`'s.
pub(crate) fn write_shot_usd(
    config: &PipelineConfig,
    layout: &OutputLayout,
    particles: &ParticleSet,
    last: &FragmentFrame,
    sim_frames: &SimFrames,
    reentries: Option<&Reentries>,
) -> Result<(), RigidError> {
    let shot = Shot::of(config, layout).map_err(RigidError::Input)?;
    let pieces = last.fragment_count();
    let meshes = piece_surfaces(particles, &last.fragment_of, pieces);
    let elements = element_of_pieces(&last.fragment_of, pieces);
    let mut transforms = Vec::with_capacity(shot.last as usize);
    let mut debris = Vec::with_capacity(shot.last as usize);
    // physical m/s to metres per playback second at the simulated frames (the others emit none)
    let mut speed = Vec::with_capacity(shot.last as usize);
    let mut times = Vec::with_capacity(shot.last as usize);
    let mut previous_time_s = f64::NEG_INFINITY;
    let mut splits = Splits::new(last, &elements);
    for frame in 1..=shot.last {
        let path = shot.fragments(layout, frame);
        if let Some(message) = missing_input(&path, shot.locate(frame).0.command()) {
            return Err(RigidError::Input(message));
        }
        let fragments = FragmentFrame::read(&path)?;
        let time_s = std::mem::replace(&mut previous_time_s, fragments.meta.time_s);
        times.push(shot.time_s(frame, fragments.meta.time_s));
        transforms.push(PieceTransform::of_pieces(&fragments, &elements));
        let none = DebrisFrame { frame, ..DebrisFrame::default() };
        match shot.locate(frame) {
            (Source::Post, local) => {
                let path = layout.debris_points(local);
                debris.push(if path.is_file() { read_point_cache(&path)? } else { none });
                speed.push(sim_frames.speed[local as usize - 1]);
            }
            (Source::Rigid, _) => {
                splits.add(frame as usize - 1, &fragments, particles);
                // the debris of the re-entries whose pieces came back since the frame before
                let mut points = none;
                if let Some(reentries) = reentries {
                    reentries.debris_between(time_s, fragments.meta.time_s, &mut points)?;
                }
                debris.push(points);
                speed.push(1.0);
            }
            _ => {
                debris.push(none);
                speed.push(1.0);
            }
        }
    }
    let path = layout.rigid_usd();
    let (hidden, wholes) = splits.finish();
    let usd = UsdShot {
        meshes: &meshes,
        hidden: &hidden,
        wholes: &wholes,
        transforms: &transforms,
        first_frame: 1,
        fps: config.scene.frames_per_second,
        debris: &debris,
        width_m: 0.5 * particles.meta.lambda_m,
        velocity_scale: &speed,
        physical_time_s: Some(&times),
    };
    write_usda(&path, &usd).map_err(|source| RigidError::Usd { path, source })
}

/// The pieces of the follow-through's frames that broke again later: each drawn whole (a mesh of
/// its own) at the frames it is one fragment, the last frame's pieces inside it hidden then.
struct Splits<'a> {
    last: &'a FragmentFrame,
    element_of_piece: &'a [u32],
    /// Per piece of the last frame, the frames it is inside a larger fragment.
    hidden: Vec<Range<usize>>,
    /// The wholes seen so far, by piece and element count (a piece only loses elements).
    wholes: BTreeMap<(usize, u32), WholeMesh>,
}

impl<'a> Splits<'a> {
    fn new(last: &'a FragmentFrame, element_of_piece: &'a [u32]) -> Self {
        Splits { last, element_of_piece, hidden: vec![0..0; element_of_piece.len()], wholes: BTreeMap::new() }
    }

    /// Takes the follow-through's frame at index `index` (from 0), `fragments`.
    fn add(&mut self, index: usize, fragments: &FragmentFrame, particles: &ParticleSet) {
        for (piece, &element) in self.element_of_piece.iter().enumerate() {
            let holder = fragments.fragment_of[element as usize] as usize;
            if fragments.elements[holder] == self.last.elements[piece] {
                continue;
            }
            let hidden = &mut self.hidden[piece];
            *hidden = if hidden.start == hidden.end { index..index + 1 } else { hidden.start..index + 1 };
            let key = (holder, fragments.elements[holder]);
            if let Some(whole) = self.wholes.get_mut(&key) {
                whole.shown.end = index + 1;
                continue;
            }
            let inside: Vec<u32> = fragments.fragment_of.iter().map(|&f| u32::from(f as usize != holder)).collect();
            let mesh = piece_surfaces(particles, &inside, 2).swap_remove(0);
            self.wholes.insert(key, WholeMesh { piece: holder, mesh, shown: index..index + 1 });
        }
    }

    /// The pieces' hidden frames and the wholes, by piece and then as they broke.
    fn finish(self) -> (Vec<Range<usize>>, Vec<WholeMesh>) {
        let mut wholes: Vec<WholeMesh> = self.wholes.into_values().collect();
        wholes.sort_by_key(|whole| (whole.piece, whole.shown.start));
        (self.hidden, wholes)
    }
}
