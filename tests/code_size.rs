//! The size rules of CONTRIBUTING.md, checked on the workspace's sources: outside tests, no source
//! file over [`MAX_FILE_LINES`] lines and no function over [`MAX_FN_LINES`]; nowhere an allow of
//! clippy's lint against long argument lists (pass a struct). Tests are files under `tests/` and
//! `benches/`, a trailing `#[cfg(test)] mod` of a file, and modules declared under `#[cfg(test)]`.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use crate::support::rust_files;

/// Most lines a source file may have outside its tests.
const MAX_FILE_LINES: usize = 600;
/// Most lines a function may have, outside tests, from its `fn` line to its closing brace.
const MAX_FN_LINES: usize = 100;

/// The workspace root.
fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The production sources: each crate's `src/` but the files of test-only modules.
fn production_sources() -> Vec<(PathBuf, String)> {
    let mut files = Vec::new();
    for dir in ["src", "core", "geometry", "gpu", "preprocess", "sim", "post", "rigid", "render"] {
        let src = if dir == "src" { root().join("src") } else { root().join(dir).join("src") };
        rust_files(&src, &mut files);
    }
    let sources: Vec<(PathBuf, String)> =
        files.into_iter().map(|p| (p.clone(), std::fs::read_to_string(&p).expect("read a source file"))).collect();
    let test_only = test_only_modules(&sources);
    sources.into_iter().filter(|(path, _)| !test_only.iter().any(|module| path.starts_with(module))).collect()
}

/// The paths (a file, or a folder and all below it) of modules declared under `#[cfg(test)]`.
fn test_only_modules(sources: &[(PathBuf, String)]) -> BTreeSet<PathBuf> {
    let mut modules = BTreeSet::new();
    for (path, text) in sources {
        let lines: Vec<&str> = text.lines().collect();
        for pair in lines.windows(2) {
            let declared = pair[1].trim().strip_prefix("mod ").and_then(|rest| rest.strip_suffix(';'));
            if let (true, Some(name)) = (pair[0].trim() == "#[cfg(test)]", declared) {
                let folder = module_folder(path);
                modules.insert(folder.join(format!("{name}.rs")));
                modules.insert(folder.join(name));
            }
        }
    }
    modules
}

/// Where the child modules of the module in `path` live.
fn module_folder(path: &Path) -> PathBuf {
    let parent = path.parent().expect("a file's folder").to_path_buf();
    match path.file_name().and_then(|n| n.to_str()) {
        Some("lib.rs" | "main.rs" | "mod.rs") => parent,
        _ => parent.join(path.file_stem().expect("a file name")),
    }
}

/// `text` without its trailing `#[cfg(test)] mod NAME { ... }`.
fn without_tests(text: &str) -> Vec<&str> {
    let lines: Vec<&str> = text.lines().collect();
    let cut = (0..lines.len().saturating_sub(1))
        .find(|&i| lines[i] == "#[cfg(test)]" && lines[i + 1].starts_with("mod ") && lines[i + 1].ends_with('{'));
    lines[..cut.unwrap_or(lines.len())].to_vec()
}

/// A string literal still open at the end of a line.
#[derive(Clone, Copy, PartialEq)]
enum Open {
    /// `"..."`, with escapes.
    Plain,
    /// `r#"..."#`, with this many hashes.
    Raw(usize),
}

/// Where the string literal open at `chars[i]` ends (the index after its closing quote), or
/// None when it goes on past the line.
fn string_end(chars: &[char], mut i: usize, open: Open) -> Option<usize> {
    while i < chars.len() {
        match (open, chars[i]) {
            (Open::Plain, '\\') => i += 1,
            (Open::Plain, '"') => return Some(i + 1),
            (Open::Raw(hashes), '"') if chars[i + 1..].iter().take(hashes).filter(|&&c| c == '#').count() == hashes => {
                return Some(i + 1 + hashes);
            }
            _ => {}
        }
        i += 1;
    }
    None
}

/// The change of brace depth over a line of code, and whether it opens a brace, with strings,
/// characters and comments skipped; `open` carries a string literal across lines.
fn braces(line: &str, open: &mut Option<Open>) -> (i64, bool) {
    let chars: Vec<char> = line.chars().collect();
    let (mut depth, mut opened, mut i) = (0i64, false, 0);
    if let Some(string) = *open {
        match string_end(&chars, 0, string) {
            Some(end) => (i, *open) = (end, None),
            None => return (0, false),
        }
    }
    while i < chars.len() {
        let string = match chars[i] {
            '/' if chars.get(i + 1) == Some(&'/') => break,
            '"' => Some((Open::Plain, i + 1)),
            'r' if (i == 0 || !chars[i - 1].is_alphanumeric() && chars[i - 1] != '_') => {
                let hashes = chars[i + 1..].iter().take_while(|&&c| c == '#').count();
                (chars.get(i + 1 + hashes) == Some(&'"')).then_some((Open::Raw(hashes), i + 2 + hashes))
            }
            '\'' if chars.get(i + 1) == Some(&'\\') => {
                i += 2;
                while i < chars.len() && chars[i] != '\'' {
                    i += 1;
                }
                None
            }
            '\'' if chars.get(i + 2) == Some(&'\'') => {
                i += 2;
                None
            }
            '{' => {
                depth += 1;
                opened = true;
                None
            }
            '}' => {
                depth -= 1;
                None
            }
            _ => None,
        };
        if let Some((kind, from)) = string {
            match string_end(&chars, from, kind) {
                Some(end) => {
                    i = end;
                    continue;
                }
                None => {
                    *open = Some(kind);
                    break;
                }
            }
        }
        i += 1;
    }
    (depth, opened)
}

/// Whether `line` starts a function item.
fn is_fn_line(line: &str) -> bool {
    let mut words = line.split_whitespace().peekable();
    while let Some(&word) = words.peek() {
        if word == "pub" || word.starts_with("pub(") || ["const", "async", "unsafe", "extern", "\"C\""].contains(&word)
        {
            words.next();
        } else {
            break;
        }
    }
    words.next() == Some("fn")
}

/// (first line, lines) of every function in `lines` longer than `max`.
fn long_functions(lines: &[&str], max: usize) -> Vec<(usize, usize)> {
    let mut long = Vec::new();
    for start in (0..lines.len()).filter(|&i| is_fn_line(lines[i])) {
        let (mut depth, mut opened, mut open) = (0i64, false, None);
        for (end, line) in lines.iter().enumerate().skip(start) {
            if !opened && open.is_none() && line.trim_end().ends_with(';') {
                break;
            }
            let (change, opens) = braces(line, &mut open);
            depth += change;
            opened |= opens;
            if opened && depth <= 0 {
                if end - start + 1 > max {
                    long.push((start + 1, end - start + 1));
                }
                break;
            }
        }
    }
    long
}

fn relative(path: &Path) -> String {
    path.strip_prefix(root()).unwrap_or(path).display().to_string()
}

#[test]
fn no_source_file_outside_tests_is_over_600_lines() {
    let long: Vec<String> = production_sources()
        .iter()
        .map(|(path, text)| (relative(path), without_tests(text).len()))
        .filter(|(_, lines)| *lines > MAX_FILE_LINES)
        .map(|(path, lines)| format!("{path}: {lines} lines"))
        .collect();
    assert!(long.is_empty(), "split these by concept (at most {MAX_FILE_LINES} lines):\n{}", long.join("\n"));
}

#[test]
fn no_function_outside_tests_is_over_100_lines() {
    let mut long = Vec::new();
    for (path, text) in production_sources() {
        for (line, length) in long_functions(&without_tests(&text), MAX_FN_LINES) {
            long.push(format!("{}:{line}: {length} lines", relative(&path)));
        }
    }
    assert!(long.is_empty(), "split these into named phases (at most {MAX_FN_LINES} lines):\n{}", long.join("\n"));
}

#[test]
fn no_code_allows_long_argument_lists() {
    let mut files = Vec::new();
    for dir in ["src", "tests", "core", "geometry", "gpu", "preprocess", "sim", "post", "rigid", "render"] {
        rust_files(&root().join(dir), &mut files);
    }
    let lint = ["too_many", "arguments"].join("_");
    let allowing: Vec<String> = files
        .iter()
        .filter(|p| std::fs::read_to_string(p).is_ok_and(|text| text.contains(&lint)))
        .map(|p| relative(p))
        .collect();
    assert!(allowing.is_empty(), "pass a struct instead of a long argument list in: {allowing:?}");
}

#[test]
fn the_function_measure_counts_a_functions_lines_and_skips_braces_in_strings() {
    let source = ["fn short() {", "    let s = \"}}\\\"}\";", "}", "fn long() {", "    let c = '{';", "    // }", "}"];
    assert_eq!(long_functions(&source, 3), vec![(4, 4)]);
    assert_eq!(long_functions(&source, 4), Vec::<(usize, usize)>::new());
    let raw = ["fn raw() {", "    let s = r#\"{ \"", "    }\"#;", "}"];
    assert_eq!(long_functions(&raw, 3), vec![(1, 4)]);
    let declaration = ["trait T {", "    fn f(&self);", "}"];
    assert_eq!(long_functions(&declaration, 0), Vec::<(usize, usize)>::new());
    assert!(is_fn_line("    pub(crate) fn x() {") && !is_fn_line("    let f = fn_name();"));
}
