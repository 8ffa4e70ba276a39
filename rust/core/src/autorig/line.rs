//! A path of the centre-line tree as a polyline with radii and arc length: points and radii
//! at an arc length, where it crosses a height, where its tube starts, its sharpest bend near a
//! place. Used by `body` (where a leg is at a height) and `embed` (every joint).

use super::centreline::Tree;
use glam::DVec3;

/// Search this fraction of a limb's length either side of a proportional joint for a bend.
const BEND_WINDOW: f64 = 0.12;
/// A bend sharper than this (degrees) places the joint.
const MIN_BEND_DEG: f64 = 15.0;
/// A limb's tube starts where its radius is at most this times the radius of its middle.
const TUBE: f64 = 1.3;

/// A polyline with radii and arc length.
#[derive(Clone)]
pub(crate) struct Line {
    pub p: Vec<DVec3>,
    r: Vec<f64>,
    pub s: Vec<f64>,
}

impl Line {
    pub fn new(tree: &Tree, nodes: &[usize]) -> Line {
        Line::from_points(nodes.iter().map(|&n| (tree.pos[n], tree.radius[n])))
    }

    pub fn from_points(points: impl Iterator<Item = (DVec3, f64)>) -> Line {
        let (p, r): (Vec<DVec3>, Vec<f64>) = points.unzip();
        let mut s = vec![0.0];
        for w in p.windows(2) {
            s.push(s.last().unwrap() + (w[1] - w[0]).length());
        }
        Line { p, r, s }
    }

    pub fn len(&self) -> f64 {
        *self.s.last().unwrap()
    }

    fn seg(&self, s: f64) -> (usize, f64) {
        let s = s.clamp(0.0, self.len());
        let i = self.s.partition_point(|&x| x <= s).clamp(1, self.p.len().max(2) - 1);
        if self.p.len() < 2 {
            return (0, 0.0);
        }
        let d = self.s[i] - self.s[i - 1];
        (i - 1, if d > 0.0 { (s - self.s[i - 1]) / d } else { 0.0 })
    }

    pub fn at(&self, s: f64) -> DVec3 {
        if self.p.len() < 2 {
            return self.p[0];
        }
        let (i, t) = self.seg(s);
        self.p[i].lerp(self.p[i + 1], t)
    }

    pub fn radius(&self, s: f64) -> f64 {
        if self.p.len() < 2 {
            return self.r[0];
        }
        let (i, t) = self.seg(s);
        self.r[i] + (self.r[i + 1] - self.r[i]) * t
    }

    /// Arc lengths where the height crosses `z`, from the start on (one per segment that
    /// crosses or touches it; level segments never do).
    pub fn crossings(&self, z: f64) -> impl DoubleEndedIterator<Item = f64> + '_ {
        (0..self.p.len().saturating_sub(1)).filter_map(move |i| {
            let (a, b) = (self.p[i].z, self.p[i + 1].z);
            ((a - z) * (b - z) <= 0.0 && a != b).then(|| self.s[i] + (self.s[i + 1] - self.s[i]) * (z - a) / (b - a))
        })
    }

    /// First arc length (from the start) where the height crosses `z`.
    pub fn at_height(&self, z: f64) -> Option<f64> {
        self.crossings(z).next()
    }

    /// Median radius over arc lengths `a..b`.
    pub fn median_radius(&self, a: f64, b: f64) -> f64 {
        let mut r: Vec<f64> = (0..=10).map(|k| self.radius(a + (b - a) * k as f64 / 10.0)).collect();
        r.sort_by(f64::total_cmp);
        r[5]
    }

    /// Where the tube starts: the first arc length from `from` on with radius <= TUBE x the middle's.
    pub fn tube_start(&self, from: f64) -> f64 {
        let len = self.len();
        let mid = self.median_radius(from + 0.3 * (len - from), from + 0.8 * (len - from));
        let steps = 100;
        (0..=steps)
            .map(|k| from + (len - from) * k as f64 / steps as f64)
            .find(|&s| self.radius(s) <= TUBE * mid)
            .unwrap_or(from)
            .min(from + 0.5 * (len - from))
    }

    /// `s0`, or the sharpest bend within the window around it when it bends enough.
    pub fn bend_near(&self, s0: f64, lo: f64, hi: f64) -> f64 {
        let w = BEND_WINDOW * (hi - lo);
        let h = (0.08 * (hi - lo)).max(1e-6);
        let mut best = (s0, MIN_BEND_DEG.to_radians());
        for k in 0..=20 {
            let s = s0 - w + 2.0 * w * k as f64 / 20.0;
            if s - h < lo || s + h > hi {
                continue;
            }
            let (a, b) = (self.at(s) - self.at(s - h), self.at(s + h) - self.at(s));
            let angle = a.angle_between(b);
            if angle > best.1 {
                best = (s, angle);
            }
        }
        best.0
    }

    /// The first arc length in `from..to` below height `z` where the line, having come down,
    /// runs more along than down (over a step of a twentieth of that stretch), or `None`.
    pub fn turn_down_to_along(&self, from: f64, to: f64, z: f64) -> Option<f64> {
        let h = 0.05 * (to - from);
        if h <= 0.0 {
            return None;
        }
        (0..=40).map(|k| from + (to - from) * k as f64 / 40.0).find(|&s| {
            let (a, b) = (self.at(s), self.at((s + h).min(self.len())));
            let d = b - a;
            a.z < z && d.z.abs() < DVec3::new(d.x, d.y, 0.0).length() && s + h < to
        })
    }

    /// The arc length of the node nearest to `q`.
    pub fn nearest(&self, q: DVec3) -> f64 {
        let i =
            (0..self.p.len()).min_by(|&a, &b| (self.p[a] - q).length().total_cmp(&(self.p[b] - q).length())).unwrap();
        self.s[i]
    }
}
