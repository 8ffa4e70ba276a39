//! Bone tails from the joints alone, for rigs whose tails an importer invented (glTF and FBX
//! store joints, not bones: Blender's importers give each bone a tail of their own choosing,
//! which may point anywhere and be many times the skeleton's size).
//!
//! Inputs
//!   heads    #B by 3 bone heads (the joints)
//!   tails    #B by 3 the tails as imported (used only where the joints say nothing)
//!   parents  #B parent index, -1 for roots (validated: a forest)
//! Output
//!   #B by 3 tails: a bone with children ends at the mean of its children's heads that lie
//!   away from its own; a bone without (a leaf, or one whose children all start at its head)
//!   continues its parent's line from its head for half its parent's span; a root with no
//!   such joint keeps its imported tail.
//!
//! See also: `weights/heat/reach.rs`, which represents the same bones for bone heat by the
//! spans to their children's heads.

use glam::Vec3;

/// Children heads closer than this fraction of the skeleton's size to a bone's head start at
/// the head (a twist bone, a socket) and say nothing of where the bone points.
const SAME_JOINT: f32 = 1e-4;

/// Tails from the joints (see the module doc). `parents` must be valid
/// ([`crate::skeleton::validate_parents`]).
pub fn joint_tails(heads: &[[f32; 3]], tails: &[[f32; 3]], parents: &[i32]) -> Vec<[f32; 3]> {
    let n = heads.len();
    let h = |b: usize| Vec3::from(heads[b]);
    let (lo, hi) = heads
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(Vec3::from(*p)), hi.max(Vec3::from(*p))));
    let near = SAME_JOINT * (hi - lo).length().max(f32::MIN_POSITIVE);
    let mut sum = vec![Vec3::ZERO; n];
    let mut count = vec![0u32; n];
    for (b, &p) in parents.iter().enumerate() {
        if p >= 0 && (h(b) - h(p as usize)).length() > near {
            sum[p as usize] += h(b);
            count[p as usize] += 1;
        }
    }
    (0..n)
        .map(|b| {
            if count[b] > 0 {
                return (sum[b] / count[b] as f32).to_array();
            }
            match usize::try_from(parents[b]) {
                Ok(p) if (h(b) - h(p)).length() > near => (h(b) + (h(b) - h(p)) * 0.5).to_array(),
                _ => tails[b],
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tails_follow_the_joints() {
        // hips -> (spine, thigh); thigh -> shin; shin leaf; spine leaf; a twist bone at the
        // thigh's head.
        let heads = [[0.0, 0.0, 1.0], [0.0, 0.0, 1.2], [0.1, 0.0, 1.0], [0.1, 0.0, 0.5], [0.1, 0.0, 1.0]];
        let tails = [[0.0, 40.0, 1.0]; 5];
        let parents = [-1, 0, 0, 2, 2];
        let t = joint_tails(&heads, &tails, &parents);
        // hips: mean of spine and thigh heads (the thigh's head is away from the hips' head)
        assert_eq!(t[0], [0.05, 0.0, 1.1]);
        // spine: a leaf continuing hips -> spine for half that span
        assert!((Vec3::from(t[1]) - Vec3::new(0.0, 0.0, 1.3)).length() < 1e-6);
        // thigh: its one child away from it, the twist bone at its head says nothing
        assert_eq!(t[2], [0.1, 0.0, 0.5]);
        // shin: continues thigh -> shin
        assert!((Vec3::from(t[3]) - Vec3::new(0.1, 0.0, 0.25)).length() < 1e-6);
        // the twist bone starts at its parent's head: no line to continue, imported tail kept
        assert_eq!(t[4], tails[4]);
    }
}
