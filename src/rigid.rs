//! `shatter rigid`: the follow-through on rigid bodies, after post.

use shatter_core::PipelineConfig;

use crate::Failure;
use crate::progress_bars::for_stderr;

/// Command-line choices of `shatter rigid`.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct RigidArgs {
    /// Continue from the follow-through's checkpoint (when it belongs to the same inputs)
    /// instead of starting at the handoff.
    #[arg(long)]
    pub resume: bool,
}

/// Runs the follow-through.
pub fn run(config: &PipelineConfig, args: &RigidArgs) -> Result<(), Failure> {
    let report = shatter_rigid::run_rigid(config, args.resume, &*for_stderr())?;
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
    let asleep = match report.asleep_from {
        Some(frame) => format!("; every piece asleep from frame {frame}"),
        None => format!("; {} of {} pieces still moving at the end", report.awake_at_end, report.pieces),
    };
    println!(
        "  frames {}-{} written{asleep}; deepest overlap at the end {:.2} mm",
        report.last_frame + 1 - report.frames_written,
        report.last_frame,
        report.deepest_overlap_m * 1e3
    );
    println!("wrote {} in {:.1} s", shatter_core::OutputLayout::of(config).rigid_dir().display(), report.wall_s);
    Ok(())
}
