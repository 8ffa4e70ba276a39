//! How flat the solid is across a path of the centre-line tree: a limb is a tube, round or oval
//! across; a wing's membrane, a fin or a cape is a sheet.
//!
//! Inputs: the [`Tree`], its [`Voxels`], a path of tree nodes (from a leaf inward) and the stretch
//! of it to read, `from..to` (arc lengths from the path's start, unit frame).
//! Output: the median, over the path's nodes in the stretch that lie inside the solid, of the
//! widest chord of the solid through the node across the path over the narrowest (1 for a round
//! tube, about 1.5 for an oval limb, the width over the thickness for a sheet); `None` when no
//! node of the stretch lies inside.
//!
//! Method: at each node, the path's direction over [`SPAN`] nodes either side; in the plane
//! perpendicular to it, [`DIRECTIONS`] chords over half a turn, each the solid's reach from the
//! node both ways (`Voxels::reach`, half-voxel steps, at most [`CAP`] times the node's depth or
//! a voxel each way) and a voxel (the half voxels beyond the last inside points). The median
//! over the nodes outvotes a few nodes where the path turns (a knee, an ankle).
//!
//! Known limits: a sheet or a limb one or two voxels thick is read in half voxels, so ratios
//! there are coarse (a thin tube reads up to about 2); a sheet narrower than [`CAP`] times its
//! thickness reads no flatter than it is wide.

use super::centreline::Tree;
use super::voxels::Voxels;
use glam::DVec3;

/// Nodes either side of a node that give the path's direction there.
const SPAN: usize = 2;
/// Chords across the path, over half a turn.
const DIRECTIONS: usize = 8;
/// A chord reaches at most this many times the node's depth each way.
const CAP: f64 = 10.0;

/// The median flatness of the solid across `path` over arc lengths `from..to` (see the module).
pub(super) fn flatness(tree: &Tree, vox: &Voxels, path: &[usize], from: f64, to: f64) -> Option<f64> {
    let mut ratios = Vec::new();
    let mut walked = 0.0;
    for i in 0..path.len() {
        if i > 0 {
            walked += (tree.pos[path[i]] - tree.pos[path[i - 1]]).length();
        }
        if walked > to {
            break;
        }
        if walked >= from {
            ratios.extend(across(tree, vox, path, i));
        }
    }
    if ratios.is_empty() {
        return None;
    }
    ratios.sort_by(f64::total_cmp);
    Some(ratios[ratios.len() / 2])
}

/// The widest chord over the narrowest across `path` at its `i`-th node, `None` when the node
/// lies outside the solid.
fn across(tree: &Tree, vox: &Voxels, path: &[usize], i: usize) -> Option<f64> {
    let p = tree.pos[path[i]];
    if !vox.inside_at(p) {
        return None;
    }
    let a = tree.pos[path[i.saturating_sub(SPAN)]];
    let b = tree.pos[path[(i + SPAN).min(path.len() - 1)]];
    let d = (b - a).normalize_or(DVec3::Z);
    let u = d.any_orthonormal_vector();
    let v = d.cross(u);
    let cap = CAP * tree.radius[path[i]].max(vox.step);
    let (mut widest, mut narrowest) = (0.0f64, f64::INFINITY);
    for k in 0..DIRECTIONS {
        let angle = k as f64 * std::f64::consts::PI / DIRECTIONS as f64;
        let e = u * angle.cos() + v * angle.sin();
        // The inside points reached both ways, each standing for its half voxel either side.
        let chord = vox.reach(p, e, cap) + vox.reach(p, -e, cap) + vox.step;
        widest = widest.max(chord);
        narrowest = narrowest.min(chord);
    }
    Some(widest / narrowest)
}
