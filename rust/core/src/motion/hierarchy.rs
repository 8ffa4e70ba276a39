//! The hierarchy a rig really has, for finding its roles (`roles.rs`): trees that touch are
//! joined into one, feet hanging off the root ride on their legs, and the main tree is the
//! root with the most bones below it.
//!
//! Hand-made and glTF rigs are often several root chains meeting at shared joints (a neck
//! tree, leg trees, a body tree), and game rigs exported from an IK set-up parent each foot to
//! the ground root bone; either way the parent indices alone do not say which bones form the
//! body. Thresholds are fractions of the rig's height.

use glam::Vec3;

/// A leaf bone ending this low (fraction of the height above the lowest point) is a foot.
pub(crate) const GROUND_FRACTION: f32 = 0.2;

/// Where a foot riding on the root may lie, as fractions of the height: within `reach`
/// horizontally and `lift` below the end of its leg chain (RobotExpressive's shins end at the
/// knee, 0.3 above), or below the head of the chain's last bone (its knee or stifle, whose tail an
/// importer invented) by at least `drop` and at most `lift`, sloping no more than `slope`
/// sideways per unit down (a hock behind the stifle slopes 1); its chain starts at most `top`
/// above the lowest point and reaches within `ground` of it (a foot stands on the ground; a
/// tabard's flap or an IK target at the ankle does not).
const RIDER: Rider = Rider { reach: 0.1, lift: 0.5, drop: 0.05, slope: 1.2, top: 0.35, ground: 0.05 };
/// A foot riding on the root whose chain ends this far (per unit of the height) above the
/// lowest point counts this much further from its leg: a foot chain down to the toes rides
/// before an IK target at the ankle.
const RIDER_LOW_COST: f32 = 0.5;

/// The rider thresholds ([`RIDER`]), fractions of the height or, for `slope`, a ratio.
#[derive(Clone, Copy)]
struct Rider {
    reach: f32,
    lift: f32,
    drop: f32,
    slope: f32,
    top: f32,
    ground: f32,
}

/// The main tree of a hierarchy (`build_tree`).
pub(crate) struct Tree {
    /// Each bone's children.
    pub children: Vec<Vec<usize>>,
    /// Main-tree bones in depth-first pre-order (parents before children).
    pub order: Vec<usize>,
    /// The root of the main tree (the one with the most bones).
    pub root: usize,
}

fn v(p: [f32; 3]) -> Vec3 {
    Vec3::from_array(p)
}

/// Step 1 of [`crate::motion::roles::detect_roles`]: separate trees joined where they touch
/// ([`joined_parents`]), then feet hanging off a root made children of their leg
/// ([`foot_riders`]). Returns the joined parents and the riders.
pub(crate) fn joined_hierarchy(heads: &[[f32; 3]], tails: &[[f32; 3]], parents: &[i32]) -> (Vec<i32>, Vec<[usize; 2]>) {
    let n = heads.len();
    let all: Vec<Vec3> = heads.iter().chain(tails).map(|&p| v(p)).collect();
    let zmin = all.iter().map(|p| p.z).fold(f32::INFINITY, f32::min);
    let zmax = all.iter().map(|p| p.z).fold(f32::NEG_INFINITY, f32::max);
    let lo = all.iter().fold(Vec3::splat(f32::INFINITY), |a, &p| a.min(p));
    let hi = all.iter().fold(Vec3::splat(f32::NEG_INFINITY), |a, &p| a.max(p));
    let mut has_child = vec![false; n];
    for &p in parents.iter().filter(|&&p| p >= 0) {
        has_child[p as usize] = true;
    }
    let ground_leaf: Vec<bool> = (0..n)
        .map(|b| !has_child[b] && heads[b][2].min(tails[b][2]) - zmin <= GROUND_FRACTION * (zmax - zmin))
        .collect();
    let mut joined = joined_parents(heads, tails, parents, &ground_leaf, 1e-3 * (hi - lo).length());
    let riders = foot_riders(heads, tails, &joined, (zmin, zmax - zmin));
    for &[r, e] in &riders {
        joined[r] = e as i32;
    }
    (joined, riders)
}

/// Parents with separate trees joined where they touch: rigs made of several root chains
/// (a neck tree, leg trees, a body tree meeting at shared joints) become one tree. A root whose
/// head lies on another tree's bone tail becomes that bone's child; a root whose head coincides
/// with another tree's bone head joins that bone's parent (or that bone). Trees holding more
/// ground leaves (feet), then more bones, win the root. `tol` is the coincidence distance.
fn joined_parents(heads: &[[f32; 3]], tails: &[[f32; 3]], parents: &[i32], ground_leaf: &[bool], tol: f32) -> Vec<i32> {
    let n = parents.len();
    let mut eff = parents.to_vec();
    let root_of = |eff: &[i32], mut b: usize| {
        while eff[b] >= 0 {
            b = eff[b] as usize;
        }
        b
    };
    let close = |a: [f32; 3], b: [f32; 3]| (v(a) - v(b)).length() <= tol;
    // tails first
    for r in 0..n {
        if eff[r] >= 0 {
            continue;
        }
        let cand = (0..n).filter(|&b| root_of(&eff, b) != r && close(heads[r], tails[b])).min_by(|&a, &b| {
            let da = (v(heads[r]) - v(tails[a])).length();
            let db = (v(heads[r]) - v(tails[b])).length();
            da.partial_cmp(&db).unwrap_or(std::cmp::Ordering::Equal)
        });
        if let Some(b) = cand {
            eff[r] = b as i32;
        }
    }
    // then shared heads, weakest trees first
    let strength = |eff: &[i32], root: usize| {
        let members: Vec<usize> = (0..n).filter(|&b| root_of(eff, b) == root).collect();
        (members.iter().filter(|&&b| ground_leaf[b]).count(), members.len())
    };
    let mut roots: Vec<usize> = (0..n).filter(|&b| eff[b] < 0).collect();
    roots.sort_by_key(|&r| strength(&eff, r));
    for r in roots {
        let best = (0..n)
            .filter(|&b| root_of(&eff, b) != r && close(heads[r], heads[b]))
            .max_by_key(|&b| strength(&eff, root_of(&eff, b)));
        if let Some(b) = best {
            eff[r] = if eff[b] >= 0 { eff[b] } else { b as i32 };
        }
    }
    eff
}

/// Feet that ride on the root: game rigs exported from an IK set-up (Quaternius characters,
/// RobotExpressive, a quadruped whose hind feet start at the hock) parent each foot, and often
/// its IK target and pole, to the ground root bone; their leg chain stops at the ankle or hock
/// (or, with an invented tail, at the knee). A bone hanging off a root (or a root itself) whose
/// subtree reaches the ground (the lowest point `zmin`) and starts low ([`RIDER`]'s `ground`
/// and `top`) rides on the leaf bone of another branch that comes down as a leg
/// does (it, or its parent's head to its own, points down) and is itself not off a root: the
/// foot lies below that leaf's tail, or below its head ([`Rider`]). Pairs are taken cheapest
/// first, each bone once: the cost is the distance from the leaf's tail or from its head (a
/// shin's knee before a tail's root at the hips), whichever is less, plus [`RIDER_LOW_COST`]
/// times how high the rider's chain ends (a foot before its IK target). `height` is the rig's.
/// Returns (rider, carrier) pairs.
fn foot_riders(heads: &[[f32; 3]], tails: &[[f32; 3]], parents: &[i32], (zmin, height): (f32, f32)) -> Vec<[usize; 2]> {
    let n = parents.len();
    let tree = build_tree(parents);
    let kids = &tree.children;
    let ancestor_of = |a: usize, mut b: usize| {
        while parents[b] >= 0 {
            b = parents[b] as usize;
            if b == a {
                return true;
            }
        }
        false
    };
    let off_root = |b: usize| parents[b] < 0 || parents[parents[b] as usize] < 0;
    // a leg's last bone points down, or its parent comes down to it (an invented tail may point
    // anywhere); a tail or an ear does neither
    let down = |d: Vec3| -d.z >= 0.5 * d.length() && d.length() > 0.0;
    let comes_down = |e: usize| {
        down(v(tails[e]) - v(heads[e])) || (parents[e] >= 0 && down(v(heads[e]) - v(heads[parents[e] as usize])))
    };
    let r = RIDER;
    let tol = 1e-3 * height;
    let mut cands: Vec<(f32, usize, usize)> = Vec::new();
    for rider in (0..n).filter(|&b| off_root(b)) {
        let below = subtree(kids, rider);
        let zs = below.iter().flat_map(|&b| [heads[b][2], tails[b][2]]);
        let (low, high) = zs.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), z| (lo.min(z), hi.max(z)));
        if low - zmin > r.ground * height || high - zmin > r.top * height {
            continue;
        }
        let foot = v(heads[rider]);
        for e in 0..n {
            if !kids[e].is_empty() || off_root(e) || below.contains(&e) || ancestor_of(e, rider) || !comes_down(e) {
                continue;
            }
            let d = v(tails[e]) - foot;
            let by_tail = d.z >= -tol && d.z <= r.lift * height && d.truncate().length() <= r.reach * height;
            let k = foot - v(heads[e]);
            let flat = k.truncate().length();
            let by_head = -k.z >= r.drop * height && -k.z <= r.lift * height && flat <= r.slope * -k.z;
            let cost = match (by_tail, by_head) {
                (true, true) => d.length().min(k.length()),
                (true, false) => d.length(),
                (false, true) => k.length(),
                (false, false) => continue,
            };
            cands.push((cost + RIDER_LOW_COST * (low - zmin), rider, e));
        }
    }
    cands.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap_or(std::cmp::Ordering::Equal));
    let mut used = vec![false; n];
    let mut out = Vec::new();
    for (_, rider, e) in cands {
        if !used[rider] && !used[e] {
            used[rider] = true;
            used[e] = true;
            out.push([rider, e]);
        }
    }
    out
}

/// `root` and every bone below it (`kids`: each bone's children), `root` first.
pub(crate) fn subtree(kids: &[Vec<usize>], root: usize) -> Vec<usize> {
    let mut out = vec![root];
    let mut i = 0;
    while i < out.len() {
        out.extend(&kids[out[i]]);
        i += 1;
    }
    out
}

/// Children of every bone and the main tree: the root with the most bones below it.
pub(crate) fn build_tree(parents: &[i32]) -> Tree {
    let n = parents.len();
    let mut children = vec![Vec::new(); n];
    for (b, &p) in parents.iter().enumerate() {
        if p >= 0 {
            children[p as usize].push(b);
        }
    }
    let preorder = |r: usize| {
        let mut out = Vec::new();
        let mut stack = vec![r];
        while let Some(b) = stack.pop() {
            out.push(b);
            stack.extend(children[b].iter().rev());
        }
        out
    };
    let mut best: Vec<usize> = Vec::new();
    for r in (0..n).filter(|&b| parents[b] < 0) {
        let o = preorder(r);
        if o.len() > best.len() {
            best = o;
        }
    }
    Tree { root: best[0], children, order: best }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A body chain (hips, spine, chest, and a clavicle off the chest, not connected) with a
    /// neck tree starting at the chest's tail and a tree starting at the clavicle's head (a
    /// shoulder twist bone): the neck becomes the chest's child, the twist bone the clavicle's
    /// sibling, as in a rig built in one tree.
    #[test]
    fn trees_that_touch_are_joined_as_one_rig_would_be() {
        let heads =
            [[0.0, 0.0, 1.0], [0.0, 0.0, 1.2], [0.0, 0.0, 1.5], [0.0, 0.0, 1.8], [0.1, 0.0, 1.7], [0.1, 0.0, 1.7]];
        let tails =
            [[0.0, 0.0, 1.2], [0.0, 0.0, 1.5], [0.0, 0.0, 1.8], [0.0, 0.0, 2.0], [0.25, 0.0, 1.75], [0.3, 0.0, 1.6]];
        let parents = [-1, 0, 1, -1, 2, -1];
        let joined = joined_parents(&heads, &tails, &parents, &[false; 6], 1e-3);
        assert_eq!(joined, [-1, 0, 1, 2, 2, 2]);
    }

    /// Feet hanging off the ground root ride on the nearest free leg end, each leg carrying one
    /// foot: with the feet close together, the right foot lies nearer the left shin's end than
    /// its own, but the left foot is nearer still and takes it.
    #[test]
    fn each_leg_carries_one_foot() {
        let heads =
            [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.1, 0.0, 1.0], [-0.1, 0.0, 1.0], [0.1, 0.0, 0.0], [0.01, 0.0, 0.0]];
        let tails =
            [[0.0, 0.2, 0.0], [0.0, 0.0, 1.2], [0.1, 0.0, 0.1], [-0.1, 0.0, 0.1], [0.1, -0.1, 0.0], [0.01, -0.1, 0.0]];
        let parents = [-1, 0, 1, 1, 0, 0];
        assert_eq!(foot_riders(&heads, &tails, &parents, (0.0, 1.2)), [[4, 2], [5, 3]]);
    }

    /// A quadruped's hind foot that starts at the hock, behind and below the stifle where its
    /// shin's invented tail does not reach, rides on the shin; its IK target at the hock, off
    /// the root as well, does not take the shin from it (the foot reaches the ground).
    #[test]
    fn a_foot_at_the_hock_rides_before_its_ik_target() {
        // root, hips, thigh (hip -> stifle), shin (stifle, tail invented along the thigh),
        // foot (hock -> fetlock) off the root, toe, IK target at the hock off the root, and a
        // tail on the hips, nearer the foot than the knee is horizontally
        let heads = [
            [0.0, 0.0, 0.0],
            [0.0, 0.3, 0.55],
            [0.12, 0.3, 0.5],
            [0.12, 0.2, 0.32],
            [0.12, 0.36, 0.16],
            [0.12, 0.34, 0.03],
            [0.12, 0.36, 0.16],
            [0.0, 0.42, 0.5],
        ];
        let tails = [
            [0.0, 0.2, 0.0],
            [0.0, 0.05, 0.57],
            [0.12, 0.2, 0.32],
            [0.12, 0.15, 0.23],
            [0.12, 0.34, 0.03],
            [0.12, 0.27, 0.0],
            [0.12, 0.46, 0.16],
            [0.0, 0.65, 0.4],
        ];
        let parents = [-1, 0, 1, 2, 0, 4, 0, 1];
        assert_eq!(foot_riders(&heads, &tails, &parents, (0.0, 0.8)), [[4, 3]]);
    }
}
