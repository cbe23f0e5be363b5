//! What each stage's outputs were made from, as a digest stored in the outputs themselves, so a
//! later stage can tell outputs of other inputs (stale) from its own inputs, whichever command
//! runs it: the simulation's frames carry [`sim_inputs`], post's fragments files
//! [`post_inputs`].

use crate::PipelineConfig;

/// A hash of everything that shapes a simulation besides the particle file: the `[sim]` and
/// `[material]` settings.
pub fn sim_settings(config: &PipelineConfig) -> u32 {
    let mut settings = serde_json::json!({ "sim": config.sim, "material": config.material });
    // the lead-in sets where the simulation starts (absent, the digest is what it always was)
    if let Some(lead_in) = &config.lead_in {
        settings["lead_in"] = serde_json::json!({ "lead_in": lead_in, "fps": config.scene.frames_per_second });
    }
    // the timeline sets the frames, which with [rigid] end at its longest fracture
    if let Some(timeline) = &config.timeline {
        let fracture_cap_s = config.rigid.as_ref().map(|rigid| rigid.max_fracture_duration_s);
        settings["timeline"] = serde_json::json!({ "timeline": timeline, "fracture_cap_s": fracture_cap_s });
    }
    crc32fast::hash(settings.to_string().as_bytes())
}

/// What a simulation's frames are made from: the particle file (by its checksum) and
/// [`sim_settings`].
pub fn sim_inputs(particles_checksum: u32, config: &PipelineConfig) -> u32 {
    let mut hasher = crc32fast::Hasher::new();
    hasher.update(&particles_checksum.to_le_bytes());
    hasher.update(&sim_settings(config).to_le_bytes());
    hasher.finalize()
}

/// What post's fragments are made from: the frames (by their [`sim_inputs`]) and the `[post]`
/// settings.
pub fn post_inputs(sim_inputs: u32, config: &PipelineConfig) -> u32 {
    let mut hasher = crc32fast::Hasher::new();
    hasher.update(&sim_inputs.to_le_bytes());
    hasher.update(serde_json::json!({ "post": config.post }).to_string().as_bytes());
    hasher.finalize()
}

/// What the follow-through's frames are made from: the fragments (by their [`post_inputs`]),
/// the `[rigid]` settings and the frame rate.
pub fn rigid_inputs(post_inputs: u32, config: &PipelineConfig) -> u32 {
    let mut hasher = crc32fast::Hasher::new();
    hasher.update(&post_inputs.to_le_bytes());
    let settings = serde_json::json!({ "rigid": config.rigid, "fps": config.scene.frames_per_second });
    hasher.update(settings.to_string().as_bytes());
    hasher.finalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn each_digest_follows_its_inputs_and_only_them() {
        let text = "[scene]\nname = \"t\"\noutput_dir = \"out\"\nseed = 1\n[geometry]\nsource = \"box\"\n\
                    box_size_m = [0.004, 0.004, 0.004]\nsampler = \"grid\"\nspacing_m = 0.001\nhorizon_factor = 2.0\n\
                    [material]\ndensity_kg_m3 = 2200.0\nbulk_modulus_pa = 14.9e9\n";
        let config = PipelineConfig::from_toml_str(text, Path::new("p.toml")).expect("config");
        let mut other_sim = config.clone();
        other_sim.sim.steps_per_frame += 1;
        let mut other_post = config.clone();
        other_post.post.usd = !other_post.post.usd;
        let mut other_render = config.clone();
        other_render.render.samples_per_pixel += 1;
        let base = sim_inputs(7, &config);
        assert_ne!(base, sim_inputs(8, &config), "the particle file");
        assert_ne!(base, sim_inputs(7, &other_sim), "the [sim] settings");
        assert_eq!(base, sim_inputs(7, &other_post), "[post] does not shape the frames");
        assert_ne!(post_inputs(base, &config), post_inputs(base, &other_post), "the [post] settings");
        assert_eq!(post_inputs(base, &config), post_inputs(base, &other_render), "[render] shapes no stage file");
    }
}
