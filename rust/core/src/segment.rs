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
}
