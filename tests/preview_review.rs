//! `shatter preview` reviewing a scene's own output folder: a block dropped from a metre, run
//! and rendered by `shatter run`, then previewed. The review offers the folder's frames (the
//! lead-in's, the simulation's with post's debris points, the follow-through's, as the files
//! place them), the bonds broken and the kinetic energy per simulation frame, every rendered
//! frame's passes at the render's size, and the Cryptomatte pick, which names the piece the id
//! pass shows; a writer takes the folder's lock while the review reads it. In the browser, a
//! click on the preview's block turns its drop to land there; the page switches to the folder's
//! frames, draws the plot and the beauty pass, and names the piece clicked on the picture.

use serde_json::{Value, json};
use shatter_core::fragments::FragmentFrame;
use shatter_core::frames::PointFrame;
use shatter_render::image_out::read_exr;

use crate::support;
use crate::support::preview::{Browser, DROP, Message, start_preview};

fn get_json(url: &str) -> Value {
    ureq::get(url).call().unwrap_or_else(|error| panic!("{url}: {error}")).into_json().expect("JSON")
}

#[test]
fn the_preview_reviews_a_finished_run_its_frames_plots_passes_and_pieces() {
    let dir = tempfile::tempdir().expect("tempdir");
    // from a metre, and simulated until it has landed, so that it breaks where it lands
    let scene = DROP
        .replace("translate_m = [0.0, 0.05, 0.0]", "translate_m = [0.0, 1.0, 0.0]")
        .replace("steps_per_frame = 100", "steps_per_frame = 2000")
        + "[render.camera]\nposition_m = [0.04, 0.08, 0.2]\nlook_at_m = [0.04, 0.01, 0.0]\nfov_deg = 45.0\n";
    std::fs::write(dir.path().join("pipeline.toml"), scene).expect("config");
    let output = support::shatter(&["run"], dir.path());
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let out = dir.path().join("out");
    let (_preview, url) = start_preview(dir.path(), 600);

    let state = get_json(&format!("{url}api/state"));
    assert_eq!(state["review"], json!(true), "the scene's output is offered");
    let review = get_json(&format!("{url}api/review"));
    let frames = review["frames"].as_u64().expect("frames") as u32;
    let lead_in = review["lead_in_frames"].as_u64().expect("lead-in") as u32;
    let handoff = review["handoff"].as_u64().expect("handoff") as u32;
    assert!(lead_in > 0 && frames > lead_in + handoff, "{review}");
    assert_eq!(review["rendered"], json!((1..=frames).collect::<Vec<u32>>()), "every frame is rendered");
    // the kinetic energy of a simulation frame: half m v^2 over its particles
    let energy = review["kinetic_energy_j"].as_array().expect("energies");
    assert_eq!(energy.len() as u32, handoff);
    let particles = shatter_core::particles::ParticleSet::read(&out.join("particles.shp")).expect("particles");
    let points = PointFrame::read(&out.join("frames/points.0003.ply")).expect("frame 3");
    let expected: f64 = (0..particles.len())
        .map(|i| {
            let mass = f64::from(particles.volume_m3[i]) * 2200.0;
            0.5 * mass * (0..3).map(|a| f64::from(points.velocity[a][i]).powi(2)).sum::<f64>()
        })
        .sum();
    let got = energy[2].as_f64().expect("energy");
    assert!((got - expected).abs() <= 1e-9 * expected, "{got} J against {expected} J");
    assert_eq!(review["broken_bonds"].as_array().expect("broken").len() as u32, handoff - 1);

    // a simulation frame's debris points are post's
    let debris = (lead_in + 2..=lead_in + handoff)
        .map(|frame| (frame, Message::fetch(&url, "api/review/frame?", frame).debris))
        .find(|(_, points)| *points > 0)
        .expect("a frame that breaks bonds");
    let file = shatter_core::debris_points::read_point_cache(
        &out.join(format!("fragments/debris.{:04}.ply", debris.0 - lead_in)),
    )
    .expect("debris points");
    assert_eq!(debris.1, file.position.len());

    // the last frame as the follow-through's file has it, at full resolution
    let last = Message::fetch(&url, "api/review/frame?", frames);
    let rigid = FragmentFrame::read(&out.join(format!("rigid/fragments.{:04}.shp", frames - lead_in))).expect("rigid");
    assert_eq!((last.source, &last.fragment_of), (2, &rigid.fragment_of));
    assert_eq!(last.position_m.len(), particles.len());

    // each pass at the render's size; the pick names the piece the id pass shows, on the first
    // frame that shows one
    let (shown, width, ids) = (1..=frames)
        .find_map(|frame| {
            let (width, _, channels) = read_exr(&out.join(format!("render/drop.{frame:04}.exr"))).expect("a frame");
            let ids = channels.into_iter().find(|c| c.name == "ViewLayer.FragmentIndex.X").expect("id pass").values;
            ids.iter().any(|&id| id > 0.0).then_some((frame, width, ids))
        })
        .expect("a frame that shows the block");
    for pass in ["beauty", "depth", "normal", "motion"] {
        let response = ureq::get(&format!("{url}api/review/image?frame={shown}&pass={pass}")).call().expect(pass);
        let mut png = Vec::new();
        std::io::Read::read_to_end(&mut response.into_reader(), &mut png).expect("bytes");
        let image = image::load_from_memory(&png).expect("a PNG").to_rgb8();
        assert_eq!(image.dimensions(), (48, 32), "{pass}");
    }
    let pixel = ids.iter().position(|&id| id > 0.0).expect("a piece in the frame");
    let (x, y) = (pixel % width, pixel / width);
    let picked = get_json(&format!("{url}api/review/pick?frame={shown}&x={x}&y={y}"));
    let name = format!("piece_{:05}", ids[pixel] as u32 - 1);
    assert_eq!(picked["pieces"][0][0], json!(name), "{picked}");
    assert_eq!(picked["pieces"][0][1], json!(1.0), "one sample a pixel: full coverage");

    // a writer takes the folder while the review reads it
    let output = support::shatter(&["render", "--frames", "1"], dir.path());
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));

    review_in_the_browser(&url, shown, &name, (x, y));
}

/// The page's review: the folder's frames, the plot, frame `shown`'s beauty pass, a pick by
/// clicking its pixel (x, y).
fn review_in_the_browser(url: &str, shown: u32, name: &str, (x, y): (usize, usize)) {
    let browser = Browser::start();
    browser.command("url", json!({ "url": url }));
    aim_the_drop(&browser);
    browser.wait_for("the review offered", "return !document.getElementById('review').hidden;");
    browser.click("input[name='source'][value='review']");
    browser.wait_for(
        "the folder's frames",
        "const r = shatterPreview.review; return r && shatterPreview.mode === 'review' \
         && shatterPreview.frames.length === r.frames && shatterPreview.shown === r.frames;",
    );
    browser.script(&format!(
        "document.getElementById('follow').checked = false; document.getElementById('frame').value = {shown};"
    ));
    let plotted = browser.script(
        "const c = document.getElementById('plot'); const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data; \
         let lit = 0; for (let i = 3; i < d.length; i += 4) lit += d[i] > 0; return lit;",
    );
    assert!(plotted.as_u64().expect("pixels") > 100, "the plot is drawn: {plotted}");
    browser.wait_for(
        "the beauty pass",
        &format!(
            "const i = document.getElementById('rendered'); \
             return !i.hidden && i.src.includes('frame={shown}&') && i.complete && i.naturalWidth === 48;"
        ),
    );
    // click the pixel's centre on the picture, as the page scales it
    let at = browser.script(&format!(
        "const i = document.getElementById('rendered'); i.scrollIntoView(); const r = i.getBoundingClientRect(); \
         return [r.left + ({x} + 0.5) * r.width / 48, r.top + ({y} + 0.5) * r.height / 32];"
    ));
    browser.click_at(at[0].as_f64().expect("x"), at[1].as_f64().expect("y"));
    let picked = browser.wait_for("the pick", "return shatterPreview.picked;");
    assert_eq!(picked["pieces"][0][0], json!(name), "{picked}");
    let text = browser.script("return document.getElementById('picked').textContent;");
    assert!(text.as_str().is_some_and(|t| t.contains(name)), "{text}");
    assert_eq!(browser.script("return shatterPreview.errors"), json!([]), "the page's console");
}

/// A click on the preview's dropped block at its release turns the block so that the particle
/// clicked faces the floor: in the next run's release frame it is among the lowest.
fn aim_the_drop(browser: &Browser) {
    browser.wait_for(
        "the preview's first run",
        "const s = shatterPreview.state; return s && s.run && s.run.status === 'finished' \
         && shatterPreview.frames.length === s.run.frames;",
    );
    // the release frame, and its highest particle: a corner of the tilted block, which a turn
    // that points it down makes the lowest
    let picked = browser.script(
        "document.getElementById('follow').checked = false; document.getElementById('frame').value = 1; \
         const f = shatterPreview.frames[0]; let best = -1, top = -Infinity; \
         for (let i = 0; i < f.count; i++) if (f.positions[3 * i + 1] > top) { top = f.positions[3 * i + 1]; best = i; } \
         return best;",
    );
    let particle = picked.as_u64().expect("a particle");
    browser.wait_for("the release frame shown", "return shatterPreview.shown === 1;");
    let at = browser.script(&format!("const p = shatterPreview.project({particle}); return [p.x, p.y];"));
    browser.click_at(at[0].as_f64().expect("x"), at[1].as_f64().expect("y"));
    let clicked =
        browser.wait_for("the aim", "return document.getElementById('aim').textContent.match(/particle (\\d+)/);");
    let clicked: u64 = clicked[1].as_str().expect("a number").parse().expect("a particle");
    let lowest = browser.wait_for(
        "the turned drop's release",
        &format!(
            "const s = shatterPreview.state; const f = shatterPreview.frames[0]; \
             if (!(s.run.generation === 2 && f && shatterPreview.generation === 2)) return null; \
             let low = Infinity; for (let i = 0; i < f.count; i++) low = Math.min(low, f.positions[3 * i + 1]); \
             return [f.positions[3 * {clicked} + 1] - low, s.run.spacing_m];"
        ),
    );
    let (above, spacing) = (lowest[0].as_f64().expect("height"), lowest[1].as_f64().expect("spacing"));
    assert!(above < 0.75 * spacing, "particle {clicked} is {above} m above the lowest (spacing {spacing} m)");
    browser.script("document.getElementById('follow').checked = true;");
}
