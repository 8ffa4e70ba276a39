//! MiniSkeleton core: geometry processing for automatic rigging, in pure Rust.
//!
//! One algorithm per module, libigl style. Inputs are plain slices (`[f32; 3]` positions,
//! `[u32; 3]` triangles) so the Python bindings can pass numpy buffers straight through.
//! Nothing here knows about Python or Blender.

pub mod error;
pub use error::{Error, Result};

// Mesh input, topology and operators.
pub mod mesh;
pub mod segment;
pub mod weld;
pub mod islands;
pub mod cotan;
pub mod visibility;
pub mod primitives;

// Skinning weights.
pub mod influence;
pub mod idw;
pub mod bilinear;
pub mod heat;
pub mod symmetry;
pub mod reach;

// Posing.
pub mod lbs;
pub mod ik2d;

// Skeleton.
pub mod fit;

// Motion.
pub mod roles;
pub mod gait;
