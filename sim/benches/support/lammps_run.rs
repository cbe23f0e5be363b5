//! LAMMPS (`lmp`, Debian's `lammps` package) on the benchmarks' particles, timed beside shatter.

use std::process::Command;

/// A LAMMPS case: its input script and, for particles read from a file, that file's text.
pub struct LammpsCase {
    /// The input script.
    pub input: String,
    /// The data file `particles.data` that the script reads, if any.
    pub data: Option<String>,
}

/// The lines shared by every case after its atoms and pair style: density 2200, small random
/// velocities, `steps` steps of `timestep_s` seconds.
pub fn run_lines(timestep_s: f64, steps: usize) -> String {
    format!(
        "velocity all create 1.0e-3 12345 dist gaussian\nfix 1 all nve\ntimestep {timestep_s:e}\n\
         thermo {steps}\nrun {steps}\n"
    )
}

/// LAMMPS's loop time for `case`, seconds, if `lmp` runs (in a temporary folder named after
/// `tag`).
pub fn loop_time_s(case: &LammpsCase, tag: &str) -> Option<f64> {
    let dir = std::env::temp_dir().join(format!("shatter-lammps-{}-{tag}", std::process::id()));
    std::fs::create_dir_all(&dir).ok()?;
    std::fs::write(dir.join("in.bench"), &case.input).ok()?;
    if let Some(data) = &case.data {
        std::fs::write(dir.join("particles.data"), data).ok()?;
    }
    let output = Command::new("lmp").args(["-in", "in.bench", "-log", "none"]).current_dir(&dir).output().ok()?;
    let _ = std::fs::remove_dir_all(&dir);
    let text = String::from_utf8_lossy(&output.stdout);
    let line = text.lines().find(|line| line.starts_with("Loop time of"));
    if line.is_none() {
        eprintln!("LAMMPS gave no loop time:\n{text}\n{}", String::from_utf8_lossy(&output.stderr));
    }
    line?.split_whitespace().nth(3)?.parse().ok()
}
