//! What the command-line tests share (each uses a part of it): running `shatter` in a folder and
//! reading what it wrote.

#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// Runs `shatter ARGS` in `dir`.
pub fn shatter(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shatter")).args(args).current_dir(dir).output().expect("shatter runs")
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
