//! The stages of [`voxel_weights`](super::voxel_weights), run inside heat's solve
//! (`heat::stages::run` with [`Given::Provided`]): heat prepares the mesh (unit frame, welding,
//! the segments standing for the bones, pieces and normals) and, from what this module
//! provides, smooths and caps the weights.
//!
//! 1. [`solid`]: the faces wound outward per piece, the solid of voxels (`grid`) and every
//!    voxel's nearest bones through it (`geodesic`);
//! 2. [`vertex_distances`]: each vertex's nearest bones, from the voxels around it;
//! 3. [`sources`]: the falloff: which bones share each vertex's heat, and how much.

use super::geodesic::{nearest_bones, Labels};
use super::grid::{outward, voxelize, Grid, EMPTY};
use super::VoxelReport;
use crate::mesh::orient::piece_volumes;
use crate::mesh::segment::closest_point_on_segment;
use crate::mesh::visibility::RayMesh;
use crate::weights::heat::stages::{Prepared, Provided, Visibility};
use crate::weights::heat::MIN_DISTANCE;
use crate::weights::influence::{insert_ranked, normalize_pruned, Influences};
use crate::Result;
use glam::DVec3;
use rayon::prelude::*;
use std::time::Instant;

/// Labels kept per voxel: the falloff needs a vertex's nearest few bones only.
pub(super) const VOXEL_LABELS: usize = 6;
/// Bones that share a vertex's heat at most.
pub(super) const SHARED: usize = 4;
/// A bone shares a vertex's heat when its share is at least this fraction of the largest.
const LEAST_SHARE: f32 = 1e-3;
/// A 26-connected path is at most about 8 % longer than the straight line it follows: a
/// geodesic distance within this fraction (plus [`STRAIGHT_SLACK`]) of the straight-line one
/// is that straight line, and the exact straight distance is used.
const STRAIGHT_RATIO: f32 = 1.1;
/// See [`STRAIGHT_RATIO`]: in voxels (the seed's and the vertex's offsets from the voxel centres).
const STRAIGHT_SLACK: f32 = 2.0;
/// The heat a vertex that sees no bone holds, as a fraction of what its geodesic distance
/// gives (`H = 4 UNSEEN_HEAT / d^2`): between heat's rule (none: its weights diffuse from the
/// vertices around it, which mixes the bones they see) and a full source on the bone nearest
/// through the solid (which overrides an artist's blend there). Measured on the models of
/// `testkit/eval_weights.py` (docs/journal.md).
const UNSEEN_HEAT: f64 = 0.4;

/// The voxels and their nearest bones.
pub(super) struct Solid {
    pub grid: Grid,
    pub labels: Labels,
}

/// Stage 1 (see the module doc); fills the report's grid, counts and timings. `tick()` says
/// stop.
pub(super) fn solid(
    prep: &Prepared,
    vis: &Visibility,
    resolution: usize,
    report: &mut VoxelReport,
    cancelled: &dyn Fn() -> bool,
) -> Result<Solid> {
    let clock = Instant::now();
    let npieces = vis.labels.iter().map(|&l| l as usize + 1).max().unwrap_or(0);
    let tris = outward(&vis.oriented, &vis.labels, &piece_volumes(&prep.wpos, &vis.oriented, &vis.labels, npieces));
    let built;
    let rays = match &vis.ray_mesh {
        Some(r) => r,
        None => {
            let wpos32: Vec<[f32; 3]> = prep.wpos.iter().map(|p| p.as_vec3().to_array()).collect();
            built = RayMesh::new(&wpos32, &prep.tris);
            &built
        }
    };
    let (lo, hi) =
        tris.iter().flatten().fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(l, h), &i| {
            (l.min(prep.wpos[i as usize]), h.max(prep.wpos[i as usize]))
        });
    if tris.is_empty() {
        // No faces, no solid: every vertex takes its straight distances (`vertex_distances`).
        let grid = Grid::new(DVec3::ZERO, DVec3::ONE, 1);
        let labels = Labels::none(grid.len());
        return Ok(Solid { grid, labels });
    }
    let grid = Grid::new(lo, hi, resolution);
    let state = voxelize(&grid, &prep.wpos, &tris, rays);
    report.grid = grid.dims;
    report.solid_voxels = state.iter().filter(|&&s| s != EMPTY).count();
    report.timings.push(("voxelize", clock.elapsed().as_secs_f64()));
    let clock = Instant::now();
    let (labels, outside) = nearest_bones(&grid, &state, &vis.segs, &vis.owner, VOXEL_LABELS, cancelled)?;
    report.outside_bones = outside;
    report.timings.push(("geodesic", clock.elapsed().as_secs_f64()));
    Ok(Solid { grid, labels })
}

/// Each welded vertex's nearest bones through the solid: `k` slots per vertex, ascending by
/// geodesic distance (unit frame), with each bone's straight-line distance to the vertex and
/// the cosine between the vertex normal and the direction from the bone's nearest point.
pub(crate) struct Nearest {
    pub k: usize,
    /// `(nw * k,)` bone, -1 unused.
    pub bone: Vec<i32>,
    pub geodesic: Vec<f32>,
    pub euclid: Vec<f32>,
    pub cos: Vec<f32>,
}

/// Stage 2: each welded vertex's `k` nearest bones ([`Nearest`]). A vertex on the surface
/// takes, per bone, the least of `d + |p - c|` over the eight voxels around it (`c` their
/// centres, `d` their distances); a vertex in no triangle, or with no voxel reached around it,
/// its straight distances to the bones' segments.
pub(super) fn vertex_distances(prep: &Prepared, vis: &Visibility, solid: &Solid, k: usize) -> Nearest {
    let Solid { grid, labels } = solid;
    let (segs, owner) = (&vis.segs, &vis.owner);
    let nw = prep.wpos.len();
    let mut on_faces = vec![false; nw];
    for t in &prep.tris {
        for &i in t {
            on_faces[i as usize] = true;
        }
    }
    let mut out = Nearest {
        k,
        bone: vec![-1; nw * k],
        geodesic: vec![0.0; nw * k],
        euclid: vec![0.0; nw * k],
        cos: vec![0.0; nw * k],
    };
    out.bone
        .par_chunks_mut(k)
        .zip(out.geodesic.par_chunks_mut(k))
        .zip(out.euclid.par_chunks_mut(k).zip(out.cos.par_chunks_mut(k)))
        .enumerate()
        .with_min_len(256)
        .for_each(|(v, ((bone, geo), (euc, cos)))| {
            let p = prep.wpos[v];
            let mut cand: Vec<(u32, f32)> = Vec::with_capacity(8 * labels.k);
            if on_faces[v] {
                let g = grid.local(p).floor();
                for corner in 0..8 {
                    let c = [0, 1, 2].map(|a| (g[a] as isize + ((corner >> a) & 1) as isize).max(0) as usize);
                    if c.iter().zip(grid.dims).any(|(&x, d)| x >= d) {
                        continue;
                    }
                    let vox = grid.index(c);
                    let off = (p - grid.centre(vox)).length() as f32;
                    cand.extend(labels.of(vox).map(|(j, d)| (j, d + off)));
                }
            }
            if cand.is_empty() {
                cand = segs
                    .iter()
                    .zip(owner)
                    .map(|(&(h, t), &j)| (j, closest_point_on_segment(p, h, t).1 as f32))
                    .collect();
            }
            cand.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
            cand.dedup_by_key(|c| c.0);
            cand.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            for (s, &(j, d)) in cand.iter().take(k).enumerate() {
                let (mut best, mut dir) = (f64::INFINITY, DVec3::ZERO);
                for (&(h, t), _) in segs.iter().zip(owner).filter(|(_, &o)| o == j) {
                    let (u, dq) = closest_point_on_segment(p, h, t);
                    if dq < best {
                        best = dq;
                        dir = (p - (h + (t - h) * u)).normalize_or_zero();
                    }
                }
                bone[s] = j as i32;
                geo[s] = d;
                euc[s] = best as f32;
                cos[s] = dir.dot(vis.normals[v]) as f32;
            }
        });
    out
}

/// Stage 3, the falloff: per welded vertex, the bones that share its heat and the distance in
/// its heat term. A geodesic distance `d` that follows the straight line (within
/// [`STRAIGHT_RATIO`] and [`STRAIGHT_SLACK`] voxels of `step`) is replaced by the exact straight
/// one, so the sweep's metric error does not decide between bones at nearly the same distance.
/// Bones are ranked by Blender's normal-weighted distance on it, `r = d / ((cos + 1.001) / 2)`.
/// A vertex that sees a bone (heat's nearest visible bones in `vis`, ties) takes those as its
/// nearest: bones ranked nearer that it does not see are dropped, and the seen ones share the
/// least rank among them; its heat term takes that rank as the distance, as heat's does. A
/// vertex that sees none keeps the geodesic ranking, and its heat term the nearest's `d` with
/// [`UNSEEN_HEAT`] of the heat (the distance over its square root). Bone `j` takes the share
/// `exp(-(r_j - r_min) / (falloff r_min))` of the nearest's (up to [`SHARED`] bones).
pub(super) fn sources(near: &Nearest, vis: &Visibility, falloff: f32, step: f64) -> Provided {
    let slack = STRAIGHT_SLACK * step as f32;
    let (k, nw) = (near.k, near.bone.len() / near.k.max(1));
    let mut rows = Influences::empty(nw, SHARED);
    let mut dist = vec![0.0f64; nw];
    rows.indices
        .par_chunks_mut(SHARED)
        .zip(rows.weights.par_chunks_mut(SHARED))
        .zip(dist.par_iter_mut())
        .enumerate()
        .for_each(|(v, ((idx, w), d))| {
            let r = v * k..(v + 1) * k;
            let ranked: Vec<(i32, f32, f32)> = (near.bone[r.clone()].iter().zip(&near.geodesic[r.clone()]))
                .zip(near.euclid[r.clone()].iter().zip(&near.cos[r]))
                .filter(|((&j, _), _)| j >= 0)
                .map(|((&j, &g), (&e, &c))| {
                    let g = if g <= STRAIGHT_RATIO * e + slack { e } else { g }.max(MIN_DISTANCE as f32);
                    (j, g / ((c + 1.001) / 2.0), g)
                })
                .collect();
            let mut ranked = ranked;
            let src = &vis.sources[v];
            let seen = |j: i32| src.bones[..src.count as usize].contains(&(j as u32));
            let sees = ranked.iter().filter(|c| seen(c.0)).map(|c| c.1).reduce(f32::min);
            if let Some(rv) = sees {
                ranked.retain(|c| c.1 >= rv || seen(c.0));
                ranked.iter_mut().filter(|c| seen(c.0)).for_each(|c| c.1 = rv);
            }
            let Some(&(_, rmin, gmin)) = ranked.iter().min_by(|a, b| a.1.total_cmp(&b.1)) else { return };
            *d = match sees {
                Some(_) => rmin as f64,
                None => gmin as f64 / UNSEEN_HEAT.sqrt(),
            };
            let width = (falloff * rmin).max(f32::MIN_POSITIVE);
            let mut used = 0;
            for &(j, rj, _) in &ranked {
                used = insert_ranked(j, (-(rj - rmin) / width).exp(), idx, w, used);
            }
            normalize_pruned(idx, w, used, LEAST_SHARE);
        });
    Provided { rows, dist }
}
