//! Each workspace crate builds one integration-test binary, so the suite links wgpu and rapier a
//! handful of times rather than once per test file. Where a crate's binary is
//! `tests/integration.rs` (with `autotests = false`), every file and folder module under its
//! `tests/` must be declared there, or its tests would silently never build.

use std::path::Path;

use crate::support;

/// (package name, manifest folder, the source paths of its integration-test targets).
fn test_targets() -> Vec<(String, String, Vec<String>)> {
    let metadata = support::workspace_metadata();
    let packages = metadata["packages"].as_array().expect("packages");
    packages
        .iter()
        .map(|package| {
            let manifest = Path::new(package["manifest_path"].as_str().expect("manifest path"));
            let folder = manifest.parent().expect("manifest folder").to_string_lossy().into_owned();
            let tests = package["targets"]
                .as_array()
                .expect("targets")
                .iter()
                .filter(|t| t["kind"].as_array().expect("kind").iter().any(|k| k == "test"))
                .map(|t| t["src_path"].as_str().expect("src_path").to_owned())
                .collect();
            (package["name"].as_str().expect("package name").to_owned(), folder, tests)
        })
        .collect()
}

/// The module names a `tests/` folder holds: its `*.rs` files and its folders with a `mod.rs`.
fn modules_in(tests_dir: &Path, root_file: &Path) -> Vec<String> {
    let mut names = Vec::new();
    for entry in std::fs::read_dir(tests_dir).expect("read tests folder") {
        let path = entry.expect("folder entry").path();
        if path == root_file {
            continue;
        }
        let is_file_module = path.extension().is_some_and(|e| e == "rs");
        let is_folder_module = path.join("mod.rs").is_file();
        if is_file_module || is_folder_module {
            names.push(path.file_stem().expect("file name").to_string_lossy().into_owned());
        }
    }
    names.sort();
    names
}

#[test]
fn every_crate_has_at_most_one_integration_test_binary() {
    for (name, _, tests) in test_targets() {
        assert!(
            tests.len() <= 1,
            "{name} builds {} test binaries ({tests:?}): declare the files as modules of one",
            tests.len()
        );
    }
}

#[test]
fn every_test_file_is_a_module_of_its_crates_binary() {
    for (name, folder, tests) in test_targets() {
        let Some(root) = tests.first() else { continue };
        let root = Path::new(root);
        let tests_dir = Path::new(&folder).join("tests");
        if root.parent() != Some(tests_dir.as_path()) || root.file_name().is_some_and(|f| f != "integration.rs") {
            continue;
        }
        let source = std::fs::read_to_string(root).expect("read the test binary's root");
        let missing: Vec<String> = modules_in(&tests_dir, root)
            .into_iter()
            .filter(|m| !source.lines().any(|line| line.trim() == format!("mod {m};")))
            .collect();
        assert!(missing.is_empty(), "{name}: {} does not declare {missing:?}; their tests never run", root.display());
    }
}
