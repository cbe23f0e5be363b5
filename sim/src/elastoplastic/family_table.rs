//! The state-based model's bonds in a fixed-stride layout: every particle's family has `stride`
//! entries (its file row, then padding), interleaved by groups of [`LANES`] particles: entry k
//! of particle i sits at (i / 8) 8 stride + 8 k + i % 8 ([`FamilyView::entry`]). The passes then
//! work on eight particles at once, one lane each, and load entry k of all eight as one vector;
//! each lane still walks its own family in order, so every sum is the one-particle sum. A chunk
//! of particles (a multiple of eight) owns one contiguous run of entries, and each pass splits
//! the arrays by plain chunks. A bond is stored in both its particles' families: the
//! state-based force scalar t_ij depends on i's dilatation and i's plastic extension of the
//! bond, so t_ij and t_ji differ.

use rayon::prelude::*;
use shatter_core::particles::ParticleSet;

use super::StateBasedConstants;
use super::passes::{
    ChunkOutputs, DilatationInputs, DilatationOutputs, FamilyView, ForceInputs, LANES, Record, bond_forces, dilatation,
    energy_j, stiffness_n_m,
};
use crate::SimError;
use crate::bond_layouts::row_layout::rest_vector;

/// The bonds, their state, and the per-particle values the passes share.
#[derive(Debug, Clone)]
pub struct FamilyTable {
    /// Entries per particle: the longest family.
    pub stride: usize,
    /// Particles per chunk of every pass (a function of the particle count only; a multiple of
    /// [`LANES`]).
    pub chunk_size: usize,
    /// The model's constants.
    pub constants: StateBasedConstants,
    /// Partner particle of each entry (the particle itself for padding; 0 past the last
    /// particle).
    pub neighbor: Vec<u32>,
    /// The entry of the same bond in the partner's family.
    pub reverse: Vec<u32>,
    /// Rest vector xi = X_j - X_i, metres.
    pub rest_vector: [Vec<f32>; 3],
    /// Rest length |xi|, metres (1 for padding).
    pub rest_length_m: Vec<f32>,
    /// Influence omega = delta / |xi|; 0 for padding and once the bond has broken.
    pub influence: Vec<f32>,
    /// Critical value of the weighted elastic stretch (e - e_p) / (omega |xi|), art direction
    /// included.
    pub threshold: Vec<f32>,
    /// 1 / (omega_mean |xi|), omega_mean the mean of both ends' influences (1 / delta without
    /// anisotropy): (e - e_p) times it is the paper's weighted elastic stretch s_e / omega.
    pub break_scale: Vec<f32>,
    /// The partner's influence omega_ji of each entry (0 for padding).
    pub reverse_influence: Vec<f32>,
    /// Plastic deviatoric extension e_p of each entry, metres: the model's per-bond state.
    pub plastic_m: Vec<f32>,
    /// The next evaluation's plastic extensions (scratch: the buffers swap after each).
    pub plastic_next: Vec<f32>,
    /// No yield and every plastic extension zero: they stay zero, and the force pass skips them.
    pub plastic_frozen: bool,
    /// Each entry's extension at the last evaluation, metres (scratch).
    pub extension: Vec<f32>,
    /// The particle file's row offsets: the id of bond (i, j), i < j, is `file_offset[i]` plus
    /// its place in i's row.
    pub file_offset: Vec<u64>,
    /// Particle volumes V_i, m^3.
    pub volume: Vec<f32>,
    /// Weighted volume m_i = sum of omega |xi|^2 V_j over the family (or pi delta^5), m^5.
    pub weighted_volume: Vec<f32>,
    /// Each particle's [V, 15 mu / m, 3 K / m, yield force] (see [`FamilyView::particle`]).
    pub particle: Vec<[f32; 4]>,
    /// What the passes gather of each partner, one 32-byte record per particle (see
    /// [`super::passes::Record`]).
    pub record: Vec<[f32; 8]>,
    /// Dilatation theta_i at the last force evaluation (scratch).
    pub dilatation: Vec<f32>,
    /// Damage phi_i = 1 - intact / initial bonds, as of the step's start (scratch).
    pub damage: Vec<f32>,
    /// Intact bonds per particle.
    pub intact: Vec<u32>,
    /// Bonds per particle in the particle file.
    pub initial: Vec<u32>,
    /// Bonds broken in the last force evaluation, per chunk, logged by the lower particle.
    pub breaks: Vec<Vec<u64>>,
}

impl FamilyTable {
    /// The table of a particle set: `threshold(k)` is the critical stretch of file entry k
    /// (jitter, material rescale and art direction included). `chunk_size` must be a multiple of
    /// [`LANES`].
    pub fn new(
        particles: &ParticleSet,
        constants: StateBasedConstants,
        chunk_size: usize,
        threshold: impl Fn(usize) -> f32 + Sync,
    ) -> Result<FamilyTable, SimError> {
        let n = particles.len();
        let bonds = &particles.bonds;
        assert!(chunk_size.is_multiple_of(LANES), "chunks of whole lane groups");
        let stride = (0..n).map(|i| bonds.row(i).len()).max().unwrap_or(0).max(1);
        let entries = n.next_multiple_of(LANES).checked_mul(stride).filter(|e| *e <= u32::MAX as usize).ok_or_else(|| {
            SimError::BadInput(format!(
                "the elastoplastic model stores {n} families of up to {stride} bonds; that is more than 2^32 entries"
            ))
        })?;
        let delta = particles.meta.delta_m;
        let position = &particles.rest_position_m;
        let mut table = FamilyTable {
            stride,
            chunk_size,
            constants,
            neighbor: vec![0; entries],
            reverse: vec![0; entries],
            rest_vector: [vec![0.0; entries], vec![0.0; entries], vec![0.0; entries]],
            rest_length_m: vec![1.0; entries],
            influence: vec![0.0; entries],
            threshold: vec![f32::INFINITY; entries],
            break_scale: vec![0.0; entries],
            reverse_influence: vec![0.0; entries],
            plastic_m: vec![0.0; entries],
            plastic_next: vec![0.0; entries],
            plastic_frozen: constants.yield_force_n_m6 == f64::INFINITY,
            extension: vec![0.0; entries],
            file_offset: bonds.offsets.clone(),
            volume: particles.volume_m3.clone(),
            weighted_volume: vec![0.0; n],
            particle: vec![[0.0; 4]; n],
            record: vec![[0.0; 8]; n],
            dilatation: vec![0.0; n],
            damage: vec![0.0; n],
            intact: (0..n).map(|i| bonds.row(i).len() as u32).collect(),
            initial: (0..n).map(|i| bonds.row(i).len() as u32).collect(),
            breaks: vec![Vec::new(); n.div_ceil(chunk_size)],
        };
        let entry = |i: usize, k: usize| FamilyView::entry_of(stride, i, k);
        for i in 0..n {
            for (local, k) in bonds.row(i).enumerate() {
                let e = entry(i, local);
                let j = bonds.neighbor[k] as usize;
                table.neighbor[e] = j as u32;
                let xi = rest_vector(position[i], position[j]);
                for (axis, lanes) in table.rest_vector.iter_mut().enumerate() {
                    lanes[e] = xi[axis];
                }
                table.rest_length_m[e] = bonds.rest_length_m[k];
                table.influence[e] = constants.influence(delta, position[i], xi);
                table.threshold[e] = threshold(k);
                let back = bonds.find(j, i as u32).ok_or_else(|| {
                    SimError::BadInput(format!("the particle file's bond {i}-{j} is missing from particle {j}'s row"))
                })?;
                table.reverse[e] = entry(j, back - bonds.row(j).start) as u32;
            }
            for local in bonds.row(i).len()..stride {
                table.neighbor[entry(i, local)] = i as u32;
            }
        }
        for i in 0..n {
            for local in 0..bonds.row(i).len() {
                let e = entry(i, local);
                let back = table.reverse[e] as usize;
                let mean = 0.5 * (f64::from(table.influence[e]) + f64::from(table.influence[back]));
                table.break_scale[e] = (1.0 / (mean * f64::from(table.rest_length_m[e]))) as f32;
                table.reverse_influence[e] = table.influence[back];
            }
        }
        let weighted = constants.weighted_volumes(particles);
        table.particle = constants.particle_values(&table.volume, &weighted, delta);
        table.weighted_volume = weighted;
        for (record, particle) in table.record.iter_mut().zip(&table.particle) {
            [record[Record::VOLUME], record[Record::DEVIATORIC], record[Record::DILATATIONAL]] =
                [particle[0], particle[1], particle[2]];
        }
        Ok(table)
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.volume.len()
    }

    /// True without particles.
    pub fn is_empty(&self) -> bool {
        self.volume.is_empty()
    }

    /// Marks bonds broken by id (sorted or not): both entries lose their influence, and the
    /// intact counts follow.
    pub fn mark_broken(&mut self, ids: &[u64]) {
        for &id in ids {
            let i = self.file_offset.partition_point(|offset| *offset <= id) - 1;
            let e = FamilyView::entry_of(self.stride, i, (id - self.file_offset[i]) as usize);
            for entry in [e, self.reverse[e] as usize] {
                self.influence[entry] = 0.0;
            }
        }
        let stride = self.stride;
        let influence = &self.influence;
        self.intact.par_iter_mut().enumerate().for_each(|(i, intact)| {
            *intact = (0..stride).filter(|&k| influence[FamilyView::entry_of(stride, i, k)] > 0.0).count() as u32;
        });
    }

    /// The plastic extensions in the particle file's entry order (for checkpoints).
    pub fn plastic_in_file_order(&self) -> Vec<f32> {
        let n = self.len();
        let total = self.file_offset[n] as usize;
        let mut out = Vec::with_capacity(total);
        for i in 0..n {
            let count = (self.file_offset[i + 1] - self.file_offset[i]) as usize;
            out.extend((0..count).map(|k| self.plastic_m[FamilyView::entry_of(self.stride, i, k)]));
        }
        out
    }

    /// Sets the plastic extensions from the particle file's entry order (a checkpoint's). Fails
    /// when `plastic` does not hold one value per file entry.
    pub fn set_plastic_from_file_order(&mut self, plastic: &[f32]) -> Result<(), String> {
        let n = self.len();
        let total = self.file_offset[n] as usize;
        if plastic.len() != total {
            return Err(format!("{} plastic extensions for {total} bond entries", plastic.len()));
        }
        for i in 0..n {
            let (start, end) = (self.file_offset[i] as usize, self.file_offset[i + 1] as usize);
            for (k, value) in plastic[start..end].iter().enumerate() {
                self.plastic_m[FamilyView::entry_of(self.stride, i, k)] = *value;
            }
        }
        self.plastic_frozen = self.constants.yield_force_n_m6 == f64::INFINITY && plastic.iter().all(|p| *p == 0.0);
        Ok(())
    }
}

impl FamilyTable {
    /// What the passes read of the bonds and particles.
    pub fn view(&self) -> FamilyView<'_> {
        FamilyView {
            stride: self.stride,
            neighbor: &self.neighbor,
            reverse: &self.reverse,
            rest_vector: [&self.rest_vector[0], &self.rest_vector[1], &self.rest_vector[2]],
            rest_length_m: &self.rest_length_m,
            reverse_influence: &self.reverse_influence,
            particle: &self.particle,
            weighted_volume: &self.weighted_volume,
        }
    }

    /// Entry k of particle i's family.
    pub fn entry(&self, i: usize, k: usize) -> usize {
        FamilyView::entry_of(self.stride, i, k)
    }

    /// One force evaluation at displacements `disp`: the two passes, each over the chunks in
    /// parallel. Writes the bond forces into `force` (newtons) and leaves the bonds broken in
    /// [`FamilyTable::breaks`]; moves the plastic extensions.
    pub fn evaluate(&mut self, disp: [&[f32]; 3], force: [&mut [f32]; 3]) {
        let (size, stride) = (self.chunk_size, self.stride);
        let run = size * stride;
        self.record.par_chunks_mut(size).enumerate().for_each(|(c, record)| {
            for (local, r) in record.iter_mut().enumerate() {
                let i = c * size + local;
                (r[0], r[1], r[2]) = (disp[0][i], disp[1][i], disp[2][i]);
            }
        });
        // the view borrows the geometry; the passes' outputs are taken out meanwhile
        let mut theta = std::mem::take(&mut self.dilatation);
        let mut damage = std::mem::take(&mut self.damage);
        let mut record = std::mem::take(&mut self.record);
        let mut plastic_next = std::mem::take(&mut self.plastic_next);
        let mut extension = std::mem::take(&mut self.extension);
        let mut influence = std::mem::take(&mut self.influence);
        let mut intact = std::mem::take(&mut self.intact);
        let mut breaks = std::mem::take(&mut self.breaks);
        {
            let view = self.view();
            let first_pass =
                DilatationInputs { influence: &influence, record: &record, intact: &intact, initial: &self.initial };
            (theta.par_chunks_mut(size), damage.par_chunks_mut(size), extension.par_chunks_mut(run))
                .into_par_iter()
                .enumerate()
                .for_each(|(c, (theta, damage, extension))| {
                    dilatation(&view, &first_pass, c * size, &mut DilatationOutputs { theta, damage, extension });
                });
            record.par_iter_mut().zip(theta.par_iter().zip(&damage)).for_each(|(r, (theta, damage))| {
                (r[Record::THETA], r[Record::DAMAGE]) = (*theta, *damage);
            });
            let inputs = ForceInputs {
                record: &record,
                extension: &extension,
                plastic: &self.plastic_m,
                threshold: &self.threshold,
                break_scale: &self.break_scale,
                file_offset: &self.file_offset,
            };
            let (constants, frozen) = (&self.constants, self.plastic_frozen);
            let [fx, fy, fz] = force;
            (
                influence.par_chunks_mut(run),
                plastic_next.par_chunks_mut(run),
                intact.par_chunks_mut(size),
                fx.par_chunks_mut(size),
                fy.par_chunks_mut(size),
                fz.par_chunks_mut(size),
                breaks.par_iter_mut(),
            )
                .into_par_iter()
                .enumerate()
                .for_each(|(c, (influence, plastic, intact, fx, fy, fz, breaks))| {
                    breaks.clear();
                    let mut out = ChunkOutputs { influence, plastic, intact, force: [fx, fy, fz], breaks };
                    if frozen {
                        bond_forces::<false>(&view, constants, &inputs, c * size, &mut out);
                    } else {
                        bond_forces::<true>(&view, constants, &inputs, c * size, &mut out);
                    }
                });
        }
        std::mem::swap(&mut self.plastic_m, &mut plastic_next);
        self.plastic_next = plastic_next;
        self.extension = extension;
        self.dilatation = theta;
        self.damage = damage;
        self.record = record;
        self.influence = influence;
        self.intact = intact;
        self.breaks = breaks;
    }

    /// The elastic energy stored at each particle, joules.
    pub fn energy_per_particle(&self, disp: [&[f32]; 3]) -> Vec<f64> {
        let view = self.view();
        (0..self.len())
            .into_par_iter()
            .map(|i| energy_j(&view, &self.constants, &self.influence, &self.plastic_m, disp, i))
            .collect()
    }

    /// The largest stable time step, seconds: min over particles of sqrt(2 m_i / k_i) with
    /// k_i [`stiffness_n_m`] and m_i the particle's mass at `density_kg_m3`.
    pub fn stable_dt_s(&self, density_kg_m3: f64) -> f64 {
        let view = self.view();
        (0..self.len())
            .into_par_iter()
            .map(|i| {
                let k = stiffness_n_m(&view, &self.constants, &self.influence, i);
                let mass = density_kg_m3 * f64::from(self.volume[i]);
                if k > 0.0 { (2.0 * mass / k).sqrt() } else { f64::INFINITY }
            })
            .reduce(|| f64::INFINITY, f64::min)
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use shatter_core::NoProgress;
    use shatter_core::config::PipelineConfig;
    use shatter_core::random::splitmix64;

    use super::*;

    #[test]
    fn entries_and_places_are_inverse() {
        for stride in [1, 3, 17] {
            let mut seen = vec![false; 24 * stride];
            for i in 0..24 {
                for k in 0..stride {
                    let e = FamilyView::entry_of(stride, i, k);
                    assert!(!seen[e], "entry {e} twice");
                    seen[e] = true;
                    assert_eq!(FamilyView::place_of(stride, e), (i, k));
                }
            }
        }
    }

    /// An elastic table skips its frozen plastic extensions; the general pass, made to read and
    /// write them, gives the same bits: forces, breaks, influences, and zeros left zero.
    #[test]
    fn the_frozen_plastic_pass_gives_the_general_passs_bits() {
        // 7 x 5 x 3 = 105 particles: the last lane group is partly empty
        let text = r#"
[scene]
name = "frozen"
output_dir = "out"
seed = 3
[geometry]
source = "box"
box_size_m = [0.007, 0.005, 0.003]
sampler = "grid"
spacing_m = 0.001
horizon_factor = 2.5
[material]
model = "elastoplastic"
density_kg_m3 = 2200.0
bulk_modulus_pa = 14.9e9
shear_modulus_pa = 8e9
critical_stretch = 0.004
"#;
        let config = PipelineConfig::from_toml_str(text, Path::new("/nonexistent/pipeline.toml")).expect("config");
        let particles = shatter_preprocess::preprocess(&config, &NoProgress).expect("preprocess").particles;
        let n = particles.len();
        assert_eq!(n % LANES, 1);
        let constants = StateBasedConstants::of(&config, particles.meta.delta_m);
        let frozen = FamilyTable::new(&particles, constants, 1024, |_| 0.004).expect("table");
        assert!(frozen.plastic_frozen);
        let mut general = frozen.clone();
        general.plastic_frozen = false;
        let random = |i: usize, axis: usize| (splitmix64((3 * i + axis) as u64) % 2001) as f32 / 1000.0 - 1.0;
        let disp: [Vec<f32>; 3] = [0, 1, 2].map(|axis| (0..n).map(|i| 8e-6 * random(i, axis)).collect());
        let run = |table: &mut FamilyTable| {
            let mut force = [vec![0.0f32; n], vec![0.0f32; n], vec![0.0f32; n]];
            let [fx, fy, fz] = &mut force;
            table.evaluate([&disp[0], &disp[1], &disp[2]], [fx, fy, fz]);
            let breaks: Vec<u64> = table.breaks.iter().flatten().copied().collect();
            (force, breaks)
        };
        let (mut frozen_table, mut general_table) = (frozen, general);
        let (frozen_force, frozen_breaks) = run(&mut frozen_table);
        let (general_force, general_breaks) = run(&mut general_table);
        assert_eq!(frozen_table.influence, general_table.influence);
        assert_eq!(frozen_table.intact, general_table.intact);
        assert!(!general_breaks.is_empty() && general_breaks.len() * 4 < particles.bonds.neighbor.len());
        assert!(general_breaks.is_sorted());
        assert_eq!(frozen_breaks, general_breaks);
        for axis in 0..3 {
            let same = frozen_force[axis].iter().zip(&general_force[axis]).all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "forces along axis {axis} differ");
        }
        assert!(general_table.plastic_m.iter().chain(&general_table.plastic_next).all(|p| *p == 0.0));
    }
}
