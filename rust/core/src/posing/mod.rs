//! Posing: linear blend skinning of a mesh by posed bones, and planar IK for shadow puppets.
//!
//! - [`lbs`]: linear blend skinning;
//! - [`ik2d`]: planar chains solved by CCD, FABRIK and their variants.

pub mod ik2d;
mod lbs;

pub use lbs::lbs;
