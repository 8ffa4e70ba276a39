//! Posing: linear blend skinning of a mesh by posed bones, planar IK for shadow puppets, and
//! two-bone IK for legs.
//!
//! - [`lbs`]: linear blend skinning;
//! - [`ik2d`]: planar chains solved by CCD, FABRIK and their variants;
//! - [`two_bone_ik`]: the analytic two-bone IK that plants a walking leg's foot.

pub mod ik2d;
mod lbs;
mod two_bone;

pub use lbs::lbs;
pub use two_bone::{frame_turn, two_bone_ik, TwoBone};
