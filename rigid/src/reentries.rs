//! Pieces that break again (`[rigid.secondary_fracture]`): the follow-through watches the
//! contacts of every piece of at least `min_elements` elements; at a hard one (see
//! [`crate::world::critical_speed_m_s`]) it steps back to the step before, takes the piece (or
//! the two pieces that met) out of the rigid world and writes it as a re-entry for the
//! simulation: `rigid/reentry.###.shp`, the pieces' particles and intact bonds as a particle file
//! of their own and their rigid motions as a lead-in handoff, both in `reentry/###/`. Once the
//! simulation and post have run there ([`shatter_core::reentry::pass_config`]), the handoff rule
//! picks the re-entry's end, and the pieces it broke into come back as rigid bodies at that time:
//! the largest part of each keeps its id, the others take new ids after the last. The other
//! pieces fly on meanwhile.

use std::collections::BTreeMap;

use rapier3d_f64::math::{Rotation, Vector};
use serde::{Deserialize, Serialize};
use shatter_core::config::{RigidConfig, SecondaryFractureConfig};
use shatter_core::debris_points::{DebrisFrame, read_point_cache};
use shatter_core::fragments::{AFFINE_RIGID, FragmentFrame};
use shatter_core::frames::{BreakLog, PointFrame};
use shatter_core::lead_in::LeadIn;
use shatter_core::reentry::{Reentry, ReentryMeta, pass_config};
use shatter_core::sim_frames::SimFrames;
use shatter_core::{OutputLayout, ParticleSet, PipelineConfig, digest};

use crate::hand_over::{Balance, MemberMotion, PieceMaker, conservation, vectors};
use crate::handoff::members_of_pieces;
use crate::rigid_driver::{Conservation, RigidError, choose_handoff, read_fragments, world_settings};
use crate::world::{Impact, ImpactWatch, RigidWorld, Struck, WorldSettings, critical_speed_m_s};

mod approach;
mod plastic;
mod start_file;

use approach::{Approach, BodyState};
use plastic::{Handoff, PlasticReturn, PlasticState};
use start_file::StartFiles;

/// What the follow-through keeps of its re-entries between runs (in its checkpoint).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReentryState {
    /// The rigid world's time, seconds since the simulation's start.
    pub time_s: f64,
    /// Re-entries started.
    pub started: u32,
    /// Started and not yet back, in the order they started.
    pub active: Vec<u32>,
    /// Back, in the order they came back.
    pub returned: Vec<u32>,
}

/// What a re-entry's return did.
#[derive(Debug, Clone, PartialEq)]
pub struct ReentryReport {
    /// Its number.
    pub number: u32,
    /// The pieces that went back.
    pub pieces_in: Vec<u32>,
    /// What the first hit.
    pub hit: String,
    /// The approach speed and the threshold it passed, m/s.
    pub impact_speed_m_s: f64,
    /// The threshold, m/s.
    pub threshold_m_s: f64,
    /// When it went back and when its pieces came back, seconds since the simulation's start.
    pub start_time_s: f64,
    /// When its pieces came back.
    pub return_time_s: f64,
    /// The pieces it came back as.
    pub pieces: usize,
    /// The return's handoff bookkeeping.
    pub conservation: Conservation,
}

/// A re-entry's simulation, read back from its folder.
struct Outcome {
    reentry: Reentry,
    /// Its fragments at its handoff (ids local to the re-entry).
    handoff: FragmentFrame,
    /// Its particles' positions and velocities there.
    position_m: Vec<Vector>,
    velocity_m_s: Vec<Vector>,
    /// When its pieces come back, seconds since the simulation's start.
    return_time_s: f64,
    /// The bonds it broke, as canonical entries of the shot's particle file.
    broken: Vec<usize>,
    /// Its pieces' plastic state, for the elastoplastic model.
    plastic: Option<PlasticReturn>,
    /// Its folder's layout and each of its frames' time since its start, up to the handoff.
    layout: OutputLayout,
    frame_times_s: Vec<f64>,
}

/// The follow-through's re-entries.
pub(crate) struct Reentries<'a> {
    config: &'a PipelineConfig,
    rigid: &'a RigidConfig,
    secondary: &'a SecondaryFractureConfig,
    layout: &'a OutputLayout,
    particles: &'a ParticleSet,
    settings: WorldSettings,
    maker: PieceMaker,
    threshold_m_s: f64,
    /// The follow-through's inputs digest.
    inputs: u32,
    /// The pieces now: each element's piece, and each piece's pose at which its elements'
    /// affine maps hold (the handoff's, or its return's).
    pub(crate) table: FragmentFrame,
    /// Each bond entry of the shot's particle file, by its canonical index: broken.
    broken: Vec<bool>,
    /// The pieces' shapes and plastic extensions, for the elastoplastic model.
    plastic: Option<PlasticState>,
    pub(crate) state: ReentryState,
    /// The active re-entries' outcomes.
    outcomes: Vec<Outcome>,
    /// The returns this run made.
    pub(crate) reports: Vec<ReentryReport>,
    /// Every re-entry whose pieces came back, in that order (this run's and those resumed).
    returned: Vec<Returned>,
}

/// A re-entry whose pieces came back: where its debris points are and how its fragment ids
/// became the shot's.
struct Returned {
    layout: OutputLayout,
    /// Its handoff frame.
    handoff_frame: u32,
    /// The shot's id of each of its fragments at its handoff.
    ids: Vec<u32>,
    start_time_s: f64,
    return_time_s: f64,
}

/// Where the follow-through stands after stepping.
pub(crate) enum Stop {
    /// It reached the time asked for.
    Reached,
    /// A re-entry started (the checkpoint must be written now).
    Started(u32),
}

impl<'a> Reentries<'a> {
    /// The re-entries of a follow-through handed over at `handoff` (frame `handoff_frame`):
    /// none yet, the bonds broken as the simulation left them.
    pub(crate) fn new(
        config: &'a PipelineConfig,
        layout: &'a OutputLayout,
        particles: &'a ParticleSet,
        handoff: &FragmentFrame,
        inputs: u32,
    ) -> Result<Option<Reentries<'a>>, RigidError> {
        let Some(rigid) = &config.rigid else { return Ok(None) };
        let Some(secondary) = rigid.secondary_fracture.as_ref().filter(|s| s.enabled()) else { return Ok(None) };
        let mut broken = vec![false; particles.bonds.neighbor.len()];
        for block in BreakLog::read_through(&layout.break_log(), handoff.meta.frame)? {
            for event in block.events {
                broken[event.bond as usize] = true;
            }
        }
        let threshold_m_s = secondary.threshold_scale
            * critical_speed_m_s(
                config.material.p_wave_modulus_pa(),
                config.material.density_kg_m3,
                particles.meta.mean_critical_stretch,
            );
        Ok(Some(Reentries {
            config,
            rigid,
            secondary,
            layout,
            particles,
            settings: world_settings(config, rigid, particles.meta.lambda_m),
            maker: PieceMaker::new(particles, config.material.density_kg_m3, rigid),
            threshold_m_s,
            inputs,
            table: handoff.clone(),
            broken,
            plastic: PlasticState::of_shot(config, layout, particles, handoff)?,
            state: ReentryState { time_s: handoff.meta.time_s, started: 0, active: Vec::new(), returned: Vec::new() },
            outcomes: Vec::new(),
            reports: Vec::new(),
            returned: Vec::new(),
        }))
    }

    /// Continues from a checkpoint's `state`: the returns it made applied again to the pieces
    /// and bonds (the world has their bodies already), the active re-entries' outcomes read.
    /// Returns the first active re-entry whose outcome is missing.
    pub(crate) fn resume(&mut self, state: ReentryState) -> Result<Option<u32>, RigidError> {
        for &number in &state.returned {
            let Some(outcome) = self.read_outcome(number)? else {
                return Err(RigidError::Input(format!(
                    "{}: its simulation or post is missing; run `shatter rigid` again",
                    self.layout.reentry_dir(number).display()
                )));
            };
            self.apply(&outcome, None);
        }
        self.state = state;
        self.load_active()
    }

    /// Reads the outcomes of the active re-entries not read yet; the first missing one.
    pub(crate) fn load_active(&mut self) -> Result<Option<u32>, RigidError> {
        for number in self.state.active.clone() {
            if self.outcomes.iter().any(|o| o.reentry.meta.number == number) {
                continue;
            }
            match self.read_outcome(number)? {
                Some(outcome) => self.outcomes.push(outcome),
                None => return Ok(Some(number)),
            }
        }
        Ok(None)
    }

    /// Steps `world` to `until_s` (seconds since the simulation's start), bringing back the
    /// pieces of re-entries that end before, and stopping at a hard contact; counts the steps
    /// kept in `steps`.
    pub(crate) fn step_to(
        &mut self,
        world: &mut RigidWorld,
        until_s: f64,
        frame: u32,
        steps: &mut u64,
    ) -> Result<Stop, RigidError> {
        while self.state.time_s < until_s {
            let returns = self.outcomes.iter().map(|o| o.return_time_s).fold(f64::INFINITY, f64::min);
            let target_s = until_s.min(returns);
            let duration_s = target_s - self.state.time_s;
            if duration_s > 0.0 {
                // the world is saved to step back to only while some piece is watched
                let watch = self.watch(world.piece_count()).filter(|watch| watch.watched.contains(&true));
                let saved = match watch {
                    Some(_) => Some(world.snapshot().map_err(|e| self.snapshot_error(e.to_string()))?),
                    None => None,
                };
                let stepped = world.step_for(duration_s, self.rigid.max_step_s, watch.as_ref());
                if let (Some(impact), Some(saved)) = (stepped.impact, saved) {
                    // back to the step before the contact, then out of the world
                    *world = RigidWorld::restore(&saved).map_err(|e| self.snapshot_error(e.to_string()))?;
                    world.step_exactly(stepped.dt_s, stepped.steps - 1);
                    *steps += stepped.steps - 1;
                    let before_s = (stepped.steps - 1) as f64 * stepped.dt_s;
                    world.end_interval(before_s);
                    self.state.time_s += before_s;
                    return self.start(world, impact, frame).map(Stop::Started);
                }
                world.end_interval(duration_s);
                *steps += stepped.steps;
            }
            self.state.time_s = target_s;
            self.bring_back(world, target_s);
        }
        Ok(Stop::Reached)
    }

    /// The contacts to watch: none once `max_reentries` have started.
    fn watch(&self, pieces: usize) -> Option<ImpactWatch> {
        if self.state.started >= self.secondary.max_reentries {
            return None;
        }
        let away: Vec<u32> = self.outcomes.iter().flat_map(|o| o.reentry.meta.pieces.clone()).collect();
        let watched = (0..pieces)
            .map(|piece| self.table.elements[piece] >= self.secondary.min_elements && !away.contains(&(piece as u32)))
            .collect();
        Some(ImpactWatch { threshold_m_s: self.threshold_m_s, watched })
    }

    fn snapshot_error(&self, what: String) -> RigidError {
        RigidError::Snapshot { path: self.layout.rigid_checkpoint(), what }
    }

    /// Starts a re-entry of `impact`'s pieces: writes its request, particle file and start, and
    /// takes the pieces out of `world`.
    fn start(&mut self, world: &mut RigidWorld, impact: Impact, frame: u32) -> Result<u32, RigidError> {
        let number = self.state.started + 1;
        let pieces = impact.pieces();
        let mut all = members_of_pieces(&self.table.fragment_of, self.table.fragment_count());
        let members: Vec<Vec<u32>> = pieces.iter().map(|&piece| std::mem::take(&mut all[piece])).collect();
        let shard_centres_m = self
            .config
            .sim
            .shards
            .as_ref()
            .map_or(Vec::new(), |shards| shards.centres(&self.particles.rest_position_m, self.config.scene.seed));
        let (poses, velocities, centres) = (world.poses(), world.velocities(), world.centres());
        let bodies: Vec<BodyState> = pieces
            .iter()
            .map(|&piece| BodyState {
                rotation: poses[piece].0,
                translation: poses[piece].1,
                centre: centres[piece],
                linear: velocities[piece].0,
                angular: velocities[piece].1,
            })
            .collect();
        let lead_time_s = match self.config.lead_in {
            Some(_) => LeadIn::read_for(self.layout).map_err(RigidError::Input)?.handoff_time_s,
            None => 0.0,
        };
        let gravity = Vector::from_array(self.config.sim.gravity_m_s2);
        let approach = Approach {
            particles: self.particles,
            shape_m: self.plastic.as_ref().map_or(&self.particles.rest_position_m, PlasticState::shape_m),
            members: &members,
            bodies: &bodies,
            gravity,
            max_step_s: self.rigid.max_step_s,
        };
        let approach_s = match (impact.struck, &self.config.sim.floor) {
            (Struck::Floor, Some(floor)) => approach.to_floor_s(floor.height_m),
            (Struck::Piece(_), _) => approach.to_each_other_s(self.contact_distance_m()),
            _ => 0.0,
        };
        let starts: Vec<BodyState> = bodies.iter().map(|body| body.after(approach_s, gravity)).collect();
        let start_time_s = self.state.time_s + approach_s;
        let meta = ReentryMeta {
            number,
            frame,
            start_time_s,
            pieces: pieces.iter().map(|&piece| piece as u32).collect(),
            hit: impact.struck.name(),
            impact_speed_m_s: impact.speed_m_s,
            threshold_m_s: impact.threshold_m_s(self.threshold_m_s),
            inputs: self.inputs,
            shard_centres_m,
        };
        let files = StartFiles {
            config: self.config,
            particles: self.particles,
            broken: &self.broken,
            plastic: self.plastic.as_ref(),
        };
        let members = files.write(&meta, &members, &starts, lead_time_s + start_time_s)?;
        Reentry { meta, members }.write(&self.layout.reentry(number))?;
        for &piece in &pieces {
            world.withdraw_piece(piece);
        }
        self.state.started = number;
        self.state.active.push(number);
        Ok(number)
    }

    /// The simulation's contact distance d_c, metres (`sim.contact.distance_m`, by default
    /// half the spacing).
    fn contact_distance_m(&self) -> f64 {
        self.config.sim.contact.distance_m.unwrap_or(0.5 * self.particles.meta.lambda_m)
    }

    /// Brings back the pieces of every active re-entry that ends at `time_s`.
    fn bring_back(&mut self, world: &mut RigidWorld, time_s: f64) {
        while let Some(index) = self.outcomes.iter().position(|o| o.return_time_s <= time_s) {
            let outcome = self.outcomes.remove(index);
            let number = outcome.reentry.meta.number;
            let report = self.apply(&outcome, Some(world));
            self.reports.extend(report);
            self.state.active.retain(|&n| n != number);
            self.state.returned.push(number);
        }
    }

    /// Puts `outcome`'s pieces into the table (and, given a world, their bodies into it): the
    /// largest of the fragments of its handoff that hold a piece's elements continues the piece
    /// and keeps its id, and the others take new ids after the last, in order.
    fn apply(&mut self, outcome: &Outcome, world: Option<&mut RigidWorld>) -> Option<ReentryReport> {
        let members = &outcome.reentry.members;
        let handoff = &outcome.handoff;
        let local = members_of_pieces(&handoff.fragment_of, handoff.fragment_count());
        let continuing = self.continuing(members, handoff);
        let first_new = self.table.fragment_count();
        let mut next = first_new;
        let ids: Vec<usize> = (0..local.len())
            .map(|fragment| match continuing.iter().find(|&(_, &f)| f as usize == fragment) {
                Some((&piece, _)) => piece,
                None => {
                    next += 1;
                    next - 1
                }
            })
            .collect();
        let added = next - first_new;
        self.table.rotation.extend(std::iter::repeat_n([0.0, 0.0, 0.0, 1.0], added));
        self.table.translation_m.extend(std::iter::repeat_n([0.0; 3], added));
        self.table.elements.extend(std::iter::repeat_n(0, added));
        self.table.mass_kg.extend(std::iter::repeat_n(0.0, added));
        let mut bodies = Vec::with_capacity(local.len());
        let mut parts: Vec<Balance> = Vec::with_capacity(local.len());
        for (fragment, local_members) in local.iter().enumerate() {
            let id = ids[fragment];
            let global: Vec<u32> = local_members.iter().map(|&i| members[i as usize]).collect();
            for (&g, &l) in global.iter().zip(local_members) {
                self.table.fragment_of[g as usize] = id as u32;
                if let (Some(affine), Some(from)) = (&mut self.table.element_affine, &handoff.element_affine) {
                    affine[g as usize] = from.get(l as usize).copied().unwrap_or(AFFINE_RIGID);
                }
            }
            self.table.rotation[id] = handoff.rotation[fragment];
            self.table.translation_m[id] = handoff.translation_m[fragment];
            self.table.elements[id] = handoff.elements[fragment];
            self.table.mass_kg[id] = handoff.mass_kg[fragment];
            if world.is_some() {
                let x: Vec<Vector> = local_members.iter().map(|&i| outcome.position_m[i as usize]).collect();
                let v: Vec<Vector> = local_members.iter().map(|&i| outcome.velocity_m_s[i as usize]).collect();
                let motion = MemberMotion { members: &global, position_m: &x, velocity_m_s: &v };
                let rest = self.maker.rest_of(&global);
                let (body, part) =
                    self.maker.body(&rest, (handoff.rotation[fragment], handoff.translation_m[fragment]), &motion);
                bodies.push(body);
                parts.push(part);
            }
        }
        for &entry in &outcome.broken {
            self.broken[entry] = true;
        }
        if let (Some(state), Some(back)) = (&mut self.plastic, &outcome.plastic) {
            state.absorb(&Handoff { members, position_m: &outcome.position_m, fragments: handoff }, back);
        }
        self.returned.push(Returned {
            layout: outcome.layout.clone(),
            handoff_frame: handoff.meta.frame,
            ids: ids.iter().map(|&id| id as u32).collect(),
            start_time_s: outcome.reentry.meta.start_time_s,
            return_time_s: outcome.return_time_s,
        });
        let world = world?;
        for (&id, body) in ids.iter().zip(&bodies) {
            if id < first_new {
                world.replace_piece(&self.settings, id, body);
            } else {
                let index = world.add_piece(&self.settings, body);
                debug_assert_eq!(index, id);
            }
        }
        let meta = &outcome.reentry.meta;
        Some(ReentryReport {
            number: meta.number,
            pieces_in: meta.pieces.clone(),
            hit: meta.hit.clone(),
            impact_speed_m_s: meta.impact_speed_m_s,
            threshold_m_s: meta.threshold_m_s,
            start_time_s: meta.start_time_s,
            return_time_s: outcome.return_time_s,
            pieces: local.len(),
            conservation: conservation(&parts),
        })
    }

    /// The outcome of re-entry `number`, when its simulation and post have run on this
    /// request.
    fn read_outcome(&self, number: u32) -> Result<Option<Outcome>, RigidError> {
        let reentry = Reentry::read(&self.layout.reentry(number))?;
        let pass = pass_config(self.config, &reentry.meta);
        let layout = OutputLayout::of(&pass);
        let Ok(frames) = SimFrames::read(&pass, &layout) else { return Ok(None) };
        let count = frames.count();
        if !layout.particles().is_file() || !layout.fragments(count).is_file() {
            return Ok(None);
        }
        let (particles, checksum) = ParticleSet::read_with_checksum(&layout.particles())?;
        let post_inputs = digest::post_inputs(digest::sim_inputs(checksum, &pass), &pass);
        if FragmentFrame::read(&layout.fragments(count))?.meta.inputs != Some(post_inputs) {
            return Ok(None);
        }
        let (frame, _) = choose_handoff(&pass, self.rigid, count, &layout, &particles, post_inputs)?;
        let handoff = read_fragments(&layout, frame, &particles, post_inputs)?;
        let (position_m, velocity_m_s) = vectors(&PointFrame::read(&layout.frame_points(frame))?);
        let mut broken = Vec::new();
        for block in BreakLog::read_through(&layout.break_log(), frame)? {
            for event in block.events {
                broken.push(self.global_entry(&particles, &reentry.members, event.bond as usize));
            }
        }
        let frame_times_s = frames.steps[..frame as usize].iter().map(|&steps| steps as f64 * frames.dt_s).collect();
        let plastic = match self.plastic {
            Some(_) => Some(PlasticState::read_return(&layout, self.particles, &particles, &reentry.members, frame)?),
            None => None,
        };
        Ok(Some(Outcome {
            return_time_s: reentry.meta.start_time_s + handoff.meta.time_s,
            reentry,
            handoff,
            position_m,
            velocity_m_s,
            broken,
            plastic,
            layout,
            frame_times_s,
        }))
    }

    /// The debris points of the re-entries whose pieces came back after `after_s` and by
    /// `until_s` (seconds since the simulation's start), appended to `debris`: their post's
    /// points through their handoff, with the shot's fragment ids and break times.
    pub(crate) fn debris_between(
        &self,
        after_s: f64,
        until_s: f64,
        debris: &mut DebrisFrame,
    ) -> Result<(), RigidError> {
        for returned in self.returned.iter().filter(|r| r.return_time_s > after_s && r.return_time_s <= until_s) {
            let id = |k: i32| usize::try_from(k).ok().and_then(|k| returned.ids.get(k)).map_or(k, |&id| id as i32);
            for frame in 1..=returned.handoff_frame {
                let path = returned.layout.debris_points(frame);
                if !path.is_file() {
                    continue;
                }
                let points = read_point_cache(&path)?;
                debris.position.extend(points.position);
                debris.velocity.extend(points.velocity);
                debris.broken_bonds.extend(points.broken_bonds);
                debris.fragment.extend(points.fragment.into_iter().map(id));
                debris.other_fragment.extend(points.other_fragment.into_iter().map(id));
                let start_s = returned.start_time_s;
                debris.time_s.extend(points.time_s.into_iter().map(|t| (f64::from(t) + start_s) as f32));
            }
        }
        Ok(())
    }

    /// The canonical entry in the shot's particle file of the re-entry's bond `entry`.
    fn global_entry(&self, subset: &ParticleSet, members: &[u32], entry: usize) -> usize {
        let row = subset.bonds.offsets.partition_point(|&offset| offset as usize <= entry) - 1;
        let (i, j) = (members[row], members[subset.bonds.neighbor[entry] as usize]);
        let (low, high) = if i < j { (i, j) } else { (j, i) };
        self.particles.bonds.find(low as usize, high).unwrap_or(0)
    }

    /// The fragment of a re-entry's `fragments` (its particles the shot's `members`) that
    /// continues each piece that went back: the largest holding its elements (the lowest id of
    /// equals). A fragment lies within one piece: no bond joined two pieces that met.
    fn continuing(&self, members: &[u32], fragments: &FragmentFrame) -> BTreeMap<usize, u32> {
        let mut continuing: BTreeMap<usize, u32> = BTreeMap::new();
        for (&global, &fragment) in members.iter().zip(&fragments.fragment_of) {
            let best = continuing.entry(self.table.fragment_of[global as usize] as usize).or_insert(fragment);
            let size = |f: u32| fragments.elements[f as usize];
            if (size(fragment), std::cmp::Reverse(fragment)) > (size(*best), std::cmp::Reverse(*best)) {
                *best = fragment;
            }
        }
        continuing
    }

    /// The poses of `world`'s pieces at `time_s`, those away in a re-entry as the re-entry's
    /// frame nearest that time shows the fragment that continues each.
    pub(crate) fn frame_poses(&self, world: &RigidWorld, time_s: f64) -> Result<Vec<(Rotation, Vector)>, RigidError> {
        let mut poses = world.poses();
        for outcome in &self.outcomes {
            let since_s = time_s - outcome.reentry.meta.start_time_s;
            let nearest = outcome
                .frame_times_s
                .iter()
                .enumerate()
                .min_by(|a, b| (a.1 - since_s).abs().total_cmp(&(b.1 - since_s).abs()))
                .map_or(1, |(index, _)| index as u32 + 1);
            let fragments = FragmentFrame::read(&outcome.layout.fragments(nearest))?;
            for (piece, fragment) in self.continuing(&outcome.reentry.members, &fragments) {
                let q = fragments.rotation[fragment as usize].map(f64::from);
                poses[piece] = (
                    Rotation::from_xyzw(q[0], q[1], q[2], q[3]).normalize(),
                    Vector::from_array(fragments.translation_m[fragment as usize]),
                );
            }
        }
        Ok(poses)
    }
}
