//! `[sim]`: how the simulation runs, what acts on the body, and art direction of the cracks.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::ConfigError;
use super::checker::Checker;
pub use super::shards::ShardsConfig;

/// The most frames a simulation may write.
pub const MAX_FRAMES: u32 = 1_000_000;

/// `[sim]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimConfig {
    /// Which backend runs the simulation.
    pub backend: BackendChoice,
    /// Time step, seconds. Unset, the simulation takes one from the material
    /// ([`crate::time_step`]); it serializes then as [`crate::time_step::UNSET_STEP_STAND_IN_S`].
    #[serde(serialize_with = "crate::time_step::serialize_dt_s")]
    pub dt_s: Option<f64>,
    /// Steps between written frames.
    pub steps_per_frame: u32,
    /// Frames written; frame 1 is the rest state, frame k the state after (k - 1) frames of steps.
    pub frames: u32,
    /// Which particle's threshold decides a bond: the larger (the paper) or the smaller.
    pub break_rule: BreakRule,
    /// How bond stiffness is corrected for the discrete neighbourhood.
    pub stiffness_correction: StiffnessCorrection,
    /// The rule set: `levine` (the paper's, the default) or `lammps` (LAMMPS's `peri/pmb`). It
    /// sets the four rules below, each of which may also be given on its own.
    #[serde(skip_serializing_if = "RuleSet::is_levine")]
    pub rules: RuleSet,
    /// Whether a neighbour near the horizon counts with part of its volume: `none` or `lammps`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub partial_volumes: Option<PartialVolumes>,
    /// The contact between close particles: `penalty` (the paper's eq. 6 between unbonded pairs)
    /// or `lammps` (LAMMPS's short-range force between every close pair).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contact_model: Option<ContactModel>,
    /// Whether a bond's force counts in the step in which it breaks: `skipped` or `applied`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub breaking_step_force: Option<BreakingStepForce>,
    /// The compression boost of a particle's thresholds: `clamped` (-alpha min(0, s_min)) or
    /// `signed` (-alpha s_min, whatever its sign).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub compression_boost: Option<CompressionBoost>,
    /// A checkpoint (full state, for `--resume`) is written every this many frames and at the end.
    pub checkpoint_every_frames: u32,
    /// The run stops as unstable when kinetic plus bond energy exceeds this factor times the
    /// initial energy plus the work done by external forces.
    pub runaway_energy_factor: f64,
    /// Gravitational acceleration, m/s^2 (Y is up).
    pub gravity_m_s2: [f64; 3],
    /// Velocity every particle starts with, m/s: a body dropped from high up starts just above
    /// the floor at its impact speed instead of falling for a million steps.
    pub initial_velocity_m_s: [f64; 3],
    /// `[sim.contact]`: repulsion between particles that are not bonded.
    pub contact: ContactConfig,
    /// `[sim.floor]`: a floor plane y = height; absent, there is no floor.
    pub floor: Option<FloorConfig>,
    /// `[[sim.projectile]]`: spheres on a straight path pushing with the paper's eq. 7.
    pub projectile: Vec<ProjectileConfig>,
    /// `[[sim.indenter]]`: spheres on a straight path pushing with F = K (R - r)^2.
    pub indenter: Vec<IndenterConfig>,
    /// `[[sim.grip]]`: boxes whose particles move at a set velocity, whatever pulls on them
    /// (a beam stretched, a sheet torn).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub grip: Vec<GripConfig>,
    /// `[[sim.weakened_path]]`: random-walk crack paths with weaker bonds.
    pub weakened_path: Vec<WeakenedPathConfig>,
    /// `[[sim.seam]]`: pre-scored surfaces (a plane or a mesh) with weaker bonds across them.
    pub seam: Vec<SeamConfig>,
    /// `[sim.shards]`: a Voronoi shard pattern, strong inside shards and weak across.
    pub shards: Option<ShardsConfig>,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            backend: BackendChoice::Auto,
            dt_s: None,
            steps_per_frame: 500,
            frames: 48,
            break_rule: BreakRule::Max,
            stiffness_correction: StiffnessCorrection::Energy,
            rules: RuleSet::Levine,
            partial_volumes: None,
            contact_model: None,
            breaking_step_force: None,
            compression_boost: None,
            checkpoint_every_frames: 1,
            runaway_energy_factor: 2.0,
            gravity_m_s2: [0.0, -9.81, 0.0],
            initial_velocity_m_s: [0.0; 3],
            contact: ContactConfig::default(),
            floor: None,
            projectile: Vec::new(),
            indenter: Vec::new(),
            grip: Vec::new(),
            weakened_path: Vec::new(),
            seam: Vec::new(),
            shards: None,
        }
    }
}

/// Where the simulation runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BackendChoice {
    /// A hardware GPU when one is found, else the CPU.
    Auto,
    /// The CPU (rayon).
    Cpu,
    /// The GPU (wgpu); fails when there is none.
    Gpu,
}

/// Which particle's effective threshold decides whether a bond breaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BreakRule {
    /// Breaks when the stretch exceeds the larger of the two (the paper's rule).
    Max,
    /// Breaks when the stretch exceeds the smaller of the two.
    Min,
}

/// A rule set: the four rules on which peridynamic codes differ (docs/DECISIONS.md#lammps-rules).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RuleSet {
    /// Levine et al.'s rules, as shatter has always run them.
    #[default]
    Levine,
    /// LAMMPS's `pair_style peri/pmb` (Parks et al.).
    Lammps,
}

impl RuleSet {
    fn is_levine(&self) -> bool {
        *self == RuleSet::Levine
    }
}

/// Whether a neighbour's volume counts whole or in part near the horizon.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PartialVolumes {
    /// Every neighbour within the horizon counts whole.
    None,
    /// LAMMPS's linear scale: a neighbour whose rest distance lies within half a lattice spacing
    /// of the horizon delta counts with (delta + lambda/2 - |xi|) / lambda of its volume.
    Lammps,
}

/// The contact force between close particles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ContactModel {
    /// The paper's eq. 6, K_c (d - r)^2, between particles that are not bonded (`[sim.contact]`).
    Penalty,
    /// LAMMPS's short-range force between every pair closer than
    /// d_ij = min(0.9 |xi_ij|, 1.35 lambda), bonded or not: 15 c V_i V_j (d_ij - r) / delta.
    Lammps,
}

/// Whether a bond's force counts in the step in which it breaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BreakingStepForce {
    /// A bond that breaks pulls no more in that step.
    Skipped,
    /// It pulls one last time, and its stretch counts towards the compression boost.
    Applied,
}

/// How a particle's smallest bond stretch strengthens its thresholds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CompressionBoost {
    /// -alpha min(0, s_min): compression strengthens, stretch never weakens.
    Clamped,
    /// -alpha s_min, whatever its sign: a particle whose every bond is stretched is weakened.
    Signed,
}

/// The four rules a run follows, resolved from `sim.rules` and the keys given on their own.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rules {
    /// Partial volumes near the horizon.
    pub partial_volumes: PartialVolumes,
    /// The contact force.
    pub contact: ContactModel,
    /// The breaking step's force.
    pub breaking_step_force: BreakingStepForce,
    /// The compression boost.
    pub compression_boost: CompressionBoost,
}

impl Rules {
    /// Levine et al.'s rules.
    pub const LEVINE: Rules = Rules {
        partial_volumes: PartialVolumes::None,
        contact: ContactModel::Penalty,
        breaking_step_force: BreakingStepForce::Skipped,
        compression_boost: CompressionBoost::Clamped,
    };
    /// LAMMPS's `peri/pmb` rules.
    pub const LAMMPS: Rules = Rules {
        partial_volumes: PartialVolumes::Lammps,
        contact: ContactModel::Lammps,
        breaking_step_force: BreakingStepForce::Applied,
        compression_boost: CompressionBoost::Signed,
    };
}

/// How the bond constant is corrected for the discrete neighbourhood.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StiffnessCorrection {
    /// Each particle's bonds are scaled so that a uniform dilation stores the continuum energy
    /// density 4.5 K s^2 (interior and surface alike); a bond takes the mean of its two factors.
    Energy,
    /// The bare c = 18 K / (pi delta^4) of the paper.
    None,
}

/// `[sim.contact]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ContactConfig {
    /// K_c in f = K_c (d_c - |x_i - x_j|)^2 (the paper's eq. 6), Pa; 0 turns contact off.
    pub stiffness_pa: f64,
    /// d_c, the distance below which unbonded particles repel, metres; default lambda / 2.
    pub distance_m: Option<f64>,
}

impl Default for ContactConfig {
    fn default() -> Self {
        ContactConfig { stiffness_pa: 1e8, distance_m: None }
    }
}

/// `[sim.floor]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FloorConfig {
    /// Height of the floor plane, metres.
    pub height_m: f64,
    /// Fraction of the normal velocity kept when a particle bounces (the paper: 0.99).
    pub restitution: f64,
}

impl Default for FloorConfig {
    fn default() -> Self {
        FloorConfig { height_m: 0.0, restitution: 0.99 }
    }
}

/// `[[sim.projectile]]`: the paper's eq. 7. A particle at distance d in [3r/4, 3r/2] from the
/// centre feels f = K_S (16 (d - 3r/4) (d - 3r/2)^2)^(2/3), peaking at K_S r^2 at d = r, directed
/// halfway between the projectile's direction of travel and the push away from its centre.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProjectileConfig {
    /// Centre at t = 0, metres.
    pub center_m: [f64; 3],
    /// Constant velocity, m/s.
    pub velocity_m_s: [f64; 3],
    /// Radius r, metres.
    pub radius_m: f64,
    /// K_S, Pa.
    pub stiffness_pa: f64,
}

/// A body that pushes particles: a projectile or an indenter, with the largest force it exerts
/// and the distance over which it acts.
#[derive(Debug, Clone, PartialEq)]
pub struct PushingBody {
    /// The key of its stiffness, e.g. `sim.projectile[0].stiffness_pa`.
    pub key: String,
    /// Its stiffness, in the key's units.
    pub stiffness: f64,
    /// The largest force it exerts on a particle, newtons.
    pub peak_n: f64,
    /// How far inside its reach that force acts, metres.
    pub reach_m: f64,
}

impl PushingBody {
    /// The longest time step in which its largest force carries a particle of `mass_kg` no
    /// farther than its reach (F dt^2 / m <= reach): past it, a particle passes through the body
    /// instead of bouncing off, gaining energy.
    pub fn max_dt_s(&self, mass_kg: f64) -> f64 {
        (self.reach_m * mass_kg / self.peak_n).sqrt()
    }
}

/// `[[sim.indenter]]`: a sphere pushing particles inside it out with F = K (R - r)^2.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IndenterConfig {
    /// Centre at t = 0, metres.
    pub center_m: [f64; 3],
    /// Constant velocity, m/s.
    pub velocity_m_s: [f64; 3],
    /// Radius R, metres.
    pub radius_m: f64,
    /// K, N/m^2. May be left out for `lammps_stiffness_n_m5`.
    #[serde(default = "super::lammps_terms::unset")]
    pub stiffness_n_m2: f64,
    /// LAMMPS's `fix indent` K, per unit volume (N/m^5), instead of `stiffness_n_m2`: K lambda^3.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lammps_stiffness_n_m5: Option<f64>,
}

/// `[[sim.grip]]`: the particles whose rest positions lie in a box move at a set velocity until
/// `release_s`: the grip takes up whatever force their bonds exert (and its work counts as
/// external work).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GripConfig {
    /// The box's lower corner, metres (scene space, rest positions).
    pub box_min_m: [f64; 3],
    /// The box's upper corner, metres.
    pub box_max_m: [f64; 3],
    /// The velocity the gripped particles keep, m/s.
    pub velocity_m_s: [f64; 3],
    /// When the grip lets go, seconds of simulated time; absent: never.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub release_s: Option<f64>,
}

/// `[[sim.weakened_path]]`: a persistent random walk; bonds whose midpoint lies within `radius_m`
/// of the walk get their thresholds multiplied by `threshold_factor` (the paper's glass plate).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WeakenedPathConfig {
    /// Where the walk starts, metres.
    pub start_m: [f64; 3],
    /// Initial direction (any length).
    pub direction: [f64; 3],
    /// If given, the walk stays in the plane through `start_m` with this normal.
    #[serde(default)]
    pub plane_normal: Option<[f64; 3]>,
    /// Number of steps.
    pub steps: u32,
    /// Length of each step, metres.
    pub step_length_m: f64,
    /// Largest random turn per step, degrees.
    #[serde(default = "default_max_turn_deg")]
    pub max_turn_deg: f64,
    /// Half-width of the weakened band, metres.
    pub radius_m: f64,
    /// Threshold multiplier inside the band (0.5 halves the strength).
    pub threshold_factor: f64,
}

fn default_max_turn_deg() -> f64 {
    30.0
}

/// `[[sim.seam]]`: bonds crossing a surface get their thresholds multiplied by
/// `threshold_factor`. The surface is a plane (`point_m`, `normal`, optionally limited to a disc
/// of `radius_m`) or a triangle mesh (`mesh`, in world coordinates, metres).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SeamConfig {
    /// A point on the plane, metres.
    #[serde(default)]
    pub point_m: Option<[f64; 3]>,
    /// The plane's normal (any length).
    #[serde(default)]
    pub normal: Option<[f64; 3]>,
    /// Limit the plane to a disc of this radius around `point_m`, metres.
    #[serde(default)]
    pub radius_m: Option<f64>,
    /// A Wavefront OBJ surface instead of a plane (relative to the config file's folder).
    #[serde(default)]
    pub mesh: Option<PathBuf>,
    /// Threshold multiplier for bonds across the seam.
    pub threshold_factor: f64,
}

impl SimConfig {
    /// Resolves relative paths (seam meshes) against the config file's folder.
    pub(super) fn resolve_paths(&mut self, base: &std::path::Path) {
        for seam in &mut self.seam {
            if let Some(mesh) = &mut seam.mesh {
                super::relative_paths::resolve_path(base, mesh);
            }
        }
    }

    /// The projectiles and indenters: the paper's eq. 7 projectile force peaks at K_S r^2 half
    /// a radius into its 1.5 r reach; an indenter's K (R - r)^2 at K R^2, R inside it.
    pub fn pushing_bodies(&self) -> Vec<PushingBody> {
        let projectiles = self.projectile.iter().enumerate().map(|(index, projectile)| PushingBody {
            key: format!("sim.projectile[{index}].stiffness_pa"),
            stiffness: projectile.stiffness_pa,
            peak_n: projectile.stiffness_pa * projectile.radius_m * projectile.radius_m,
            reach_m: 0.75 * projectile.radius_m,
        });
        let indenters = self.indenter.iter().enumerate().map(|(index, indenter)| PushingBody {
            key: format!("sim.indenter[{index}].stiffness_n_m2"),
            stiffness: indenter.stiffness_n_m2,
            peak_n: indenter.stiffness_n_m2 * indenter.radius_m * indenter.radius_m,
            reach_m: indenter.radius_m,
        });
        projectiles.chain(indenters).collect()
    }

    /// The rules this run follows: the rule set's, with each rule given on its own in its place.
    pub fn rules(&self) -> Rules {
        let set = match self.rules {
            RuleSet::Levine => Rules::LEVINE,
            RuleSet::Lammps => Rules::LAMMPS,
        };
        Rules {
            partial_volumes: self.partial_volumes.unwrap_or(set.partial_volumes),
            contact: self.contact_model.unwrap_or(set.contact),
            breaking_step_force: self.breaking_step_force.unwrap_or(set.breaking_step_force),
            compression_boost: self.compression_boost.unwrap_or(set.compression_boost),
        }
    }

    /// Checks `[sim]`.
    pub(super) fn validate(&self, check: &Checker) -> Result<(), ConfigError> {
        self.validate_stepping(check)?;
        self.validate_bodies(check)?;
        self.validate_art_direction(check)
    }

    /// Checks the time step, the frames, the runaway guard, the body forces, contact and the floor.
    fn validate_stepping(&self, check: &Checker) -> Result<(), ConfigError> {
        if let Some(dt_s) = self.dt_s {
            check.positive("sim.dt_s", dt_s, "seconds")?;
        }
        check.that(self.steps_per_frame > 0, "sim.steps_per_frame", "0", || "must be at least 1".into())?;
        check.that(self.frames > 0, "sim.frames", "0", || "must be at least 1 (frame 1 is the rest state)".into())?;
        check.that(self.frames <= MAX_FRAMES, "sim.frames", &self.frames.to_string(), || {
            format!("must be at most {MAX_FRAMES} (each frame is a file)")
        })?;
        check.that(self.checkpoint_every_frames > 0, "sim.checkpoint_every_frames", "0", || {
            "must be at least 1".into()
        })?;
        let factor = self.runaway_energy_factor;
        check.that(factor.is_finite() && factor > 1.0, "sim.runaway_energy_factor", &factor.to_string(), || {
            "must be a finite number greater than 1".into()
        })?;
        check.finite_array("sim.gravity_m_s2", &self.gravity_m_s2)?;
        check.finite_array("sim.initial_velocity_m_s", &self.initial_velocity_m_s)?;
        check.non_negative("sim.contact.stiffness_pa", self.contact.stiffness_pa, "Pa")?;
        if let Some(distance) = self.contact.distance_m {
            check.positive("sim.contact.distance_m", distance, "metres")?;
        }
        if let Some(floor) = &self.floor {
            check.finite("sim.floor.height_m", floor.height_m)?;
            let restitution = floor.restitution;
            check.that(
                (0.0..=1.0).contains(&restitution),
                "sim.floor.restitution",
                &restitution.to_string(),
                || "must be between 0 and 1".into(),
            )?;
        }
        Ok(())
    }

    /// Checks the projectiles, grips and indenters.
    fn validate_bodies(&self, check: &Checker) -> Result<(), ConfigError> {
        for (index, projectile) in self.projectile.iter().enumerate() {
            let key = |name: &str| format!("sim.projectile[{index}].{name}");
            check.finite_array(&key("center_m"), &projectile.center_m)?;
            check.finite_array(&key("velocity_m_s"), &projectile.velocity_m_s)?;
            check.positive(&key("radius_m"), projectile.radius_m, "metres")?;
            check.positive(&key("stiffness_pa"), projectile.stiffness_pa, "Pa")?;
        }
        for (index, grip) in self.grip.iter().enumerate() {
            let key = |name: &str| format!("sim.grip[{index}].{name}");
            check.finite_array(&key("box_min_m"), &grip.box_min_m)?;
            check.finite_array(&key("box_max_m"), &grip.box_max_m)?;
            check.that(
                (0..3).all(|a| grip.box_min_m[a] < grip.box_max_m[a]),
                &key("box_max_m"),
                &format!("{:?}", grip.box_max_m),
                || format!("must exceed box_min_m = {:?} on every axis", grip.box_min_m),
            )?;
            check.finite_array(&key("velocity_m_s"), &grip.velocity_m_s)?;
            if let Some(release) = grip.release_s {
                check.positive(&key("release_s"), release, "seconds")?;
            }
        }
        for (index, indenter) in self.indenter.iter().enumerate() {
            let key = |name: &str| format!("sim.indenter[{index}].{name}");
            check.finite_array(&key("center_m"), &indenter.center_m)?;
            check.finite_array(&key("velocity_m_s"), &indenter.velocity_m_s)?;
            check.positive(&key("radius_m"), indenter.radius_m, "metres")?;
            check.positive(&key("stiffness_n_m2"), indenter.stiffness_n_m2, "N/m^2")?;
        }
        Ok(())
    }

    /// Checks the art direction: weakened paths, seams and shards.
    fn validate_art_direction(&self, check: &Checker) -> Result<(), ConfigError> {
        for (index, path) in self.weakened_path.iter().enumerate() {
            let key = |name: &str| format!("sim.weakened_path[{index}].{name}");
            check.finite_array(&key("start_m"), &path.start_m)?;
            check.direction(&key("direction"), &path.direction)?;
            if let Some(normal) = &path.plane_normal {
                check.direction(&key("plane_normal"), normal)?;
            }
            check.positive(&key("step_length_m"), path.step_length_m, "metres")?;
            check.that(path.steps > 0, &key("steps"), "0", || "must be at least 1".into())?;
            let turn = path.max_turn_deg;
            check.that((0.0..=180.0).contains(&turn), &key("max_turn_deg"), &turn.to_string(), || {
                "must be between 0 and 180 degrees".into()
            })?;
            check.positive(&key("radius_m"), path.radius_m, "metres")?;
            check.positive(&key("threshold_factor"), path.threshold_factor, "a multiplier")?;
        }
        for (index, seam) in self.seam.iter().enumerate() {
            let key = |name: &str| format!("sim.seam[{index}].{name}");
            match (&seam.point_m, &seam.normal, &seam.mesh) {
                (Some(point), Some(normal), None) => {
                    check.finite_array(&key("point_m"), point)?;
                    check.direction(&key("normal"), normal)?;
                    if let Some(radius) = seam.radius_m {
                        check.positive(&key("radius_m"), radius, "metres")?;
                    }
                }
                (None, None, Some(mesh)) => {
                    let shown = format!("{:?}", mesh.display().to_string());
                    check.that(mesh.is_file(), &key("mesh"), &shown, || {
                        "mesh file not found (relative paths start at the config file's folder)".into()
                    })?;
                    check.that(seam.radius_m.is_none(), &key("radius_m"), "(set)", || {
                        "applies to plane seams only".into()
                    })?;
                }
                _ => {
                    return Err(check.invalid(
                        &format!("sim.seam[{index}]"),
                        "(table)",
                        "give either point_m and normal (a plane) or mesh (a surface), not both",
                    ));
                }
            }
            check.positive(&key("threshold_factor"), seam.threshold_factor, "a multiplier")?;
        }
        if let Some(shards) = &self.shards {
            check.that(shards.count >= 2, "sim.shards.count", &shards.count.to_string(), || {
                "must be at least 2".into()
            })?;
            check.positive("sim.shards.inside_factor", shards.inside_factor, "a multiplier")?;
            check.positive("sim.shards.across_factor", shards.across_factor, "a multiplier")?;
            let centres = shards.centres_m.len();
            check.that(
                centres == 0
                    || (centres == shards.count as usize && shards.centres_m.iter().flatten().all(|c| c.is_finite())),
                "sim.shards.centres_m",
                &format!("({centres} centres)"),
                || format!("must be empty or sim.shards.count ({}) finite points", shards.count),
            )?;
        }
        Ok(())
    }
}
