//! Fixed-length arrays (`box_size_m = [x, y, z]`, `resolution = [w, h]`, ...) must have exactly
//! their length in the file. The TOML reader fills a fixed-size array from the first entries of a
//! longer one and drops the rest without a word, so the parsed config is compared with the text:
//! every array the file gives must have as many entries as the parsed value holds.

use serde_json::Value;

/// The first array, in key order, whose length in `given` (the file as parsed, without types)
/// differs from its length in `parsed` (the typed config, serialized): its dotted key, the
/// expected and the given length.
pub(super) fn first_mismatch(given: &Value, parsed: &Value, key: &str) -> Option<(String, usize, usize)> {
    match (given, parsed) {
        (Value::Object(given), Value::Object(parsed)) => given.iter().find_map(|(name, value)| {
            let child = if key.is_empty() { name.clone() } else { format!("{key}.{name}") };
            parsed.get(name).and_then(|typed| first_mismatch(value, typed, &child))
        }),
        (Value::Array(given), Value::Array(parsed)) if given.len() != parsed.len() => {
            Some((key.to_owned(), parsed.len(), given.len()))
        }
        (Value::Array(given), Value::Array(parsed)) => given
            .iter()
            .zip(parsed)
            .enumerate()
            .find_map(|(index, (value, typed))| first_mismatch(value, typed, &format!("{key}[{index}]"))),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn a_longer_or_shorter_array_is_named_by_its_key() {
        let parsed =
            json!({"geometry": {"box_size_m": [1.0, 2.0, 3.0]}, "sim": {"projectile": [{"center_m": [0, 0, 0]}]}});
        let same = json!({"geometry": {"box_size_m": [1.0, 2.0, 3.0]}});
        assert_eq!(first_mismatch(&same, &parsed, ""), None);
        let longer = json!({"geometry": {"box_size_m": [1.0, 2.0, 3.0, 4.0]}});
        assert_eq!(first_mismatch(&longer, &parsed, ""), Some(("geometry.box_size_m".into(), 3, 4)));
        let nested = json!({"sim": {"projectile": [{"center_m": [0, 0, 0, 9]}]}});
        assert_eq!(first_mismatch(&nested, &parsed, ""), Some(("sim.projectile[0].center_m".into(), 3, 4)));
        let unknown_to_the_types = json!({"render": {"resolution": [1, 2, 3]}});
        assert_eq!(first_mismatch(&unknown_to_the_types, &parsed, ""), None);
    }
}
