//! The ground a walk stands on: a level plane, or a height field sampled over a grid (the
//! add-on fills it by casting rays down onto a ground mesh), with its height and surface
//! normal anywhere (a stage of `gait.rs`, read by `footfalls::foot_target`).
//!
//! Inputs
//!   origin      (x, y) of grid point (0, 0), in the skeleton's space and units, +Z up
//!   cell        spacing of the grid points along X and Y (> 0), same unit
//!   nx, ny      grid points along X and Y (each >= 2)
//!   heights     nx * ny heights, row-major by Y (index i + nx * j is the point at
//!               origin + (i, j) * cell); NaN where the ray missed
//! Output
//!   [`Terrain`]: [`Terrain::height`] and [`Terrain::normal`] at any (x, y); a level ground
//!   ([`Terrain::LEVEL`]) answers the caller's level height and straight up.
//!
//! Method: a missed point takes the height of the nearest hit point (breadth-first over the
//! grid, 4-neighbours, so "nearest" in grid steps); a grid with no hit is level. Heights are
//! bilinear between grid points; outside the grid the border's heights continue. The normal is
//! that of the bilinear surface's central differences over one cell.
//!
//! Known limits: one height per (x, y), so overhangs, tunnels and walls are not seen (a ray
//! cast finds the top); a step is a slope one cell wide, so a foot landing on its edge tilts.

use crate::error::{Error, Result};
use glam::Vec3;
use std::collections::VecDeque;

/// A height field over a grid (see the module doc); `None` inside for the level ground.
#[derive(Debug, Clone, Default)]
pub struct Terrain {
    field: Option<Field>,
}

#[derive(Debug, Clone)]
struct Field {
    origin: [f32; 2],
    cell: f32,
    nx: usize,
    ny: usize,
    heights: Vec<f32>,
}

impl Terrain {
    /// The level ground (the height the caller gives).
    pub const LEVEL: Terrain = Terrain { field: None };

    /// A height field (see the module doc); an error for a grid of the wrong size, a cell that
    /// is not positive, or an infinite height. A grid with no hit at all is level.
    pub fn field(origin: [f32; 2], cell: f32, (nx, ny): (usize, usize), heights: &[f32]) -> Result<Terrain> {
        if nx < 2 || ny < 2 || heights.len() != nx * ny {
            return Err(Error::Shape(format!(
                "the ground's grid is {nx} x {ny} points (each at least 2) with {} heights",
                heights.len()
            )));
        }
        if !(cell > 0.0 && cell.is_finite() && origin.iter().all(|v| v.is_finite())) {
            return Err(Error::InvalidArgument(format!(
                "the ground's cell must be positive and its origin finite, got {cell} at {origin:?}"
            )));
        }
        let infinite = heights.iter().filter(|h| h.is_infinite()).count();
        if infinite > 0 {
            return Err(Error::NonFinite { what: "ground height", count: infinite });
        }
        let mut heights = heights.to_vec();
        // misses take the nearest hit's height, breadth first from every hit
        let mut queue: VecDeque<usize> = (0..heights.len()).filter(|&i| !heights[i].is_nan()).collect();
        if queue.is_empty() {
            return Ok(Terrain::LEVEL);
        }
        while let Some(i) = queue.pop_front() {
            let (x, y) = (i % nx, i / nx);
            let near =
                [(x > 0, i.wrapping_sub(1)), (x + 1 < nx, i + 1), (y > 0, i.wrapping_sub(nx)), (y + 1 < ny, i + nx)];
            for (inside, k) in near {
                if inside && heights[k].is_nan() {
                    heights[k] = heights[i];
                    queue.push_back(k);
                }
            }
        }
        Ok(Terrain { field: Some(Field { origin, cell, nx, ny, heights }) })
    }

    /// Whether this is the level ground.
    pub fn is_level(&self) -> bool {
        self.field.is_none()
    }

    /// The ground's height under `p` (its z is ignored); `level` for the level ground.
    pub fn height(&self, p: Vec3, level: f32) -> f32 {
        let Some(f) = &self.field else { return level };
        let u = ((p.x - f.origin[0]) / f.cell).clamp(0.0, (f.nx - 1) as f32);
        let v = ((p.y - f.origin[1]) / f.cell).clamp(0.0, (f.ny - 1) as f32);
        let (i, j) = ((u as usize).min(f.nx - 2), (v as usize).min(f.ny - 2));
        let (a, b) = (u - i as f32, v - j as f32);
        let h = |i: usize, j: usize| f.heights[i + f.nx * j];
        let low = h(i, j) * (1.0 - a) + h(i + 1, j) * a;
        let high = h(i, j + 1) * (1.0 - a) + h(i + 1, j + 1) * a;
        low * (1.0 - b) + high * b
    }

    /// The ground's unit normal under `p` (straight up on the level ground).
    pub fn normal(&self, p: Vec3) -> Vec3 {
        let Some(f) = &self.field else { return Vec3::Z };
        let d = 0.5 * f.cell;
        let dx = self.height(p + Vec3::X * d, 0.0) - self.height(p - Vec3::X * d, 0.0);
        let dy = self.height(p + Vec3::Y * d, 0.0) - self.height(p - Vec3::Y * d, 0.0);
        Vec3::new(-dx / f.cell, -dy / f.cell, 1.0).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_slope_has_its_height_and_normal_and_misses_take_the_nearest_hit() {
        // a 15 degree slope rising along +X, one corner missed
        let slope = 15f32.to_radians().tan();
        let (nx, ny, cell) = (6, 4, 0.5);
        let mut hs: Vec<f32> = (0..nx * ny).map(|i| (i % nx) as f32 * cell * slope).collect();
        hs[0] = f32::NAN;
        let t = Terrain::field([-1.0, -1.0], cell, (nx, ny), &hs).unwrap();
        let p = Vec3::new(0.3, 0.1, 7.0);
        assert!((t.height(p, 9.0) - 1.3 * slope).abs() < 1e-5, "{}", t.height(p, 9.0));
        let n = t.normal(p);
        assert!((n.angle_between(Vec3::Z).to_degrees() - 15.0).abs() < 0.01 && n.x < 0.0, "{n}");
        // the missed corner took its neighbour's height; outside, the border continues
        assert!((t.height(Vec3::new(-1.0, -1.0, 0.0), 0.0) - cell * slope).abs() < 1e-6);
        assert!((t.height(Vec3::new(9.0, 0.0, 0.0), 0.0) - 5.0 * cell * slope).abs() < 1e-5);
        // nothing hit: level; bad grids are errors
        assert!(Terrain::field([0.0; 2], 1.0, (2, 2), &[f32::NAN; 4]).unwrap().is_level());
        assert!(Terrain::field([0.0; 2], 1.0, (2, 3), &[0.0; 4]).is_err());
        assert!(Terrain::field([0.0; 2], 0.0, (2, 2), &[0.0; 4]).is_err());
        assert_eq!(Terrain::LEVEL.height(p, 2.5), 2.5);
    }
}
