//! What the command-line tests share (each uses a part of it): running `shatter` in a folder and
//! reading what it wrote.

#![allow(dead_code)]

pub mod preview;

use std::path::Path;
use std::process::{Command, Output};

/// A small good scene: a 10 x 10 x 4 mm glass plate of 1 mm cubes at N = 3 (400 particles),
/// with every other setting at its default.
pub const SMALL_PLATE: &str = r#"
[scene]
name = "glass_plate"
output_dir = "out"
seed = 1
[geometry]
source = "box"
box_size_m = [0.01, 0.01, 0.004]
sampler = "grid"
spacing_m = 0.001
horizon_factor = 3.0
[material]
density_kg_m3 = 2200.0
bulk_modulus_pa = 14.9e9
"#;

/// The workspace's `cargo metadata` (its own packages only), as JSON.
pub fn workspace_metadata() -> serde_json::Value {
    let output = Command::new(env!("CARGO"))
        .args(["metadata", "--format-version", "1", "--no-deps", "--offline"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run cargo metadata");
    assert!(output.status.success(), "cargo metadata failed: {}", String::from_utf8_lossy(&output.stderr));
    serde_json::from_slice(&output.stdout).expect("cargo metadata prints JSON")
}

/// Every `.rs` file under `dir`, into `out`.
pub fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// Runs `shatter ARGS` in `dir`.
pub fn shatter(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shatter")).args(args).current_dir(dir).output().expect("shatter runs")
}

/// The number printed after `label` in `text` (a stage's summary line), up to a space, comma or
/// semicolon.
pub fn figure(text: &str, label: &str) -> f64 {
    let at = text.find(label).unwrap_or_else(|| panic!("no {label:?} in {text}")) + label.len();
    let number: String =
        text[at..].trim_start().chars().take_while(|c| !c.is_whitespace() && !matches!(c, ',' | ';')).collect();
    number.parse().unwrap_or_else(|_| panic!("{number:?} after {label:?} is not a number"))
}

/// A command's standard error as text.
pub fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// The files of `folder` (not its subfolders), by name, sorted.
pub fn folder_files(folder: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(folder)
        .expect("folder")
        .map(|entry| {
            let path = entry.expect("entry").path();
            (path.file_name().expect("name").to_string_lossy().into_owned(), std::fs::read(&path).expect("read"))
        })
        .collect();
    files.sort();
    files
}

/// Every file under `folder`, its subfolders included, by path relative to `folder`, sorted;
/// files whose name is in `skip` are left out.
pub fn tree_files(folder: &Path, skip: &[&str]) -> Vec<(String, Vec<u8>)> {
    let mut files = Vec::new();
    let mut stack = vec![folder.to_path_buf()];
    while let Some(current) = stack.pop() {
        for entry in std::fs::read_dir(&current).expect("folder") {
            let path = entry.expect("entry").path();
            if path.is_dir() {
                stack.push(path);
            } else if !skip.iter().any(|name| path.file_name().is_some_and(|file| file == *name)) {
                let name = path.strip_prefix(folder).expect("inside").display().to_string();
                files.push((name, std::fs::read(&path).expect("read")));
            }
        }
    }
    files.sort();
    files
}

/// FLIP of `test` against `reference`: the error map, its mean and 99th percentile.
pub fn flip(reference: &image::RgbImage, test: &image::RgbImage) -> (nv_flip::FlipImageFloat, f32, f32) {
    let (width, height) = reference.dimensions();
    let reference = nv_flip::FlipImageRgb8::with_data(width, height, reference.as_raw());
    let test = nv_flip::FlipImageRgb8::with_data(width, height, test.as_raw());
    let error = nv_flip::flip(reference, test, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    let mut pool = nv_flip::FlipPool::from_image(&error);
    let (mean, p99) = (pool.mean(), pool.get_percentile(0.99, false));
    (error, mean, p99)
}
