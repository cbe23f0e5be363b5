//! The simulation's time step when `sim.dt_s` is unset, and how the stages after the simulation
//! learn the step it took (docs/DECISIONS.md#time-step-from-the-material).
//!
//! The simulation takes the largest power of two at most [`STABLE_STEP_FRACTION`] of the
//! smallest of the material's stable step (Silling and Askari's bound, which needs the bond
//! tables the simulation builds) and the steps at which the pushing bodies hold a particle. Its
//! frames record it: each frame's `time_s` is its step times the time step, so a later stage
//! reads the step from the first frame after the rest state ([`recorded_s`]).

use serde::Serializer;

use crate::OutputLayout;
use crate::frames::PointFrame;

/// The fraction of the stable step under which an unset `sim.dt_s` is taken. Half the stable
/// step: the paper's glass on its 1 mm grid (stable step 2.44e-7 s) lands on the paper's 2^-23 s.
pub const STABLE_STEP_FRACTION: f64 = 0.5;

/// What an unset `sim.dt_s` counts as in the settings' digests and hashes: the paper's 2^-23 s
/// (the power of two nearest Silling and Askari's 1e-7 s), which the scenes that leave the step
/// unset have always run at. The step taken follows from the particle file and the settings,
/// which the digests cover already; counting it as this keeps the digests of those scenes, and so
/// their outputs, what they were.
pub const UNSET_STEP_STAND_IN_S: f64 = 1.0 / 8_388_608.0;

/// The step taken under `limit_s` (the smallest of the stable step and the pushing bodies'
/// limits, seconds): the largest power of two at most [`STABLE_STEP_FRACTION`] of it. `None`
/// when nothing limits the step (no bonds and no pushing body) or the limit is not a positive
/// number.
pub fn from_limit_s(limit_s: f64) -> Option<f64> {
    let bound = STABLE_STEP_FRACTION * limit_s;
    if !bound.is_finite() || !bound.is_normal() || bound <= 0.0 {
        return None;
    }
    // a positive normal f64 with its mantissa cleared is the largest power of two at most it
    Some(f64::from_bits(bound.to_bits() & 0xfff0_0000_0000_0000))
}

/// `dt_s` as "2^-23" when it is a power of two, for messages.
pub fn power_of_two_name(dt_s: f64) -> Option<String> {
    let exponent = dt_s.log2().round() as i32;
    (dt_s > 0.0 && 2f64.powi(exponent) == dt_s).then(|| format!("2^{exponent}"))
}

/// The time step the simulation of `layout` took, seconds, read from its frame 2 (frame 1 is
/// the rest state, at step 0). An error names the file, and what to run when it is missing.
pub fn recorded_s(layout: &OutputLayout) -> Result<f64, String> {
    let path = layout.frame_points(2);
    if !path.is_file() {
        return Err(format!(
            "{}: missing (sim.dt_s is unset, and the simulation's frames record the step it took); run `shatter \
             sim` first",
            path.display()
        ));
    }
    let frame = PointFrame::read(&path).map_err(|error| error.to_string())?;
    let dt_s = frame.time_s / frame.step as f64;
    if frame.step == 0 || !dt_s.is_normal() || frame.step as f64 * dt_s != frame.time_s {
        return Err(format!(
            "{}: step {} at time_s {:e} gives no time step; run `shatter sim` again",
            path.display(),
            frame.step,
            frame.time_s
        ));
    }
    Ok(dt_s)
}

/// Serializes `sim.dt_s`, an unset step as [`UNSET_STEP_STAND_IN_S`].
pub(crate) fn serialize_dt_s<S: Serializer>(dt_s: &Option<f64>, serializer: S) -> Result<S::Ok, S::Error> {
    serializer.serialize_f64(dt_s.unwrap_or(UNSET_STEP_STAND_IN_S))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_step_is_the_largest_power_of_two_under_half_the_limit() {
        // the paper's glass on its 1 mm grid: 2^-23 s
        assert_eq!(from_limit_s(2.442e-7), Some(UNSET_STEP_STAND_IN_S));
        // steel on a 1 mm grid
        assert_eq!(from_limit_s(8.97e-8), Some(2f64.powi(-25)));
        // a limit of exactly twice a power of two takes that power
        assert_eq!(from_limit_s(2f64.powi(-20)), Some(2f64.powi(-21)));
        assert_eq!(from_limit_s(2f64.powi(-20) * 0.999_999), Some(2f64.powi(-22)));
        for nothing in [f64::INFINITY, 0.0, -1.0, f64::NAN] {
            assert_eq!(from_limit_s(nothing), None, "{nothing}");
        }
        assert_eq!(power_of_two_name(UNSET_STEP_STAND_IN_S).as_deref(), Some("2^-23"));
        assert_eq!(power_of_two_name(1e-7), None);
    }
}
