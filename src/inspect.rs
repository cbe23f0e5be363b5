//! `shatter inspect`: summarise any stage file (particles, checkpoint, point caches of the
//! simulation and of post, break log, fragments, the USD shot, rendered EXR frames).

use std::io::Read;
use std::path::Path;

use serde_json::json;
use shatter_core::checkpoint;
use shatter_core::fragments::{AFFINE_RIGID, FragmentFrame};
use shatter_core::frames::{BreakLog, PointFrame};
use shatter_core::lead_in::LeadIn;
use shatter_core::particles::ParticleSet;
use shatter_core::ply::PointCache;
use shatter_core::reentry::Reentry;
use shatter_core::rigid_checkpoint::RigidCheckpoint;
use shatter_core::stage_file::{StageKind, read_header};
use shatter_post::components::size_histogram;
use shatter_rigid::checkpoint_world;

use crate::Failure;

/// Prints a summary of the file at `path`, as text or JSON.
pub fn run(path: &Path, json: bool) -> Result<(), Failure> {
    let mut magic = [0u8; 8];
    let read = std::fs::File::open(path)
        .and_then(|mut file| file.read(&mut magic))
        .map_err(|error| anyhow::anyhow!("{}: cannot read: {error}", path.display()))?;
    let summary = if magic[..read.min(4)] == *b"ply\n" {
        point_frame(path)?
    } else if magic[..read.min(4)] == [0x76, 0x2f, 0x31, 0x01] {
        exr_frame(path)?
    } else if magic[..read.min(5)] == *b"#usda" {
        usd_shot(path)?
    } else if &magic == b"SHBREAKS" {
        break_log(path)?
    } else {
        // stage files; anything else gets the stage reader's "not a shatter stage file"
        match read_header(path)?.kind {
            StageKind::Particles => serde_json::to_value(ParticleSet::read(path)?.summary())?,
            StageKind::Checkpoint => {
                let (meta, particles) = checkpoint::summary(path)?;
                json!({"kind": "checkpoint", "particles": particles, "frame": meta.frame, "step": meta.step,
                       "broken_bonds": meta.broken_bonds, "external_work_j": meta.external_work_j,
                       "initial_energy_j": meta.initial_energy_j})
            }
            StageKind::Fragments => {
                let frame = FragmentFrame::read(path)?;
                let largest = frame.elements.iter().copied().max().unwrap_or(0);
                let mut summary = json!({"kind": "fragments", "frame": frame.meta.frame, "step": frame.meta.step,
                       "time_s": frame.meta.time_s, "elements": frame.fragment_of.len(),
                       "fragments": frame.fragment_count(), "largest_fragment_elements": largest,
                       "size_histogram": size_histogram(&frame.elements), "smoothed": frame.meta.smoothed});
                if let Some(shares) = frame.mass_shares() {
                    summary["largest_fragment_mass_share"] = json!(shares.largest);
                    summary["fragments_over_1_percent_of_mass"] = json!(shares.over_one_percent);
                    summary["single_element_mass_share"] = json!(shares.single_elements);
                }
                if let Some(affine) = &frame.element_affine {
                    // deformed elements (post.element_shapes): those drawn in their own shape
                    let deformed = affine.iter().filter(|a| **a != AFFINE_RIGID).count();
                    summary["deformed_elements"] = json!(deformed);
                }
                summary
            }
            StageKind::LeadIn => {
                let lead_in = LeadIn::read(path)?;
                let mut summary = serde_json::to_value(&lead_in)?;
                if !lead_in.others.is_empty() {
                    // a re-entry of pieces that met: each body's particles
                    let mut counts = vec![0usize; lead_in.others.len() + 1];
                    for &body in &lead_in.body_of {
                        counts[body as usize] += 1;
                    }
                    summary["particles_per_body"] = json!(counts);
                }
                if let Some(plastic) = &lead_in.plastic {
                    // an elastoplastic re-entry's plastic state: how many bonds have flowed
                    let flowed = plastic.extension_m.iter().filter(|e| **e != 0.0).count();
                    let largest = plastic.extension_m.iter().fold(0.0f32, |most, e| most.max(e.abs()));
                    summary["plastic_bond_entries"] = json!(flowed);
                    summary["largest_plastic_extension_m"] = json!(largest);
                }
                summary
            }
            StageKind::Reentry => {
                let reentry = Reentry::read(path)?;
                let mut summary = serde_json::to_value(&reentry.meta)?;
                summary["kind"] = json!("reentry");
                summary["elements"] = json!(reentry.members.len());
                summary
            }
            StageKind::RigidCheckpoint => rigid_checkpoint(path)?,
        }
    };
    let text = if json {
        format!("{}\n", serde_json::to_string_pretty(&summary)?)
    } else {
        let mut text = format!("{}\n", path.display());
        write_text(&summary, 1, &mut text);
        text
    };
    // `shatter inspect FILE | head` closes the pipe early: that is not an error
    match std::io::Write::write_all(&mut std::io::stdout().lock(), text.as_bytes()) {
        Err(error) if error.kind() != std::io::ErrorKind::BrokenPipe => Err(error.into()),
        _ => Ok(()),
    }
}

/// The follow-through's checkpoint: where it stands, what keeps the shot from settling, and its
/// re-entries.
fn rigid_checkpoint(path: &Path) -> Result<serde_json::Value, Failure> {
    let checkpoint = RigidCheckpoint::read(path)?;
    let meta = checkpoint.meta;
    let mut summary = json!({"kind": "rigid_checkpoint", "handoff_frame": meta.handoff_frame,
           "handoff_time_s": meta.handoff_time_s, "frame": meta.frame, "last_frame": meta.last_frame,
           "rigid_steps": meta.steps, "every_piece_asleep": meta.asleep,
           "world_bytes": checkpoint.world.len()});
    // what keeps a shot from settling: pieces still awake, and the deepest overlap
    // (pieces by their index in the handoff's fragments; null is the floor or a sphere)
    let (world, reentries) = checkpoint_world(&checkpoint.world)
        .map_err(|error| anyhow::anyhow!("{}: cannot restore the rigid world: {error}", path.display()))?;
    if let Some(reentries) = reentries {
        summary["reentries"] = json!({"started": reentries.started, "active": reentries.active,
            "returned": reentries.returned, "time_s": reentries.time_s});
    }
    let awake = world.awake_pieces();
    summary["awake_pieces"] = json!(awake.len());
    if !awake.is_empty() {
        // where the awake ones are: still sliding nearby, or flung far off
        let (velocities, centres) = (world.velocities(), world.centres());
        let speed = |i: &usize| velocities[*i].0.length();
        let reach = |i: &usize| centres[*i].with_y(0.0).length();
        let fastest = awake.iter().copied().max_by(|a, b| speed(a).total_cmp(&speed(b)));
        let farthest = awake.iter().map(reach).fold(0.0, f64::max);
        let airborne = awake.iter().filter(|&&i| world.clearance_m(i) > 0.0).count();
        // rolling (spin times its reach near speed) or sliding, and how big
        let spin = |i: &usize| velocities[*i].1.length();
        let masses = world.masses_kg();
        summary["awake"] = json!({"fastest_piece": fastest, "fastest_m_s": fastest.as_ref().map(speed),
            "fastest_spin_rad_s": fastest.as_ref().map(spin),
            "fastest_mass_kg": fastest.map(|i| masses[i]),
            "farthest_from_axis_m": farthest, "airborne": airborne});
    }
    if let Some((a, b, depth)) = world.overlaps().first() {
        summary["deepest_overlap"] = json!({"pieces": [a, b], "depth_m": depth});
    }
    Ok(summary)
}

/// A simulation's point cache, post's (a `fragment` column and no velocities), or post's debris
/// points (a `broken_bonds` column).
fn point_frame(path: &Path) -> Result<serde_json::Value, Failure> {
    let cache = PointCache::read(path)?;
    if let Some(broken) = cache.ints("broken_bonds") {
        return Ok(json!({
            "kind": "debris_points",
            "frame": cache.comment("frame"),
            "time_s": cache.comment("time_s"),
            "points": cache.len(),
            "broken_bond_ends": broken.iter().map(|b| i64::from(*b)).sum::<i64>(),
        }));
    }
    if cache.floats("vx").is_none()
        && let Some(fragment) = cache.ints("fragment")
    {
        return fragment_points(path, &cache, fragment);
    }
    let frame = PointFrame::read(path)?;
    let n = frame.damage.len();
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for axis in 0..3 {
        for value in &frame.position[axis] {
            lo[axis] = lo[axis].min(*value);
            hi[axis] = hi[axis].max(*value);
        }
    }
    let speed = (0..n).map(|i| (0..3).map(|a| frame.velocity[a][i].powi(2)).sum::<f32>().sqrt()).fold(0.0f32, f32::max);
    let damaged = frame.damage.iter().filter(|d| **d > 0.0).count();
    Ok(json!({
        "kind": "point_cache",
        "frame": frame.frame,
        "step": frame.step,
        "time_s": frame.time_s,
        "particles": n,
        "bounds_m": [lo, hi],
        "max_speed_m_s": speed,
        "mean_damage": frame.damage.iter().map(|d| f64::from(*d)).sum::<f64>() / n.max(1) as f64,
        "damaged_particles": damaged,
    }))
}

/// A rendered frame: its size, channels, alpha coverage and fragment ids.
fn exr_frame(path: &Path) -> Result<serde_json::Value, Failure> {
    let (width, height, channels) = shatter_render::image_out::read_exr(path)?;
    let channel = |name: &str| channels.iter().find(|c| c.name == name);
    let covered = channel("A").map(|a| a.values.iter().filter(|v| **v > 0.0).count());
    let fragments = channel("ViewLayer.FragmentIndex.X").map(|f| {
        let mut ids: Vec<u32> = f.values.iter().map(|v| *v as u32).filter(|id| *id != 0).collect();
        ids.sort_unstable();
        ids.dedup();
        ids.len()
    });
    Ok(json!({
        "kind": "render",
        "width": width,
        "height": height,
        "channels": channels.iter().map(|c| format!("{} ({})", c.name, c.sample_type)).collect::<Vec<_>>(),
        "covered_pixels": covered,
        "fragments_seen": fragments,
    }))
}

/// Post's USD shot: its pieces and time codes.
fn usd_shot(path: &Path) -> Result<serde_json::Value, Failure> {
    let text =
        std::fs::read_to_string(path).map_err(|error| anyhow::anyhow!("{}: cannot read: {error}", path.display()))?;
    let field = |name: &str| {
        text.lines()
            .find_map(|line| line.trim().strip_prefix(name)?.trim().strip_prefix('=').map(|v| v.trim().to_owned()))
    };
    let pieces = text.lines().filter(|line| line.trim_start().starts_with("def Mesh ")).count();
    Ok(json!({
        "kind": "usd",
        "pieces": pieces,
        "start_time_code": field("startTimeCode"),
        "end_time_code": field("endTimeCode"),
        "frames_per_second": field("framesPerSecond"),
    }))
}

/// Post's point cache: positions and fragment ids.
fn fragment_points(path: &Path, cache: &PointCache, fragment: &[i32]) -> Result<serde_json::Value, Failure> {
    let frame = cache.comment("frame").and_then(|frame| frame.parse::<u32>().ok());
    let (Some(frame), Some(x), Some(y), Some(z)) = (frame, cache.floats("x"), cache.floats("y"), cache.floats("z"))
    else {
        return Err(
            anyhow::anyhow!("{}: not a shatter fragment point cache: no frame or positions", path.display()).into()
        );
    };
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for (axis, values) in [x, y, z].into_iter().enumerate() {
        for value in values {
            lo[axis] = lo[axis].min(*value);
            hi[axis] = hi[axis].max(*value);
        }
    }
    let mut ids = fragment.to_vec();
    ids.sort_unstable();
    ids.dedup();
    Ok(json!({
        "kind": "fragment_point_cache",
        "frame": frame,
        "step": cache.comment("step"),
        "time_s": cache.comment("time_s"),
        "particles": cache.len(),
        "bounds_m": [lo, hi],
        "fragments": ids.len(),
    }))
}

fn break_log(path: &Path) -> Result<serde_json::Value, Failure> {
    let blocks = BreakLog::read(path)?;
    let breaks: usize = blocks.iter().map(|b| b.events.len()).sum();
    let steps = blocks.iter().flat_map(|b| b.events.iter().map(|e| e.step));
    Ok(json!({
        "kind": "break_log",
        "blocks": blocks.len(),
        "frames": [blocks.first().map(|b| b.frame), blocks.last().map(|b| b.frame)],
        "broken_bonds": breaks,
        "first_step": steps.clone().min(),
        "last_step": steps.max(),
    }))
}

fn write_text(value: &serde_json::Value, depth: usize, text: &mut String) {
    let indent = "  ".repeat(depth);
    if let serde_json::Value::Object(map) = value {
        for (key, value) in map {
            match value {
                serde_json::Value::Object(_) => {
                    text.push_str(&format!("{indent}{key}:\n"));
                    write_text(value, depth + 1, text);
                }
                other => text.push_str(&format!("{indent}{key:<20} {other}\n")),
            }
        }
    }
}
