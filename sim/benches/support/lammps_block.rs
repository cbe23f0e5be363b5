//! LAMMPS on the benchmarks' simple cubic block, made by LAMMPS's own lattice commands.

use crate::lammps_run::{LammpsCase, run_lines};

/// A `side`^3 simple cubic block of 1 mm cubes (`atom_style peri`, density 2200) with the pair
/// style and coefficients `pair` (the `pair_style` and `pair_coeff` lines).
pub fn block_input(side: usize, pair: &str, timestep_s: f64, steps: usize) -> LammpsCase {
    let input = format!(
        "units si\nboundary s s s\natom_style peri\natom_modify map array\nneighbor 0.0005 bin\n\
         lattice sc 0.001\nregion block block 0 {last} 0 {last} 0 {last}\ncreate_box 1 block\n\
         create_atoms 1 region block\n{pair}\n\
         set group all density 2200\nset group all volume 1.0e-9\n{run}",
        last = side - 1,
        run = run_lines(timestep_s, steps)
    );
    LammpsCase { input, data: None }
}
