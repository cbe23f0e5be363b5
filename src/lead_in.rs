//! `shatter lead-in`: the intact body's rigid flight to its first contact, before the
//! simulation.

use shatter_core::PipelineConfig;

use crate::Failure;
use crate::progress_bars::for_stderr;

/// Runs the lead-in.
pub fn run(config: &PipelineConfig) -> Result<(), Failure> {
    let report = shatter_rigid::run_lead_in(config, &*for_stderr())?;
    let lead_in = &report.lead_in;
    let [vx, vy, vz] = lead_in.velocity_m_s;
    println!(
        "lead-in: {} frames; the simulation starts at {:.4} s, {:.2} mm from the first contact, at {:.3} m/s",
        lead_in.frames,
        lead_in.handoff_time_s,
        report.gap_m * 1e3,
        (vx * vx + vy * vy + vz * vz).sqrt()
    );
    println!(
        "wrote {} in {:.2} s ({} rigid steps of {:.3e} s)",
        shatter_core::OutputLayout::of(config).lead_in().display(),
        report.wall_s,
        lead_in.steps,
        report.step_s
    );
    Ok(())
}
