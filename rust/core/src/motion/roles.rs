//! Skeleton roles: which bones are the spine, neck, head, tail, legs and arms of a character,
//! found from the bone geometry and hierarchy (bone names only confirm).
//!
//! Inputs
//!   heads, tails  #B by 3 bone end points, one common space with +Z up (world space in the
//!                 add-on), any unit
//!   parents       #B parent index per bone, -1 for a root
//!   names         #B bone names, or empty: used as hints only (`head`, `tail`, `.L`/`.R` …)
//! Output
//!   [`Roles`]: bone indices per role, the body's up/forward/left axes and the leg length.
//!
//! Method (all thresholds relative to the skeleton height h = top z - lowest z):
//! 1. Main tree: trees that touch are joined (see below); then the root whose subtree has the
//!    most bones; other trees are ignored.
//! 2. Sagittal plane: the vertical plane through the end points' centroid whose mirror image
//!    of the end points best matches them (1° scan then refinement). Bones within 0.05 h of
//!    it are *midline* bones.
//! 3. Legs: "ground leaves" are leaf bones ending within 0.2 h of the lowest point. Bottom up,
//!    a bone with two or more "long" children (reaching down 0.2 h or more from their head)
//!    that contain ground leaves is a split: each such child holding one foot is a leg top, and
//!    the leg is the chain from it down to its foot. Short branches (toe and heel) merge.
//! 4. Head: the highest midline end (a midline bone with no midline bone below it) outside the
//!    legs (a bone named head/neck/jaw/skull on its way scores higher, one named tail lower).
//!    The path root → that end is the body axis; the head bone is on it (by name, else the
//!    end's parent when the end is a leaf with non-limb siblings like ears, else the end). The
//!    spine is the axis from the root down to the deepest bone carrying a limb (leg or arm),
//!    plus the bones carrying legs off the axis; the neck lies between spine and head.
//! 5. Forward is the horizontal axis in the sagittal plane pointing from the legs to the head
//!    (bipeds: along the feet; if still undecided Blender's -Y); left = up × forward; legs get
//!    their side from the plane and their front/back group from their position along forward.
//! 6. Arms: paired, non-midline chains of two or more bones and length ≥ 0.2 h hanging off the
//!    spine, rising above where they start by at most a quarter of their length (a T-posed arm
//!    with a raised clavicle; horns and ears point up). Tail: the midline chain hanging off the
//!    spine that points backwards, not carrying legs.
//!
//! Rigs made of several root chains that meet at shared joints (common in hand-made and
//! glTF rigs) are joined first, and feet that hang off the root instead of their leg (game rigs
//! exported from an IK set-up) then ride on their leg: see `hierarchy.rs`.
//!
//! Known limitations: assumes +Z up and a roughly symmetric rest pose; legs must reach the
//! ground in the rest pose; control rigs (IK targets, mechanism bones) should be filtered out
//! by the caller (the add-on passes deform bones only).
//!
//! See also: `gait.rs`, which turns these roles into head-shake, walk and run cycles.

use crate::error::{Error, Result};
use crate::motion::hierarchy::{build_tree, joined_hierarchy, subtree, Tree, GROUND_FRACTION};
use crate::skeleton::validate_parents;
use glam::Vec3;

/// Which side of the body a limb is on (the character's own left/right).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    Left,
    Right,
}

/// A leg or arm: its bones from the top (hip / shoulder / clavicle) down to the foot or hand.
#[derive(Debug, Clone, PartialEq)]
pub struct Limb {
    /// Bone indices, parent first.
    pub bones: Vec<usize>,
    pub side: Side,
    /// 0 = the front-most group of legs along the spine; bipeds have one group.
    pub group: usize,
}

/// What kind of body the legs make.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BodyPlan {
    /// Two legs in one group.
    Biped,
    /// Four legs: a front pair and a back pair.
    Quadruped,
    /// Anything else with legs (three, six …).
    Multiped,
}

/// Bone indices per role. Every index refers to the input arrays.
#[derive(Debug, Clone)]
pub struct Roles {
    /// The main tree's root bone.
    pub root: usize,
    /// Root first, ending at the deepest bone that carries a limb (hips … chest).
    pub spine: Vec<usize>,
    /// Between the spine and the head, spine side first (may be empty).
    pub neck: Vec<usize>,
    pub head: usize,
    /// Every bone below the head (jaw, ears, horns …).
    pub head_extras: Vec<usize>,
    /// Tail chain, base first (may be empty).
    pub tail: Vec<usize>,
    pub legs: Vec<Limb>,
    pub arms: Vec<Limb>,
    pub plan: BodyPlan,
    /// Unit axes of the body in the input space: up (+Z), forward (towards the head), left.
    pub up: [f32; 3],
    pub forward: [f32; 3],
    pub left: [f32; 3],
    /// Lowest z of the skeleton and its height.
    pub ground: f32,
    pub height: f32,
    /// Mean vertical reach of the legs (hip head to the ground), same unit as the input.
    pub leg_length: f32,
    /// Whether every role bone descends from `root` in the input hierarchy (else the trees were
    /// joined where they touch, and moving the root bone would not move the whole body).
    pub single_tree: bool,
    /// Feet that hang off a root bone instead of their leg (game rigs exported from an IK set-up),
    /// as (foot, the leg's last bone it rides on): a motion moves them by location as well.
    pub riders: Vec<[usize; 2]>,
    /// Remarks for the user (names disagreeing with the geometry, guessed forward …).
    pub notes: Vec<String>,
}

const LONG_FRACTION: f32 = 0.2;
const MIDLINE_FRACTION: f32 = 0.05;
const ARM_FRACTION: f32 = 0.2;
/// How far an arm may rise above its shoulder, as a fraction of its reach (a T-posed arm with a
/// raised clavicle and fingers rises ~0.1; ears and horns, which point up, ~1).
const ARM_RISE: f32 = 0.25;
fn v(p: [f32; 3]) -> Vec3 {
    Vec3::from_array(p)
}

fn lower(names: &[String], b: usize) -> String {
    names.get(b).map(|s| s.to_ascii_lowercase()).unwrap_or_default()
}

/// The side a bone name states (`.L`, `_R`, `Left…`, `l_…`), if any.
pub fn name_side(name: &str) -> Option<Side> {
    let n = name.to_ascii_lowercase();
    for (suffix, side) in [("l", Side::Left), ("r", Side::Right)] {
        for sep in ['.', '_', '-', ' '] {
            if n.ends_with(&format!("{sep}{suffix}")) || n.starts_with(&format!("{suffix}{sep}")) {
                return Some(side);
            }
        }
    }
    if n.contains("left") {
        return Some(Side::Left);
    }
    if n.contains("right") {
        return Some(Side::Right);
    }
    None
}

fn validate(heads: &[[f32; 3]], tails: &[[f32; 3]], parents: &[i32], names: &[String]) -> Result<()> {
    let n = heads.len();
    if n == 0 {
        return Err(Error::NoBones("the armature has no bones".into()));
    }
    if tails.len() != n || parents.len() != n {
        return Err(Error::Shape(format!(
            "{n} heads, {} tails and {} parents: one of each per bone",
            tails.len(),
            parents.len()
        )));
    }
    if !names.is_empty() && names.len() != n {
        return Err(Error::Shape(format!("{} names for {n} bones", names.len())));
    }
    let bad = heads.iter().chain(tails).filter(|p| p.iter().any(|c| !c.is_finite())).count();
    if bad > 0 {
        return Err(Error::NonFinite { what: "bone", count: bad });
    }
    validate_parents(parents, n)
}

/// Most points the mirror-plane scan compares: each score is quadratic in them (4000 bones took
/// 6.4 s); above this, every k-th point.
const MIRROR_POINTS: usize = 1024;

/// Unit normal (horizontal) of the best mirror plane through `centre` for `points`.
fn mirror_normal(points: &[Vec3], centre: Vec3) -> Vec3 {
    let sampled: Vec<Vec3> = points.iter().step_by(points.len().div_ceil(MIRROR_POINTS).max(1)).copied().collect();
    let points = &sampled[..];
    let score = |deg: f32| -> f32 {
        let a = deg.to_radians();
        let n = Vec3::new(a.cos(), a.sin(), 0.0);
        points
            .iter()
            .map(|&p| {
                let q = p - 2.0 * (p - centre).dot(n) * n;
                points.iter().map(|&r| (r - q).length_squared()).fold(f32::INFINITY, f32::min).sqrt()
            })
            .sum()
    };
    let (mut best, mut best_s) = (0.0f32, f32::INFINITY);
    for d in 0..180 {
        let s = score(d as f32);
        if s < best_s - 1e-7 {
            best = d as f32;
            best_s = s;
        }
    }
    let mut step = 0.5;
    while step > 0.01 {
        for cand in [best - step, best + step] {
            let s = score(cand);
            if s < best_s - 1e-7 {
                best = cand;
                best_s = s;
            }
        }
        step *= 0.5;
    }
    let a = best.to_radians();
    Vec3::new(a.cos(), a.sin(), 0.0)
}

/// Find the roles of a skeleton's bones (see the module doc). Fails with
/// [`Error::NoBones`] naming what is missing when no legs or no head can be found.
pub fn detect_roles(heads: &[[f32; 3]], tails: &[[f32; 3]], parents: &[i32], names: &[String]) -> Result<Roles> {
    validate(heads, tails, parents, names)?;
    let (joined, riders) = joined_hierarchy(heads, tails, parents);
    let rig = Rig::new(heads, tails, names, &joined)?;
    let legs = find_legs(&rig)?;
    let mid = Midplane::of(&rig);
    let head_leaf = head_leaf(&rig, &legs, &mid)?;
    let axis = rig.ancestors(head_leaf);
    let mut on_axis = vec![false; rig.n()];
    for &b in &axis {
        on_axis[b] = true;
    }
    let reach = rig.reaches();
    let arm_chains = arm_chains(&rig, &legs, &mid, &axis, &on_axis, &reach);
    let trunk = split_axis(&rig, &legs, &axis, &on_axis, &arm_chains, head_leaf)?;
    let mut notes = Vec::new();
    if !riders.is_empty() {
        let mut feet: Vec<String> =
            riders.iter().map(|&[r, _]| names.get(r).cloned().unwrap_or_else(|| format!("bone {r}"))).collect();
        feet.sort();
        notes.push(format!(
            "feet hanging off the root bone, not their legs (an IK rig without its constraints): {}; \
             a walk moves them with their legs by location keys",
            feet.join(", ")
        ));
    }
    let (forward, left) = body_axes(&rig, &legs, &mid, trunk.head, &mut notes);
    let (leg_limbs, plan) = leg_limbs(&rig, &legs, mid.centre, forward, left);
    let arms: Vec<Limb> = arm_chains
        .iter()
        .filter(|(i, _)| *i <= trunk.spine_end)
        .map(|(_, c)| Limb { bones: c.clone(), side: limb_side(&rig, mid.centre, c, left), group: 0 })
        .collect();
    let is_arm_top = |b: usize| arm_chains.iter().any(|(_, c)| c[0] == b);
    let tail = find_tail(&rig, &legs, &mid, &trunk, &on_axis, is_arm_top, &reach, forward);

    // does moving the root bone move every role bone (one real tree)?
    let real_root = |mut b: usize| {
        while parents[b] >= 0 {
            b = parents[b] as usize;
        }
        b
    };
    let root = rig.tree.root;
    let single_tree = trunk
        .spine
        .iter()
        .chain(&trunk.neck)
        .chain(&tail)
        .chain([&trunk.head])
        .chain(leg_limbs.iter().flat_map(|l| &l.bones))
        .all(|&b| real_root(b) == root);
    let leg_length =
        leg_limbs.iter().map(|l| rig.h(l.bones[0]).z - legs.low[l.bones[0]]).sum::<f32>() / leg_limbs.len() as f32;
    Ok(Roles {
        root,
        spine: trunk.spine,
        neck: trunk.neck,
        head: trunk.head,
        head_extras: trunk.head_extras,
        tail,
        legs: leg_limbs,
        arms,
        plan,
        up: Vec3::Z.to_array(),
        forward: forward.to_array(),
        left: left.to_array(),
        ground: rig.ground,
        height: rig.height,
        leg_length,
        single_tree,
        riders,
        notes,
    })
}

/// The skeleton as [`detect_roles`] reads it: bone ends, names, the joined hierarchy and its
/// main tree, and that tree's vertical extent.
struct Rig<'a> {
    heads: &'a [[f32; 3]],
    tails: &'a [[f32; 3]],
    names: &'a [String],
    /// Joined parents ([`crate::motion::hierarchy::joined_hierarchy`]).
    parents: &'a [i32],
    tree: Tree,
    /// Head and tail of every main-tree bone, in tree order.
    pts: Vec<Vec3>,
    /// Lowest z of the main tree, and its height above that.
    ground: f32,
    height: f32,
}

impl<'a> Rig<'a> {
    /// The main tree of `parents`; an error when it is flat (no height along +Z).
    fn new(heads: &'a [[f32; 3]], tails: &'a [[f32; 3]], names: &'a [String], parents: &'a [i32]) -> Result<Self> {
        let tree = build_tree(parents);
        let pts: Vec<Vec3> = tree.order.iter().flat_map(|&b| [v(heads[b]), v(tails[b])]).collect();
        let ground = pts.iter().map(|p| p.z).fold(f32::INFINITY, f32::min);
        let top = pts.iter().map(|p| p.z).fold(f32::NEG_INFINITY, f32::max);
        let height = top - ground;
        let lo = pts.iter().fold(Vec3::splat(f32::INFINITY), |a, &p| a.min(p));
        let hi = pts.iter().fold(Vec3::splat(f32::NEG_INFINITY), |a, &p| a.max(p));
        let size = (hi - lo).length();
        if !(height > 1e-6 * size.max(1e-30)) || height <= 0.0 {
            return Err(Error::NoBones(
                "no legs: the skeleton is flat (no height along +Z), so no chain reaches down to the ground".into(),
            ));
        }
        Ok(Rig { heads, tails, names, parents, tree, pts, ground, height })
    }

    fn n(&self) -> usize {
        self.heads.len()
    }

    fn h(&self, b: usize) -> Vec3 {
        v(self.heads[b])
    }

    fn t(&self, b: usize) -> Vec3 {
        v(self.tails[b])
    }

    fn kids(&self, b: usize) -> &[usize] {
        &self.tree.children[b]
    }

    /// The path from the root down to `b`, root first.
    fn ancestors(&self, b: usize) -> Vec<usize> {
        let mut path = vec![b];
        let mut cur = self.parents[b];
        while cur >= 0 {
            path.push(cur as usize);
            cur = self.parents[cur as usize];
        }
        path.reverse();
        path
    }

    /// Per bone, the length of the longest chain from its head down; a bone spans at least to
    /// its child's head (glTF importers invent short tails for joints).
    fn reaches(&self) -> Vec<f32> {
        let mut reach = vec![0.0f32; self.n()];
        for &b in self.tree.order.iter().rev() {
            let own = (self.t(b) - self.h(b)).length();
            reach[b] =
                self.kids(b).iter().map(|&c| own.max((self.h(c) - self.h(b)).length()) + reach[c]).fold(own, f32::max);
        }
        reach
    }

    /// The chain from `top` down, following the child with the longest `reach` below it; and
    /// the reach of `top`.
    fn chain_down(&self, reach: &[f32], top: usize) -> (Vec<usize>, f32) {
        let mut chain = vec![top];
        let mut cur = top;
        while let Some(&c) = self
            .kids(cur)
            .iter()
            .max_by(|&&a, &&b| reach[a].partial_cmp(&reach[b]).unwrap_or(std::cmp::Ordering::Equal))
        {
            chain.push(c);
            cur = c;
        }
        (chain, reach[top])
    }
}

/// The legs of step 3.
struct Legs {
    /// Lowest z in each bone's subtree.
    low: Vec<f32>,
    /// Each leg's top bone, and its chain from there down to the foot.
    tops: Vec<usize>,
    chains: Vec<Vec<usize>>,
    /// Bones in some leg's subtree.
    member: Vec<bool>,
}

/// Step 3: bottom-up foot counts over the main tree; an error when no two chains reach the ground.
fn find_legs(rig: &Rig) -> Result<Legs> {
    let (n, ground, height) = (rig.n(), rig.ground, rig.height);
    let order = &rig.tree.order;
    let mut low = vec![f32::INFINITY; n];
    let mut feet = vec![0usize; n];
    let mut long_kids: Vec<Vec<usize>> = vec![Vec::new(); n];
    for &b in order.iter().rev() {
        low[b] = rig.h(b).z.min(rig.t(b).z);
        for &c in rig.kids(b) {
            low[b] = low[b].min(low[c]);
        }
        if rig.kids(b).is_empty() {
            let near = low[b] - ground <= GROUND_FRACTION * height;
            feet[b] = usize::from(near && !lower(rig.names, b).contains("tail"));
            continue;
        }
        let longs: Vec<usize> = rig
            .kids(b)
            .iter()
            .copied()
            .filter(|&c| feet[c] > 0 && rig.h(c).z - low[c] >= LONG_FRACTION * height)
            .collect();
        feet[b] = match longs.len() {
            0 => usize::from(rig.kids(b).iter().any(|&c| feet[c] > 0)),
            1 => feet[longs[0]],
            _ => longs.iter().map(|&c| feet[c]).sum(),
        };
        long_kids[b] = longs;
    }
    let mut tops = Vec::new();
    for &b in order {
        if long_kids[b].len() >= 2 {
            tops.extend(long_kids[b].iter().copied().filter(|&c| feet[c] == 1));
        }
    }
    if tops.is_empty() {
        return Err(Error::NoBones(format!(
            "no legs: no two bone chains branch off the body and reach down to the lowest point \
             (within {:.0}% of the skeleton's height)",
            GROUND_FRACTION * 100.0
        )));
    }
    let leg_chain = |top: usize| {
        let mut chain = vec![top];
        let mut cur = top;
        loop {
            let next = rig.kids(cur).iter().copied().filter(|&c| feet[c] > 0).max_by(|&a, &b| {
                let ka = (rig.h(cur).z - low[a], (rig.t(a) - rig.h(a)).length());
                let kb = (rig.h(cur).z - low[b], (rig.t(b) - rig.h(b)).length());
                ka.partial_cmp(&kb).unwrap_or(std::cmp::Ordering::Equal)
            });
            match next {
                Some(c) => {
                    chain.push(c);
                    cur = c;
                }
                None => break,
            }
        }
        chain
    };
    let chains: Vec<Vec<usize>> = tops.iter().map(|&b| leg_chain(b)).collect();
    let mut member = vec![false; n];
    for &top in &tops {
        for b in subtree(&rig.tree.children, top) {
            member[b] = true;
        }
    }
    Ok(Legs { low, tops, chains, member })
}

/// Step 2: the sagittal plane (through `centre`, horizontal unit `normal`) and the midline
/// tolerance `tol`.
struct Midplane {
    centre: Vec3,
    normal: Vec3,
    tol: f32,
}

impl Midplane {
    fn of(rig: &Rig) -> Midplane {
        let centre = rig.pts.iter().copied().sum::<Vec3>() / rig.pts.len() as f32;
        Midplane { centre, normal: mirror_normal(&rig.pts, centre), tol: MIDLINE_FRACTION * rig.height }
    }

    /// Signed distance of `p` from the plane.
    fn lateral(&self, p: Vec3) -> f32 {
        (p - self.centre).dot(self.normal)
    }

    /// Both ends of bone `b` lie within the tolerance of the plane.
    fn holds(&self, rig: &Rig, b: usize) -> bool {
        self.lateral(rig.h(b)).abs() <= self.tol && self.lateral(rig.t(b)).abs() <= self.tol
    }
}

/// Step 4's end of the body axis: the highest midline end outside the legs (a midline bone
/// with no midline bone below it: a jaw, a head whose children are all paired, a tail tip),
/// names of the head on its way scoring higher and a tail lower.
fn head_leaf(rig: &Rig, legs: &Legs, mid: &Midplane) -> Result<usize> {
    const HEAD_WORDS: [&str; 5] = ["head", "neck", "jaw", "skull", "face"];
    let order = &rig.tree.order;
    let mut midline_below = vec![false; rig.n()];
    for &b in order.iter().rev() {
        midline_below[b] = rig.kids(b).iter().any(|&c| mid.holds(rig, c) || midline_below[c]);
    }
    order
        .iter()
        .copied()
        .filter(|&b| !midline_below[b] && !legs.member[b] && mid.holds(rig, b) && b != rig.tree.root)
        .map(|b| {
            let mut score = (rig.h(b).z.max(rig.t(b).z) - rig.ground) / rig.height;
            let path = rig.ancestors(b);
            if path.iter().rev().take(4).any(|&a| HEAD_WORDS.iter().any(|w| lower(rig.names, a).contains(w))) {
                score += 1.0;
            }
            if lower(rig.names, b).contains("tail") {
                score -= 1.0;
            }
            (b, score)
        })
        .max_by(|a, b| a.1.partial_cmp(&b.1).unwrap_or(std::cmp::Ordering::Equal))
        .map(|(b, _)| b)
        .ok_or_else(|| Error::NoBones("no head: no bone chain runs along the body's middle away from the legs".into()))
}

/// Step 6's arms: paired non-midline chains hanging off the `axis`, as (axis index, chain).
fn arm_chains(
    rig: &Rig,
    legs: &Legs,
    mid: &Midplane,
    axis: &[usize],
    on_axis: &[bool],
    reach: &[f32],
) -> Vec<(usize, Vec<usize>)> {
    let height = rig.height;
    let mut cands: Vec<(usize, Vec<usize>)> = Vec::new();
    for (i, &a) in axis.iter().enumerate() {
        for &c in rig.kids(a) {
            if on_axis[c] || legs.member[c] || mid.holds(rig, c) {
                continue;
            }
            let (chain, reach) = rig.chain_down(reach, c);
            // arms hang from their shoulder or reach sideways (a T-posed arm may rise a little
            // with its clavicle and fingers), unlike horns and ears, which point up
            let top_z = chain.iter().map(|&b| rig.h(b).z.max(rig.t(b).z)).fold(f32::NEG_INFINITY, f32::max);
            let below = top_z - rig.h(c).z.max(rig.h(a).z) <= (0.05 * height).max(ARM_RISE * reach);
            if chain.len() >= 2 && reach >= ARM_FRACTION * height && below {
                cands.push((i, chain));
            }
        }
    }
    // keep those with a partner on the other side of the plane
    let side = |chain: &Vec<usize>| mid.lateral(rig.t(*chain.last().unwrap())).signum();
    cands.iter().filter(|(_, c)| cands.iter().any(|(_, d)| side(d) == -side(c) && side(c) != 0.0)).cloned().collect()
}

/// Step 4's split of the body axis.
struct Trunk {
    spine: Vec<usize>,
    neck: Vec<usize>,
    head: usize,
    head_extras: Vec<usize>,
    /// Index on the axis of the spine's last axis bone (arms hang off the axis up to here).
    spine_end: usize,
    /// Bones carrying a leg (a leg's ancestors).
    leg_carrier: Vec<bool>,
}

/// Split the `axis` (root -> `head_leaf`) into spine, neck and head (step 4).
fn split_axis(
    rig: &Rig,
    legs: &Legs,
    axis: &[usize],
    on_axis: &[bool],
    arm_chains: &[(usize, Vec<usize>)],
    head_leaf: usize,
) -> Result<Trunk> {
    let (kids, parents) = (&rig.tree.children, rig.parents);
    let is_arm_top = |b: usize| arm_chains.iter().any(|(_, c)| c[0] == b);
    let named_head = axis.iter().position(|&b| {
        let s = lower(rig.names, b);
        s.contains("head") && !s.ends_with("end") && !s.contains("top")
    });
    let leaf_parent = parents[head_leaf];
    let mut hi_idx = match named_head {
        Some(i) => i,
        None => {
            let siblings_non_limb = kids[head_leaf].is_empty()
                && leaf_parent >= 0
                && kids[leaf_parent as usize].iter().any(|&c| c != head_leaf && !legs.member[c] && !is_arm_top(c));
            if siblings_non_limb {
                axis.len() - 2
            } else {
                axis.len() - 1
            }
        }
    };
    // deepest axis bone carrying a limb, before the head
    let carries_limb = |b: usize| {
        kids[b].iter().any(|&c| legs.tops.contains(&c) || is_arm_top(c))
            || legs.tops.iter().any(|&top| {
                // a leg hanging off a side branch (e.g. hips beside the spine) counts at the
                // axis bone the branch leaves from
                let p = rig.ancestors(top);
                let last_on_axis = p.iter().rev().find(|&&x| on_axis[x]).copied();
                last_on_axis == Some(b)
            })
    };
    let mut s_idx = (0..axis.len()).filter(|&i| i < hi_idx && carries_limb(axis[i])).max().unwrap_or(0);
    if hi_idx == 0 {
        if axis.len() < 2 {
            return Err(Error::NoBones("no head: the body axis has a single bone".into()));
        }
        hi_idx = axis.len() - 1;
    }
    if s_idx >= hi_idx {
        s_idx = hi_idx - 1;
    }
    let mut spine: Vec<usize> = axis[..=s_idx].to_vec();
    // bones carrying legs off the axis (a body chain running back to the hips) join the spine
    let mut leg_carrier = vec![false; rig.n()];
    for &top in &legs.tops {
        let mut cur = parents[top];
        while cur >= 0 && !leg_carrier[cur as usize] {
            leg_carrier[cur as usize] = true;
            cur = parents[cur as usize];
        }
    }
    for &b in &rig.tree.order {
        if leg_carrier[b] && !on_axis[b] && !legs.member[b] {
            spine.push(b);
        }
    }
    let head = axis[hi_idx];
    let mut head_extras = subtree(kids, head).split_off(1);
    head_extras.sort_unstable();
    Ok(Trunk { spine, neck: axis[s_idx + 1..hi_idx].to_vec(), head, head_extras, spine_end: s_idx, leg_carrier })
}

/// Step 5: forward (horizontal, in the sagittal plane, from the legs to the head; bipeds:
/// along the feet; else Blender's -Y) and left = up x forward, checked against the legs'
/// .L/.R names; remarks go to `notes`.
fn body_axes(rig: &Rig, legs: &Legs, mid: &Midplane, head: usize, notes: &mut Vec<String>) -> (Vec3, Vec3) {
    let (up, height) = (Vec3::Z, rig.height);
    let along = up.cross(mid.normal).normalize();
    let leg_top_mean = legs.tops.iter().map(|&b| rig.h(b)).sum::<Vec3>() / legs.tops.len() as f32;
    let mut to_head = rig.h(head) - leg_top_mean;
    to_head.z = 0.0;
    let mut forward = if to_head.dot(along).abs() >= 0.1 * height {
        along * to_head.dot(along).signum()
    } else {
        let feet_dir: Vec3 = legs.chains.iter().map(|c| rig.t(*c.last().unwrap()) - rig.h(*c.last().unwrap())).sum();
        let d = feet_dir.dot(along);
        if d.abs() >= 0.02 * height {
            along * d.signum()
        } else {
            notes.push("forward direction guessed as Blender's -Y (no head offset, flat feet)".into());
            let s = along.dot(Vec3::NEG_Y);
            along * if s < 0.0 { -1.0 } else { 1.0 }
        }
    };
    let mut left = up.cross(forward).normalize();
    let (mut agree, mut disagree) = (0, 0);
    for c in &legs.chains {
        let geo = limb_side(rig, mid.centre, c, left);
        if let Some(named) = c.iter().find_map(|&b| rig.names.get(b).and_then(|s| name_side(s))) {
            if named == geo {
                agree += 1
            } else {
                disagree += 1
            }
        }
    }
    if disagree > 0 && agree == 0 && to_head.dot(along).abs() < 0.1 * height {
        // a biped whose forward was a guess: trust the names
        forward = -forward;
        left = -left;
        notes.push("forward direction taken from the .L/.R bone names".into());
    } else if disagree > 0 {
        notes
            .push(format!("{disagree} leg(s) named for the other side than where they are; roles follow the geometry"));
    }
    (forward, left)
}

/// The side of the body (from `centre`, along `left`) a limb's bones lie on, on average.
fn limb_side(rig: &Rig, centre: Vec3, chain: &[usize], left: Vec3) -> Side {
    let m = chain.iter().map(|&b| (rig.h(b) + rig.t(b)) * 0.5).sum::<Vec3>() / chain.len() as f32;
    if (m - centre).dot(left) >= 0.0 {
        Side::Left
    } else {
        Side::Right
    }
}

/// Step 5's legs as limbs, grouped along `forward` (front first) with their sides, and the
/// body plan they make. Legs whose tops lie within 0.15 h along `forward` form a group; four
/// legs that this splits otherwise go in a front and a back pair when each pair is one left and
/// one right leg and the pairs lie further apart than the legs within a pair (a scanned animal
/// in mid-stride, its rough hips above its feet: the horse's front tops are 0.154 h apart).
fn leg_limbs(rig: &Rig, legs: &Legs, centre: Vec3, forward: Vec3, left: Vec3) -> (Vec<Limb>, BodyPlan) {
    let proj: Vec<f32> = legs.tops.iter().map(|&b| rig.h(b).dot(forward)).collect();
    let sides: Vec<Side> = legs.chains.iter().map(|c| limb_side(rig, centre, c, left)).collect();
    let mut order: Vec<usize> = (0..legs.tops.len()).collect();
    order.sort_by(|&a, &b| proj[b].partial_cmp(&proj[a]).unwrap_or(std::cmp::Ordering::Equal));
    let mut group_of = vec![0usize; legs.tops.len()];
    let mut g = 0;
    for w in 1..order.len() {
        if proj[order[w - 1]] - proj[order[w]] > 0.15 * rig.height {
            g += 1;
        }
        group_of[order[w]] = g;
    }
    let front_pair = group_of.iter().filter(|&&g| g == 0).count() == 2;
    if order.len() == 4 && !(g == 1 && front_pair) {
        let gap = |a: usize, b: usize| proj[order[a]] - proj[order[b]];
        let mixed = |a: usize, b: usize| sides[order[a]] != sides[order[b]];
        if mixed(0, 1) && mixed(2, 3) && gap(1, 2) > gap(0, 1).max(gap(2, 3)) {
            for (w, &i) in order.iter().enumerate() {
                group_of[i] = w / 2;
            }
        }
    }
    let groups = group_of.iter().max().map_or(1, |g| g + 1);
    let mut limbs: Vec<Limb> =
        order.iter().map(|&i| Limb { bones: legs.chains[i].clone(), side: sides[i], group: group_of[i] }).collect();
    limbs.sort_by_key(|l| (l.group, l.side == Side::Right));
    let plan = match (limbs.len(), groups) {
        (2, _) => BodyPlan::Biped,
        (4, 2) if limbs.iter().filter(|l| l.group == 0).count() == 2 => BodyPlan::Quadruped,
        _ => BodyPlan::Multiped,
    };
    (limbs, plan)
}

/// Step 6's tail: the midline chain off the spine pointing furthest backwards (more than
/// 0.05 h), not on the axis, a leg, a leg carrier or an arm.
#[allow(clippy::too_many_arguments)]
fn find_tail(
    rig: &Rig,
    legs: &Legs,
    mid: &Midplane,
    trunk: &Trunk,
    on_axis: &[bool],
    is_arm_top: impl Fn(usize) -> bool,
    reach: &[f32],
    forward: Vec3,
) -> Vec<usize> {
    let mut tail = Vec::new();
    let mut best = 0.0f32;
    for &sb in &trunk.spine {
        for &c in rig.kids(sb) {
            if on_axis[c] || legs.member[c] || trunk.leg_carrier[c] || is_arm_top(c) || !mid.holds(rig, c) {
                continue;
            }
            let (chain, _) = rig.chain_down(reach, c);
            let back = (rig.h(c) - rig.t(*chain.last().unwrap())).dot(forward);
            if back > best && back > 0.05 * rig.height {
                best = back;
                tail = chain.into_iter().filter(|&b| mid.holds(rig, b)).collect();
            }
        }
    }
    tail
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A test rig: bone names, heads, tails, parent indices (-1: root).
    pub type Skeleton = (Vec<String>, Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<i32>);
    /// One bone of a hand-written rig: name, head, tail, parent's name (`None`: root).
    type BoneSpec = (String, [f32; 3], [f32; 3], Option<String>);

    /// The index of the bone called `name`.
    pub fn bone(names: &[String], name: &str) -> usize {
        names.iter().position(|n| n == name).unwrap()
    }

    /// The add-on's generated quadruped (scripts/creature.py), faces -Y.
    pub fn creature() -> Skeleton {
        let mut joints: Vec<(&str, [f32; 3])> = vec![
            ("hips", [0.0, 0.55, 1.00]),
            ("spine", [0.0, 0.05, 1.05]),
            ("chest", [0.0, -0.45, 1.08]),
            ("neck", [0.0, -0.75, 1.38]),
            ("head", [0.0, -0.95, 1.58]),
            ("snout", [0.0, -1.30, 1.50]),
            ("tail1", [0.0, 0.85, 1.08]),
            ("tail2", [0.0, 1.15, 1.20]),
            ("tail3", [0.0, 1.40, 1.22]),
            ("ear.L", [0.12, -0.92, 1.85]),
            ("ear.R", [-0.12, -0.92, 1.85]),
        ];
        let sides: [(&str, f32); 2] = [("L", 0.24), ("R", -0.24)];
        let mut owned: Vec<(String, [f32; 3])> = joints.drain(..).map(|(a, p)| (a.to_string(), p)).collect();
        for (s, x) in sides {
            for (j, p) in [
                ("shoulder", [x, -0.45, 0.95]),
                ("elbow", [x, -0.48, 0.55]),
                ("wrist", [x, -0.45, 0.12]),
                ("fronttoe", [x, -0.60, 0.05]),
                ("hip", [x, 0.55, 0.92]),
                ("knee", [x, 0.62, 0.55]),
                ("ankle", [x, 0.52, 0.12]),
                ("hindtoe", [x, 0.38, 0.05]),
            ] {
                owned.push((format!("{j}.{s}"), p));
            }
        }
        let jp = |name: &str| owned.iter().find(|(n, _)| n == name).unwrap().1;
        let mut bones: Vec<(String, String, String, Option<String>)> = vec![
            ("spine", "hips", "spine", None),
            ("chest", "spine", "chest", Some("spine")),
            ("neck", "chest", "neck", Some("chest")),
            ("head", "neck", "head", Some("neck")),
            ("jaw", "head", "snout", Some("head")),
            ("tail.001", "hips", "tail1", Some("spine")),
            ("tail.002", "tail1", "tail2", Some("tail.001")),
            ("tail.003", "tail2", "tail3", Some("tail.002")),
            ("ear.L", "head", "ear.L", Some("head")),
            ("ear.R", "head", "ear.R", Some("head")),
        ]
        .into_iter()
        .map(|(a, b, c, d)| (a.into(), b.into(), c.into(), d.map(String::from)))
        .collect();
        for s in ["L", "R"] {
            let f = |x: &str| format!("{x}.{s}");
            bones.extend([
                (f("upper_arm"), f("shoulder"), f("elbow"), Some("chest".to_string())),
                (f("forearm"), f("elbow"), f("wrist"), Some(f("upper_arm"))),
                (f("hand"), f("wrist"), f("fronttoe"), Some(f("forearm"))),
                (f("thigh"), f("hip"), f("knee"), Some("spine".to_string())),
                (f("shin"), f("knee"), f("ankle"), Some(f("thigh"))),
                (f("foot"), f("ankle"), f("hindtoe"), Some(f("shin"))),
            ]);
        }
        let names: Vec<String> = bones.iter().map(|b| b.0.clone()).collect();
        let idx = |n: &str| bone(&names, n) as i32;
        let heads = bones.iter().map(|b| jp(&b.1)).collect();
        let tails = bones.iter().map(|b| jp(&b.2)).collect();
        let parents = bones.iter().map(|b| b.3.as_deref().map_or(-1, idx)).collect();
        (names, heads, tails, parents)
    }

    /// A hand-written rig as arrays, parents looked up by name.
    fn skeleton_of(b: &[BoneSpec]) -> Skeleton {
        let names: Vec<String> = b.iter().map(|x| x.0.clone()).collect();
        let idx = |n: &str| bone(&names, n) as i32;
        let parents = b.iter().map(|x| x.3.as_deref().map_or(-1, idx)).collect();
        (names.clone(), b.iter().map(|x| x.1).collect(), b.iter().map(|x| x.2).collect(), parents)
    }

    /// A simple human, facing -Y, arms down: hips root, 3 spine bones, neck, head,
    /// clavicle/upper arm/forearm/hand, thigh/shin/foot/toe.
    pub fn biped() -> Skeleton {
        skeleton_of(&biped_bones())
    }

    /// The bones of [`biped`], to extend.
    fn biped_bones() -> Vec<BoneSpec> {
        let mut b: Vec<BoneSpec> = vec![
            ("hips".into(), [0.0, 0.0, 1.0], [0.0, 0.0, 1.1], None),
            ("spine".into(), [0.0, 0.0, 1.1], [0.0, 0.0, 1.3], Some("hips".into())),
            ("chest".into(), [0.0, 0.0, 1.3], [0.0, 0.0, 1.5], Some("spine".into())),
            ("neck".into(), [0.0, 0.0, 1.5], [0.0, 0.0, 1.6], Some("chest".into())),
            ("head".into(), [0.0, 0.0, 1.6], [0.0, 0.0, 1.8], Some("neck".into())),
        ];
        for (s, x) in [("L", 1.0f32), ("R", -1.0)] {
            let f = |n: &str| format!("{n}.{s}");
            b.extend([
                (f("shoulder"), [0.02 * x, 0.0, 1.45], [0.18 * x, 0.0, 1.45], Some("chest".into())),
                (f("upper_arm"), [0.18 * x, 0.0, 1.45], [0.2 * x, 0.0, 1.17], Some(f("shoulder"))),
                (f("forearm"), [0.2 * x, 0.0, 1.17], [0.21 * x, -0.02, 0.92], Some(f("upper_arm"))),
                (f("hand"), [0.21 * x, -0.02, 0.92], [0.21 * x, -0.02, 0.75], Some(f("forearm"))),
                (f("thigh"), [0.1 * x, 0.0, 1.0], [0.1 * x, -0.02, 0.52], Some("hips".into())),
                (f("shin"), [0.1 * x, -0.02, 0.52], [0.1 * x, 0.0, 0.08], Some(f("thigh"))),
                (f("foot"), [0.1 * x, 0.0, 0.08], [0.1 * x, -0.14, 0.02], Some(f("shin"))),
                (f("toe"), [0.1 * x, -0.14, 0.02], [0.1 * x, -0.2, 0.02], Some(f("foot"))),
            ]);
        }
        b
    }

    /// A six-legged insect facing -Y, Z up: abdomen (root) -> thorax -> head, and three pairs
    /// of legs off the thorax, each a femur rising outward and a tibia down to the ground, with
    /// a short foot.
    pub fn hexapod() -> Skeleton {
        let mut b: Vec<BoneSpec> = vec![
            ("abdomen".into(), [0.0, 0.7, 0.5], [0.0, 0.3, 0.5], None),
            ("thorax".into(), [0.0, 0.3, 0.5], [0.0, -0.3, 0.5], Some("abdomen".into())),
            ("head".into(), [0.0, -0.3, 0.5], [0.0, -0.55, 0.55], Some("thorax".into())),
        ];
        for (s, x) in [("L", 1.0f32), ("R", -1.0)] {
            for (pair, y) in [("front", -0.25f32), ("middle", 0.0), ("back", 0.25)] {
                let f = |n: &str| format!("{pair}_{n}.{s}");
                b.extend([
                    (f("femur"), [0.08 * x, y, 0.5], [0.35 * x, y, 0.6], Some("thorax".into())),
                    (f("tibia"), [0.35 * x, y, 0.6], [0.5 * x, y, 0.05], Some(f("femur"))),
                    (f("foot"), [0.5 * x, y, 0.05], [0.55 * x, y, 0.0], Some(f("tibia"))),
                ]);
            }
        }
        skeleton_of(&b)
    }

    /// A game-style biped exported from an IK set-up (the structure of the Quaternius and
    /// RobotExpressive rigs, not their data): a ground root carrying the feet and knee pole
    /// targets, a body bone carrying the legs and a hips -> torso -> neck -> head chain, long
    /// ears, T-posed arms whose clavicle and fingers rise a little. The leg chains stop at the
    /// ankle; with `invented_tails`, every bone has a tiny tail along its direction (glTF stores
    /// joints only: RobotExpressive imports so), and the shins end at the knee.
    /// Faces -Y, Z up.
    pub fn ik_biped(invented_tails: bool) -> Skeleton {
        let mut b: Vec<BoneSpec> = vec![
            ("Root".into(), [0.0, 0.2, 0.0], [0.0, 0.2, 0.35], None),
            ("Body".into(), [0.0, 0.05, 0.95], [0.0, 0.05, 1.2], Some("Root".into())),
            ("Hips".into(), [0.0, 0.25, 0.8], [0.0, 0.3, 1.1], Some("Body".into())),
            ("Abdomen".into(), [0.0, 0.3, 1.1], [0.0, 0.27, 1.4], Some("Hips".into())),
            ("Torso".into(), [0.0, 0.27, 1.4], [0.0, 0.2, 1.7], Some("Abdomen".into())),
            ("Neck".into(), [0.0, 0.1, 1.95], [0.0, -0.05, 2.05], Some("Torso".into())),
            ("Head".into(), [0.0, -0.05, 2.05], [0.0, -0.2, 2.4], Some("Neck".into())),
        ];
        for (s, x) in [("L", 1.0f32), ("R", -1.0)] {
            let f = |n: &str| format!("{n}.{s}");
            let knee = [0.35 * x, 0.2, 0.55];
            let ankle = [0.35 * x, 0.25, 0.13];
            let shin_end = if invented_tails { [0.35 * x, 0.2, 0.4] } else { ankle };
            b.extend([
                (f("Ear1"), [0.24 * x, -0.2, 2.3], [0.36 * x, -0.2, 2.6], Some("Head".into())),
                (f("Ear2"), [0.36 * x, -0.2, 2.6], [0.42 * x, -0.2, 3.05], Some(f("Ear1"))),
                (f("Ear3"), [0.42 * x, -0.2, 3.05], [0.43 * x, -0.35, 3.5], Some(f("Ear2"))),
                (f("Shoulder"), [0.17 * x, 0.22, 1.65], [0.37 * x, 0.22, 1.82], Some("Torso".into())),
                (f("UpperArm"), [0.37 * x, 0.22, 1.82], [1.2 * x, 0.18, 1.82], Some(f("Shoulder"))),
                (f("LowerArm"), [1.2 * x, 0.18, 1.82], [1.74 * x, 0.16, 1.85], Some(f("UpperArm"))),
                (f("Middle1"), [1.74 * x, 0.16, 1.85], [2.0 * x, 0.15, 1.88], Some(f("LowerArm"))),
                (f("Middle2"), [2.0 * x, 0.15, 1.88], [2.23 * x, 0.15, 1.86], Some(f("Middle1"))),
                (f("UpperLeg"), [0.34 * x, 0.22, 0.97], knee, Some("Body".into())),
                (f("LowerLeg"), knee, shin_end, Some(f("UpperLeg"))),
                (f("Foot"), [0.35 * x, 0.28, 0.04], [0.35 * x, -0.07, 0.04], Some("Root".into())),
                (f("PoleTarget"), [0.35 * x, -1.6, 0.6], [0.35 * x, -1.6, 0.95], Some("Root".into())),
            ]);
        }
        if invented_tails {
            for bone in &mut b {
                let (h, t) = (Vec3::from(bone.1), Vec3::from(bone.2));
                bone.2 = (h + 0.006 * (t - h).normalize()).to_array();
            }
        }
        skeleton_of(&b)
    }

    /// A generated rig with the structure of Spot the cow's hand-made one (not its data): seven
    /// separate root trees meeting at shared joints (chest, hips, skull), glTF-style "_leaf"
    /// bones pointing straight down, legs about 40 units long, facing +Y, Z up.
    pub fn spot() -> Skeleton {
        let chest = [0.0, 0.0, -2.0];
        let hips = [0.0, -20.0, 0.0];
        let skull = [0.0, 19.0, 10.0];
        let down = |p: [f32; 3], d: f32| [p[0], p[1], p[2] - d];
        let mut rows: Vec<(String, i32, [f32; 3], [f32; 3])> = Vec::new();
        let mut add = |name: &str, parent: i32, h: [f32; 3], t: [f32; 3]| -> i32 {
            rows.push((name.to_string(), parent, h, t));
            rows.len() as i32 - 1
        };
        let root = add("neck_root", -1, chest, [0.0, 13.0, 6.0]);
        let mid = add("neck_mid", root, [0.0, 13.0, 6.0], skull);
        for (side, x) in [("L", -1.0f32), ("R", 1.0)] {
            let horn = add(&format!("horn_{side}"), mid, skull, [6.5 * x, 25.0, 24.5]);
            add(&format!("horn_{side}_leaf"), horn, [6.5 * x, 25.0, 24.5], [6.5 * x, 25.0, 8.0]);
        }
        let head = add("head", mid, skull, [0.0, 30.0, 1.0]);
        for (side, x) in [("L", -1.0f32), ("R", 1.0)] {
            let m = add(&format!("mouth_corner_{side}"), head, [0.0, 30.0, 1.0], [9.0 * x, 30.0, -3.0]);
            add(&format!("mouth_corner_{side}_leaf"), m, [9.0 * x, 30.0, -3.0], [9.0 * x, 30.0, -13.0]);
        }
        for (side, x) in [("L", -1.0f32), ("R", 1.0)] {
            let e = add(&format!("ear_{side}"), mid, skull, [13.0 * x, 20.0, 18.0]);
            add(&format!("ear_{side}_leaf"), e, [13.0 * x, 20.0, 18.0], [13.0 * x, 20.0, 2.5]);
        }
        let tail = add("tail", -1, hips, [0.0, -31.0, 2.0]);
        add("tail_leaf", tail, [0.0, -31.0, 2.0], down([0.0, -31.0, 2.0], 11.5));
        // (upper end, knee, ankle) per pair: front knees bend forward, hind hocks backward
        let legs = [
            ("back", hips, [7.5, -24.0, -8.5], [9.0, -26.0, -15.0], [8.5, -29.5, -23.0]),
            ("front", chest, [8.5, 2.5, -14.5], [9.5, 0.5, -23.5], [9.5, -1.5, -30.5]),
        ];
        for (end, root_joint, hip, knee, ankle) in legs {
            for (side, x) in [("L", -1.0f32), ("R", 1.0)] {
                let hip = [hip[0] * x, hip[1], hip[2]];
                let knee = [knee[0] * x, knee[1], knee[2]];
                let ankle = [ankle[0] * x, ankle[1], ankle[2]];
                let h = add(&format!("leg_{end}_{side}_hip"), -1, root_joint, hip);
                let k = add(&format!("leg_{end}_{side}_knee"), h, hip, knee);
                let a = add(&format!("leg_{end}_{side}_ankle"), k, knee, ankle);
                add(&format!("leg_{end}_{side}_ankle_leaf"), a, ankle, down(ankle, 8.5));
            }
        }
        let body = add("body_root", -1, chest, [0.0, -5.0, -2.5]);
        let spine = add("body_spine", body, [0.0, -5.0, -2.5], [0.0, -10.0, -2.5]);
        let back = add("body_back", spine, [0.0, -10.0, -2.5], hips);
        add("body_back_leaf", back, hips, down(hips, 10.0));
        (
            rows.iter().map(|r| r.0.clone()).collect(),
            rows.iter().map(|r| r.2).collect(),
            rows.iter().map(|r| r.3).collect(),
            rows.iter().map(|r| r.1).collect(),
        )
    }

    #[test]
    fn quadruped_made_of_separate_trees() {
        let (names, h, t, p) = spot();
        let r = detect_roles(&h, &t, &p, &names).unwrap();
        assert_eq!(r.plan, BodyPlan::Quadruped);
        assert_eq!(names[r.root], "body_root");
        assert_eq!(named(&names, &r.spine), ["body_root", "body_spine", "body_back"]);
        assert_eq!(named(&names, &r.neck), ["neck_root", "neck_mid"]);
        assert_eq!(names[r.head], "head");
        assert_eq!(named(&names, &r.tail), ["tail", "tail_leaf"]);
        assert_eq!(leg(&names, &r, Side::Left, 0)[0], "leg_front_L_hip");
        assert_eq!(leg(&names, &r, Side::Right, 0)[0], "leg_front_R_hip");
        assert_eq!(leg(&names, &r, Side::Left, 1)[..3], ["leg_back_L_hip", "leg_back_L_knee", "leg_back_L_ankle"]);
        assert!((Vec3::from(r.forward) - Vec3::Y).length() < 1e-2, "{:?}", r.forward);
        assert!(!r.single_tree);
        // without names the head is still found at the front end
        let r2 = detect_roles(&h, &t, &p, &[]).unwrap();
        assert_eq!(r2.legs.len(), 4);
        assert!(["head", "neck_mid"].contains(&names[r2.head].as_str()), "{}", names[r2.head]);
    }

    fn named(names: &[String], ids: &[usize]) -> Vec<String> {
        ids.iter().map(|&i| names[i].clone()).collect()
    }

    fn leg(names: &[String], r: &Roles, side: Side, group: usize) -> Vec<String> {
        let l = r.legs.iter().find(|l| l.side == side && l.group == group).expect("leg");
        named(names, &l.bones)
    }

    #[test]
    fn quadruped_roles() {
        let (names, h, t, p) = creature();
        let r = detect_roles(&h, &t, &p, &names).unwrap();
        assert_eq!(r.plan, BodyPlan::Quadruped);
        assert_eq!(named(&names, &r.spine), ["spine", "chest"]);
        assert_eq!(named(&names, &r.neck), ["neck"]);
        assert_eq!(names[r.head], "head");
        assert_eq!(named(&names, &r.head_extras).len(), 3);
        assert_eq!(named(&names, &r.tail), ["tail.001", "tail.002", "tail.003"]);
        assert_eq!(leg(&names, &r, Side::Left, 0), ["upper_arm.L", "forearm.L", "hand.L"]);
        assert_eq!(leg(&names, &r, Side::Right, 0), ["upper_arm.R", "forearm.R", "hand.R"]);
        assert_eq!(leg(&names, &r, Side::Left, 1), ["thigh.L", "shin.L", "foot.L"]);
        assert_eq!(leg(&names, &r, Side::Right, 1), ["thigh.R", "shin.R", "foot.R"]);
        assert!(r.arms.is_empty());
        assert!((Vec3::from(r.forward) - Vec3::NEG_Y).length() < 1e-3, "{:?}", r.forward);
        assert!((Vec3::from(r.left) - Vec3::X).length() < 1e-3);
        assert!(r.notes.is_empty(), "{:?}", r.notes);
        assert!(r.single_tree);
    }

    /// The creature's tail dropped to the ground or curled up above its head stays its tail: a
    /// tail reaching the ground is no leg, and the head end of the body is found by the names on
    /// the way to it (a plume rising above the head, named without "tail") or by a tail's own
    /// name (head bones named without a head word).
    #[test]
    fn a_tail_on_the_ground_or_above_the_head_stays_the_tail() {
        const TAIL: [&str; 3] = ["tail.001", "tail.002", "tail.003"];
        // The roles' tail and head with the tail's joints (tail1, tail2, tail3) moved and bones
        // renamed.
        let tailed = |joints: [[f32; 3]; 3], rename: &[(&str, &str)]| {
            let (mut names, mut h, mut t, p) = creature();
            for (k, name) in TAIL.iter().enumerate() {
                let b = bone(&names, name);
                if k > 0 {
                    h[b] = joints[k - 1];
                }
                t[b] = joints[k];
            }
            for (from, to) in rename {
                let k = bone(&names, from);
                names[k] = to.to_string();
            }
            let r = detect_roles(&h, &t, &p, &names).unwrap();
            assert_eq!(r.plan, BodyPlan::Quadruped, "{rename:?}");
            (named(&names, &r.tail), names[r.head].clone())
        };
        let tail = TAIL.map(String::from).to_vec();
        let base = [0.0, 0.85, 1.08];
        assert_eq!(tailed([base, [0.0, 1.10, 0.6], [0.0, 1.25, 0.03]], &[]), (tail.clone(), "head".into()));
        let up = [base, [0.0, 1.0, 1.6], [0.0, 0.9, 2.1]];
        let plume = [("tail.001", "plume.001"), ("tail.002", "plume.002"), ("tail.003", "plume.003")];
        let (_, head) = tailed(up, &plume);
        assert_eq!(head, "head");
        let unnamed = [("neck", "n1"), ("head", "n2"), ("jaw", "n3")];
        assert_eq!(tailed(up, &unnamed), (tail, "n2".into()));
        // Hanging straight down under the hips (2 cm back over its 0.5 m), the chain is a
        // flap, not a tail: a tail points back by more than 5 % of the height.
        let flap = [[0.0, 0.56, 0.8], [0.0, 0.565, 0.65], [0.0, 0.57, 0.5]];
        assert_eq!(tailed(flap, &[]), (vec![], "head".into()));
    }

    /// A pair of cape panels (one long bone each, hanging off the chest like a pair of arms)
    /// are no arms: an arm is a chain of two bones or more, with a partner on the other side.
    #[test]
    fn hanging_single_bones_are_not_arms() {
        let (mut names, mut h, mut t, mut p) = creature();
        let chest = bone(&names, "chest") as i32;
        for (side, x) in [("L", 0.15), ("R", -0.15)] {
            names.push(format!("cape.{side}"));
            h.push([x, -0.2, 1.1]);
            t.push([x, -0.2, 0.5]);
            p.push(chest);
        }
        let r = detect_roles(&h, &t, &p, &names).unwrap();
        assert!(r.arms.is_empty(), "{:?}", r.arms);
        assert_eq!(r.plan, BodyPlan::Quadruped);
        // Nor is a chain on one side only (a bag's strap): arms come in pairs.
        let (mut names, mut h, mut t, mut p) = creature();
        for (k, (a, b)) in
            [([0.2, -0.3, 1.05], [0.25, -0.3, 0.8]), ([0.25, -0.3, 0.8], [0.25, -0.2, 0.5])].into_iter().enumerate()
        {
            names.push(format!("strap.00{k}"));
            h.push(a);
            t.push(b);
            p.push(if k == 0 { chest } else { names.len() as i32 - 2 });
        }
        let r = detect_roles(&h, &t, &p, &names).unwrap();
        assert!(r.arms.is_empty(), "{:?}", r.arms);
    }

    /// The creature with each leg's bones moved by `dy` along Y (forward is -Y).
    fn creature_with_legs_moved(dy: [(&str, f32); 4]) -> Skeleton {
        let (names, mut h, mut t, p) = creature();
        for (leg, d) in dy {
            let (kind, side) = leg.split_once('.').unwrap();
            let bones = if kind == "front" { ["upper_arm", "forearm", "hand"] } else { ["thigh", "shin", "foot"] };
            for b in bones {
                let i = bone(&names, &format!("{b}.{side}"));
                h[i][1] += d;
                t[i][1] += d;
            }
        }
        (names, h, t, p)
    }

    #[test]
    fn quadruped_in_mid_stride_keeps_a_front_and_a_back_pair() {
        // The horse scan's rough rig: hips above the feet, each pair's tops apart by more
        // than the 0.15 h that groups legs (h = 1.8 here), the pairs much further apart.
        let (names, h, t, p) =
            creature_with_legs_moved([("front.L", -0.35), ("front.R", 0.0), ("back.L", 0.0), ("back.R", 0.30)]);
        let r = detect_roles(&h, &t, &p, &names).unwrap();
        assert_eq!(r.plan, BodyPlan::Quadruped);
        assert_eq!(leg(&names, &r, Side::Left, 0)[0], "upper_arm.L");
        assert_eq!(leg(&names, &r, Side::Right, 0)[0], "upper_arm.R");
        assert_eq!(leg(&names, &r, Side::Left, 1)[0], "thigh.L");
        assert_eq!(leg(&names, &r, Side::Right, 1)[0], "thigh.R");
        // Four legs evenly along the body (left, right, left, right) are no two pairs.
        let (names, h, t, p) =
            creature_with_legs_moved([("front.L", -0.5), ("front.R", 0.0), ("back.L", -0.5), ("back.R", 0.0)]);
        let r = detect_roles(&h, &t, &p, &names).unwrap();
        assert_eq!(r.plan, BodyPlan::Multiped);
    }

    #[test]
    fn six_legs_make_three_groups_front_to_back() {
        // The creature with a middle pair of legs (its hind legs moved 0.5 forward, off the
        // spine): the tops of each pair lie within 0.15 h, the pairs 0.5 apart (h ~ 1.85).
        let (mut names, mut h, mut t, mut p) = creature();
        let spine = bone(&names, "spine") as i32;
        for s in ["L", "R"] {
            let mut parent = spine;
            for b in ["thigh", "shin", "foot"] {
                let i = bone(&names, &format!("{b}.{s}"));
                let (mut head, mut tail) = (h[i], t[i]);
                head[1] -= 0.5;
                tail[1] -= 0.5;
                names.push(format!("mid_{b}.{s}"));
                h.push(head);
                t.push(tail);
                p.push(parent);
                parent = names.len() as i32 - 1;
            }
        }
        let r = detect_roles(&h, &t, &p, &names).unwrap();
        assert_eq!((r.plan, r.legs.len()), (BodyPlan::Multiped, 6));
        for (group, top) in [(0, "upper_arm"), (1, "mid_thigh"), (2, "thigh")] {
            for side in [Side::Left, Side::Right] {
                let first = &leg(&names, &r, side, group)[0];
                assert!(first.starts_with(top), "group {group} {side:?}: {first}");
            }
        }
    }

    #[test]
    fn quadruped_roles_without_names_and_turned() {
        // same creature rotated 90° about Z (faces +X), names hidden
        let (names, h, t, p) = creature();
        let rot = |q: [f32; 3]| [-q[1], q[0], q[2]];
        let h: Vec<_> = h.into_iter().map(rot).collect();
        let t: Vec<_> = t.into_iter().map(rot).collect();
        let r = detect_roles(&h, &t, &p, &[]).unwrap();
        assert_eq!(r.plan, BodyPlan::Quadruped);
        assert!((Vec3::from(r.forward) - Vec3::X).length() < 1e-3, "{:?}", r.forward);
        assert_eq!(named(&names, &r.spine), ["spine", "chest"]);
        assert_eq!(names[r.head], "head");
        assert_eq!(leg(&names, &r, Side::Left, 0)[0], "upper_arm.L");
        assert_eq!(leg(&names, &r, Side::Right, 1)[0], "thigh.R");
    }

    #[test]
    fn biped_roles() {
        let (names, h, t, p) = biped();
        let r = detect_roles(&h, &t, &p, &names).unwrap();
        assert_eq!(r.plan, BodyPlan::Biped);
        assert_eq!(named(&names, &r.spine), ["hips", "spine", "chest"]);
        assert_eq!(named(&names, &r.neck), ["neck"]);
        assert_eq!(names[r.head], "head");
        assert_eq!(leg(&names, &r, Side::Left, 0), ["thigh.L", "shin.L", "foot.L", "toe.L"]);
        assert_eq!(leg(&names, &r, Side::Right, 0)[0], "thigh.R");
        assert_eq!(r.arms.len(), 2);
        let la = r.arms.iter().find(|a| a.side == Side::Left).unwrap();
        assert_eq!(named(&names, &la.bones)[..3], ["shoulder.L", "upper_arm.L", "forearm.L"]);
        assert!((Vec3::from(r.forward) - Vec3::NEG_Y).length() < 1e-3, "{:?}", r.forward);
        assert!((r.leg_length - 0.98).abs() < 1e-3, "{}", r.leg_length);
        // without names too
        let r2 = detect_roles(&h, &t, &p, &[]).unwrap();
        assert_eq!(names[r2.head], "head");
        assert_eq!(r2.legs.len(), 2);
    }

    /// Legs are long (their chain drops at least a fifth of the height) and arms reach a fifth
    /// of it: a biped's two short flaps hanging from the hips toward the ground (a tabard)
    /// and two short pouch chains on the chest are neither legs nor arms.
    #[test]
    fn short_flaps_and_pouches_are_neither_legs_nor_arms() {
        let mut b = biped_bones();
        for (s, x) in [("L", 1.0f32), ("R", -1.0)] {
            let f = |n: &str| format!("{n}.{s}");
            b.extend([
                (f("flap"), [0.15 * x, -0.1, 0.4], [0.15 * x, -0.1, 0.28], Some("hips".into())),
                (f("flap_end"), [0.15 * x, -0.1, 0.28], [0.15 * x, -0.1, 0.15], Some(f("flap"))),
                (f("pouch"), [0.1 * x, -0.1, 1.35], [0.2 * x, -0.1, 1.3], Some("chest".into())),
                (f("pouch_end"), [0.2 * x, -0.1, 1.3], [0.26 * x, -0.1, 1.25], Some(f("pouch"))),
            ]);
        }
        let (names, h, t, p) = skeleton_of(&b);
        let r = detect_roles(&h, &t, &p, &names).unwrap();
        assert_eq!(r.plan, BodyPlan::Biped);
        assert_eq!(r.legs.len(), 2);
        assert_eq!(leg(&names, &r, Side::Left, 0)[0], "thigh.L");
        assert_eq!(r.arms.len(), 2);
        assert!(r.arms.iter().all(|a| names[a.bones[1]].starts_with("upper_arm")), "{:?}", r.arms);
    }

    #[test]
    fn ik_exported_biped_feet_ride_on_their_legs_and_t_posed_arms_are_arms() {
        for invented_tails in [false, true] {
            let (names, h, t, p) = ik_biped(invented_tails);
            let r = detect_roles(&h, &t, &p, &names).unwrap();
            assert_eq!(r.plan, BodyPlan::Biped);
            assert_eq!(leg(&names, &r, Side::Left, 0), ["UpperLeg.L", "LowerLeg.L", "Foot.L"]);
            assert_eq!(leg(&names, &r, Side::Right, 0), ["UpperLeg.R", "LowerLeg.R", "Foot.R"]);
            let riders: Vec<[String; 2]> =
                r.riders.iter().map(|&[a, b]| [names[a].clone(), names[b].clone()]).collect();
            assert_eq!(riders.len(), 2, "{riders:?}");
            for s in ["L", "R"] {
                assert!(riders.contains(&[format!("Foot.{s}"), format!("LowerLeg.{s}")]), "{riders:?}");
            }
            assert!(r.notes.iter().any(|n| n.contains("Foot.L")), "{:?}", r.notes);
            // the arms rise 0.23 above the shoulder over a reach of 2.1: arms, so the spine
            // reaches the torso they hang from and the neck is the neck alone (not the torso)
            assert_eq!(r.arms.len(), 2);
            let la = r.arms.iter().find(|a| a.side == Side::Left).unwrap();
            assert_eq!(named(&names, &la.bones)[..3], ["Shoulder.L", "UpperArm.L", "LowerArm.L"]);
            assert_eq!(named(&names, &r.spine), ["Root", "Body", "Hips", "Abdomen", "Torso"]);
            assert_eq!(named(&names, &r.neck), ["Neck"]);
            assert_eq!(names[r.head], "Head");
            assert!(r.head_extras.iter().all(|&b| names[b].starts_with("Ear")));
            assert!((Vec3::from(r.forward) - Vec3::NEG_Y).length() < 1e-3, "{:?}", r.forward);
        }
    }

    #[test]
    fn rigs_with_feet_on_their_legs_have_no_riders() {
        for (names, h, t, p) in [biped(), creature(), spot()] {
            assert!(detect_roles(&h, &t, &p, &names).unwrap().riders.is_empty());
        }
        // a narrow biped, arms out, whose feet hang off the hips level with the shins' ends:
        // the only leaf end above a foot is the head's, too high to be a leg's
        let mut b: Vec<BoneSpec> = vec![
            ("hips".into(), [0.0, 0.0, 1.0], [0.0, 0.0, 1.2], None),
            ("spine".into(), [0.0, 0.0, 1.2], [0.0, 0.0, 1.5], Some("hips".into())),
            ("neck".into(), [0.0, 0.0, 1.5], [0.0, 0.0, 1.6], Some("spine".into())),
            ("head".into(), [0.0, 0.0, 1.6], [0.0, 0.0, 1.8], Some("neck".into())),
        ];
        for (s, x) in [("L", 1.0f32), ("R", -1.0)] {
            let f = |n: &str| format!("{n}.{s}");
            b.extend([
                (f("thigh"), [0.1 * x, 0.0, 1.0], [0.1 * x, 0.0, 0.5], Some("hips".into())),
                (f("shin"), [0.1 * x, 0.0, 0.5], [0.1 * x, 0.0, 0.0], Some(f("thigh"))),
                (f("arm"), [0.2 * x, 0.0, 1.45], [0.5 * x, 0.0, 1.45], Some("spine".into())),
                (f("hand"), [0.5 * x, 0.0, 1.45], [0.7 * x, 0.0, 1.45], Some(f("arm"))),
                (f("foot"), [0.1 * x, -0.02, 0.0], [0.1 * x, -0.2, 0.0], Some("hips".into())),
            ]);
        }
        let (names, h, t, p) = skeleton_of(&b);
        let r = detect_roles(&h, &t, &p, &names).unwrap();
        assert!(r.riders.is_empty(), "{:?}", r.riders);
        assert_eq!(names[r.head], "head");
    }

    #[test]
    fn thousands_of_hair_bones_leave_the_roles_as_they_were() {
        // 400 strands of 10 bones hanging off the head: the mirror-plane scan samples the
        // 8000+ bone ends (it compares every pair) and still finds the body's plane
        let (mut names, mut h, mut t, mut p) = biped();
        let plain = detect_roles(&h, &t, &p, &names).unwrap();
        let head = bone(&names, "head") as i32;
        for k in 0..400 {
            let x = 0.1 * ((k as f32 * 0.618).fract() - 0.5);
            for j in 0..10 {
                let z = 1.78 - 0.01 * j as f32;
                names.push(format!("hair{k}_{j}"));
                h.push([x, 0.05 + 0.01 * j as f32, z]);
                t.push([x, 0.06 + 0.01 * j as f32, z - 0.01]);
                p.push(if j == 0 { head } else { h.len() as i32 - 2 });
            }
        }
        let r = detect_roles(&h, &t, &p, &names).unwrap();
        assert_eq!(named(&names, &r.spine), named(&names, &plain.spine));
        assert_eq!(r.legs.len(), 2);
        assert_eq!(leg(&names, &r, Side::Left, 0), leg(&names, &plain, Side::Left, 0));
        assert_eq!(r.arms.len(), 2);
        assert_eq!(names[r.head], "head");
        assert!((Vec3::from(r.forward) - Vec3::from(plain.forward)).length() < 1e-3, "{:?}", r.forward);
    }

    /// A small separate tree starting where the body's root starts (a skirt or a belly flap
    /// rigged on its own) joins the body, not the body it: the weaker tree is joined first, so
    /// the body's root stays the root whatever the bones' order.
    #[test]
    fn a_small_tree_at_the_roots_head_joins_the_body() {
        let (plain_names, h, t, p) = biped();
        let plain = detect_roles(&h, &t, &p, &plain_names).unwrap();
        let mut b = biped_bones();
        let hips = b[0].1; // the body's root, listed first
        b.extend([
            ("skirt0".into(), hips, [0.0, 0.1, 0.85], None),
            ("skirt1".into(), [0.0, 0.1, 0.85], [0.0, 0.15, 0.7], Some("skirt0".into())),
        ]);
        let (names, h, t, p) = skeleton_of(&b);
        let r = detect_roles(&h, &t, &p, &names).unwrap();
        assert_eq!(names[r.root], "hips");
        assert_eq!(named(&names, &r.spine), named(&plain_names, &plain.spine));
        assert_eq!(leg(&names, &r, Side::Left, 0), leg(&plain_names, &plain, Side::Left, 0));
        assert_eq!(names[r.head], "head");
    }

    #[test]
    fn no_legs_is_a_clear_error() {
        let h = vec![[0.0, 0.0, 1.0], [0.0, 0.0, 2.0]];
        let t = vec![[0.0, 0.0, 2.0], [0.0, 0.0, 3.0]];
        let err = detect_roles(&h, &t, &[-1, 0], &[]).unwrap_err();
        assert!(err.to_string().contains("no legs"), "{err}");
    }

    #[test]
    fn no_head_is_a_clear_error() {
        // a hip bone with two legs and nothing else
        let h = vec![[-0.2, 0.0, 1.0], [-0.2, 0.0, 1.0], [0.2, 0.0, 1.0]];
        let t = vec![[0.2, 0.0, 1.0], [-0.2, 0.0, 0.0], [0.2, 0.0, 0.0]];
        let err = detect_roles(&h, &t, &[-1, 0, 0], &[]).unwrap_err();
        assert!(err.to_string().contains("no head"), "{err}");
    }

    #[test]
    fn bad_input_is_rejected() {
        assert!(detect_roles(&[], &[], &[], &[]).is_err());
        let h = vec![[0.0; 3], [0.0, 0.0, 1.0]];
        let t = vec![[0.0, 0.0, 1.0], [0.0, 0.0, 2.0]];
        assert!(matches!(detect_roles(&h, &t, &[1, 0], &[]), Err(Error::InvalidArgument(_))));
        assert!(matches!(detect_roles(&h, &t, &[-1], &[]), Err(Error::Shape(_))));
        let nan = vec![[f32::NAN; 3], [0.0; 3]];
        assert!(matches!(detect_roles(&nan, &t, &[-1, 0], &[]), Err(Error::NonFinite { .. })));
    }

    #[test]
    fn name_sides() {
        assert_eq!(name_side("thigh.L"), Some(Side::Left));
        assert_eq!(name_side("R_foot"), Some(Side::Right));
        assert_eq!(name_side("LeftUpLeg"), Some(Side::Left));
        assert_eq!(name_side("mixamorig:RightHand"), Some(Side::Right));
        assert_eq!(name_side("shin-r"), Some(Side::Right));
        assert_eq!(name_side("l ear"), Some(Side::Left));
        assert_eq!(name_side("spine"), None);
        assert_eq!(name_side("tail.l1"), None);
    }
}
