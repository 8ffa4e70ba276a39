//! "Bilinear" bone weights: radial falloff from the nearest bone segments, blended along each
//! bone towards the connected neighbour across its nearer joint. Smooth across joints, cheap,
//! and independent of mesh topology (works on point clouds and broken meshes).

use crate::mesh::bones_in_frame;
use crate::mesh::segment::closest_point_on_segment;
use crate::mesh::{validate_bones, validate_mesh, Frame};
use crate::skeleton::validate_parents;
use crate::weights::influence::{top_k_row, Influences};
use crate::{Error, Result};
use rayon::prelude::*;

/// Radial falloff of the distance `d` to a bone segment.
#[derive(Debug, Clone, PartialEq)]
pub enum Falloff {
    /// `exp(-d^2 / (2 sigma^2))`, `sigma` in input units; `None` = half the median bone length
    /// (or 5% of the mesh bounding-box diagonal if all bones have zero length).
    Gaussian { sigma: Option<f32> },
    /// `(d + eps)^-power`, `eps = 1e-4` bbox diagonals.
    InversePower { power: f32 },
}

/// The power of [`Falloff::InversePower`] when none is given.
pub const INVERSE_POWER: f32 = 2.0;

/// Options of [`bilinear_weights`].
#[derive(Debug, Clone, PartialEq)]
pub struct BilinearOptions {
    /// Number `K` of nearest bone segments that receive a radial share (>= 1). Default 3.
    pub nearest: usize,
    /// Radial falloff. Default Gaussian with automatic sigma.
    pub falloff: Falloff,
    /// Bones kept per vertex (>= 1; the result has min(this, bones) columns). Default 4.
    pub max_influences: usize,
}

impl Default for BilinearOptions {
    fn default() -> Self {
        BilinearOptions { nearest: 3, falloff: Falloff::Gaussian { sigma: None }, max_influences: 4 }
    }
}

/// Two bone ends closer than this (in bbox diagonals) are "connected".
pub const JOINT_TOLERANCE: f64 = 1e-4;

/// Bilinear bone weights.
///
/// Inputs: `vertices` `(n, 3)`, `heads` / `tails` `(b, 3)` (same unit), `parents` `(b,)` the
/// parent bone index or `-1`.
/// Per vertex: the `K = nearest` closest bone segments get a radial share
/// `s = (falloff(d) - falloff(d_K+1)) / falloff(d_min)` (minus the share the next, `K+1`-th
/// bone would get, so that a bone fades to 0 before it leaves the `K` nearest and weights stay
/// continuous; raw shares are kept if this would leave nothing). Along a bone with
/// closest-point parameter `t in [0, 1]` the nearer joint is the tail if `t > 0.5`, else the head; the neighbour across it is the
/// connected child (`parents[c] == bone` and `|head_c - tail| < JOINT_TOLERANCE` diagonals; of
/// several, the one nearest the vertex) or the connected parent (whose tail touches this
/// head). The neighbour gets `s * (t - 0.5)` (tail side) or `s * (0.5 - t)` (head side) and
/// the bone keeps the rest, so at a joint both bones hold equal shares and the weights are
/// continuous across it. Finally the `max_influences` largest are kept and renormalized.
/// Output: [`Influences`] with `n` rows, none empty. Scale-free (unit frame of the mesh bbox).
/// Errors: bad mesh / bones, `parents` of wrong length or with an index out of range or
/// pointing to itself, `nearest == 0`, `max_influences == 0`, non-positive sigma/power.
pub fn bilinear_weights(
    vertices: &[[f32; 3]],
    heads: &[[f32; 3]],
    tails: &[[f32; 3]],
    parents: &[i32],
    opts: &BilinearOptions,
) -> Result<Influences> {
    validate_mesh(vertices, &[], false)?;
    validate_bones(heads, tails)?;
    let b = heads.len();
    validate_parents(parents, b)?;
    if opts.nearest == 0 || opts.max_influences == 0 {
        return Err(Error::InvalidArgument("nearest and max_influences must be >= 1".into()));
    }
    let frame = Frame::of_points(vertices);
    let bones = bones_in_frame(&frame, heads, tails);

    enum Fall {
        Gauss(f64),
        Power(f64),
    }
    let fall = match opts.falloff {
        Falloff::Gaussian { sigma: Some(s) } => {
            if !(s.is_finite() && s > 0.0) {
                return Err(Error::InvalidArgument(format!("sigma must be > 0, got {s}")));
            }
            Fall::Gauss(s as f64 / frame.diagonal)
        }
        Falloff::Gaussian { sigma: None } => {
            let mut lens: Vec<f64> = bones.iter().map(|(h, t)| (*t - *h).length()).collect();
            lens.sort_by(|a, b| a.total_cmp(b));
            let median = lens[lens.len() / 2];
            Fall::Gauss(if median > 0.0 { 0.5 * median } else { 0.05 })
        }
        Falloff::InversePower { power } => {
            if !(power.is_finite() && power > 0.0) {
                return Err(Error::InvalidArgument(format!("power must be > 0, got {power}")));
            }
            Fall::Power(power as f64)
        }
    };
    // Relative share of a bone at distance d given the nearest distance dmin (<= d).
    let share = |d: f64, dmin: f64| -> f64 {
        match fall {
            Fall::Gauss(s) => (-(d * d - dmin * dmin) / (2.0 * s * s)).exp(),
            Fall::Power(p) => ((dmin + 1e-4) / (d + 1e-4)).powf(p),
        }
    };

    // Connectivity: connected children per bone (CSR) and connected parent.
    let tol = JOINT_TOLERANCE;
    let mut child_start = vec![0usize; b + 1];
    let mut children = Vec::new();
    for j in 0..b {
        child_start[j] = children.len();
        for c in 0..b {
            if parents[c] == j as i32 && (bones[c].0 - bones[j].1).length() <= tol {
                children.push(c);
            }
        }
    }
    child_start[b] = children.len();
    let conn_parent: Vec<Option<usize>> = (0..b)
        .map(|j| {
            let p = parents[j];
            (p >= 0 && (bones[p as usize].1 - bones[j].0).length() <= tol).then_some(p as usize)
        })
        .collect();

    let kn = opts.nearest.min(b);
    let mut out = Influences::empty(vertices.len(), opts.max_influences.min(b));
    let k = out.k;
    out.indices
        .par_chunks_mut(k)
        .zip(out.weights.par_chunks_mut(k))
        .zip(vertices.par_iter())
        .with_min_len(256)
        .for_each_init(
            || (vec![0.0f64; b], vec![0.0f64; b], vec![0.0f64; b], Vec::<usize>::with_capacity(b)),
            |(dist, tpar, acc, order), ((idx, w), v)| {
                let x = frame.to_unit(*v);
                for j in 0..b {
                    let (t, d) = closest_point_on_segment(x, bones[j].0, bones[j].1);
                    dist[j] = d;
                    tpar[j] = t;
                    acc[j] = 0.0;
                }
                order.clear();
                order.extend(0..b);
                if kn < b {
                    order.select_nth_unstable_by(kn, |&a, &c| dist[a].total_cmp(&dist[c]).then(a.cmp(&c)));
                }
                let near = &order[..kn];
                let dmin = near.iter().map(|&j| dist[j]).fold(f64::INFINITY, f64::min);
                // Fade out the K-th share as the (K+1)-th bone catches up with it (continuity
                // when the K-nearest set changes); keep raw shares if that leaves nothing.
                let cut = if kn < b { share(dist[order[kn]], dmin) } else { 0.0 };
                let total: f64 = near.iter().map(|&j| (share(dist[j], dmin) - cut).max(0.0)).sum();
                let cut = if total > 1e-9 { cut } else { 0.0 };
                for &j in near {
                    let s = (share(dist[j], dmin) - cut).max(0.0);
                    let t = tpar[j];
                    let neighbour = if t > 0.5 {
                        children[child_start[j]..child_start[j + 1]]
                            .iter()
                            .copied()
                            .min_by(|&a, &c| dist[a].total_cmp(&dist[c]))
                            .map(|c| (c, t - 0.5))
                    } else if t < 0.5 {
                        conn_parent[j].map(|p| (p, 0.5 - t))
                    } else {
                        None
                    };
                    match neighbour {
                        Some((nb, f)) => {
                            acc[nb] += s * f;
                            acc[j] += s * (1.0 - f);
                        }
                        None => acc[j] += s,
                    }
                }
                top_k_row(|j| acc[j] as f32, b, 0.0, idx, w);
            },
        );
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn joint_is_shared_equally() {
        let heads = [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
        let tails = [[0.0, 0.0, 1.0], [0.0, 0.0, 2.0]];
        let verts = [[0.2, 0.0, 1.0], [0.2, 0.0, 0.1], [0.2, 0.0, 1.9], [0.0, 0.0, -5.0]];
        let inf = bilinear_weights(&verts, &heads, &tails, &[-1, 0], &BilinearOptions::default()).unwrap();
        let d = inf.to_dense(2);
        assert!((d[0] - 0.5).abs() < 1e-4 && (d[1] - 0.5).abs() < 1e-4, "{:?}", &d[..2]);
        assert!(d[2] > 0.9);
        assert!(d[5] > 0.9);
        assert!(inf.row(3).1[0] > 0.0);
        assert!(bilinear_weights(&verts, &heads, &tails, &[-1, 1], &BilinearOptions::default()).is_err());
        assert!(bilinear_weights(&verts, &heads, &tails, &[-1], &BilinearOptions::default()).is_err());
    }

    /// Of several connected children, the one nearest the vertex takes the share across the
    /// tail: a T of a bone and two children to its sides, one nearest bone (`nearest` 1), a
    /// vertex at t = 0.8 on the right: 0.7 stays, 0.3 goes to the right child, none to the left.
    #[test]
    fn the_nearest_connected_child_takes_the_share() {
        let heads = [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]];
        let tails = [[0.0, 0.0, 1.0], [-1.0, 0.0, 1.0], [1.0, 0.0, 1.0]];
        let verts = [[0.1, 0.0, 0.8], [-1.0, 0.0, 0.0], [1.0, 0.0, 1.0]];
        let opts = BilinearOptions { nearest: 1, ..Default::default() };
        let d = bilinear_weights(&verts, &heads, &tails, &[-1, 0, 0], &opts).unwrap().to_dense(3);
        assert!((d[0] - 0.7).abs() < 1e-4 && d[1] == 0.0 && (d[2] - 0.3).abs() < 1e-4, "{:?}", &d[..3]);
    }

    /// Only a connected parent or child (its end at the bone's end) takes a share: a child that
    /// starts 0.5 past the parent's tail shares nothing either way.
    #[test]
    fn an_unconnected_parent_or_child_takes_no_share() {
        let heads = [[0.0, 0.0, 0.0], [0.0, 0.0, 1.5]];
        let tails = [[0.0, 0.0, 1.0], [0.0, 0.0, 2.5]];
        let verts = [[0.2, 0.0, 0.9], [0.2, 0.0, 1.6], [0.2, 0.0, 0.5], [0.2, 0.0, 2.5]];
        let opts = BilinearOptions { nearest: 1, ..Default::default() };
        let d = bilinear_weights(&verts, &heads, &tails, &[-1, 0], &opts).unwrap().to_dense(2);
        assert_eq!(&d[..4], &[1.0, 0.0, 0.0, 1.0], "{d:?}");
        // Connected (the child moved onto the tail): the same vertices share.
        let heads = [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
        let tails = [[0.0, 0.0, 1.0], [0.0, 0.0, 2.0]];
        let verts = [[0.2, 0.0, 0.9], [0.2, 0.0, 1.1], [0.2, 0.0, 0.5], [0.2, 0.0, 2.0]];
        let d = bilinear_weights(&verts, &heads, &tails, &[-1, 0], &opts).unwrap().to_dense(2);
        assert!((d[0] - 0.6).abs() < 1e-4 && (d[3] - 0.6).abs() < 1e-4, "{d:?}");
    }

    /// A vertex as far from the bone after the nearest ones as from them (four bones around it,
    /// three taken) is still weighted: the cut-off at the next bone's share would leave nothing.
    #[test]
    fn a_tie_with_the_next_bone_still_weights_the_vertex() {
        let heads = [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0]];
        let tails = heads.map(|h| [h[0], h[1], 1.0]);
        let inf = bilinear_weights(&[[0.0, 0.0, 0.5]], &heads, &tails, &[-1; 4], &BilinearOptions::default()).unwrap();
        let (idx, w) = inf.row(0);
        assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-5, "{idx:?} {w:?}");
        assert_eq!(w.iter().filter(|&&x| x > 0.0).count(), 3, "{idx:?} {w:?}");
    }

    /// Inverse-power falloff: the weights go as `(d_min / d)^power` (two bones in reach, no
    /// neighbour share at a bone's middle).
    #[test]
    fn inverse_power_weights_go_as_the_distance_ratio_to_the_power() {
        let heads = [[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]];
        let tails = [[0.0, 0.0, 1.0], [3.0, 0.0, 1.0]];
        for power in [1.0f32, 3.0] {
            let opts = BilinearOptions { nearest: 2, falloff: Falloff::InversePower { power }, ..Default::default() };
            let d = bilinear_weights(&[[1.0, 0.0, 0.5]], &heads, &tails, &[-1, -1], &opts).unwrap().to_dense(2);
            let r = 2f32.powf(power);
            assert!((d[0] - r / (r + 1.0)).abs() < 1e-3 && (d[1] - 1.0 / (r + 1.0)).abs() < 1e-3, "{power}: {d:?}");
        }
    }

    /// The Gaussian's sigma is in input units (the weights of a scene scaled by 1000 with its
    /// sigma are the same), and without one it is half the median bone length.
    #[test]
    fn sigma_is_in_input_units_and_defaults_to_half_the_median_bone() {
        // Bones 0.2, 1.0 and 3.0 long along z: median 1.0.
        let heads = [[0.0, 0.0, 0.0], [0.0, 0.0, 0.2], [0.0, 0.0, 1.2]];
        let tails = [[0.0, 0.0, 0.2], [0.0, 0.0, 1.2], [0.0, 0.0, 4.2]];
        let verts: Vec<[f32; 3]> = (0..60).map(|i| [0.3, 0.1 * (i % 3) as f32, -0.5 + 0.09 * i as f32]).collect();
        let gauss = |sigma| BilinearOptions { falloff: Falloff::Gaussian { sigma }, ..Default::default() };
        let run = |s: f32, o: &BilinearOptions| {
            let sc = |a: &[[f32; 3]]| a.iter().map(|p| p.map(|c| c * s)).collect::<Vec<_>>();
            bilinear_weights(&sc(&verts), &sc(&heads), &sc(&tails), &[-1, 0, 1], o).unwrap().to_dense(3)
        };
        let near = |a: &[f32], b: &[f32]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-4);
        let given = run(1.0, &gauss(Some(0.5)));
        assert!(near(&given, &run(1000.0, &gauss(Some(500.0)))));
        assert!(near(&given, &run(1.0, &gauss(None))));
        // A different sigma gives different weights (the comparisons above can fail).
        assert!(!near(&given, &run(1.0, &gauss(Some(0.1)))));
        assert!(!near(&given, &run(1.0, &gauss(Some(1.5)))));
    }
}
