//! What the stages pass on about a body: the [`Template`], the [`Body`] (its parts found in
//! the centre-line tree and its directions) and, for chain and winged bodies, its [`Axial`]
//! part; with the small geometric helpers they share (`horizontal`, `frame`, `end_thickness`).

use super::centreline::Tree;
use crate::{Error, Result};
use glam::DVec3;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Template {
    /// Decide from the shape: legs, wings, or neither.
    Auto,
    Biped,
    Quadruped,
    /// No legs: a spine from tail to head, fins or tentacles as side chains (Rigify's shark).
    Chain,
    /// Wings spread to the sides, with two, four or no legs (Rigify's bird).
    Winged,
}

impl Template {
    /// The name the bindings and reports use: "BIPED", "QUADRUPED", "CHAIN", "WINGED", "AUTO".
    pub fn name(self) -> &'static str {
        match self {
            Template::Auto => "AUTO",
            Template::Biped => "BIPED",
            Template::Quadruped => "QUADRUPED",
            Template::Chain => "CHAIN",
            Template::Winged => "WINGED",
        }
    }
}

/// The parts found in the tree (node indices) and the body's directions.
#[derive(Debug, Clone)]
pub(crate) struct Body {
    pub template: Template,
    /// Why this template, for the report ("4 legs hold the body up", ...).
    pub reason: String,
    /// Biped: [left, right]; quadruped: [hind left, hind right, front left, front right];
    /// chain: none; winged: none, [left, right] or the quadruped's four.
    pub feet: Vec<usize>,
    /// Biped: [left, right], when both are found.
    pub hands: Option<[usize; 2]>,
    pub head: usize,
    pub tail: Option<usize>,
    /// Where the legs join (biped: one; quadruped: hind, front).
    pub hips: usize,
    pub chest: Option<usize>,
    /// Biped: the point between the legs where the body closes over them (the crotch), when
    /// the legs' paths show it; the tree's own junction can sit far higher when a flat torso
    /// lets each leg's path run up it on its own.
    pub crotch: Option<DVec3>,
    /// The mirror plane: `p . left = plane`, midway between the legs where they are shins (the
    /// legs are the most reliably symmetric part; a hand's pose or a prop is not).
    pub plane: f64,
    /// Pairs are made mirror images across the plane (off for a body that is not symmetric,
    /// such as a snake lying in curves).
    pub symmetric: bool,
    pub forward: DVec3,
    pub left: DVec3,
    /// Lowest vertex height (unit frame).
    pub ground: f64,
    /// Chain and winged bodies: the spine and the side chains.
    pub axial: Option<Axial>,
}

impl Body {
    /// How far `p` lies off the mirror plane, to the `left` (negative: to the right).
    pub(crate) fn side(&self, p: DVec3) -> f64 {
        p.dot(self.left) - self.plane
    }

    /// The mirror image of `p` across the mirror plane.
    pub(crate) fn mirror(&self, p: DVec3) -> DVec3 {
        p - self.left * (2.0 * self.side(p))
    }

    /// `p` moved straight onto the mirror plane.
    pub(crate) fn onto_plane(&self, p: DVec3) -> DVec3 {
        p - self.left * self.side(p)
    }
}

pub(crate) fn horizontal(v: DVec3) -> DVec3 {
    DVec3::new(v.x, v.y, 0.0)
}

/// The spine and the side chains of a chain or winged body (tree node indices).
#[derive(Debug, Clone)]
pub(crate) struct Axial {
    /// The spine's nodes, from the tail end to the head end.
    pub spine: Vec<usize>,
    /// The spine's ends pushed out along it to the surface: tail end, head end.
    pub tips: [DVec3; 2],
    /// The spine stands (an upright blob, a moth): its lower end is no tail.
    pub upright: bool,
    /// Wing tips, [left, right].
    pub wings: Option<[usize; 2]>,
    /// Other paired side chains' tips, [left, right], from the head back.
    pub fins: Vec<[usize; 2]>,
}

/// Forward (horizontal, unit) and left (`up x forward`).
pub(crate) fn frame(facing: DVec3) -> Result<(DVec3, DVec3)> {
    let f = horizontal(facing);
    if !(f.length() > 1e-9) {
        return Err(Error::InvalidArgument("the facing direction must have a horizontal part".into()));
    }
    let f = f.normalize();
    Ok((f, DVec3::Z.cross(f)))
}

/// The mean radius of the tree over the last `reach` of the way from node `far` into the body:
/// a head is a bulb, a tail tapers.
pub(crate) fn end_thickness(tree: &Tree, far: usize, reach: f64) -> f64 {
    let path = tree.path(far, tree.deepest());
    let (mut walked, mut sum, mut n) = (0.0, 0.0, 0usize);
    for w in path.windows(2) {
        sum += tree.radius[w[0]];
        n += 1;
        walked += (tree.pos[w[1]] - tree.pos[w[0]]).length();
        if walked >= reach {
            break;
        }
    }
    if n == 0 {
        tree.radius[far]
    } else {
        sum / n as f64
    }
}
