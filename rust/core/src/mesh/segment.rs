//! Point-to-segment distance, the basic query behind every bone-weighting scheme
//! (a bone is the straight segment head -> tail).

use glam::DVec3;

/// Closest point on the segment `a`-`b` to the point `p`.
///
/// Inputs: three points in any consistent length unit.
/// Output: `(t, distance)` where `t` in `[0, 1]` is the parameter of the closest point
/// `a + t (b - a)` and `distance` is `|p - (a + t (b - a))|` in the input unit.
/// A zero-length (or numerically degenerate) segment is treated as the point `a`
/// with `t = 0`. Non-finite input yields non-finite distance (callers validate first).
///
/// Formula: `t = clamp(((p - a) . (b - a)) / |b - a|^2, 0, 1)`.
#[inline]
pub fn closest_point_on_segment(p: DVec3, a: DVec3, b: DVec3) -> (f64, f64) {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > f64::MIN_POSITIVE { ((p - a).dot(ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    (t, (p - (a + ab * t)).length())
}

/// A segment prepared for many point queries (the bone-heat sources ask every vertex against
/// every bone): `a`, `b - a` and `1 / |b - a|^2` (0 for a degenerate segment), so a query
/// needs no division. Same formula as [`closest_point_on_segment`].
#[derive(Clone, Copy, Debug)]
pub struct Segment {
    /// Start point.
    pub a: DVec3,
    /// `b - a`.
    pub ab: DVec3,
    inv_len2: f64,
    centre: DVec3,
    half: f64,
}

impl Segment {
    /// The segment `a`-`b`; zero-length (or numerically degenerate) counts as the point `a`.
    pub fn new(a: DVec3, b: DVec3) -> Segment {
        let ab = b - a;
        let len2 = ab.length_squared();
        let inv_len2 = if len2 > f64::MIN_POSITIVE { 1.0 / len2 } else { 0.0 };
        Segment { a, ab, inv_len2, centre: a + 0.5 * ab, half: 0.5 * len2.sqrt() }
    }

    /// Squared distance from `p` to the segment's midpoint: with [`half_length`](Self::half_length),
    /// the bounding ball that bounds the distance from below (`|p - centre| - half length`).
    #[inline]
    pub fn centre_distance_squared(&self, p: DVec3) -> f64 {
        (p - self.centre).length_squared()
    }

    /// Half the segment's length.
    #[inline]
    pub fn half_length(&self) -> f64 {
        self.half
    }

    /// `(t, p - q)`: the parameter `t` in `[0, 1]` of the closest point `q = a + t (b - a)` to
    /// `p`, and the offset from it to `p` (its length is the distance).
    #[inline]
    pub fn offset(&self, p: DVec3) -> (f64, DVec3) {
        let ap = p - self.a;
        let t = (ap.dot(self.ab) * self.inv_len2).clamp(0.0, 1.0);
        (t, ap - self.ab * t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interior_endpoint_and_degenerate() {
        let a = DVec3::ZERO;
        let b = DVec3::new(0.0, 0.0, 2.0);
        let (t, d) = closest_point_on_segment(DVec3::new(1.0, 0.0, 1.0), a, b);
        assert!((t - 0.5).abs() < 1e-12 && (d - 1.0).abs() < 1e-12);
        let (t, d) = closest_point_on_segment(DVec3::new(0.0, 0.0, 5.0), a, b);
        assert!((t - 1.0).abs() < 1e-12 && (d - 3.0).abs() < 1e-12);
        let (t, d) = closest_point_on_segment(DVec3::new(0.0, 3.0, 0.0), a, a);
        assert_eq!(t, 0.0);
        assert!((d - 3.0).abs() < 1e-12);
    }

    #[test]
    fn prepared_segment_agrees_with_the_formula() {
        let (a, b) = (DVec3::new(0.3, -1.0, 2.0), DVec3::new(1.5, 0.25, -0.5));
        for p in [DVec3::new(1.0, 1.0, 1.0), DVec3::new(-4.0, 0.0, 7.0), DVec3::new(9.0, 2.0, -3.0), a, b] {
            for (s, e) in [(a, b), (a, a)] {
                let (t, d) = closest_point_on_segment(p, s, e);
                let (t2, off) = Segment::new(s, e).offset(p);
                assert!((t - t2).abs() < 1e-12 && (d - off.length()).abs() < 1e-12, "{p} {s} {e}");
                let seg = Segment::new(s, e);
                assert!(seg.centre_distance_squared(p).sqrt() - seg.half_length() <= d + 1e-12, "{p} {s} {e}");
            }
        }
    }
}
