//! LAMMPS on a particle set that is not a lattice: the particles written as a data file.

use std::fmt::Write;

use crate::lammps_run::{LammpsCase, run_lines};

/// Particles at `positions_m` with `volumes_m3` (density 2200), read from a data file, with the
/// pair style `pair`. `lattice_m` is the spacing LAMMPS's peri styles take for their volume
/// correction (they require a lattice, though the atoms are not on it).
pub fn particles_input(
    positions_m: &[[f32; 3]],
    volumes_m3: &[f32],
    lattice_m: f64,
    pair: &str,
    timestep_s: f64,
    steps: usize,
) -> LammpsCase {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in positions_m {
        for axis in 0..3 {
            lo[axis] = lo[axis].min(f64::from(p[axis]));
            hi[axis] = hi[axis].max(f64::from(p[axis]));
        }
    }
    let margin = lattice_m;
    let mut data = format!("shatter benchmark particles\n\n{} atoms\n1 atom types\n\n", positions_m.len());
    for (axis, name) in ["x", "y", "z"].iter().enumerate() {
        let _ = writeln!(data, "{:e} {:e} {name}lo {name}hi", lo[axis] - margin, hi[axis] + margin);
    }
    data.push_str("\nAtoms # peri\n\n");
    for (i, (p, v)) in positions_m.iter().zip(volumes_m3).enumerate() {
        let _ = writeln!(data, "{} 1 {v:e} 2200 {:e} {:e} {:e}", i + 1, p[0], p[1], p[2]);
    }
    let input = format!(
        "units si\nboundary s s s\natom_style peri\natom_modify map array\nneighbor {skin:e} bin\n\
         lattice sc {lattice_m:e}\nread_data particles.data\n{pair}\n{run}",
        skin = lattice_m / 2.0,
        run = run_lines(timestep_s, steps)
    );
    LammpsCase { input, data: Some(data) }
}
