//! `shatter preview`: the scene live in a browser. A local web server runs the scene's own
//! stages at a coarser spacing into a scratch folder (`preview_run`: `shatter run --until rigid`
//! as a child process) and serves the page that draws its frames as they land; an edit on the
//! page restarts the run with the edited config, and "Save" writes the edits into the scene's
//! file after showing the diff.
//!
//! - `preview_config`: the scene as edited, and the preview's config from it.
//! - `preview_run`: one run of it, in its own folder.
//! - `resolution`: the spacing that gives the particle count asked for.
//! - `review`: the scene's own output folder, finished or being written: frames, plots, passes.
//! - `page_frames`: the shot's frames as far as written, whichever stage writes each.
//! - `frame_message`: one frame as the binary message the page draws.
//! - `run_folder`: what the page is shown of an output folder: frames, fragments, broken bonds.
//! - `scene_file`: "Save": the edits written into the scene's file, comments kept.
//! - `session`: the edits and the current run.
//! - `server`: the HTTP routes.
//! - `page/`: the page (WebGL2, no library).

mod frame_message;
mod page_frames;
mod preview_config;
mod preview_run;
mod resolution;
mod review;
mod run_folder;
mod scene_file;
mod server;
mod session;

use std::path::PathBuf;

use anyhow::Context;

pub use preview_config::DEFAULT_TARGET_PARTICLES;

/// `shatter preview`'s arguments.
#[derive(Debug, clap::Args)]
pub struct PreviewArgs {
    /// The port on 127.0.0.1 (0: any free one).
    #[arg(long, default_value_t = 8765)]
    port: u16,
    /// Particles the preview aims at (the page can change it).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_TARGET_PARTICLES)]
    particles: u64,
}

/// Serves the preview of the scene at `config` until the process is stopped.
pub fn run(config: PathBuf, args: &PreviewArgs) -> anyhow::Result<()> {
    // the scene's own check first: a bad config is refused as by every other command
    shatter_core::PipelineConfig::load(&config)?;
    let session = session::Session::start(config, args.particles).map_err(anyhow::Error::msg)?;
    let server = tiny_http::Server::http(("127.0.0.1", args.port))
        .map_err(|error| anyhow::anyhow!("cannot listen on 127.0.0.1:{}: {error}", args.port))?;
    let address = server.server_addr().to_ip().context("the server has no IP address")?;
    println!("preview: http://{address}/");
    server::serve(server, session);
    Ok(())
}
