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
//!    of the end points best matches them (1° scan then refinement); a biped's (two legs in
//!    step 3, which does not need the plane) within 60° of square to the line between its
//!    legs: a T-posed biped lying in one vertical plane mirrors onto itself across that plane
//!    too. Bones within 0.05 h of it are *midline* bones.
//! 3. Legs: "ground leaves" are leaf bones ending within 0.2 h of the lowest point. Bottom up,
//!    a bone with two or more "long" children (reaching down 0.2 h or more from their head)
//!    that contain ground leaves is a split: each such child holding one foot is a leg top, and
//!    the leg is the chain from it down to its foot. Short branches (toe and heel) merge.
//! 4. Head: the highest midline end (a midline bone with no midline bone below it) outside the
//!    legs (a bone named head/jaw/skull/face on its way scores higher, one named neck less,
//!    one named tail lower).
//!    The path root → that end is the body axis; the head bone is on it (by name, else the
//!    end's parent when the end is a leaf with non-limb siblings like ears, else the end). The
//!    spine is the axis from the root down to the deepest bone carrying a limb (leg or arm),
//!    plus the bones carrying legs off the axis, less a tail the axis starts from (midline
//!    bones before the first leg's junction running backwards from it); the neck lies between
//!    spine and head.
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
use crate::skeleton::{name_side, validate_parents, Skeleton};
use glam::Vec3;

/// Which side of the body a limb is on: the side of bone names (`skeleton::names`).
pub use crate::skeleton::Side;

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
    /// No legs (a blob, a flyer, a bust): a head shake works, a walk or run does not.
    Legless,
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
    /// Vertical reach of the shortest leg (its top bone's head to its lowest point), same unit
    /// as the input: the stride every leg can take. A quadruped's front legs reach from the top
    /// of the shoulder blade, so this is mostly its hip height, the length gaits scale by
    /// (Alexander and Jayes 1983); a rest pose with raised hind hooves (Spot's) walks on the
    /// stride of its shorter hind legs.
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

/// The words of bone `b`'s name, lower case: split at anything not a letter or digit, between
/// letters and digits, and before a capital that follows a small letter (`b_Head_05`, `Head2`,
/// `HeadTop_End` and `DEF-forehead.R` have the words head; head; head, top, end; def,
/// forehead, r).
fn words(names: &[String], b: usize) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut prev: Option<char> = None;
    for c in names.get(b).map_or("", |s| s.as_str()).chars() {
        if !c.is_alphanumeric() {
            prev = None;
            continue;
        }
        let split = match prev {
            None => true,
            Some(p) => p.is_ascii_digit() != c.is_ascii_digit() || (p.is_lowercase() && c.is_uppercase()),
        };
        if split {
            out.push(String::new());
        }
        if let Some(w) = out.last_mut() {
            w.extend(c.to_lowercase());
        }
        prev = Some(c);
    }
    out
}

/// The message of a rig without legs, for a walk or run.
pub(crate) fn no_legs_message() -> String {
    format!(
        "no legs: no two bone chains branch off the body and reach down to the lowest point \
         (within {:.0}% of the skeleton's height)",
        GROUND_FRACTION * 100.0
    )
}

fn validate(skeleton: &Skeleton) -> Result<()> {
    let Skeleton { heads, tails, parents, names } = *skeleton;
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

/// How far (degrees) a biped's sagittal plane may turn from square to the line between its two
/// legs: a biped in mid-stride has its legs apart along the body too.
const BIPED_PLANE_TURN: f32 = 60.0;

/// Unit normal (horizontal) of the best mirror plane through `centre` for `points`; with
/// `across` (a biped's horizontal direction from one leg to the other), only among the planes
/// within [`BIPED_PLANE_TURN`] of square to it. A T-posed biped lies nearly in one vertical
/// plane, which mirrors it front to back as well as its sagittal plane mirrors it left to right
/// (and better, once an arm holds a prop or the torso bends aside); its legs lie in that plane.
fn mirror_normal(points: &[Vec3], centre: Vec3, across: Option<Vec3>) -> Vec3 {
    let sampled: Vec<Vec3> = points.iter().step_by(points.len().div_ceil(MIRROR_POINTS).max(1)).copied().collect();
    let points = &sampled[..];
    let normal = |deg: f32| {
        let a = deg.to_radians();
        Vec3::new(a.cos(), a.sin(), 0.0)
    };
    let allowed = |deg: f32| across.is_none_or(|a| normal(deg).dot(a).abs() >= BIPED_PLANE_TURN.to_radians().cos());
    let score = |deg: f32| -> f32 {
        let n = normal(deg);
        points
            .iter()
            .map(|&p| {
                let q = p - 2.0 * (p - centre).dot(n) * n;
                points.iter().map(|&r| (r - q).length_squared()).fold(f32::INFINITY, f32::min).sqrt()
            })
            .sum()
    };
    let (mut best, mut best_s) = (0.0f32, f32::INFINITY);
    for d in (0..180).filter(|&d| allowed(d as f32)) {
        let s = score(d as f32);
        if s < best_s - 1e-7 {
            best = d as f32;
            best_s = s;
        }
    }
    let mut step = 0.5;
    while step > 0.01 {
        for cand in [best - step, best + step] {
            if !allowed(cand) {
                continue;
            }
            let s = score(cand);
            if s < best_s - 1e-7 {
                best = cand;
                best_s = s;
            }
        }
        step *= 0.5;
    }
    normal(best)
}

/// Find the roles of a skeleton's bones (see the module doc). Fails with
/// [`Error::NoBones`] naming what is missing when no head can be found; a rig without legs
/// gets [`BodyPlan::Legless`] and no legs (a walk or run refuses it, a head shake works).
pub fn detect_roles(skeleton: &Skeleton) -> Result<Roles> {
    validate(skeleton)?;
    let Skeleton { heads, tails, parents, names } = *skeleton;
    let (joined, riders) = joined_hierarchy(heads, tails, parents);
    let rig = Rig::new(heads, tails, names, &joined)?;
    let legs = find_legs(&rig);
    let mid = Midplane::of(&rig, &legs);
    let head_leaf = head_leaf(&rig, &legs, &mid)?;
    let axis = rig.ancestors(head_leaf);
    let mut on_axis = vec![false; rig.n()];
    for &b in &axis {
        on_axis[b] = true;
    }
    let reach = rig.reaches();
    let arm_chains = arm_chains(&rig, &legs, &mid, &axis, &on_axis, &reach);
    let mut trunk = split_axis(&rig, &legs, &axis, &on_axis, &arm_chains, head_leaf)?;
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
    let reversed = reversed_tail(&rig, &legs, &mid, &axis, &on_axis, forward);
    trunk.spine.retain(|b| !reversed.contains(b));
    if reversed.iter().any(|&b| b != rig.tree.root) {
        let named: Vec<String> =
            reversed.iter().map(|&b| names.get(b).cloned().unwrap_or_else(|| format!("bone {b}"))).collect();
        notes.push(format!(
            "bones behind the hips that the hierarchy starts from (a tail whose tip is the root): {}; \
             left at rest, carrying the body",
            named.join(", ")
        ));
    }
    let (leg_limbs, plan) = leg_limbs(&rig, &legs, mid.centre, forward, left);
    let arms: Vec<Limb> = arm_chains
        .iter()
        .filter(|(i, _)| *i <= trunk.spine_end)
        .map(|(_, c)| Limb { bones: c.clone(), side: limb_side(&rig, mid.centre, c, left), group: 0 })
        .collect();
    let is_arm_top = |b: usize| arm_chains.iter().any(|(_, c)| c[0] == b);
    let tail = find_tail(&rig, &legs, &mid, &trunk, (&reversed, &on_axis), is_arm_top, (&reach, forward));

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
        leg_limbs.iter().map(|l| rig.h(l.bones[0]).z - legs.low[l.bones[0]]).reduce(f32::min).unwrap_or(0.0);
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
fn find_legs(rig: &Rig) -> Legs {
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
    Legs { low, tops, chains, member }
}

/// Step 2: the sagittal plane (through `centre`, horizontal unit `normal`) and the midline
/// tolerance `tol`.
struct Midplane {
    centre: Vec3,
    normal: Vec3,
    tol: f32,
}

impl Midplane {
    /// The plane of the skeleton's end points; a biped's (two `legs`) turned less than
    /// [`BIPED_PLANE_TURN`] from square to the line between its legs.
    fn of(rig: &Rig, legs: &Legs) -> Midplane {
        let centre = rig.pts.iter().copied().sum::<Vec3>() / rig.pts.len() as f32;
        let across = match &legs.chains[..] {
            [a, b] => {
                let d = limb_middle(rig, a) - limb_middle(rig, b);
                Some(Vec3::new(d.x, d.y, 0.0).normalize_or_zero()).filter(|d| *d != Vec3::ZERO)
            }
            _ => None,
        };
        Midplane { centre, normal: mirror_normal(&rig.pts, centre, across), tol: MIDLINE_FRACTION * rig.height }
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
    const HEAD_WORDS: [&str; 4] = ["head", "jaw", "skull", "face"];
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
            // a bone named for the head on the way outranks one named neck, which also carries
            // a mane or a crest that reaches higher than the head (Rigify's horse)
            let named = |set: &[&str]| {
                path.iter().rev().take(4).any(|&a| words(rig.names, a).iter().any(|w| set.contains(&w.as_str())))
            };
            if named(&HEAD_WORDS) {
                score += 1.0;
            } else if named(&["neck"]) {
                score += 0.5;
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

/// The last axis bone on the way from the root to the leg top `top`: where its leg joins the
/// body axis.
fn leg_junction(rig: &Rig, top: usize, on_axis: &[bool]) -> Option<usize> {
    rig.ancestors(top).into_iter().rev().find(|&x| on_axis[x])
}

/// The axis bones before the first one carrying a leg, when they run backwards from it along
/// the midline (a tail that the hierarchy starts from, as in Rigify's quadruped and cat
/// metarigs, whose spine chain begins at the tail's tip, or a pelvis root behind the hips):
/// they are no spine, as turning one would swing the whole body about a point behind the
/// hips. Empty otherwise (a root bone under or ahead of the hips).
fn reversed_tail(
    rig: &Rig,
    legs: &Legs,
    mid: &Midplane,
    axis: &[usize],
    on_axis: &[bool],
    forward: Vec3,
) -> Vec<usize> {
    let junction = legs
        .tops
        .iter()
        .filter_map(|&top| leg_junction(rig, top, on_axis))
        .filter_map(|b| axis.iter().position(|&a| a == b))
        .min();
    let Some(j) = junction else { return Vec::new() };
    let before = &axis[..j];
    if before.is_empty() || !before.iter().all(|&b| mid.holds(rig, b)) {
        return Vec::new();
    }
    let hips = rig.h(axis[j]);
    let back = before.iter().flat_map(|&b| [rig.h(b), rig.t(b)]).map(|p| (hips - p).dot(forward)).fold(0.0, f32::max);
    if back > 0.05 * rig.height {
        before.to_vec()
    } else {
        Vec::new()
    }
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
        let w = words(rig.names, b);
        w.iter().any(|x| x == "head") && !w.iter().any(|x| x == "end" || x == "top")
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
    // a leg hanging off a side branch (e.g. hips beside the spine) counts at the axis bone the
    // branch leaves from
    let junctions: Vec<usize> = legs.tops.iter().filter_map(|&top| leg_junction(rig, top, on_axis)).collect();
    let carries_limb =
        |b: usize| kids[b].iter().any(|&c| legs.tops.contains(&c) || is_arm_top(c)) || junctions.contains(&b);
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
    // from the legs to the head; without legs, from the root
    let leg_top_mean = match legs.tops.len() {
        0 => rig.h(rig.tree.root),
        k => legs.tops.iter().map(|&b| rig.h(b)).sum::<Vec3>() / k as f32,
    };
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

/// The mean of a limb's bone midpoints.
fn limb_middle(rig: &Rig, chain: &[usize]) -> Vec3 {
    chain.iter().map(|&b| (rig.h(b) + rig.t(b)) * 0.5).sum::<Vec3>() / chain.len() as f32
}

/// The side of the body (from `centre`, along `left`) a limb's bones lie on, on average.
fn limb_side(rig: &Rig, centre: Vec3, chain: &[usize], left: Vec3) -> Side {
    if (limb_middle(rig, chain) - centre).dot(left) >= 0.0 {
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
        (0, _) => BodyPlan::Legless,
        (2, _) => BodyPlan::Biped,
        (4, 2) if limbs.iter().filter(|l| l.group == 0).count() == 2 => BodyPlan::Quadruped,
        _ => BodyPlan::Multiped,
    };
    (limbs, plan)
}

/// Step 6's tail: the midline chain off the spine (or off the axis bones `behind` the hips,
/// [`reversed_tail`]) pointing furthest backwards (more than 0.05 h), not on the axis, a leg,
/// a leg carrier or an arm (`is_arm_top`); `reach` per bone, as [`Rig::chain_down`] reads it.
fn find_tail(
    rig: &Rig,
    legs: &Legs,
    mid: &Midplane,
    trunk: &Trunk,
    (behind, on_axis): (&[usize], &[bool]),
    is_arm_top: impl Fn(usize) -> bool,
    (reach, forward): (&[f32], Vec3),
) -> Vec<usize> {
    let mut tail = Vec::new();
    let mut best = 0.0f32;
    for &sb in trunk.spine.iter().chain(behind) {
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
