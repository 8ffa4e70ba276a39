//! The bones a template is built of, and the joints of a limb along a path: the [`Builder`]
//! that adds named bones and connected chains under a parent, Rigify's spine names, a leg's
//! hip, and a limb's inner joints at proportions moved to the sharpest bends (`limb_points`).

use super::centreline::Tree;
use super::line::Line;
use glam::DVec3;

/// Shortest bone, unit frame.
pub(super) const MIN_BONE: f64 = 2e-3;
/// A tail shorter than this share of the torso is a rump: no tail bones.
pub(super) const TAIL_MIN: f64 = 0.2;

/// One bone of the result, unit frame.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Bone {
    pub name: String,
    pub head: DVec3,
    pub tail: DVec3,
    pub parent: Option<usize>,
    pub connected: bool,
}

pub(super) struct Builder {
    pub bones: Vec<Bone>,
}

impl Builder {
    pub fn add(&mut self, name: &str, head: DVec3, tail: DVec3, parent: Option<&str>, connected: bool) -> usize {
        let parent = parent.and_then(|p| self.bones.iter().position(|b| b.name == p));
        let tail = if (tail - head).length() < MIN_BONE { head + DVec3::Z * MIN_BONE } else { tail };
        self.bones.push(Bone { name: name.into(), head, tail, parent, connected });
        self.bones.len() - 1
    }

    /// A connected chain through `points` named `names`, the first bone under `parent`.
    pub fn chain(&mut self, names: &[String], points: &[DVec3], parent: Option<&str>, connect_first: bool) {
        for (k, name) in names.iter().enumerate() {
            let par = if k == 0 { parent.map(str::to_string) } else { Some(names[k - 1].clone()) };
            // A connected bone starts on its parent's tail, which `add` may have lengthened.
            let head = if k > 0 { self.bones.last().map_or(points[k], |b| b.tail) } else { points[k] };
            self.add(name, head, points[k + 1], par.as_deref(), k > 0 || connect_first);
        }
    }
}

pub(super) fn spine_names(first: usize, count: usize) -> Vec<String> {
    (first..first + count).map(|i| if i == 0 { "spine".into() } else { format!("spine.{i:03}") }).collect()
}

/// A leg's line from its junction to its foot.
pub(super) fn leg_line(tree: &Tree, junction: usize, foot: usize) -> Line {
    Line::new(tree, &tree.path(junction, foot))
}

/// The hip joint on a leg's line and its arc length: where the leg's path, coming up from the
/// foot, crosses the height `hip_z` (default: 80 % of the way to the junction's height, raised
/// to that height).
pub(super) fn hip(line: &Line, hip_z: Option<f64>) -> (f64, DVec3) {
    let zj = line.p[0].z;
    let zf = line.p.last().unwrap().z;
    let target = hip_z.unwrap_or(zf + 0.8 * (zj - zf));
    // From the foot up: the last crossing along the line from the junction.
    let s = line.crossings(target).next_back().unwrap_or(0.0);
    let p = line.at(s);
    (s, DVec3::new(p.x, p.y, hip_z.unwrap_or(zj.max(p.z))))
}

/// 1 for three points in a straight line, 0 when they bend by 10 degrees or more.
pub(super) fn straightness(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let angle = (b - a).angle_between(c - b).to_degrees();
    (1.0 - angle / 10.0).clamp(0.0, 1.0)
}

/// A limb's joints along `line` from arc length `from`: its start `start`, the inner joints at the
/// shares `fr` of the rest (each moved to the sharpest bend near it), and the tip (one radius
/// short of the line's end). The middle joint of a straight limb is nudged along `bend` by 2 %
/// of the limb, so IK knows which way it folds.
pub(super) fn limb_points(line: &Line, from: f64, start: DVec3, fr: &[f64], bend: DVec3) -> Vec<DVec3> {
    let l = line.len();
    let mut s = vec![0.0; fr.len()];
    for (i, f) in fr.iter().enumerate() {
        let lo = if i == 0 { from } else { s[i - 1] };
        s[i] = line.bend_near(from + f * (l - from), lo, l).max(lo + MIN_BONE);
    }
    let tip = line.at(l - line.radius(l));
    let mut pts: Vec<DVec3> = std::iter::once(start).chain(s.iter().map(|&x| line.at(x))).collect();
    pts.push(tip);
    if pts.len() >= 4 {
        let (a, b, c) = (pts[0], pts[1], pts[2]);
        pts[1] += bend * 0.02 * (a - c).length() * straightness(a, b, c);
    }
    pts
}
