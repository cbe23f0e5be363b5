//! `shatter post`: frames to fragments, their motion and exports.

use shatter_core::PipelineConfig;

use crate::Failure;
use crate::progress_bars::for_stderr;

/// Runs the post stage.
pub fn run(config: &PipelineConfig) -> Result<(), Failure> {
    let report = shatter_post::run_post(config, &*for_stderr())?;
    let histogram: Vec<String> = report
        .size_histogram
        .iter()
        .filter(|(_, count)| *count > 0)
        .map(|(size, count)| format!("{count} of {size}+"))
        .collect();
    println!(
        "post: {} frames, {} fragments in the last (sizes in elements: {})",
        report.frames,
        report.fragments,
        histogram.join(", ")
    );
    println!("wrote {} in {:.1} s", report.folder.display(), report.wall_s);
    Ok(())
}
