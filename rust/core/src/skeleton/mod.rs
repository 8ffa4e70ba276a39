//! Skeletons: the one check of a parent list, left and right in bone names, and fitting a
//! skeleton's joints into its mesh.
//!
//! - [`Skeleton`]: heads, tails, parents and names as one view, as roles and motion take them;
//! - [`validate_parents`]: a parent list is a forest (used by weights, roles and motion);
//! - [`mirror_name`], [`name_side`], [`bone_mirror_indices`]: the one left/right rule for bone
//!   names (`thigh.L` <-> `thigh.R`), in `names`;
//! - [`fit_joints`]: joints moved to the centre of the limb around them, with its
//!   cross-section stage private in `sections`;
//! - [`joint_tails`]: tails from the joints, for rigs whose tails an importer invented.

mod bones;
pub mod fit;
mod names;
mod parents;
pub(crate) mod sections;
mod tails;

pub use bones::Skeleton;
pub use fit::{fit_joints, points_inside, FitOptions, FitReport};
pub use names::{bone_mirror_indices, mirror_name, name_side, Side};
pub use parents::validate_parents;
pub use tails::joint_tails;
