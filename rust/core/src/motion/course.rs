//! A walk's course: the path a walk or run follows, and the map from the straight-line gait to
//! the world (a stage of `gait.rs`).
//!
//! Inputs
//!   points   #P by 3 points of a polyline in the skeleton's space, +Z up (their heights are
//!            ignored: the ground, `terrain.rs`, gives the height), #P >= 2, at least two apart
//! Output
//!   [`Course`]: its length, and position and unit tangent (horizontal) at arc length s.
//!   [`Steering`] maps the straight-line gait's coordinates (distance along forward from an
//!   origin, offset to the right, height) to the world: distance a, offset r and height h go to
//!   position(a) + r * right(a) + h Z, with right = tangent x Z.
//!
//! Method: the polyline parameterised by arc length (points closer than 1e-6 of its length to
//! the one before dropped); positions are linear along each segment, tangents are blended
//! linearly between the vertices' (each the mean direction of the segments it joins), so the
//! heading turns smoothly through a vertex. Before the start and past the end the course goes
//! straight on along its first and last tangents. The gait is made along the straight line and
//! mapped: a stance foot at a fixed distance maps to a fixed place (it neither slides nor
//! twists through a turn), and the body is carried rigidly by the map at its own distance.
//!
//! Known limits: a polyline only (the add-on samples a curve); a turn tighter than the body's
//! length or the feet's spread squeezes the inner feet's steps and stretches the outer ones.

use crate::error::{Error, Result};
use glam::{Quat, Vec3};

/// A path parameterised by arc length (see the module doc).
#[derive(Debug, Clone)]
pub struct Course {
    points: Vec<Vec3>,
    /// Arc length at each point, from 0.
    at: Vec<f32>,
    /// Unit horizontal tangent at each point.
    tangents: Vec<Vec3>,
}

impl Course {
    /// The course through `points` (see the module doc); an error for fewer than two distinct
    /// points, a length of zero, or a NaN or infinite point.
    pub fn new(points: &[[f32; 3]]) -> Result<Course> {
        let bad = points.iter().filter(|p| !p.iter().all(|v| v.is_finite())).count();
        if bad > 0 {
            return Err(Error::NonFinite { what: "path point", count: bad });
        }
        let flat: Vec<Vec3> = points.iter().map(|p| Vec3::new(p[0], p[1], 0.0)).collect();
        let total: f32 = flat.windows(2).map(|w| (w[1] - w[0]).length()).sum();
        let mut kept: Vec<Vec3> = Vec::with_capacity(flat.len());
        for p in flat {
            if kept.last().is_none_or(|&q| (p - q).length() > 1e-6 * total) {
                kept.push(p);
            }
        }
        if kept.len() < 2 || !(total > 0.0) {
            return Err(Error::InvalidArgument(format!(
                "the path needs two points apart at least (it has {} point(s), {} apart)",
                points.len(),
                total
            )));
        }
        let mut at = vec![0.0f32];
        for w in kept.windows(2) {
            at.push(at.last().unwrap() + (w[1] - w[0]).length());
        }
        let dir = |i: usize| (kept[i + 1] - kept[i]).normalize();
        let last = kept.len() - 1;
        let tangents = (0..kept.len())
            .map(|i| match i {
                0 => dir(0),
                i if i == last => dir(last - 1),
                i => (dir(i - 1) + dir(i)).try_normalize().unwrap_or(dir(i)),
            })
            .collect();
        Ok(Course { points: kept, at, tangents })
    }

    /// Its length.
    pub fn length(&self) -> f32 {
        *self.at.last().unwrap()
    }

    /// Position (z = 0) and unit horizontal tangent at arc length `s` (see the module doc).
    pub fn at(&self, s: f32) -> (Vec3, Vec3) {
        let last = self.points.len() - 1;
        if s <= 0.0 {
            return (self.points[0] + self.tangents[0] * s, self.tangents[0]);
        }
        if s >= self.length() {
            return (self.points[last] + self.tangents[last] * (s - self.length()), self.tangents[last]);
        }
        let i = self.at.partition_point(|&a| a <= s).clamp(1, last) - 1;
        let t = (s - self.at[i]) / (self.at[i + 1] - self.at[i]);
        let p = self.points[i].lerp(self.points[i + 1], t);
        let tangent = self.tangents[i].lerp(self.tangents[i + 1], t).try_normalize().unwrap_or(self.tangents[i]);
        (p, tangent)
    }
}

/// The map from the straight-line gait to the world (see the module doc): along `fwd` (unit,
/// horizontal) from `origin` (its height ignored), through `course`; without a course, the
/// identity.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Steering<'a> {
    pub course: Option<&'a Course>,
    pub origin: Vec3,
    pub fwd: Vec3,
}

impl Steering<'_> {
    /// Distance along the course of the straight-line point `q`.
    pub(crate) fn distance(&self, q: Vec3) -> f32 {
        (q - self.origin).dot(self.fwd)
    }

    /// The world turn (about +Z) at distance `s`: forward onto the course's tangent there.
    pub(crate) fn turn(&self, s: f32) -> Quat {
        match self.course {
            Some(c) => {
                let t = c.at(s).1;
                Quat::from_rotation_z(self.fwd.cross(t).z.atan2(self.fwd.dot(t)))
            }
            None => Quat::IDENTITY,
        }
    }

    /// Where the straight-line point `q` goes, carried rigidly by the map at distance `s`.
    pub(crate) fn carry(&self, q: Vec3, s: f32) -> Vec3 {
        match self.course {
            Some(c) => {
                let base = self.origin.with_z(0.0) + self.fwd * s;
                c.at(s).0 + self.turn(s) * (q - base)
            }
            None => q,
        }
    }

    /// Where the straight-line point `q` goes, at its own distance.
    pub(crate) fn place(&self, q: Vec3) -> Vec3 {
        self.carry(q, self.distance(q))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    #[test]
    fn a_circle_maps_a_straight_line_onto_it_turning_with_it() {
        let r = 2.0;
        let pts: Vec<[f32; 3]> =
            (0..=400).map(|i| i as f32 * PI / 400.0).map(|a| [r * a.sin(), r - r * a.cos(), 5.0]).collect();
        let c = Course::new(&pts).unwrap();
        assert!((c.length() - PI * r).abs() < 1e-3, "{}", c.length());
        let s = Steering { course: Some(&c), origin: Vec3::new(0.0, 0.0, 3.0), fwd: Vec3::X };
        // a quarter of the way round: heading +Y, a point 0.5 to the right is 0.5 further out
        let q = Vec3::new(PI * r / 2.0, -0.5, 1.0);
        let p = s.place(q);
        assert!((p - Vec3::new(2.5, 2.0, 1.0)).length() < 1e-3, "{p}");
        let turned = s.turn(PI * r / 2.0) * Vec3::X;
        assert!((turned - Vec3::Y).length() < 1e-3, "{turned}");
        // carried rigidly at a point's own distance, it lands where it is placed
        assert!((s.carry(q, s.distance(q)) - p).length() < 1e-6);
        // past the end it goes straight on
        let (end, t) = c.at(PI * r + 1.0);
        assert!((end - Vec3::new(-1.0, 2.0 * r, 0.0)).length() < 1e-2 && (t + Vec3::X).length() < 1e-2, "{end} {t}");
        // no course: the identity
        let id = Steering { course: None, ..s };
        assert_eq!(id.place(q), q);
        // bad paths
        assert!(Course::new(&[[0.0; 3]]).is_err());
        assert!(Course::new(&[[1.0, 1.0, 0.0], [1.0, 1.0, 4.0]]).is_err());
        assert!(Course::new(&[[0.0; 3], [f32::NAN, 0.0, 0.0]]).is_err());
    }
}
