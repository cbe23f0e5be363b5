//! `shatter rigid`: the follow-through on rigid bodies, after post; with
//! `[rigid.secondary_fracture]`, the simulation and post of each re-entry as the follow-through
//! meets it.

use shatter_core::reentry::{Reentry, pass_config};
use shatter_core::{OutputLayout, PipelineConfig};
use shatter_rigid::RigidReport;

use crate::Failure;
use crate::progress_bars::for_stderr;
use crate::sim::SimArgs;
use crate::{post, sim};

/// Command-line choices of `shatter rigid`.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct RigidArgs {
    /// Continue from the follow-through's checkpoint (when it belongs to the same inputs)
    /// instead of starting at the handoff.
    #[arg(long)]
    pub resume: bool,
}

/// Runs the follow-through; a re-entry it stops at is simulated (with `sim_options`, resuming
/// its own checkpoint), its fragments found, and the follow-through resumed, until it ends.
pub fn run(config: &PipelineConfig, args: &RigidArgs, sim_options: &SimArgs) -> Result<(), Failure> {
    let mut resume = args.resume;
    loop {
        let report = shatter_rigid::run_rigid(config, resume, &*for_stderr())?;
        print_report(&report);
        let Some(number) = report.awaiting_reentry else { break };
        let reentry = Reentry::read(&OutputLayout::of(config).reentry(number))?;
        let pass = pass_config(config, &reentry.meta);
        println!("re-entry {number}: simulating in {}", pass.output_dir().display());
        sim::run_resuming(&pass, sim_options)?;
        post::run(&pass)?;
        resume = true;
    }
    println!("wrote {}", OutputLayout::of(config).rigid_dir().display());
    Ok(())
}

fn print_report(report: &RigidReport) {
    println!(
        "rigid: handoff at frame {} ({:.4e} s): {}",
        report.handoff_frame, report.handoff_time_s, report.handoff_reason
    );
    if let Some(c) = report.conservation {
        println!(
            "  {} pieces; momentum kept to {:.1e}, angular momentum to {:.1e}; kinetic energy {:.4e} J in the particles \
             ({:.4e} J rigid), {:.4e} J in the bodies",
            report.pieces,
            c.momentum_error,
            c.angular_momentum_error,
            c.particle_energy_j,
            c.rigid_part_j,
            c.body_energy_j
        );
    }
    for reentry in &report.reentries {
        let c = reentry.conservation;
        println!(
            "  re-entry {}: piece {} hit {} at {:.2} m/s (hard from {:.2} m/s) at {:.4} s, back at {:.4} s as {} \
             pieces; momentum kept to {:.1e}, angular momentum to {:.1e}; kinetic energy {:.4e} J in the particles, \
             {:.4e} J in the bodies",
            reentry.number,
            reentry.pieces_in[0],
            if reentry.hit.starts_with("piece") { reentry.hit.clone() } else { format!("the {}", reentry.hit) },
            reentry.impact_speed_m_s,
            reentry.threshold_m_s,
            reentry.start_time_s,
            reentry.return_time_s,
            reentry.pieces,
            c.momentum_error,
            c.angular_momentum_error,
            c.particle_energy_j,
            c.body_energy_j
        );
    }
    if let Some(number) = report.awaiting_reentry {
        println!("  stopped at re-entry {number}: its pieces go back to the simulation");
        return;
    }
    let asleep = match report.asleep_from {
        Some(frame) => format!("; every piece asleep from frame {frame}"),
        None => format!("; {} of {} pieces still moving at the end", report.awake_at_end, report.pieces),
    };
    println!(
        "  frames {}-{} written{asleep}; deepest overlap at the end {:.2} mm in {:.1} s",
        report.last_frame + 1 - report.frames_written,
        report.last_frame,
        report.deepest_overlap_m * 1e3,
        report.wall_s
    );
}
