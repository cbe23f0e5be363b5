//! Relative paths in a config: they start at the config file's folder.

use std::path::{Component, Path, PathBuf};

/// Makes a relative `path` relative to `base` (the config file's folder) and folds away its `.`
/// and `..` components as text, so that messages name `out/vase` rather than
/// `assets/scenes/../../out/vase` (like a shell's `cd`, not like following links).
pub(super) fn resolve_path(base: &Path, path: &mut PathBuf) {
    if path.is_absolute() {
        return;
    }
    let mut resolved = PathBuf::new();
    for component in base.join(&*path).components() {
        match component {
            Component::CurDir => {}
            Component::ParentDir if matches!(resolved.components().next_back(), Some(Component::Normal(_))) => {
                resolved.pop();
            }
            Component::ParentDir if resolved.has_root() => {}
            other => resolved.push(other),
        }
    }
    if resolved.as_os_str().is_empty() {
        resolved.push(".");
    }
    *path = resolved;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_paths_start_at_the_config_folder_with_dot_dots_folded() {
        let cases = [
            ("/work/assets/scenes", "../../out/vase", "/work/out/vase"),
            ("/work/assets/scenes", "./../meshes/./vase.obj", "/work/assets/meshes/vase.obj"),
            ("assets/scenes", "../../out", "out"),
            ("assets", "../../out", "../out"),
            ("", "../out", "../out"),
            ("assets", "..", "."),
            ("/", "../../x", "/x"),
            ("/work", "/abs/../kept", "/abs/../kept"),
        ];
        for (base, path, expected) in cases {
            let mut resolved = PathBuf::from(path);
            resolve_path(Path::new(base), &mut resolved);
            assert_eq!(resolved, PathBuf::from(expected), "{base} + {path}");
        }
    }
}
