//! The one-way rule of the workspace, checked on `cargo metadata`: the stage crates sit side by
//! side over the shared crates and never depend on one another; only the `shatter` CLI knows
//! every stage. See docs/ARCHITECTURE.md.

use std::collections::BTreeSet;

use crate::support;

/// The stage crates, in the order data flows through them.
const STAGES: [&str; 5] = ["shatter-preprocess", "shatter-sim", "shatter-post", "shatter-rigid", "shatter-render"];
/// What stages share: they may depend on these, and these on no stage.
const SHARED: [&str; 3] = ["shatter-core", "shatter-geometry", "shatter-gpu"];

/// (package, dependency, kind) for every dependency between workspace packages; kind is
/// "normal", "dev" or "build".
fn workspace_edges() -> (BTreeSet<String>, Vec<(String, String, String)>) {
    let metadata = support::workspace_metadata();
    let packages = metadata["packages"].as_array().expect("packages");
    let names: BTreeSet<String> =
        packages.iter().map(|p| p["name"].as_str().expect("package name").to_owned()).collect();
    let mut edges = Vec::new();
    for package in packages {
        let from = package["name"].as_str().expect("package name");
        for dependency in package["dependencies"].as_array().expect("dependencies") {
            let to = dependency["name"].as_str().expect("dependency name");
            if names.contains(to) {
                let kind = dependency["kind"].as_str().unwrap_or("normal").to_owned();
                edges.push((from.to_owned(), to.to_owned(), kind));
            }
        }
    }
    (names, edges)
}

#[test]
fn every_stage_and_shared_crate_is_a_workspace_member() {
    let (names, _) = workspace_edges();
    for name in STAGES.iter().chain(&SHARED).chain(&["shatter"]) {
        assert!(names.contains(*name), "{name} is not in the workspace: update this test with the layout");
    }
    let unknown: Vec<&String> = names
        .iter()
        .filter(|n| !STAGES.contains(&n.as_str()) && !SHARED.contains(&n.as_str()) && *n != "shatter")
        .collect();
    assert!(unknown.is_empty(), "new workspace crates {unknown:?}: list them here as a stage or as shared");
}

#[test]
fn no_stage_depends_on_another_stage() {
    let (_, edges) = workspace_edges();
    let crossing: Vec<String> = edges
        .iter()
        .filter(|(from, to, kind)| STAGES.contains(&from.as_str()) && STAGES.contains(&to.as_str()) && kind != "dev")
        .map(|(from, to, kind)| format!("{from} -> {to} ({kind})"))
        .collect();
    assert!(crossing.is_empty(), "stages must not depend on each other: {crossing:?}");
}

#[test]
fn stage_tests_take_only_upstream_stages_and_only_to_make_their_input() {
    // A stage's tests and benchmarks may use an upstream stage to make realistic input (the
    // simulation's tests preprocess a block into particles); nothing ever reaches downstream.
    let (_, edges) = workspace_edges();
    let position = |name: &str| STAGES.iter().position(|s| *s == name);
    let backwards: Vec<String> = edges
        .iter()
        .filter_map(|(from, to, kind)| match (position(from), position(to)) {
            (Some(f), Some(t)) if t >= f => Some(format!("{from} -> {to} ({kind})")),
            _ => None,
        })
        .collect();
    assert!(backwards.is_empty(), "a stage may only reach upstream stages, and only in tests: {backwards:?}");
}

#[test]
fn shared_crates_know_no_stage() {
    let (_, edges) = workspace_edges();
    let upward: Vec<String> = edges
        .iter()
        .filter(|(from, to, _)| SHARED.contains(&from.as_str()) && (STAGES.contains(&to.as_str()) || to == "shatter"))
        .map(|(from, to, kind)| format!("{from} -> {to} ({kind})"))
        .collect();
    assert!(upward.is_empty(), "core, geometry and gpu must not depend on a stage or the CLI: {upward:?}");
}

#[test]
fn only_the_cli_knows_every_stage() {
    let (_, edges) = workspace_edges();
    for stage in STAGES {
        assert!(
            edges.iter().any(|(from, to, kind)| from == "shatter" && to == stage && kind == "normal"),
            "the shatter CLI does not depend on {stage}"
        );
    }
}
