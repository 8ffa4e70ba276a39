//! MiniSkeleton core: geometry processing for automatic rigging, in pure Rust.
//!
//! Grouped by area; each area is a folder whose `mod.rs` re-exports what callers use and keeps
//! the stages of its algorithms private:
//! - [`mesh`]: input checks, the unit frame, welding, pieces, winding, the cotangent Laplacian,
//!   ray queries, inside tests, Catmull-Clark limit positions, seams between meshes;
//! - [`weights`]: skinning weights (bone heat, bilinear, inverse distance), the top-k influence
//!   rows they share and left/right symmetry;
//! - [`skeleton`]: parent lists and fitting joints into the mesh;
//! - [`autorig`]: a Rigify-style skeleton for a bare mesh of a standing biped or quadruped;
//! - [`motion`]: the roles of a rig's bones and the head-shake / walk / run clips;
//! - [`posing`]: linear blend skinning and planar IK.
//!
//! Inputs are plain slices (`[f32; 3]` positions, `[u32; 3]` triangles) so the Python bindings
//! pass numpy buffers straight through. Nothing here knows about Python or Blender.

pub mod autorig;
pub mod error;
pub use error::{Error, Result};

pub mod mesh;
pub mod motion;
pub mod posing;
pub mod primitives;
pub mod skeleton;
pub mod weights;
