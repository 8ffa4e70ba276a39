//! Motion: what each bone of a rig is (legs, spine, head, tail), and the head-shake, walk and
//! run clips built on those roles.
//!
//! - [`detect_roles`]: legs, spine, neck, head and tail from the joints' layout and the bones'
//!   names, with the joint tree it reads private in `hierarchy`;
//! - [`motion_clip`]: per-frame bone rotations (and root motion) of a clip, with the feet
//!   planted by its private stage `footfalls` on the ground the character's [`Skin`] stands on,
//!   a body that does not stand level first settled (`settle`); [`steered_clip`] the same along
//!   a [`Course`] and over a [`Terrain`] (private stages `course` and `terrain`); the clip's
//!   jobs in their own files: what is asked and given (`clip`: [`GaitParams`], [`Clip`]), the
//!   gait cycle (`gait`), the head shake (`shake`), planting the legs at one moment
//!   (`planting`) and forward kinematics (`pose`, with [`posed_points`]).

mod clip;
mod course;
mod footfalls;
pub mod gait;
mod hierarchy;
mod planting;
mod pose;
pub mod roles;
mod settle;
mod shake;
pub mod skin;
mod terrain;

/// The side a bone name states; the rule lives with the other name rules in `skeleton`.
pub use crate::skeleton::{name_side, Skeleton};
pub use clip::{Clip, GaitParams, Motion, Steer};
pub use course::Course;
pub use gait::{motion_clip, steered_clip};
pub use pose::posed_points;
pub use roles::{detect_roles, BodyPlan, Limb, Roles, Side};
pub use skin::Skin;
pub use terrain::Terrain;
