//! Debris emitter points, `fragments/debris.####.ply` (see docs/FORMATS.md): per frame, one
//! point per particle that lost bonds in it, as written by `shatter post` and read back by the
//! shot's USD export.

use std::path::Path;

use crate::ply::{Column, PlyError, PointCache};

/// One frame's debris points, in particle order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DebrisFrame {
    /// The frame.
    pub frame: u32,
    /// Positions, metres.
    pub position: Vec<[f32; 3]>,
    /// Velocities, m/s.
    pub velocity: Vec<[f32; 3]>,
    /// When the particle's first bond of the frame broke, seconds of simulated time.
    pub time_s: Vec<f32>,
    /// Bonds of the particle that broke during the frame.
    pub broken_bonds: Vec<i32>,
    /// The particle's fragment at the frame's end.
    pub fragment: Vec<i32>,
    /// The fragment across its first broken bond of the frame.
    pub other_fragment: Vec<i32>,
}

/// Writes `debris` as a PLY point cache (also when it holds no point: a frame without breaks).
pub fn write_point_cache(path: &Path, debris: &DebrisFrame, step: u64, time_s: f64) -> Result<(), PlyError> {
    let axis = |values: &[[f32; 3]], k: usize| Column::Float(values.iter().map(|v| v[k]).collect());
    let cache = PointCache {
        comments: vec![
            ("frame".into(), debris.frame.to_string()),
            ("step".into(), step.to_string()),
            ("time_s".into(), format!("{time_s:e}")),
        ],
        columns: vec![
            ("x".into(), axis(&debris.position, 0)),
            ("y".into(), axis(&debris.position, 1)),
            ("z".into(), axis(&debris.position, 2)),
            ("vx".into(), axis(&debris.velocity, 0)),
            ("vy".into(), axis(&debris.velocity, 1)),
            ("vz".into(), axis(&debris.velocity, 2)),
            ("break_time_s".into(), Column::Float(debris.time_s.clone())),
            ("broken_bonds".into(), Column::Int(debris.broken_bonds.clone())),
            ("fragment".into(), Column::Int(debris.fragment.clone())),
            ("other_fragment".into(), Column::Int(debris.other_fragment.clone())),
        ],
    };
    cache.write(path)
}

/// Reads a debris point cache written by [`write_point_cache`].
pub fn read_point_cache(path: &Path) -> Result<DebrisFrame, PlyError> {
    let cache = PointCache::read(path)?;
    let invalid = |what: &str| PlyError::Invalid { path: path.to_path_buf(), what: what.to_string() };
    let floats = |name: &str| cache.floats(name).ok_or_else(|| invalid(&format!("no float column {name}")));
    let ints =
        |name: &str| cache.ints(name).map(<[i32]>::to_vec).ok_or_else(|| invalid(&format!("no int column {name}")));
    let vectors = |names: [&str; 3]| -> Result<Vec<[f32; 3]>, PlyError> {
        let [x, y, z] = [floats(names[0])?, floats(names[1])?, floats(names[2])?];
        Ok((0..cache.len()).map(|i| [x[i], y[i], z[i]]).collect())
    };
    let frame =
        cache.comment("frame").and_then(|frame| frame.parse().ok()).ok_or_else(|| invalid("no frame number"))?;
    Ok(DebrisFrame {
        frame,
        position: vectors(["x", "y", "z"])?,
        velocity: vectors(["vx", "vy", "vz"])?,
        time_s: floats("break_time_s")?.to_vec(),
        broken_bonds: ints("broken_bonds")?,
        fragment: ints("fragment")?,
        other_fragment: ints("other_fragment")?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn debris_point_caches_round_trip() {
        let debris = DebrisFrame {
            frame: 4,
            position: vec![[0.0, 1.0, 2.0], [3.0, 4.0, 5.0]],
            velocity: vec![[0.5, 0.0, -0.5], [1.0, 2.0, 3.0]],
            time_s: vec![1e-5, 2e-5],
            broken_bonds: vec![1, 3],
            fragment: vec![0, 2],
            other_fragment: vec![1, 2],
        };
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("debris.0004.ply");
        write_point_cache(&path, &debris, 40, 4e-5).expect("write");
        assert_eq!(read_point_cache(&path).expect("read"), debris);
        let empty = DebrisFrame { frame: 5, ..DebrisFrame::default() };
        write_point_cache(&path, &empty, 50, 5e-5).expect("write");
        assert_eq!(read_point_cache(&path).expect("read"), empty);
    }
}
