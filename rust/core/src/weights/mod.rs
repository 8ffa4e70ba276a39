//! Skinning weights: for every vertex, the bones that move it and how much.
//!
//! - [`heat_weights`]: bone heat (Baran & Popovic 2007), with its stages private in `heat/`;
//! - [`bilinear_weights`]: nearest-bone weights blended across joints;
//! - [`idw_weights`]: inverse distance to the bone segments;
//! - [`voxel_weights`]: geodesic voxel binding (Dionne & de Lasa 2013), with its stages private
//!   in `voxel/`;
//! - [`transfer_weights`]: a body's weights copied onto the clothes over it, the rest inpainted;
//! - [`Influences`]: the top-k rows all methods return, and the small-weight ramp;
//! - [`symmetry`]: left/right averaging of weights.

pub mod bilinear;
pub mod heat;
pub mod idw;
pub mod influence;
pub mod symmetry;
pub mod transfer;
pub mod voxel;

pub use bilinear::{bilinear_weights, BilinearOptions, Falloff, INVERSE_POWER};
pub use heat::{heat_sources, heat_weights, heat_weights_many, heat_weights_with_sources};
pub use heat::{BoneCurves, HeatOptions, HeatReport, MeshRef};
pub use idw::{idw_weights, IdwOptions};
pub use influence::{top_k_normalized, weight_limit, Influences};
pub use transfer::{transfer_weights, TransferOptions, TransferReport};
pub use voxel::{voxel_distances, voxel_weights, VoxelDistances, VoxelOptions, VoxelReport};
