//! What the preview's tests share: `shatter preview` as a child process, a WebDriver session on
//! Debian's headless chromium (scripts/test.sh installs it and chromium-driver), and the page's
//! frame messages read back.

use std::io::{BufRead, BufReader};
use std::net::TcpListener;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use base64::Engine;
use serde_json::{Value, json};

/// A block dropped on the floor (the follow-through's tests' scene, rendered small): a lead-in,
/// the simulation and a follow-through.
pub const DROP: &str = "[scene]\nname = \"drop\"\noutput_dir = \"out\"\nseed = 3\n[geometry]\nsource = \"box\"\n\
    box_size_m = [0.012, 0.012, 0.012]\nsampler = \"grid\"\nspacing_m = 0.001\nhorizon_factor = 3.0\n\
    [geometry.transform]\ntranslate_m = [0.0, 0.0065, 0.0]\n[material]\ndensity_kg_m3 = 2200.0\n\
    bulk_modulus_pa = 14.9e9\n[lead_in]\ntranslate_m = [0.0, 0.05, 0.0]\nvelocity_m_s = [0.1, 0.0, 0.0]\n\
    rotate_axis = [1.0, 0.0, 1.0]\nrotate_deg = 30.0\n[sim]\nframes = 6\nsteps_per_frame = 100\n\
    [sim.floor]\nheight_m = 0.0\n[rigid]\nfollow_through_s = 0.25\n[render]\nbackend = \"cpu\"\n\
    resolution = [48, 32]\nsamples_per_pixel = 1\n";

/// How long the page may take to show what a step waits for.
pub const PATIENCE: Duration = Duration::from_secs(120);

/// A free port on 127.0.0.1.
pub fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0").and_then(|listener| listener.local_addr()).expect("a free port").port()
}

/// A child process killed when dropped.
pub struct Process(pub Child);

impl Drop for Process {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// `shatter preview` of `dir`'s pipeline.toml at about `particles`, and the URL it printed.
pub fn start_preview(dir: &Path, particles: u32) -> (Process, String) {
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
pub struct Browser {
    base: String,
    session: String,
    _driver: Process,
    _profile: tempfile::TempDir,
}

impl Browser {
    pub fn start() -> Browser {
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
    pub fn command(&self, path: &str, body: Value) -> Value {
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

    pub fn script(&self, script: &str) -> Value {
        self.command("execute/sync", json!({ "script": script, "args": [] }))
    }

    /// Waits until `script` returns something other than null or false; returns it.
    pub fn wait_for(&self, what: &str, script: &str) -> Value {
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
    pub fn type_into(&self, css: &str, text: &str) {
        let id = self.element(css);
        self.command(&format!("element/{id}/clear"), json!({}));
        self.command(&format!("element/{id}/value"), json!({ "text": text }));
    }

    /// A mouse click at (x, y), the viewport's CSS pixels.
    pub fn click_at(&self, x: f64, y: f64) {
        let (x, y) = (x.round() as i64, y.round() as i64);
        let actions = json!({ "actions": [{ "type": "pointer", "id": "mouse", "parameters": { "pointerType": "mouse" },
            "actions": [
                { "type": "pointerMove", "duration": 0, "x": x, "y": y, "origin": "viewport" },
                { "type": "pointerDown", "button": 0 },
                { "type": "pointerUp", "button": 0 },
            ] }] });
        self.command("actions", actions);
    }

    pub fn click(&self, css: &str) {
        let id = self.element(css);
        self.command(&format!("element/{id}/click"), json!({}));
    }

    /// The WebDriver id of the element `css` selects.
    pub fn element(&self, css: &str) -> String {
        let element = self.command("element", json!({ "using": "css selector", "value": css }));
        element["element-6066-11e4-a52e-4f735466cecf"].as_str().expect("an element").to_owned()
    }

    /// A screenshot of the element `css` selects.
    pub fn screenshot(&self, css: &str) -> image::RgbImage {
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

/// The first run's output folder in the scratch folder of the preview with process id `pid`.
pub fn scratch_run(pid: u32) -> std::path::PathBuf {
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
pub struct Message {
    pub source: u32,
    pub time_s: f32,
    pub fragments: u32,
    pub position_m: Vec<[f32; 3]>,
    pub fragment_of: Vec<u32>,
    pub debris: usize,
}

impl Message {
    /// Frame `frame` from the preview at `url` through `route` (`api/frame?generation=1&` for
    /// the first run's, `api/review/frame?` for the scene's output folder's).
    pub fn fetch(url: &str, route: &str, frame: u32) -> Message {
        let response = ureq::get(&format!("{url}{route}frame={frame}")).call().expect("the frame");
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
            debris: word(start + 24 * n) as usize,
        }
    }
}

/// The preview's first run's state once it has finished (its `run` object).
pub fn finished_run(url: &str) -> Value {
    let started = Instant::now();
    loop {
        let state: Value = ureq::get(&format!("{url}api/state")).call().expect("state").into_json().expect("JSON");
        let run = state["run"].clone();
        assert_ne!(run["status"], json!("failed"), "{run}");
        if run["status"] == json!("finished") {
            return run;
        }
        assert!(started.elapsed() < PATIENCE, "waited {PATIENCE:?} for the run");
        std::thread::sleep(Duration::from_millis(200));
    }
}
