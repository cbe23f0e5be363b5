//! LAMMPS (`lmp`, Debian's `lammps` package) on the benchmarks' block, timed beside shatter.

use std::process::Command;

/// A LAMMPS input for a `side`^3 simple cubic block of 1 mm cubes (`atom_style peri`, density
/// 2200, small random velocities) with the pair style and coefficients `pair` (the `pair_style`
/// and `pair_coeff` lines), run `steps` steps of `timestep_s` seconds.
pub fn block_input(side: usize, pair: &str, timestep_s: f64, steps: usize) -> String {
    format!(
        "units si\nboundary s s s\natom_style peri\natom_modify map array\nneighbor 0.0005 bin\n\
         lattice sc 0.001\nregion block block 0 {last} 0 {last} 0 {last}\ncreate_box 1 block\n\
         create_atoms 1 region block\n{pair}\n\
         set group all density 2200\nset group all volume 1.0e-9\n\
         velocity all create 1.0e-3 12345 dist gaussian\nfix 1 all nve\ntimestep {timestep_s:e}\n\
         thermo {steps}\nrun {steps}\n",
        last = side - 1
    )
}

/// LAMMPS's loop time for `input`, seconds, if `lmp` runs (in a temporary folder named after
/// `tag`).
pub fn loop_time_s(input: &str, tag: &str) -> Option<f64> {
    let dir = std::env::temp_dir().join(format!("shatter-lammps-{}-{tag}", std::process::id()));
    std::fs::create_dir_all(&dir).ok()?;
    std::fs::write(dir.join("in.bench"), input).ok()?;
    let output = Command::new("lmp").args(["-in", "in.bench", "-log", "none"]).current_dir(&dir).output().ok()?;
    let _ = std::fs::remove_dir_all(&dir);
    let text = String::from_utf8_lossy(&output.stdout);
    let line = text.lines().find(|line| line.starts_with("Loop time of"))?;
    line.split_whitespace().nth(3)?.parse().ok()
}
