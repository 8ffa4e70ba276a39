//! A regular grid of voxels: the addressing Auto Rig's solid and the geodesic voxel bind share.
//!
//! Voxel `(i, j, k)` of a lattice with `dims` `[nx, ny, nz]` is the cube of side `step` centred
//! on `origin + (i, j, k) step`; its states live in flat arrays of `nx*ny*nz` entries at index
//! `(k ny + j) nx + i` ([`Lattice::index`], inverted by [`Lattice::coords`]). How a lattice is
//! laid over a mesh (padding, resolution) is its user's choice.

use glam::DVec3;

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Lattice {
    pub dims: [usize; 3],
    /// Centre of voxel (0, 0, 0).
    pub origin: DVec3,
    /// Side of a voxel.
    pub step: f64,
}

impl Lattice {
    /// Number of voxels.
    pub fn len(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    /// Flat index of voxel `c = [i, j, k]`.
    #[inline]
    pub fn index(&self, c: [usize; 3]) -> usize {
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    /// `[i, j, k]` of flat index `v`.
    #[inline]
    pub fn coords(&self, v: usize) -> [usize; 3] {
        let i = v % self.dims[0];
        let j = (v / self.dims[0]) % self.dims[1];
        [i, j, v / (self.dims[0] * self.dims[1])]
    }

    /// Centre of voxel `v`.
    #[inline]
    pub fn centre(&self, v: usize) -> DVec3 {
        let [i, j, k] = self.coords(v);
        self.origin + DVec3::new(i as f64, j as f64, k as f64) * self.step
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_and_coords_invert_each_other() {
        let l = Lattice { dims: [3, 4, 5], origin: DVec3::new(1.0, 2.0, 3.0), step: 0.5 };
        for v in 0..l.len() {
            assert_eq!(l.index(l.coords(v)), v);
        }
        assert_eq!(l.coords(l.index([2, 3, 4])), [2, 3, 4]);
        assert_eq!(l.centre(l.index([2, 0, 1])), DVec3::new(2.0, 2.0, 3.5));
    }
}
