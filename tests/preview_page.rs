//! `shatter preview` in a real browser: Debian's headless `chromium`, driven through
//! `chromedriver` (WebDriver; scripts/test.sh installs both), draws with WebGL on SwiftShader.
//! The page loads for the default scene (previewed at about 4,000 particles), its frames arrive and
//! the canvas follows the frame slider; its fragment figures and ids are post's, and it colours by
//! fragment; an edit of the projectile's speed restarts the preview and changes the bonds broken; "Save" shows the diff
//! and writes that value alone into the scene's file, its comment kept; a refused edit shows the
//! config check's message; a click on the plate aims the projectile there; the console stays
//! free of errors. A drop's preview shows the lead-in's, the simulation's and the
//! follow-through's frames in turn. The canvas, at the first run's
//! last frame, is within a FLIP bound of its golden (`SHATTER_BLESS=1` rewrites it).

use std::path::Path;

use serde_json::json;
use shatter_core::fragments::FragmentFrame;

use crate::support;
use crate::support::preview::{Browser, DROP, Message, finished_run, scratch_run, start_preview};

/// The default scene (`pipeline.toml`), its assets' paths made absolute so that it runs from a
/// folder of its own.
fn default_scene() -> String {
    let root = env!("CARGO_MANIFEST_DIR");
    let text = std::fs::read_to_string(Path::new(root).join("pipeline.toml")).expect("pipeline.toml");
    text.replace("\"assets/", &format!("\"{root}/assets/"))
}

/// The canvas's golden, at the first run's last frame.
const GOLDEN: &str = "tests/golden/preview_page.png";
/// Largest mean FLIP error of the canvas against its golden (the same machine gives the same
/// pixels; SwiftShader elsewhere may round differently at the points' edges).
const MAX_MEAN_FLIP: f32 = 0.02;

/// A script's first line: `hash()`, the canvas's pixels hashed in the page.
const CANVAS_HASH: &str = "const hash = () => { const c = document.getElementById('view').toDataURL(); \
    let h = 0; for (let i = 0; i < c.length; i++) { h = (h * 31 + c.charCodeAt(i)) | 0; } return h; };";

/// The run's generation and bonds broken once it has finished and its last frame is drawn, else
/// null.
const FINISHED_RUN: &str = "const s = shatterPreview.state; \
    return s && s.run && s.run.status === 'finished' && shatterPreview.frames.length === s.run.frames \
    && shatterPreview.shown === s.run.frames ? [s.run.generation, s.run.broken_bonds[s.run.broken_bonds.length - 1] || 0] : null;";

#[test]
fn the_preview_page_draws_frames_restarts_on_an_edit_and_refuses_a_bad_one() {
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = default_scene();
    std::fs::write(dir.path().join("pipeline.toml"), &scene).expect("config");
    let (preview, url) = start_preview(dir.path(), 4000);
    let browser = Browser::start();
    browser.command("url", json!({ "url": url }));

    browser.wait_for("a frame drawn", "return shatterPreview.frames.length > 0 && shatterPreview.framesDrawn > 0");
    let run = browser.wait_for("the first run to finish", FINISHED_RUN);
    // the canvas follows the slider: the rest state differs from the last frame (the frames may
    // all have landed before the first was drawn, so the slider is moved, not the run awaited)
    let last = browser.script(&format!("{CANVAS_HASH} return hash();"));
    browser.script("document.getElementById('follow').checked = false; document.getElementById('frame').value = 1;");
    browser.wait_for(
        "the rest state drawn",
        &format!("{CANVAS_HASH} return shatterPreview.shown === 1 && hash() !== {last};"),
    );
    browser.script("document.getElementById('follow').checked = true;");
    browser.wait_for("the last frame drawn again", FINISHED_RUN);
    let (generation, broken) = (run[0].as_u64().expect("generation"), run[1].as_u64().expect("broken bonds"));
    assert_eq!(generation, 1);
    assert!(broken > 0, "the projectile breaks bonds");
    assert!(dir.path().join("out").symlink_metadata().is_err(), "the preview wrote into the scene's output folder");
    matches_golden(&browser.screenshot("#view"));
    fragments_match_post(&browser, &url, preview.0.id());

    // a slower projectile: the preview restarts and breaks another number of bonds
    browser.type_into("input[name='sim.projectile[0].velocity_m_s']", "[0, 0, -60]");
    browser.click("#apply");
    let slower = browser.wait_for(
        "the edited run to finish",
        &FINISHED_RUN.replace("return s && s.run", "return s && s.run && s.run.generation === 2"),
    );
    let broken_slower = slower[1].as_u64().expect("broken bonds");
    assert_ne!(broken_slower, broken, "bonds broken at 60 m/s and at 150 m/s");
    // the bound tells the two apart
    if !std::env::var("SHATTER_BLESS").is_ok_and(|value| value == "1") {
        let reference = image::open(Path::new(env!("CARGO_MANIFEST_DIR")).join(GOLDEN)).expect("golden").to_rgb8();
        let (_, mean, _) = support::flip(&reference, &browser.screenshot("#view"));
        assert!(mean > MAX_MEAN_FLIP, "the slower projectile's canvas is FLIP {mean} from the faster one's");
    }

    // "Save" shows the diff, then writes the edited value and nothing else into the scene's file
    browser.click("#save");
    let diff = browser.wait_for("the diff", "const d = document.getElementById('diff').textContent; return d || null;");
    assert!(diff.as_str().is_some_and(|diff| diff.contains("+velocity_m_s = [0.0, 0.0, -60.0]")), "{diff}");
    browser.click("#write");
    browser.wait_for("the save", "return document.getElementById('saved').textContent || null;");
    let saved = std::fs::read_to_string(dir.path().join("pipeline.toml")).expect("the scene");
    let changed: Vec<(&str, &str)> = scene.lines().zip(saved.lines()).filter(|(a, b)| a != b).collect();
    assert_eq!(changed, [("velocity_m_s = [0.0, 0.0, -150.0]", "velocity_m_s = [0.0, 0.0, -60.0]")]);
    assert_eq!(scene.lines().count(), saved.lines().count(), "every comment kept");

    // a refused edit names the key, as the CLI does, and leaves the run alone
    browser.type_into("input[name='material.bulk_modulus_pa']", "-1");
    browser.click("#apply");
    let message =
        browser.wait_for("the refusal", "const e = document.getElementById('error').textContent; return e || null;");
    let message = message.as_str().expect("text");
    assert!(message.contains("material.bulk_modulus_pa"), "{message}");
    assert_eq!(browser.script("return shatterPreview.state.run.generation"), json!(2));

    // a click on the body aims the projectile there: it keeps its direction and distance
    browser.script(
        "const i = document.querySelector(\"input[name='material.bulk_modulus_pa']\"); i.value = i.dataset.original;",
    );
    aim_by_click(&browser);

    let errors = browser.script("return shatterPreview.errors");
    assert_eq!(errors, json!([]), "the page's console");
}

/// The page's fragment figures are those of the shown frame, whose ids are post's for the same
/// frame (read from the preview's scratch folder); colouring by fragment changes the canvas.
fn fragments_match_post(browser: &Browser, url: &str, preview_pid: u32) {
    let shown = browser.script(
        "const f = shatterPreview.frames[shatterPreview.frames.length - 1]; \
         return [f.frame, f.fragments, document.getElementById('fragments').textContent, \
                 document.getElementById('histogram').dataset.counts, f.largestShare];",
    );
    let frame = shown[0].as_u64().expect("frame") as u32;
    let count = shown[1].as_u64().expect("fragments");
    assert!(count > 1, "the struck plate breaks into fragments: {shown}");
    assert_eq!(shown[2], json!(count.to_string()));
    let histogram: u64 = shown[3].as_str().expect("counts").split(',').map(|c| c.parse::<u64>().expect("count")).sum();
    assert_eq!(histogram, count, "the histogram counts every fragment");
    // the frame's ids as the server sends them, against post's file of that frame
    let ids = Message::fetch(url, "api/frame?generation=1&", frame).fragment_of;
    let post = FragmentFrame::read(&scratch_run(preview_pid).join(format!("fragments/fragments.{frame:04}.shp")))
        .expect("post's fragments");
    assert_eq!(ids, post.fragment_of, "the page's fragments are post's");
    let share = post.mass_shares().expect("mass").largest;
    assert!((shown[4].as_f64().expect("share") - share).abs() < 1e-6, "{shown} against {share}");

    let before = browser.script(&format!("{CANVAS_HASH} return hash();"));
    browser.click("#colour option[value='fragment']");
    browser.wait_for("the fragments' colours", &format!("{CANVAS_HASH} return hash() !== {before};"));
}

/// Clicks a particle of the plate's top face off its centre, on the rest frame: the projectile's
/// start moves over it, at the same height, and the preview restarts.
fn aim_by_click(browser: &Browser) {
    let generation = browser.script("return shatterPreview.state.run.generation").as_u64().expect("generation");
    let picked = browser.script(
        "document.getElementById('follow').checked = false; document.getElementById('frame').value = 1; \
         const f = shatterPreview.frames[0]; let top = -Infinity; \
         for (let i = 0; i < f.count; i++) top = Math.max(top, f.positions[3 * i + 2]); \
         let best = -1, bestD = Infinity; \
         for (let i = 0; i < f.count; i++) { if (f.positions[3 * i + 2] < top - 1e-5) continue; \
           const c = shatterPreview.state.values['sim.projectile[0].center_m']; \
           const d = Math.hypot(f.positions[3 * i] - c[0] - 0.012, f.positions[3 * i + 1] - c[1] - 0.008); \
           if (d < bestD) { best = i; bestD = d; } } \
         return [f.positions[3 * best], f.positions[3 * best + 1], shatterPreview.state.run.spacing_m];",
    );
    let target = [picked[0].as_f64().expect("x"), picked[1].as_f64().expect("y")];
    browser.wait_for("the rest frame shown", "return shatterPreview.shown === 1;");
    let at = browser.script(&format!(
        "const f = shatterPreview.frames[0]; for (let i = 0; i < f.count; i++) \
         if (f.positions[3 * i] === {} && f.positions[3 * i + 1] === {} && f.positions[3 * i + 2] > 0) \
         {{ const p = shatterPreview.project(i); return [p.x, p.y]; }} return null;",
        picked[0], picked[1]
    ));
    browser.click_at(at[0].as_f64().expect("x"), at[1].as_f64().expect("y"));
    let centre = browser.wait_for(
        "the aimed run",
        &format!(
            "const s = shatterPreview.state; return s.run.generation > {generation} ? \
             s.values['sim.projectile[0].center_m'] : null;"
        ),
    );
    let centre: Vec<f64> = centre.as_array().expect("a centre").iter().map(|v| v.as_f64().expect("number")).collect();
    // the pick is the particle under the pointer nearest the eye: this one or a neighbour on the
    // top face
    let spacing_m = picked[2].as_f64().expect("spacing");
    let off = (centre[0] - target[0]).hypot(centre[1] - target[1]);
    assert!(off < 1.5 * spacing_m, "{centre:?} aimed at {target:?}");
    assert!((centre[2] - 0.0087).abs() < 1e-6, "the projectile keeps its distance: {centre:?}");
    assert!(
        browser
            .script("return document.getElementById('aim').textContent")
            .as_str()
            .is_some_and(|t| t.contains("aimed"))
    );
}

/// Compares the canvas with [`GOLDEN`] (or rewrites it when SHATTER_BLESS=1); a canvas outside
/// the bound is written beside the golden's name under `target/`.
fn matches_golden(canvas: &image::RgbImage) {
    let golden = Path::new(env!("CARGO_MANIFEST_DIR")).join(GOLDEN);
    if std::env::var("SHATTER_BLESS").is_ok_and(|value| value == "1") {
        canvas.save(&golden).expect("write the golden");
        return;
    }
    let reference = image::open(&golden).expect("the golden (SHATTER_BLESS=1 makes it)").to_rgb8();
    assert_eq!(reference.dimensions(), canvas.dimensions(), "the canvas's size");
    let (_, mean, p99) = support::flip(&reference, canvas);
    eprintln!("preview canvas: FLIP mean {mean:.5}, 99th percentile {p99:.5}");
    if mean > MAX_MEAN_FLIP {
        let failed = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/preview_page.png");
        canvas.save(&failed).expect("write the canvas");
        panic!("the canvas is FLIP {mean:.4} from its golden (max {MAX_MEAN_FLIP}): {}", failed.display());
    }
}

/// A block dropped on the floor (the follow-through's tests' scene): the page's frames are the
/// lead-in's, the simulation's up to the handoff, then the follow-through's, in time order,
/// each placed as its stage's file says.
#[test]
fn the_preview_of_a_drop_shows_its_fall_break_and_settle() {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("pipeline.toml"), DROP).expect("config");
    let (preview, url) = start_preview(dir.path(), 600);
    let run = finished_run(&url);
    let frames = run["frames"].as_u64().expect("frames") as u32;
    let lead_in = run["lead_in_frames"].as_u64().expect("lead-in frames") as u32;
    let handoff = run["handoff"].as_u64().expect("a handoff") as u32;
    assert!(lead_in > 0 && handoff > 0 && frames > lead_in + handoff, "{run}");
    let messages: Vec<Message> =
        (1..=frames).map(|frame| Message::fetch(&url, "api/frame?generation=1&", frame)).collect();
    let sources: Vec<u32> = messages.iter().map(|m| m.source).collect();
    let stage = |f: u32| u32::from(f > lead_in) + u32::from(f > lead_in + handoff);
    assert_eq!(sources, (1..=frames).map(stage).collect::<Vec<u32>>());
    assert!(messages.windows(2).all(|pair| pair[0].time_s < pair[1].time_s), "the frames run forward in time");
    assert!(messages[0].time_s < 0.0 && messages[lead_in as usize].time_s == 0.0, "time counts from the impact");
    // the last frame: the follow-through's file's fragments, moved from the rest positions
    let out = scratch_run(preview.0.id());
    let last = FragmentFrame::read(&out.join(format!("rigid/fragments.{:04}.shp", frames - lead_in))).expect("last");
    let rest = shatter_core::particles::ParticleSet::read(&out.join("particles.shp")).expect("particles");
    let message = &messages[frames as usize - 1];
    assert_eq!((message.fragments as usize, &message.fragment_of), (last.fragment_count(), &last.fragment_of));
    for (i, (x, p)) in rest.rest_position_m.iter().zip(&message.position_m).enumerate() {
        let f = last.fragment_of[i] as usize;
        let q = glam::DQuat::from_array(last.rotation[f].map(f64::from));
        let placed = q * glam::DVec3::from_array(x.map(f64::from)) + glam::DVec3::from_array(last.translation_m[f]);
        assert!((placed.as_vec3() - glam::Vec3::from_array(*p)).length() < 1e-6, "particle {i}: {p:?} vs {placed}");
    }
}
