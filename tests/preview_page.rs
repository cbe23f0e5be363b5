//! `shatter preview` in a real browser: Debian's headless `chromium`, driven through
//! `chromedriver` (WebDriver; scripts/test.sh installs both), draws with WebGL on SwiftShader.
//! The page loads for a small struck plate, its frames arrive and the canvas follows the frame
//! slider; its fragment figures and ids are post's, and it colours by fragment; an edit of
//! the material's strength restarts the preview and breaks fewer bonds; "Save" shows the diff
//! and writes that value alone into the scene's file, its comment kept; a refused edit shows the
//! config check's message; a click on the plate aims the projectile there; the console stays
//! free of errors. A drop's preview shows the lead-in's, the simulation's and the
//! follow-through's frames in turn. The canvas, at the first run's
//! last frame, is within a FLIP bound of its golden (`SHATTER_BLESS=1` rewrites it).

use std::io::{BufRead, BufReader};
use std::net::TcpListener;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use base64::Engine;
use serde_json::{Value, json};
use shatter_core::fragments::FragmentFrame;

use crate::support;

/// A small plate struck by a projectile: 50 x 50 x 5 mm, 12,500 particles at full resolution,
/// previewed at about 3,000 (three layers).
const PLATE: &str = r#"[scene]
name = "preview_plate"
output_dir = "out"
seed = 3

[geometry]
source = "box"
box_size_m = [0.05, 0.05, 0.005]
sampler = "grid"
spacing_m = 0.001
horizon_factor = 3.0

[material]
density_kg_m3 = 2200.0
bulk_modulus_pa = 14.9e9
critical_stretch = 0.00032  # glass: the projectile cracks it

[sim]
frames = 16
steps_per_frame = 100

[[sim.projectile]]
center_m = [0.0, 0.0, 0.0087]
velocity_m_s = [0.0, 0.0, -150.0]
radius_m = 0.004
stiffness_pa = 4e5
"#;

/// The canvas's golden, at the first run's last frame.
const GOLDEN: &str = "tests/golden/preview_page.png";
/// Largest mean FLIP error of the canvas against its golden (the same machine gives the same
/// pixels; SwiftShader elsewhere may round differently at the points' edges).
const MAX_MEAN_FLIP: f32 = 0.02;

/// How long the page may take to show what a step waits for.
const PATIENCE: Duration = Duration::from_secs(120);

/// A free port on 127.0.0.1.
fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0").and_then(|listener| listener.local_addr()).expect("a free port").port()
}

/// A child process killed when dropped.
struct Process(Child);

impl Drop for Process {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// `shatter preview` of `dir`'s pipeline.toml at about `particles`, and the URL it printed.
fn start_preview(dir: &Path, particles: u32) -> (Process, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_shatter"))
        .args(["preview", "--port", "0", "--particles", &particles.to_string()])
        .current_dir(dir)
        .stdout(Stdio::piped())
        .spawn()
        .expect("shatter preview starts");
    let stdout = child.stdout.take().expect("stdout");
    let mut line = String::new();
    BufReader::new(stdout).read_line(&mut line).expect("the preview prints its URL");
    let url = line.trim().strip_prefix("preview: ").unwrap_or_else(|| panic!("not a URL line: {line:?}")).to_owned();
    (Process(child), url)
}

/// A WebDriver session on a headless chromium.
struct Browser {
    base: String,
    session: String,
    _driver: Process,
    _profile: tempfile::TempDir,
}

impl Browser {
    fn start() -> Browser {
        let port = free_port();
        let driver = Command::new("chromedriver")
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("chromedriver runs (scripts/test.sh installs Debian's chromium-driver)");
        let (driver, base) = (Process(driver), format!("http://127.0.0.1:{port}"));
        let started = Instant::now();
        while ureq::get(&format!("{base}/status")).call().is_err() {
            assert!(started.elapsed() < Duration::from_secs(30), "chromedriver did not answer");
            std::thread::sleep(Duration::from_millis(100));
        }
        let profile = tempfile::tempdir().expect("tempdir");
        let args = [
            "--headless=new",
            "--no-sandbox",
            "--use-angle=swiftshader",
            "--enable-unsafe-swiftshader",
            "--window-size=1400,760",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-first-run",
            &format!("--user-data-dir={}", profile.path().display()),
        ];
        let capabilities = json!({ "capabilities": { "alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": { "binary": "/usr/bin/chromium", "args": args },
        }}});
        let answer: Value = ureq::post(&format!("{base}/session"))
            .send_json(capabilities)
            .expect("a browser session")
            .into_json()
            .expect("JSON");
        let session = answer["value"]["sessionId"].as_str().expect("a session id").to_owned();
        Browser { base, session, _driver: driver, _profile: profile }
    }

    /// A WebDriver command on the session: its `value`.
    fn command(&self, path: &str, body: Value) -> Value {
        let url = format!("{}/session/{}/{path}", self.base, self.session);
        let answer: Value = match ureq::post(&url).send_json(body) {
            Ok(response) => response.into_json().expect("JSON"),
            Err(ureq::Error::Status(code, response)) => {
                panic!("{path}: {code} {}", response.into_string().unwrap_or_default())
            }
            Err(error) => panic!("{path}: {error}"),
        };
        answer["value"].clone()
    }

    fn script(&self, script: &str) -> Value {
        self.command("execute/sync", json!({ "script": script, "args": [] }))
    }

    /// Waits until `script` returns something other than null or false; returns it.
    fn wait_for(&self, what: &str, script: &str) -> Value {
        let started = Instant::now();
        loop {
            let value = self.script(script);
            if !value.is_null() && value != Value::Bool(false) {
                return value;
            }
            assert!(started.elapsed() < PATIENCE, "waited {PATIENCE:?} for {what}");
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    /// Types `text` into the element `css` holds, in place of its value.
    fn type_into(&self, css: &str, text: &str) {
        let id = self.element(css);
        self.command(&format!("element/{id}/clear"), json!({}));
        self.command(&format!("element/{id}/value"), json!({ "text": text }));
    }

    /// A mouse click at (x, y), the viewport's CSS pixels.
    fn click_at(&self, x: f64, y: f64) {
        let (x, y) = (x.round() as i64, y.round() as i64);
        let actions = json!({ "actions": [{ "type": "pointer", "id": "mouse", "parameters": { "pointerType": "mouse" },
            "actions": [
                { "type": "pointerMove", "duration": 0, "x": x, "y": y, "origin": "viewport" },
                { "type": "pointerDown", "button": 0 },
                { "type": "pointerUp", "button": 0 },
            ] }] });
        self.command("actions", actions);
    }

    fn click(&self, css: &str) {
        let id = self.element(css);
        self.command(&format!("element/{id}/click"), json!({}));
    }

    /// The WebDriver id of the element `css` selects.
    fn element(&self, css: &str) -> String {
        let element = self.command("element", json!({ "using": "css selector", "value": css }));
        element["element-6066-11e4-a52e-4f735466cecf"].as_str().expect("an element").to_owned()
    }

    /// A screenshot of the element `css` selects.
    fn screenshot(&self, css: &str) -> image::RgbImage {
        let url = format!("{}/session/{}/element/{}/screenshot", self.base, self.session, self.element(css));
        let answer: Value = ureq::get(&url).call().expect("a screenshot").into_json().expect("JSON");
        let png = base64::engine::general_purpose::STANDARD
            .decode(answer["value"].as_str().expect("base64"))
            .expect("base64 PNG");
        image::load_from_memory(&png).expect("a PNG").to_rgb8()
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = ureq::delete(&format!("{}/session/{}", self.base, self.session)).call();
    }
}

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
    std::fs::write(dir.path().join("pipeline.toml"), PLATE).expect("config");
    let (preview, url) = start_preview(dir.path(), 3000);
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

    // a stronger material: the preview restarts and breaks fewer bonds
    browser.type_into("input[name='material.critical_stretch']", "0.001");
    browser.click("#apply");
    let stronger = browser.wait_for(
        "the edited run to finish",
        &FINISHED_RUN.replace("return s && s.run", "return s && s.run && s.run.generation === 2"),
    );
    let broken_stronger = stronger[1].as_u64().expect("broken bonds");
    assert!(broken_stronger < broken, "{broken_stronger} bonds broken at a critical stretch of 0.001 against {broken}");
    // the bound tells the two apart
    if !std::env::var("SHATTER_BLESS").is_ok_and(|value| value == "1") {
        let reference = image::open(Path::new(env!("CARGO_MANIFEST_DIR")).join(GOLDEN)).expect("golden").to_rgb8();
        let (_, mean, _) = support::flip(&reference, &browser.screenshot("#view"));
        assert!(mean > MAX_MEAN_FLIP, "the stronger plate's canvas is FLIP {mean} from the weaker one's");
    }

    // "Save" shows the diff, then writes the edited value and nothing else into the scene's file
    browser.click("#save");
    let diff = browser.wait_for("the diff", "const d = document.getElementById('diff').textContent; return d || null;");
    assert!(diff.as_str().is_some_and(|diff| diff.contains("+critical_stretch = 0.001")), "{diff}");
    browser.click("#write");
    browser.wait_for("the save", "return document.getElementById('saved').textContent || null;");
    let saved = std::fs::read_to_string(dir.path().join("pipeline.toml")).expect("the scene");
    let changed: Vec<(&str, &str)> = PLATE.lines().zip(saved.lines()).filter(|(a, b)| a != b).collect();
    assert_eq!(
        changed,
        [(
            "critical_stretch = 0.00032  # glass: the projectile cracks it",
            "critical_stretch = 0.001  # glass: the projectile cracks it"
        )]
    );
    assert_eq!(PLATE.lines().count(), saved.lines().count());

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
    let ids = Message::fetch(url, frame).fragment_of;
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
           const d = Math.hypot(f.positions[3 * i] - 0.012, f.positions[3 * i + 1] - 0.008); \
           if (d < bestD) { best = i; bestD = d; } } \
         return [f.positions[3 * best], f.positions[3 * best + 1]];",
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
    // top face (2 mm apart at this coarseness)
    assert!((centre[0] - target[0]).hypot(centre[1] - target[1]) < 0.0025, "{centre:?} aimed at {target:?}");
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

/// The first run's output folder in the scratch folder of the preview with process id `pid`.
fn scratch_run(pid: u32) -> std::path::PathBuf {
    let prefix = format!("shatter-preview-{pid}-");
    std::fs::read_dir(std::env::temp_dir())
        .expect("the temp folder")
        .filter_map(Result::ok)
        .map(|entry| entry.path())
        .find(|path| path.file_name().is_some_and(|name| name.to_string_lossy().starts_with(&prefix)))
        .expect("the preview's scratch folder")
        .join("run-1/out")
}

/// A frame message's fields (src/preview/frame_message.rs), as a test reads them.
struct Message {
    source: u32,
    time_s: f32,
    fragments: u32,
    position_m: Vec<[f32; 3]>,
    fragment_of: Vec<u32>,
}

impl Message {
    /// Page frame `frame` of the first run of the preview at `url`.
    fn fetch(url: &str, frame: u32) -> Message {
        let response = ureq::get(&format!("{url}api/frame?generation=1&frame={frame}")).call().expect("the frame");
        let mut bytes = Vec::new();
        std::io::Read::read_to_end(&mut response.into_reader(), &mut bytes).expect("bytes");
        let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
        assert_eq!((&bytes[..4], word(4), word(8)), (&b"SHPV"[..], 2, frame));
        let (n, start) = (word(12) as usize, 36 + 4 * word(32) as usize);
        Message {
            source: word(20),
            time_s: f32::from_bits(word(16)),
            fragments: word(24),
            position_m: (0..n).map(|i| [0, 1, 2].map(|a| f32::from_bits(word(start + 12 * i + 4 * a)))).collect(),
            fragment_of: (0..n).map(|i| word(start + 20 * n + 4 * i)).collect(),
        }
    }
}

/// A block dropped on the floor (the follow-through's tests' scene): the page's frames are the
/// lead-in's, the simulation's up to the handoff, then the follow-through's, in time order,
/// each placed as its stage's file says.
#[test]
fn the_preview_of_a_drop_shows_its_fall_break_and_settle() {
    const DROP: &str = "[scene]\nname = \"drop\"\noutput_dir = \"out\"\nseed = 3\n[geometry]\nsource = \"box\"\n\
        box_size_m = [0.012, 0.012, 0.012]\nsampler = \"grid\"\nspacing_m = 0.001\nhorizon_factor = 3.0\n\
        [geometry.transform]\ntranslate_m = [0.0, 0.0065, 0.0]\n[material]\ndensity_kg_m3 = 2200.0\n\
        bulk_modulus_pa = 14.9e9\n[lead_in]\ntranslate_m = [0.0, 0.05, 0.0]\nvelocity_m_s = [0.1, 0.0, 0.0]\n\
        rotate_axis = [1.0, 0.0, 1.0]\nrotate_deg = 30.0\n[sim]\nframes = 6\nsteps_per_frame = 100\n\
        [sim.floor]\nheight_m = 0.0\n[rigid]\nfollow_through_s = 0.25\n";
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("pipeline.toml"), DROP).expect("config");
    let (preview, url) = start_preview(dir.path(), 600);
    let started = Instant::now();
    let run = loop {
        let state: Value = ureq::get(&format!("{url}api/state")).call().expect("state").into_json().expect("JSON");
        let run = state["run"].clone();
        assert_ne!(run["status"], json!("failed"), "{run}");
        if run["status"] == json!("finished") {
            break run;
        }
        assert!(started.elapsed() < PATIENCE, "waited {PATIENCE:?} for the run");
        std::thread::sleep(Duration::from_millis(200));
    };
    let frames = run["frames"].as_u64().expect("frames") as u32;
    let lead_in = run["lead_in_frames"].as_u64().expect("lead-in frames") as u32;
    let handoff = run["handoff"].as_u64().expect("a handoff") as u32;
    assert!(lead_in > 0 && handoff > 0 && frames > lead_in + handoff, "{run}");
    let messages: Vec<Message> = (1..=frames).map(|frame| Message::fetch(&url, frame)).collect();
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
