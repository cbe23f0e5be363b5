//! `shatter preview` in a real browser: Debian's headless `chromium`, driven through
//! `chromedriver` (WebDriver; scripts/test.sh installs both), draws with WebGL on SwiftShader.
//! The page loads for a small struck plate, its frames arrive and the canvas changes; an edit of
//! the projectile's speed restarts the preview and changes the bonds broken; "Save" shows the diff
//! and writes that value alone into the scene's file, its comment kept; a refused edit shows the
//! config check's message; the console stays free of errors. The canvas, at the first run's
//! last frame, is within a FLIP bound of its golden (`SHATTER_BLESS=1` rewrites it).

use std::io::{BufRead, BufReader};
use std::net::TcpListener;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use base64::Engine;
use serde_json::{Value, json};

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
critical_stretch = 0.00032

[sim]
frames = 16
steps_per_frame = 100

[[sim.projectile]]
center_m = [0.0, 0.0, 0.0087]
velocity_m_s = [0.0, 0.0, -150.0]  # fast enough to break the plate
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

/// `shatter preview` of `dir`'s pipeline.toml, and the URL it printed.
fn start_preview(dir: &Path) -> (Process, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_shatter"))
        .args(["preview", "--port", "0", "--particles", "3000"])
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
    let (_preview, url) = start_preview(dir.path());
    let browser = Browser::start();
    browser.command("url", json!({ "url": url }));

    browser.wait_for("a frame drawn", "return shatterPreview.frames.length > 0 && shatterPreview.framesDrawn > 0");
    let first = browser.script(&format!("{CANVAS_HASH} return hash();"));
    browser.wait_for("the canvas to change as frames arrive", &format!("{CANVAS_HASH} return hash() !== {first};"));
    let run = browser.wait_for("the first run to finish", FINISHED_RUN);
    let (generation, broken) = (run[0].as_u64().expect("generation"), run[1].as_u64().expect("broken bonds"));
    assert_eq!(generation, 1);
    assert!(broken > 0, "the projectile breaks bonds");
    assert!(dir.path().join("out").symlink_metadata().is_err(), "the preview wrote into the scene's output folder");
    matches_golden(&browser.screenshot("#view"));

    // a slower projectile: the preview restarts and breaks fewer bonds
    browser.type_into("input[name='sim.projectile[0].velocity_m_s']", "[0, 0, -40]");
    browser.click("#apply");
    let slower = browser.wait_for(
        "the edited run to finish",
        &FINISHED_RUN.replace("return s && s.run", "return s && s.run && s.run.generation === 2"),
    );
    let broken_slower = slower[1].as_u64().expect("broken bonds");
    assert!(broken_slower < broken, "{broken_slower} bonds broken at 40 m/s against {broken} at 150 m/s");
    // the bound tells the two apart
    if !std::env::var("SHATTER_BLESS").is_ok_and(|value| value == "1") {
        let reference = image::open(Path::new(env!("CARGO_MANIFEST_DIR")).join(GOLDEN)).expect("golden").to_rgb8();
        let (_, mean, _) = support::flip(&reference, &browser.screenshot("#view"));
        assert!(mean > MAX_MEAN_FLIP, "the slower projectile's canvas is FLIP {mean} from the faster one's");
    }

    // "Save" shows the diff, then writes the edited value and nothing else into the scene's file
    browser.click("#save");
    let diff = browser.wait_for("the diff", "const d = document.getElementById('diff').textContent; return d || null;");
    assert!(diff.as_str().is_some_and(|diff| diff.contains("+velocity_m_s = [0.0, 0.0, -40.0]")), "{diff}");
    browser.click("#write");
    browser.wait_for("the save", "return document.getElementById('saved').textContent || null;");
    let saved = std::fs::read_to_string(dir.path().join("pipeline.toml")).expect("the scene");
    let changed: Vec<(&str, &str)> = PLATE.lines().zip(saved.lines()).filter(|(a, b)| a != b).collect();
    assert_eq!(
        changed,
        [(
            "velocity_m_s = [0.0, 0.0, -150.0]  # fast enough to break the plate",
            "velocity_m_s = [0.0, 0.0, -40.0]  # fast enough to break the plate"
        )]
    );
    assert_eq!(PLATE.lines().count(), saved.lines().count());

    // a refused edit names the key, as the CLI does, and leaves the run alone
    browser.type_into("input[name='material.critical_stretch']", "-1");
    browser.click("#apply");
    let message =
        browser.wait_for("the refusal", "const e = document.getElementById('error').textContent; return e || null;");
    let message = message.as_str().expect("text");
    assert!(message.contains("material.critical_stretch"), "{message}");
    assert_eq!(browser.script("return shatterPreview.state.run.generation"), json!(2));

    let errors = browser.script("return shatterPreview.errors");
    assert_eq!(errors, json!([]), "the page's console");
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
