//! MiniSkeleton core: geometry processing for automatic rigging, in pure Rust.
//!
//! One algorithm per module, libigl style. Inputs are plain slices (`[f32; 3]` positions,
//! `[u32; 3]` triangles) so the Python bindings can pass numpy buffers straight through.
//! Nothing here knows about Python or Blender.

pub mod error;
pub use error::{Error, Result};

// Mesh input, topology and operators.
pub mod catmull_clark;
pub mod cotan;
pub mod islands;
pub mod mesh;
pub mod orient;
pub mod primitives;
pub mod seams;
pub mod segment;
pub mod solid;
pub mod visibility;
pub mod weld;

// Skinning weights.
pub mod bilinear;
mod blocks;
mod cholesky;
pub mod heat;
pub mod idw;
pub mod influence;
mod pieces;
pub mod reach;
mod sources;
pub mod symmetry;

// Posing.
pub mod ik2d;
pub mod lbs;

// Skeleton.
pub mod fit;
mod sections;

// Motion.
pub mod gait;
mod hierarchy;
pub mod roles;
