//! CONTRIBUTING.md's visibility rule, checked on the workspace's sources: a library crate's
//! top-level module is `pub` only when code outside the crate's `src/` (another crate, or the
//! crate's own tests, benches and examples) names it by path. The rest are private, and what the
//! crate offers from them is re-exported at its root.

use std::path::{Path, PathBuf};

use crate::support::rust_files;

/// The library crates: folder and the name other code uses.
const LIBRARIES: [(&str, &str); 8] = [
    ("core", "shatter_core"),
    ("geometry", "shatter_geometry"),
    ("gpu", "shatter_gpu"),
    ("preprocess", "shatter_preprocess"),
    ("sim", "shatter_sim"),
    ("post", "shatter_post"),
    ("rigid", "shatter_rigid"),
    ("render", "shatter_render"),
];

/// The names `text` reaches through `library::`: `library::a::...`, `library::b;` and each head
/// of a group, `library::{c, d::e, f::{g}}` giving c, d and f.
fn names_used(text: &str, library: &str) -> Vec<String> {
    let prefix = format!("{library}::");
    let mut names = Vec::new();
    for (at, _) in text.match_indices(&prefix) {
        let rest = &text[at + prefix.len()..];
        if let Some(group) = rest.strip_prefix('{') {
            names.extend(group_heads(group));
        } else {
            names.push(rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect());
        }
    }
    names
}

/// The first name of each item of a `{...}` group (`group` starts after its brace).
fn group_heads(group: &str) -> Vec<String> {
    let (mut heads, mut depth, mut head, mut at_start) = (Vec::new(), 1, String::new(), true);
    for c in group.chars() {
        match c {
            '{' => depth += 1,
            '}' if depth == 1 => break,
            '}' => depth -= 1,
            ',' if depth == 1 => {
                heads.extend((!head.is_empty()).then(|| std::mem::take(&mut head)));
                at_start = true;
            }
            c if depth == 1 && at_start && (c.is_alphanumeric() || c == '_') => head.push(c),
            _ if depth == 1 && at_start && !head.is_empty() => {
                heads.push(std::mem::take(&mut head));
                at_start = false;
            }
            _ => {}
        }
    }
    heads.extend((!head.is_empty()).then_some(head));
    heads
}

/// Every `.rs` file of the workspace outside `crate_src` and the build folder.
fn sources_outside(root: &Path, crate_src: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(root).expect("read the workspace").flatten() {
        let path = entry.path();
        if path.is_dir()
            && !path.ends_with("target")
            && !path.file_name().is_some_and(|n| n.to_string_lossy().starts_with('.'))
        {
            rust_files(&path, &mut files);
        }
    }
    files.retain(|path| !path.starts_with(crate_src));
    files
}

#[test]
fn a_module_is_public_only_when_another_crate_names_it() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut needless = Vec::new();
    for (folder, library) in LIBRARIES {
        let src = root.join(folder).join("src");
        let lib = std::fs::read_to_string(src.join("lib.rs")).expect("read a lib.rs");
        let public: Vec<&str> =
            lib.lines().filter_map(|line| line.strip_prefix("pub mod ")?.strip_suffix(';')).collect();
        let used: Vec<String> = sources_outside(root, &src)
            .iter()
            .flat_map(|path| names_used(&std::fs::read_to_string(path).expect("read a source file"), library))
            .collect();
        needless.extend(public.iter().filter(|m| !used.iter().any(|u| u == *m)).map(|m| format!("{library}::{m}")));
    }
    assert!(needless.is_empty(), "public modules that no other crate names (make them private): {needless:?}");
}

#[test]
fn the_name_reader_sees_paths_and_groups() {
    let text = "use shatter_x::a::B;\nuse shatter_x::{c, d::e, f::{g, h}, i};\nlet y = shatter_x::j(1);";
    assert_eq!(names_used(text, "shatter_x"), ["a", "c", "d", "f", "i", "j"]);
}
