//! The fragments file of one frame (`fragments.####.shp`): which fragment each element belongs
//! to and each fragment's rigid motion from the rest frame, x = R X + t; and, when elements are
//! drawn deformed (`post.element_shapes`), each element's affine map x = A X + b.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::stage_file::{StageFileError, StageKind, StageReader, StageWriter};

/// How a frame's mass is shared: the shots' shatter criterion (docs/DECISIONS.md#vase-drop-material)
/// is at least ten fragments over 1% of the mass and single elements under 10%.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassShares {
    /// The largest fragment's share of the mass.
    pub largest: f64,
    /// Fragments holding over 1% of the mass each.
    pub over_one_percent: usize,
    /// The share held by single-element fragments (dust).
    pub single_elements: f64,
}

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
    /// With deformed elements: each element's affine map from the rest frame, x = A X + b, as
    /// the rows of [A | b] ([`AFFINE_RIGID`] where the element moves with its fragment's rigid
    /// motion); None when elements are drawn rigid (the file then has no such section).
    pub element_affine: Option<Vec<[f32; 12]>>,
}

/// The affine map of an element that moves exactly as its fragment ([`FragmentFrame::rotation`],
/// [`FragmentFrame::translation_m`]): all zeros (no affine map has a zero matrix).
pub const AFFINE_RIGID: [f32; 12] = [0.0; 12];

/// Whether `affine` is [`AFFINE_RIGID`].
pub fn is_affine_rigid(affine: &[f32; 12]) -> bool {
    affine.iter().all(|v| *v == 0.0)
}

/// `affine` (an element's map at a frame where its fragment moved by `from`: rotation [x, y, z,
/// w], translation) followed by the rigid motion that takes the fragment from `from` to `to`:
/// x = R_to R_from^-1 (A X + b - t_from) + t_to. [`AFFINE_RIGID`] stays as it is (the element
/// still moves with its fragment).
pub fn compose_affine_with_motion(
    affine: &[f32; 12],
    from: ([f32; 4], [f64; 3]),
    to: ([f32; 4], [f64; 3]),
) -> [f32; 12] {
    if is_affine_rigid(affine) {
        return AFFINE_RIGID;
    }
    let quat = |q: [f32; 4]| glam::DQuat::from_array(q.map(f64::from)).normalize();
    let relative = glam::DMat3::from_quat(quat(to.0) * quat(from.0).inverse());
    let (t_from, t_to) = (glam::DVec3::from_array(from.1), glam::DVec3::from_array(to.1));
    let column = |c: usize| glam::DVec3::new(f64::from(affine[c]), f64::from(affine[4 + c]), f64::from(affine[8 + c]));
    let a = glam::DMat3::from_cols(column(0), column(1), column(2));
    let b = glam::DVec3::new(f64::from(affine[3]), f64::from(affine[7]), f64::from(affine[11]));
    let (a, b) = (relative * a, relative * (b - t_from) + t_to);
    let mut out = [0.0f32; 12];
    for r in 0..3 {
        for c in 0..3 {
            out[4 * r + c] = a.col(c)[r] as f32;
        }
        out[4 * r + 3] = b[r] as f32;
    }
    out
}

impl FragmentFrame {
    /// Number of fragments.
    pub fn fragment_count(&self) -> usize {
        self.rotation.len()
    }

    /// How the mass is shared among the fragments (None for a massless frame).
    pub fn mass_shares(&self) -> Option<MassShares> {
        let total: f64 = self.mass_kg.iter().sum();
        if total <= 0.0 {
            return None;
        }
        let dust: f64 = self.mass_kg.iter().zip(&self.elements).filter(|(_, n)| **n == 1).map(|(m, _)| m).sum();
        Some(MassShares {
            largest: self.mass_kg.iter().copied().fold(0.0, f64::max) / total,
            over_one_percent: self.mass_kg.iter().filter(|&&m| m > 0.01 * total).count(),
            single_elements: dust / total,
        })
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
        if let Some(affine) = &self.element_affine {
            out.write_rows("element_affine", affine.as_flattened())?;
        }
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
        let affine: Option<Vec<f32>> = if input.at_end() { None } else { Some(input.read_rows("element_affine")?) };
        let translation_m = translation.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
        if !translation.len().is_multiple_of(3) {
            return Err(input.malformed("translations are not triples".into()));
        }
        if affine.as_ref().is_some_and(|a| !a.len().is_multiple_of(12)) {
            return Err(input.malformed("element affine maps are not rows of 12 values".into()));
        }
        let element_affine =
            affine.map(|a| a.chunks_exact(12).map(|m| std::array::from_fn(|k| m[k])).collect::<Vec<[f32; 12]>>());
        let frame = FragmentFrame { meta, fragment_of, rotation, translation_m, elements, mass_kg, element_affine };
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
        if let Some(affine) = &self.element_affine {
            if affine.len() != self.fragment_of.len() {
                return Err(format!("{} element affine maps for {} elements", affine.len(), self.fragment_of.len()));
            }
            if let Some(element) = affine.iter().position(|m| m.iter().any(|v| !v.is_finite())) {
                return Err(format!("element {element}'s affine map is not finite"));
            }
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
            element_affine: None,
        };
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("f.shp");
        frame.write(&path).expect("write");
        assert_eq!(FragmentFrame::read(&path).expect("read"), frame);
        let mut wrong = frame.clone();
        wrong.fragment_of[2] = 5;
        assert!(wrong.validate().expect_err("range").contains("of only 2"));
        // with deformed elements: the optional last section, checked for length and finiteness
        let mut deformed = frame.clone();
        let stretch = [1.1, 0.0, 0.0, 0.5, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.9, -0.25];
        deformed.element_affine = Some(vec![stretch, AFFINE_RIGID, stretch]);
        deformed.write(&path).expect("write");
        assert_eq!(FragmentFrame::read(&path).expect("read"), deformed);
        let mut short = deformed.clone();
        short.element_affine = Some(vec![stretch]);
        assert!(short.validate().expect_err("length").contains("1 element affine maps for 3 elements"));
        let mut infinite = deformed.clone();
        infinite.element_affine = Some(vec![stretch, stretch, [f32::NAN; 12]]);
        assert!(infinite.validate().expect_err("finite").contains("element 2"));
        assert!(is_affine_rigid(&AFFINE_RIGID) && !is_affine_rigid(&stretch));
    }

    /// The follow-through moves a deformed element with its body: the map composed with the
    /// body's motion since the handoff.
    #[test]
    fn an_affine_map_follows_its_fragments_motion() {
        let map = [1.1, 0.2, 0.0, 0.5, 0.0, 0.9, 0.1, -0.2, 0.05, 0.0, 1.2, 0.3];
        let apply = |m: &[f32; 12], x: [f64; 3]| {
            [0, 1, 2].map(|r| (0..3).map(|c| f64::from(m[4 * r + c]) * x[c]).sum::<f64>() + f64::from(m[4 * r + 3]))
        };
        let from = (glam::Quat::from_rotation_y(0.3).to_array(), [0.1, 0.0, 0.0]);
        let to = (glam::Quat::from_rotation_x(1.2).to_array(), [0.0, 2.0, -1.0]);
        let moved = compose_affine_with_motion(&map, from, to);
        let motion = |(q, t): ([f32; 4], [f64; 3]), x: glam::DVec3| {
            glam::DQuat::from_array(q.map(f64::from)) * x + glam::DVec3::from_array(t)
        };
        for x in [[0.0, 0.0, 0.0], [1.0, -2.0, 0.5], [0.3, 0.7, -1.1]] {
            // where the element's point was at the handoff, taken back to the fragment's rest
            // frame and then moved as the fragment is now
            let at_handoff = glam::DVec3::from_array(apply(&map, x));
            let rest = glam::DQuat::from_array(from.0.map(f64::from)).inverse()
                * (at_handoff - glam::DVec3::from_array(from.1));
            let expected = motion(to, rest);
            let found = glam::DVec3::from_array(apply(&moved, x));
            assert!((found - expected).length() < 1e-5, "{found} vs {expected}");
        }
        assert_eq!(compose_affine_with_motion(&AFFINE_RIGID, from, to), AFFINE_RIGID);
    }

    /// A rigid frame is written exactly as before the optional section existed.
    #[test]
    fn a_rigid_frame_has_no_affine_section() {
        let frame = FragmentFrame {
            meta: FragmentMeta { frame: 1, step: 0, time_s: 0.0, smoothed: false, inputs: None },
            fragment_of: vec![0],
            rotation: vec![[0.0, 0.0, 0.0, 1.0]],
            translation_m: vec![[0.0; 3]],
            elements: vec![1],
            mass_kg: vec![1.0],
            element_affine: None,
        };
        let dir = tempfile::tempdir().expect("tempdir");
        let (rigid, deformed) = (dir.path().join("r.shp"), dir.path().join("d.shp"));
        frame.write(&rigid).expect("write");
        FragmentFrame { element_affine: Some(vec![AFFINE_RIGID]), ..frame.clone() }.write(&deformed).expect("write");
        let (rigid, deformed) = (std::fs::read(rigid).expect("read"), std::fs::read(deformed).expect("read"));
        assert!(!String::from_utf8_lossy(&rigid).contains("element_affine"));
        assert!(String::from_utf8_lossy(&deformed).contains("element_affine"));
        assert!(deformed.len() > rigid.len());
    }
}
