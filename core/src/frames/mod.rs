//! What `shatter sim` writes per frame into the frames folder: a binary PLY point cache
//! ([`point_frame`]: position, velocity, damage; readable by Blender and Houdini) and the
//! append-only bond-break log ([`break_log`]).
//!
//! Both are checksummed: the PLY header carries a CRC-32 of its body in a comment (see
//! [`crate::ply`]), and each block of the break log carries one of its records. Formats:
//! docs/FORMATS.md.

mod break_log;
mod frame_file_error;
mod point_frame;

pub use break_log::{BreakBlock, BreakEvent, BreakLog};
pub use frame_file_error::FrameFileError;
pub use point_frame::PointFrame;
