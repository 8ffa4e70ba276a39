//! Meshes: input checks, the unit frame, and the topology and geometry every other area builds
//! on. Each file is one algorithm with its own doc (inputs and outputs with shapes, the method,
//! its limits).
//!
//! - `input`: validation of vertices, triangles and bones, with errors naming the bad entry;
//! - `frame`: the unit frame (bounding box centred, diagonal 1) all tolerances live in;
//! - [`weld`]: coincident vertices merged (split seams);
//! - [`islands`]: connected pieces;
//! - `lattice`: a regular grid of voxels and its addressing;
//! - [`orient`]: consistent winding and outward vertex normals;
//! - [`cotan`]: cotangent Laplacian and lumped mass;
//! - [`mirror`]: the mirror plane and which points are each other's images;
//! - [`segment`]: point-to-segment distance (a bone is a segment);
//! - [`visibility`]: a BVH of triangles for segment and ray queries;
//! - [`solid`]: the inside test of a mesh in several pieces;
//! - [`facing`]: inside by the faces seen along the axes (open and nested pieces);
//! - [`catmull_clark`]: limit positions of a subdivision surface;
//! - [`seams`]: which meshes touch along a seam.

mod frame;
mod input;

pub mod catmull_clark;
pub mod cotan;
pub mod facing;
pub mod islands;
pub(crate) mod lattice;
pub mod mirror;
pub mod orient;
pub mod seams;
pub mod segment;
pub mod solid;
pub mod visibility;
pub mod weld;

pub use catmull_clark::limit_positions;
pub use frame::{bones_in_frame, Frame};
pub use input::{bounding_box, count_non_finite, to_dvec, validate_bones, validate_mesh};
pub use islands::connected_components;
pub use mirror::Symmetry;
pub use seams::touching_meshes;
pub use segment::closest_point_on_segment;
pub use weld::weld;
