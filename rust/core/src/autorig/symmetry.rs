//! The vertical mirror plane of a voxel solid, for bodies without legs to find it from.
//!
//! Input: [`Voxels`] (unit frame, +Z up). Output [`Mirror`]: the plane `p . normal = offset`
//! (`normal` unit and horizontal) and `score`, the share of inside voxels whose mirror image
//! is inside too (1 for a symmetric solid; a snake curled into an S or a figure lying on its
//! side scores far lower).
//!
//! Method: a left/right symmetric body's mirror plane passes through its centroid. For
//! [`ANGLES`] horizontal normals over half a turn, the plane through the centroid of the inside
//! voxels is scored on at most [`SAMPLES`] inside voxels spread over the solid; the best angle
//! is refined by halving the step [`REFINE`] times. A brute-force search over one angle: the
//! grid is coarse, so it costs a few milliseconds.
//!
//! Known limits: only vertical planes (the body stands or lies on its belly, +Z up); a body
//! whose two halves differ in mass (a raised arm) has its centroid off the plane, which lowers
//! the score, not the angle much.

use super::voxels::Voxels;
use glam::DVec3;
use std::f64::consts::PI;

/// Horizontal directions tried over half a turn.
const ANGLES: usize = 72;
/// Halvings of the angle step around the best one.
const REFINE: usize = 4;
/// Most inside voxels scored.
const SAMPLES: usize = 20_000;

/// A vertical plane and how well the solid mirrors across it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Mirror {
    pub normal: DVec3,
    pub offset: f64,
    pub score: f64,
}

impl Mirror {
    /// Signed distance of `p` from the plane (unit frame).
    pub fn distance(&self, p: DVec3) -> f64 {
        p.dot(self.normal) - self.offset
    }

    pub fn reflect(&self, p: DVec3) -> DVec3 {
        p - self.normal * (2.0 * self.distance(p))
    }
}

/// The best vertical mirror plane of the inside voxels of `vox`.
pub(crate) fn mirror_plane(vox: &Voxels) -> Mirror {
    let inside: Vec<usize> = (0..vox.inside.len()).filter(|&v| vox.inside[v]).collect();
    let stride = (inside.len() / SAMPLES).max(1);
    let sample: Vec<DVec3> = inside.iter().step_by(stride).map(|&v| vox.centre(v)).collect();
    let centroid = sample.iter().sum::<DVec3>() / sample.len().max(1) as f64;
    let plane = |angle: f64| {
        let normal = DVec3::new(angle.cos(), angle.sin(), 0.0);
        let offset = centroid.dot(normal);
        let mirror = Mirror { normal, offset, score: 0.0 };
        let hits = sample.iter().filter(|&&p| vox.inside_at(mirror.reflect(p))).count();
        Mirror { score: hits as f64 / sample.len().max(1) as f64, ..mirror }
    };
    let mut step = PI / ANGLES as f64;
    let mut best = (0..ANGLES).map(|k| plane(k as f64 * step)).max_by(|a, b| a.score.total_cmp(&b.score)).unwrap();
    for _ in 0..REFINE {
        step *= 0.5;
        let angle = best.normal.y.atan2(best.normal.x);
        for a in [angle - step, angle + step] {
            let m = plane(a);
            if m.score > best.score {
                best = m;
            }
        }
    }
    best
}
