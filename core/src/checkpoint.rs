//! The simulation's checkpoint, `sim.checkpoint.shp`: the full particle state at a frame
//! boundary, with the scalars a resumed run needs to continue bit for bit and to check that it
//! continues the same run (settings hash, particle file checksum). A stage file of kind
//! [`StageKind::Checkpoint`]; format: docs/FORMATS.md.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::stage_file::{StageFileError, StageKind, StageReader, StageWriter};

/// Scalars of a checkpoint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckpointMeta {
    /// The last frame written before the checkpoint.
    pub frame: u32,
    /// Steps simulated.
    pub step: u64,
    /// Length of the break log at the checkpoint, bytes.
    pub break_log_bytes: u64,
    /// Bonds broken so far.
    pub broken_bonds: u64,
    /// Hash of the `[sim]` and `[material]` settings.
    pub settings_hash: u32,
    /// Checksum of the particle file simulated.
    pub particles_checksum: u32,
    /// Work done by external forces, joules.
    pub external_work_j: f64,
    /// Kinetic plus bond energy at the start, joules.
    pub initial_energy_j: f64,
    /// The backend that wrote it ("CPU (N threads)", "GPU: adapter"; empty in older files). A
    /// run resumed on another kind of backend continues correctly but not bit for bit.
    #[serde(default)]
    pub backend: String,
}

/// The per-particle arrays of a checkpoint (x, y, z arrays for vectors).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CheckpointState {
    /// Displacements u, metres.
    pub disp: [Vec<f32>; 3],
    /// Velocities, m/s.
    pub vel: [Vec<f32>; 3],
    /// Forces at the checkpoint's step, newtons.
    pub force: [Vec<f32>; 3],
    /// Compression boost of each particle's thresholds for the next step.
    pub boost: Vec<f32>,
    /// The material model's per-bond state, one value per particle-file bond entry (the
    /// elastoplastic model's plastic extensions, metres); empty for a model that keeps none.
    pub bond_state: Vec<f32>,
}

/// The borrowed per-particle arrays [`write()`] stores: displacement, velocity, force (x, y, z
/// arrays) and boost.
#[derive(Debug, Clone, Copy)]
pub struct StateRef<'a> {
    /// Displacements u, metres.
    pub disp: &'a [Vec<f32>; 3],
    /// Velocities, m/s.
    pub vel: &'a [Vec<f32>; 3],
    /// Forces, newtons.
    pub force: &'a [Vec<f32>; 3],
    /// Compression boost.
    pub boost: &'a [f32],
    /// The material model's per-bond state (empty: none, and no section is written).
    pub bond_state: &'a [f32],
}

const AXES: [&str; 3] = ["x", "y", "z"];

/// Writes a checkpoint atomically.
pub fn write(path: &Path, meta: &CheckpointMeta, state: StateRef<'_>) -> Result<(), StageFileError> {
    let mut out = StageWriter::create(path, StageKind::Checkpoint)?;
    out.write_json("meta", meta)?;
    for (name, values) in [("disp", state.disp), ("vel", state.vel), ("force", state.force)] {
        for (axis, values) in AXES.iter().zip(values) {
            out.write_rows(&format!("{name}_{axis}"), values)?;
        }
    }
    out.write_rows("boost", state.boost)?;
    if !state.bond_state.is_empty() {
        out.write_rows("bond_state", state.bond_state)?;
    }
    out.finish()
}

impl CheckpointState {
    /// Particles held (every array holds this many).
    pub fn particles(&self) -> usize {
        self.boost.len()
    }
}

/// Reads a checkpoint, checking its header, sizes and checksum and that every array holds the
/// same number of particles. Whether they are the particles of the run at hand is the caller's
/// to check, after it has compared the checkpoint's particle file checksum and settings hash: a
/// checkpoint of other settings is stale, not corrupt.
pub fn read(path: &Path) -> Result<(CheckpointMeta, CheckpointState), StageFileError> {
    let mut input = StageReader::open(path, StageKind::Checkpoint)?;
    let meta: CheckpointMeta = input.read_json("meta")?;
    let mut read_xyz = |name: &str| -> Result<[Vec<f32>; 3], StageFileError> {
        let mut axes = [Vec::new(), Vec::new(), Vec::new()];
        for (axis, values) in AXES.iter().zip(axes.iter_mut()) {
            *values = input.read_rows(&format!("{name}_{axis}"))?;
        }
        Ok(axes)
    };
    let disp = read_xyz("disp")?;
    let vel = read_xyz("vel")?;
    let force = read_xyz("force")?;
    let boost: Vec<f32> = input.read_rows("boost")?;
    let bond_state: Vec<f32> = if input.at_end() { Vec::new() } else { input.read_rows("bond_state")? };
    let n = boost.len();
    if !disp.iter().chain(&vel).chain(&force).all(|a| a.len() == n) {
        return Err(input.malformed(format!("the checkpoint's arrays do not all hold {n} particles")));
    }
    input.finish()?;
    Ok((meta, CheckpointState { disp, vel, force, boost, bond_state }))
}

/// Reads a checkpoint's scalars and particle count (for `shatter inspect`).
pub fn summary(path: &Path) -> Result<(CheckpointMeta, usize), StageFileError> {
    let mut input = StageReader::open(path, StageKind::Checkpoint)?;
    let meta: CheckpointMeta = input.read_json("meta")?;
    let particles = input.read_rows::<f32>("disp_x")?.len();
    Ok((meta, particles))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::SplitMix64;

    #[test]
    fn a_checkpoint_restores_its_scalars_bit_for_bit() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("sim.checkpoint.shp");
        let mut rng = SplitMix64::new(11);
        for _ in 0..200 {
            // work sums have all 53 bits of mantissa in use; a best-effort JSON float parser
            // rounds some of them to a neighbour, and a resumed run then differs in the last bit
            let work_j = rng.next_f64() * 10.0_f64.powi((rng.next_f64() * 12.0) as i32 - 6);
            let meta = CheckpointMeta {
                frame: 3,
                step: 120,
                break_log_bytes: 64,
                broken_bonds: 7,
                settings_hash: 1,
                particles_checksum: 2,
                external_work_j: work_j,
                initial_energy_j: work_j * std::f64::consts::PI,
                backend: "CPU (2 threads)".to_owned(),
            };
            let state = CheckpointState {
                disp: [vec![1.0], vec![2.0], vec![3.0]],
                vel: [vec![0.5], vec![0.25], vec![0.125]],
                force: [vec![0.0], vec![-1.0], vec![1.0]],
                boost: vec![0.0],
                // the elastoplastic model's plastic extensions on every other round; none else
                bond_state: if rng.next_f64() < 0.5 { vec![1e-6, -2e-7, 0.0] } else { Vec::new() },
            };
            let view = StateRef {
                disp: &state.disp,
                vel: &state.vel,
                force: &state.force,
                boost: &state.boost,
                bond_state: &state.bond_state,
            };
            write(&path, &meta, view).expect("write");
            let (read_meta, read_state) = read(&path).expect("read");
            assert_eq!(read_meta.external_work_j.to_bits(), work_j.to_bits());
            assert_eq!(read_meta, meta);
            assert_eq!(read_state, state);
            assert_eq!(summary(&path).expect("summary"), (meta, 1));
        }
    }
}
