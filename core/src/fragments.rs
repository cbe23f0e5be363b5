//! The fragments file of one frame (`fragments.####.shp`): which fragment each element belongs
//! to and each fragment's rigid motion from the rest frame, x = R X + t.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::stage_file::{StageFileError, StageKind, StageReader, StageWriter};

/// Scalars of a fragments frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FragmentMeta {
    /// Frame number (1 is the rest state).
    pub frame: u32,
    /// Steps simulated to reach it.
    pub step: u64,
    /// Simulated time, seconds.
    pub time_s: f64,
    /// Whether transforms were smoothed (the post stage's PD controller).
    pub smoothed: bool,
    /// What the frame was made from ([`crate::digest::post_inputs`]); `None` in files written
    /// before it was recorded.
    #[serde(default)]
    pub inputs: Option<u32>,
}

/// One frame's fragments.
#[derive(Debug, Clone, PartialEq)]
pub struct FragmentFrame {
    /// Frame, step, time.
    pub meta: FragmentMeta,
    /// The fragment of each element; fragment ids are 0 .. fragment count, stable over frames (a
    /// fragment that splits keeps its id on its largest part; new parts get new ids).
    pub fragment_of: Vec<u32>,
    /// Rotation of each fragment from the rest frame, unit quaternion [x, y, z, w].
    pub rotation: Vec<[f32; 4]>,
    /// Translation of each fragment, metres: x = R X + t.
    pub translation_m: Vec<[f64; 3]>,
    /// Number of elements in each fragment.
    pub elements: Vec<u32>,
    /// Mass of each fragment, kg.
    pub mass_kg: Vec<f64>,
}

impl FragmentFrame {
    /// Number of fragments.
    pub fn fragment_count(&self) -> usize {
        self.rotation.len()
    }

    /// Writes the frame atomically.
    pub fn write(&self, path: &Path) -> Result<(), StageFileError> {
        let mut out = StageWriter::create(path, StageKind::Fragments)?;
        out.write_json("meta", &self.meta)?;
        out.write_rows("fragment_of", &self.fragment_of)?;
        out.write_rows("rotation", &self.rotation)?;
        let translation: Vec<f64> = self.translation_m.iter().flatten().copied().collect();
        out.write_rows("translation", &translation)?;
        out.write_rows("elements", &self.elements)?;
        out.write_rows("mass", &self.mass_kg)?;
        out.finish()
    }

    /// Reads and validates a frame.
    pub fn read(path: &Path) -> Result<FragmentFrame, StageFileError> {
        let mut input = StageReader::open(path, StageKind::Fragments)?;
        let meta = input.read_json("meta")?;
        let fragment_of = input.read_rows("fragment_of")?;
        let rotation = input.read_rows("rotation")?;
        let translation: Vec<f64> = input.read_rows("translation")?;
        let elements = input.read_rows("elements")?;
        let mass_kg = input.read_rows("mass")?;
        let translation_m = translation.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
        let frame = FragmentFrame { meta, fragment_of, rotation, translation_m, elements, mass_kg };
        if !translation.len().is_multiple_of(3) {
            return Err(input.malformed("translations are not triples".into()));
        }
        frame.validate().map_err(|what| input.malformed(what))?;
        input.finish()?;
        Ok(frame)
    }

    /// Checks the structural rules: matching lengths, ids in range, unit rotations, counts that
    /// add up.
    pub fn validate(&self) -> Result<(), String> {
        let fragments = self.rotation.len();
        if self.translation_m.len() != fragments || self.elements.len() != fragments || self.mass_kg.len() != fragments
        {
            return Err(format!("{fragments} rotations but other per-fragment arrays differ in length"));
        }
        let mut counted = vec![0u32; fragments];
        for (element, &fragment) in self.fragment_of.iter().enumerate() {
            let Some(count) = counted.get_mut(fragment as usize) else {
                return Err(format!("element {element} is in fragment {fragment}, of only {fragments}"));
            };
            *count += 1;
        }
        if counted != self.elements {
            return Err("fragment element counts do not match the elements' fragments".into());
        }
        for (fragment, q) in self.rotation.iter().enumerate() {
            let norm: f32 = q.iter().map(|c| c * c).sum();
            if !norm.is_finite() || (norm - 1.0).abs() > 1e-4 {
                return Err(format!("fragment {fragment}'s rotation {q:?} is not a unit quaternion"));
            }
        }
        if self.translation_m.iter().flatten().any(|c| !c.is_finite()) {
            return Err("a translation is not finite".into());
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_round_trip_and_inconsistencies_are_named() {
        let frame = FragmentFrame {
            meta: FragmentMeta { frame: 4, step: 300, time_s: 3.6e-5, smoothed: false, inputs: Some(0x1234_abcd) },
            fragment_of: vec![0, 0, 1],
            rotation: vec![[0.0, 0.0, 0.0, 1.0], [0.0, 0.6, 0.0, 0.8]],
            translation_m: vec![[0.0; 3], [1.0, 2.0, 3.0]],
            elements: vec![2, 1],
            mass_kg: vec![2.0, 1.0],
        };
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("f.shp");
        frame.write(&path).expect("write");
        assert_eq!(FragmentFrame::read(&path).expect("read"), frame);
        let mut wrong = frame.clone();
        wrong.fragment_of[2] = 5;
        assert!(wrong.validate().expect_err("range").contains("of only 2"));
    }
}
