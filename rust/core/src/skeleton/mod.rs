//! Skeletons: the one check of a parent list, and fitting a skeleton's joints into its mesh.
//!
//! - [`validate_parents`]: a parent list is a forest (used by weights, roles and motion);
//! - [`fit_joints`]: joints moved to the centre of the limb around them, with its
//!   cross-section stage private in `sections`;
//! - [`joint_tails`]: tails from the joints, for rigs whose tails an importer invented.

pub mod fit;
mod parents;
mod sections;
mod tails;

pub use fit::{fit_joints, points_inside, FitOptions, FitReport};
pub use parents::validate_parents;
pub use tails::joint_tails;
