//! "Save": the preview's edits written into the scene's own config file, the edited keys' values
//! and nothing else (toml_edit keeps the file's comments, order and layout, and a value's own
//! trailing comment), shown first as a diff.

use super::preview_config::Edits;

/// `original` (a scene's config text) with `edits` written in.
pub fn saved_text(original: &str, edits: &Edits) -> Result<String, String> {
    let mut document: toml_edit::DocumentMut = original.parse().map_err(|error| format!("{error}"))?;
    for (key, value) in edits {
        set(&mut document, key, value).map_err(|message| format!("{key}: {message}"))?;
    }
    Ok(document.to_string())
}

/// The lines `saved` changes in `original`, as a unified diff with 2 lines of context.
pub fn diff(label: &str, original: &str, saved: &str) -> String {
    similar::TextDiff::from_lines(original, saved)
        .unified_diff()
        .context_radius(2)
        .header(label, &format!("{label} (saved)"))
        .to_string()
}

/// Sets the dotted `key` (each part a name, or `name[i]` for entry i of an array of tables) in
/// `document` to `value`, keeping the old value's surroundings (spacing and trailing comment).
fn set(document: &mut toml_edit::DocumentMut, key: &str, value: &toml::Value) -> Result<(), String> {
    let parts: Vec<&str> = key.split('.').collect();
    let (last, path) = parts.split_last().ok_or("an empty key")?;
    let mut table: &mut dyn toml_edit::TableLike = document.as_table_mut();
    for part in path {
        table = match part.split_once('[') {
            Some((name, index)) => {
                let index: usize = index.trim_end_matches(']').parse().map_err(|_| format!("{part}: not an index"))?;
                table
                    .get_mut(name)
                    .and_then(toml_edit::Item::as_array_of_tables_mut)
                    .and_then(|array| array.get_mut(index))
                    .map(|entry| entry as &mut dyn toml_edit::TableLike)
                    .ok_or(format!("no entry {index} of [[{name}]]"))?
            }
            None => table
                .entry(part)
                .or_insert(toml_edit::table())
                .as_table_like_mut()
                .ok_or(format!("{part} is not a table"))?,
        };
    }
    let mut new: toml_edit::Value = value.to_string().parse().map_err(|error| format!("{error}"))?;
    match table.get_mut(last).and_then(toml_edit::Item::as_value_mut) {
        Some(old) => {
            *new.decor_mut() = old.decor().clone();
            *old = new;
        }
        None => {
            table.insert(last, toml_edit::Item::Value(new));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const SCENE: &str = "# a struck plate\n[scene]\nname = \"t\"   # its name\nseed = 1\n\n[material]\n\
        critical_stretch = 0.001  # the paper's\n\n[[sim.projectile]]\nradius_m = 0.002\n\
        velocity_m_s = [0.0, 0.0, -100.0] # fast\n";

    #[test]
    fn only_the_edited_values_change_and_comments_stay() {
        let mut edits = Edits::new();
        edits.insert("material.critical_stretch".into(), toml::Value::Float(0.002));
        edits.insert("sim.projectile[0].velocity_m_s".into(), toml::Value::try_from([0.0, 0.0, -40.0]).expect("value"));
        edits.insert("scene.seed".into(), toml::Value::Integer(7));
        let saved = saved_text(SCENE, &edits).expect("saved");
        let changed: Vec<(&str, &str)> = SCENE.lines().zip(saved.lines()).filter(|(a, b)| a != b).collect();
        assert_eq!(
            changed,
            [
                ("seed = 1", "seed = 7"),
                ("critical_stretch = 0.001  # the paper's", "critical_stretch = 0.002  # the paper's"),
                ("velocity_m_s = [0.0, 0.0, -100.0] # fast", "velocity_m_s = [0.0, 0.0, -40.0] # fast"),
            ]
        );
        assert_eq!(SCENE.lines().count(), saved.lines().count());
        let diff = diff("pipeline.toml", SCENE, &saved);
        assert!(diff.contains("-seed = 1\n+seed = 7\n"), "{diff}");
        assert!(saved_text(SCENE, &Edits::new()).expect("unchanged") == SCENE);
    }

    #[test]
    fn a_missing_array_entry_is_refused() {
        let mut edits = Edits::new();
        edits.insert("sim.projectile[3].radius_m".into(), toml::Value::Float(0.1));
        let error = saved_text(SCENE, &edits).expect_err("refused");
        assert!(error.contains("sim.projectile[3].radius_m"), "{error}");
    }
}
