//! Bone heat weights: Baran & Popovic 2007, "Automatic Rigging and Animation of 3D
//! Characters" (Pinocchio), made robust for real-world meshes.
//!
//! For every bone `j` solve the heat equilibrium on the surface
//! `(-Delta + H) w_j = H p_j`, discretized with the cotangent Laplacian as
//! `(L + M H) w_j = M H p_j` (`L` cotangent stiffness, `M` lumped mass), where
//! `H_ii = c / d_i^2` with `d_i` the distance from vertex `i` to its nearest *visible* bone,
//! and `p_j,i = 1` if bone `j` is that bone (shared equally between near-ties), else 0.
//! The matrix is factored once (sparse Cholesky with AMD ordering, faer) and all bones are
//! solved against the same factor.
//!
//! Robustness on top of the paper: coordinates are normalized (scale-free), coincident
//! vertices are welded (split seams), degenerate faces dropped, pieces that see no bone use
//! the nearest bone by distance, small such pieces become rigid accessories, isolated
//! vertices take their nearest bone, and the factorization retries with more regularization
//! and finally falls back to nearest-bone weights instead of failing.

use crate::cotan::{cotan_laplacian, stiffness_lower_csc, triangle_cotangents};
use crate::idw::bones_in_frame;
use crate::influence::{top_k_row, Influences};
use crate::islands::connected_components;
use crate::mesh::{validate_bones, validate_mesh, Frame};
use crate::segment::closest_point_on_segment;
use crate::symmetry::{mirror_map, symmetrize_columns, validate_bone_mirror};
use crate::visibility::RayMesh;
use crate::weld::weld;
use crate::{Error, Result};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{factorize_symbolic_cholesky, LltRef, SymbolicCholesky, SymmetricOrdering};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::time::Instant;

/// Left/right symmetry of the character, used to average the weights of mirrored vertices.
#[derive(Debug, Clone, PartialEq)]
pub struct Symmetry {
    /// Mirror axis: 0 = X, 1 = Y, 2 = Z. The mirror plane is the input coordinate 0 on it.
    pub axis: usize,
    /// `(b,)` mirror bone of each bone (itself for centre bones); must be an involution.
    pub bone_mirror: Vec<i32>,
    /// Matching tolerance for mirrored vertex positions, relative to the bbox diagonal.
    pub tolerance: f32,
}

/// Options of [`heat_weights`].
#[derive(Debug, Clone, PartialEq)]
pub struct HeatOptions {
    /// Bones kept per vertex (>= 1). Default 4.
    pub max_influences: usize,
    /// Pruning threshold relative to the kept total, see
    /// [`top_k_normalized`](crate::influence::top_k_normalized). Default 1e-3.
    pub min_weight: f32,
    /// Ray-cast visibility test (Pinocchio). `false`: the nearest bone is always used. Default true.
    pub visibility: bool,
    /// Weld distance, relative to the bbox diagonal (>= 0). Default 1e-5.
    pub weld_tolerance: f32,
    /// Heat constant `c` in `H = c / d^2` (> 0). Default 1 (Pinocchio).
    pub heat_constant: f32,
    /// Optional symmetric averaging. Default `None`.
    pub symmetry: Option<Symmetry>,
}

impl Default for HeatOptions {
    fn default() -> Self {
        HeatOptions {
            max_influences: 4,
            min_weight: 1e-3,
            visibility: true,
            weld_tolerance: 1e-5,
            heat_constant: 1.0,
            symmetry: None,
        }
    }
}

/// What [`heat_weights`] did, for the operator's report.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct HeatReport {
    /// Connected pieces of the welded mesh that have at least one usable triangle.
    pub pieces: usize,
    /// Pieces where no vertex could see a bone (nearest bone by distance used instead).
    pub fallback_pieces: usize,
    /// Fallback pieces small enough to be bound rigidly to their nearest bone
    /// (bbox diagonal <= that bone's length).
    pub rigid_pieces: usize,
    /// Input vertices merged into another one by welding (`n - welded count`).
    pub welded_vertices: usize,
    /// Vertices in no usable triangle (bound 100% to their nearest bone).
    pub isolated_vertices: usize,
    /// The first Cholesky attempt failed and a larger regularization was needed.
    pub regularized: bool,
    /// Every Cholesky attempt failed: nearest-bone weights were returned instead.
    pub factorization_failed: bool,
    /// Wall-clock seconds per stage, in order: "prepare" (normalize, weld, faces, pieces,
    /// cotangents), "stiffness" (sparse pattern), "visibility+symbolic" (wall time of the
    /// two overlapped tasks, followed by their own durations "bvh", "rays", "symbolic"),
    /// "assemble", "factor", "solve", "finish" (clip, rigid, symmetry, top-k), "total".
    pub timings: Vec<(&'static str, f64)>,
}

/// Relative distance within which two visible bones tie (Pinocchio uses 1.0001).
pub const TIE_RATIO: f64 = 1.0001;
/// Minimum vertex-to-bone distance used in `H = c / d^2`, in bbox diagonals.
pub const MIN_DISTANCE: f64 = 1e-5;
/// Diagonal regularizations tried in turn: `A_ii += r (L_ii + M_ii)`.
const REGULARIZATION: [f64; 3] = [1e-10, 1e-6, 1e-3];
/// Up to this many tied bones share a vertex's heat source.
const MAX_TIES: usize = 4;
/// A vertex whose this many nearest bones are all hidden is treated as seeing none (bounds
/// the ray casts for bone-less pieces; Pinocchio tests every bone).
pub const MAX_VISIBILITY_TESTS: usize = 12;

/// Per welded vertex: its heat source.
#[derive(Clone, Copy, Debug)]
struct Source {
    /// Nearest visible bones (ties), `u32::MAX` padded.
    bones: [u32; MAX_TIES],
    /// Number of valid entries of `bones`; 0 = sees no bone.
    count: u8,
    /// Distance to the nearest visible bone(s).
    dist: f64,
    /// Nearest bone by distance, ignoring visibility, and its distance.
    nearest: u32,
    nearest_dist: f64,
}

/// Bone heat skinning weights (Baran & Popovic 2007).
///
/// Inputs: `vertices` `(n, 3)` and `triangles` `(m, 3)` of the mesh, bone `heads` / `tails`
/// `(b, 3)` in the same (any) unit, `opts`, and an optional `progress(fraction in [0, 1])`
/// callback called a handful of times from the calling thread; returning `false` cancels.
/// Output: `(influences, report)`: [`Influences`] with `n` rows, every row non-empty and
/// summing to 1, and a [`HeatReport`].
///
/// Steps: validate; normalize to the unit bbox frame; weld within `weld_tolerance`; drop
/// degenerate faces; pieces; cotangent `L` and lumped `M` (f64); per vertex the nearest
/// visible bone among its [`MAX_VISIBILITY_TESTS`] nearest (the segment from the bone's
/// closest point to the vertex, stopped just short of the vertex, crosses no triangle;
/// ties within [`TIE_RATIO`] share); fallback pieces and isolated vertices use the nearest
/// bone; factor `L + M H` once and solve all bones; clip to `[0, 1]`; rigid pieces;
/// symmetry; top-k per vertex; copy back to every input vertex.
///
/// Errors: empty mesh, non-finite coordinates ([`Error::NonFinite`] with the count), bad
/// triangle index, no bones, invalid options, [`Error::Cancelled`]. Never fails on bad
/// geometry (degenerate/duplicate faces, bones outside the mesh, zero-length bones).
pub fn heat_weights(
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
    heads: &[[f32; 3]],
    tails: &[[f32; 3]],
    opts: &HeatOptions,
    progress: Option<&(dyn Fn(f32) -> bool + Sync)>,
) -> Result<(Influences, HeatReport)> {
    let t0 = Instant::now();
    let mut clock = t0;
    let mut report = HeatReport::default();
    let mut lap = |report: &mut HeatReport, name: &'static str| {
        let now = Instant::now();
        report.timings.push((name, (now - clock).as_secs_f64()));
        clock = now;
    };
    let tick = |f: f32| -> Result<()> {
        match progress {
            Some(p) if !p(f) => Err(Error::Cancelled),
            _ => Ok(()),
        }
    };

    // 1. Validate.
    validate_mesh(vertices, triangles, false)?;
    validate_bones(heads, tails)?;
    if opts.max_influences == 0 {
        return Err(Error::InvalidArgument("max_influences must be >= 1".into()));
    }
    if !(opts.min_weight.is_finite() && (0.0..1.0).contains(&opts.min_weight)) {
        return Err(Error::InvalidArgument(format!("min_weight must be in [0, 1), got {}", opts.min_weight)));
    }
    if !(opts.weld_tolerance.is_finite() && opts.weld_tolerance >= 0.0) {
        return Err(Error::InvalidArgument(format!("weld_tolerance must be >= 0, got {}", opts.weld_tolerance)));
    }
    if !(opts.heat_constant.is_finite() && opts.heat_constant > 0.0) {
        return Err(Error::InvalidArgument(format!("heat_constant must be > 0, got {}", opts.heat_constant)));
    }
    let b = heads.len();
    if let Some(s) = &opts.symmetry {
        validate_bone_mirror(&s.bone_mirror, b)?;
        if s.axis > 2 || !(s.tolerance.is_finite() && s.tolerance >= 0.0) {
            return Err(Error::InvalidArgument("symmetry axis must be 0..=2 and tolerance >= 0".into()));
        }
    }
    if u32::try_from(b).is_err() || u32::try_from(vertices.len()).is_err() {
        return Err(Error::InvalidArgument("too many bones or vertices (limit 2^32 - 1)".into()));
    }
    tick(0.0)?;

    // 2. Normalize, weld, clean faces.
    let frame = Frame::of_points(vertices);
    let pos = frame.normalize(vertices);
    let bones = bones_in_frame(&frame, heads, tails);
    let (map, wpos) = weld(&pos, opts.weld_tolerance as f64);
    drop(pos);
    let nw = wpos.len();
    report.welded_vertices = vertices.len() - nw;
    let tris: Vec<[u32; 3]> = triangles
        .par_iter()
        .with_min_len(2048)
        .filter_map(|t| {
            let w = t.map(|i| map[i as usize]);
            if w[0] == w[1] || w[1] == w[2] || w[0] == w[2] {
                return None;
            }
            triangle_cotangents(wpos[w[0] as usize], wpos[w[1] as usize], wpos[w[2] as usize]).map(|_| w)
        })
        .collect();

    // 3. Pieces.
    let (labels, npieces) = connected_components(nw, &tris);

    // 4. Cotangent stiffness and mass.
    let cot = cotan_laplacian(&wpos, &tris);
    lap(&mut report, "prepare");
    tick(0.05)?;

    // 5. Nearest visible bone per vertex, overlapped with the symbolic Cholesky analysis
    //    (AMD ordering + supernodes), which only needs the sparsity pattern of L.
    let csc = stiffness_lower_csc(nw, &cot.edges);
    let symbolic_mat = SymbolicSparseColMatRef::new_checked(nw, nw, &csc.col_ptr, None, &csc.row_idx);
    lap(&mut report, "stiffness");
    let ((mut symbolic, t_sym), (sources, t_bvh, t_vis)) = rayon::join(
        || {
            let s = Instant::now();
            (symbolic_factor(symbolic_mat), s.elapsed().as_secs_f64())
        },
        || {
            let s = Instant::now();
            let ray_mesh = opts.visibility.then(|| {
                let wpos32: Vec<[f32; 3]> = wpos.par_iter().map(|p| p.as_vec3().to_array()).collect();
                RayMesh::new(&wpos32, &tris)
            });
            let t_bvh = s.elapsed().as_secs_f64();
            let s = Instant::now();
            let mut sources: Vec<Source> = Vec::with_capacity(nw);
            wpos.par_iter()
                .with_min_len(256)
                .map_init(
                    || vec![0.0f64; b],
                    |dist, x| nearest_visible_bone(*x, &bones, ray_mesh.as_ref(), dist),
                )
                .collect_into_vec(&mut sources);
            (sources, t_bvh, s.elapsed().as_secs_f64())
        },
    );
    let mut sources = sources;
    lap(&mut report, "visibility+symbolic");
    report.timings.extend([("bvh", t_bvh), ("rays", t_vis), ("symbolic", t_sym)]);
    tick(0.2)?;

    // 6. Pieces: fallback and rigid accessories; isolated vertices.
    let c = opts.heat_constant as f64;
    let mass = &cot.mass;
    struct Piece {
        active: bool,
        sees: bool,
        lo: DVec3,
        hi: DVec3,
        best: (f64, u32),
    }
    let mut pieces: Vec<Piece> = (0..npieces)
        .map(|_| Piece {
            active: false,
            sees: false,
            lo: DVec3::splat(f64::INFINITY),
            hi: DVec3::splat(f64::NEG_INFINITY),
            best: (f64::INFINITY, 0),
        })
        .collect();
    for v in 0..nw {
        let p = &mut pieces[labels[v] as usize];
        p.active |= mass[v] > 0.0;
        p.sees |= sources[v].count > 0;
        p.lo = p.lo.min(wpos[v]);
        p.hi = p.hi.max(wpos[v]);
        if sources[v].nearest_dist < p.best.0 {
            p.best = (sources[v].nearest_dist, sources[v].nearest);
        }
    }
    let mut rigid_bone = vec![u32::MAX; npieces];
    for (i, p) in pieces.iter().enumerate() {
        if !p.active {
            continue;
        }
        report.pieces += 1;
        if !p.sees {
            report.fallback_pieces += 1;
            let (h, t) = bones[p.best.1 as usize];
            if (p.hi - p.lo).length() <= (t - h).length() {
                report.rigid_pieces += 1;
                rigid_bone[i] = p.best.1;
            }
        }
    }
    // Fallback sources: nearest bone by distance for vertices of pieces that see nothing.
    sources.par_iter_mut().zip(labels.par_iter()).with_min_len(1024).for_each(|(s, &l)| {
        if !pieces[l as usize].sees {
            s.bones = [s.nearest, u32::MAX, u32::MAX, u32::MAX];
            s.count = 1;
            s.dist = s.nearest_dist;
        }
    });
    report.isolated_vertices = (0..vertices.len()).filter(|&v| mass[map[v] as usize] <= 0.0).count();

    // 7. Assemble A = L + M H (+ regularization), RHS = M H P (column-major, nw x b).
    let heat: Vec<f64> = sources
        .par_iter()
        .zip(mass.par_iter())
        .with_min_len(4096)
        .map(|(s, &m)| if m > 0.0 && s.count > 0 { m * c / s.dist.max(MIN_DISTANCE).powi(2) } else { 0.0 })
        .collect();
    drop(cot.edges);
    let mut x = vec![0.0f64; nw * b];
    for v in 0..nw {
        let s = &sources[v];
        if heat[v] > 0.0 {
            let share = heat[v] / s.count as f64;
            for &j in &s.bones[..s.count as usize] {
                x[j as usize * nw + v] += share;
            }
        }
    }
    let values_for = |r: f64| -> Vec<f64> {
        let mut vals = csc.values.clone();
        for v in 0..nw {
            let d = csc.diag_pos[v];
            vals[d] = if mass[v] > 0.0 { vals[d] * (1.0 + r) + heat[v] + r * mass[v] } else { 1.0 };
        }
        vals
    };
    lap(&mut report, "assemble");
    tick(0.3)?;

    // 8. Factor once, solve all bones.
    let mut llt: Option<Factor> = None;
    for (attempt, &r) in REGULARIZATION.iter().enumerate() {
        let Some(s) = symbolic.take() else { break };
        let vals = values_for(r);
        match numeric_factor(s, SparseColMatRef::new(symbolic_mat, &vals)) {
            Ok(f) => {
                report.regularized = attempt > 0;
                llt = Some(f);
                break;
            }
            Err(s) => symbolic = Some(s),
        }
    }
    drop(symbolic);
    lap(&mut report, "factor");
    tick(0.6)?;
    match &llt {
        Some(llt) => {
            let threads = rayon::current_num_threads().max(1);
            // Two rounds (one progress report in between); each round gives every worker one
            // block of columns, so L is streamed as few times as possible.
            let chunk = threads * b.div_ceil(2 * threads).max(1);
            let mut done = 0usize;
            for cols in x.chunks_mut(chunk * nw) {
                llt.solve_columns(cols, nw);
                done += cols.len() / nw;
                tick(0.6 + 0.3 * done as f32 / b as f32)?;
            }
            // Clip; non-finite (should not happen) counts as 0.
            x.par_iter_mut().with_min_len(8192).for_each(|w| {
                *w = if w.is_finite() { w.clamp(0.0, 1.0) } else { 0.0 };
            });
        }
        None => {
            report.factorization_failed = true;
            x.par_iter_mut().for_each(|w| *w = 0.0);
            for v in 0..nw {
                let s = &sources[v];
                for &j in &s.bones[..s.count as usize] {
                    x[j as usize * nw + v] = 1.0 / s.count as f64;
                }
            }
        }
    }
    drop(llt);
    lap(&mut report, "solve");

    // 9. Rigid pieces and isolated vertices: 100% to one bone.
    for v in 0..nw {
        let bone = if mass[v] <= 0.0 {
            sources[v].nearest
        } else {
            rigid_bone[labels[v] as usize]
        };
        if bone != u32::MAX {
            for j in 0..b {
                x[j * nw + v] = 0.0;
            }
            x[bone as usize * nw + v] = 1.0;
        }
    }

    // 10. Symmetry (mirror plane: input coordinate 0 on the axis).
    if let Some(s) = &opts.symmetry {
        let plane = -frame.centre[s.axis] / frame.diagonal;
        let vm = mirror_map(&wpos, s.axis, plane, s.tolerance as f64)?;
        symmetrize_columns(&mut x, nw, &vm, &s.bone_mirror);
    }

    // 11. Top-k per welded vertex, then copy to every input vertex.
    let mut welded = Influences::empty(nw, opts.max_influences);
    let k = welded.k;
    welded
        .indices
        .par_chunks_mut(k)
        .zip(welded.weights.par_chunks_mut(k))
        .enumerate()
        .with_min_len(1024)
        .for_each(|(v, (idx, w))| {
            let used = top_k_row(|j| x[j * nw + v] as f32, b, opts.min_weight, idx, w);
            if used == 0 {
                idx[0] = sources[v].nearest as i32;
                w[0] = 1.0;
            }
        });
    drop(x);
    let mut out = Influences::empty(vertices.len(), k);
    out.indices
        .par_chunks_mut(k)
        .zip(out.weights.par_chunks_mut(k))
        .zip(map.par_iter())
        .with_min_len(1024)
        .for_each(|((idx, w), &m)| {
            let (si, sw) = welded.row(m as usize);
            idx.copy_from_slice(si);
            w.copy_from_slice(sw);
        });
    lap(&mut report, "finish");
    report.timings.push(("total", t0.elapsed().as_secs_f64()));
    tick(1.0)?;
    Ok((out, report))
}

/// A numeric Cholesky factor `A = L L^T` (faer, supernodal or simplicial, AMD ordering).
struct Factor {
    symbolic: SymbolicCholesky<usize>,
    values: Vec<f64>,
}

impl Factor {
    /// Solve `A X = B` in place for the column-major `(n, k)` block `cols`, columns split
    /// across the rayon pool (each worker solves sequentially: many cheap supernodes make
    /// fine-grained parallelism inside one solve a loss).
    fn solve_columns(&self, cols: &mut [f64], n: usize) {
        let k = cols.len() / n.max(1);
        if k == 0 {
            return;
        }
        let threads = rayon::current_num_threads().max(1);
        let per = k.div_ceil(threads).max(1);
        cols.par_chunks_mut(per * n).for_each(|chunk| {
            let kc = chunk.len() / n;
            let llt = LltRef::<usize, f64>::new(&self.symbolic, &self.values);
            let req = self.symbolic.solve_in_place_scratch::<f64>(kc, Par::Seq);
            let Ok(mut buf) = MemBuffer::try_new(req) else {
                // Out of memory for scratch: NaN is clipped to 0 and those vertices fall back
                // to their nearest bone (never a crash).
                chunk.fill(f64::NAN);
                return;
            };
            llt.solve_in_place_with_conj(
                Conj::No,
                MatMut::from_column_major_slice_mut(chunk, n, kc),
                Par::Seq,
                MemStack::new(&mut buf),
            );
        });
    }
}

/// Symbolic analysis (AMD ordering, elimination tree, supernodes) of the lower pattern.
fn symbolic_factor(a: SymbolicSparseColMatRef<'_, usize>) -> Option<SymbolicCholesky<usize>> {
    factorize_symbolic_cholesky(a, Side::Lower, SymmetricOrdering::Amd, Default::default()).ok()
}

/// Numeric factorization; `None` on a non-positive pivot or allocation failure.
fn numeric_factor(symbolic: SymbolicCholesky<usize>, a: SparseColMatRef<'_, usize, f64>) -> std::result::Result<Factor, SymbolicCholesky<usize>> {
    let par = Par::rayon(0);
    let mut values = Vec::new();
    if values.try_reserve_exact(symbolic.len_val()).is_err() {
        return Err(symbolic);
    }
    values.resize(symbolic.len_val(), 0.0);
    let req = symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default());
    let Ok(mut buf) = MemBuffer::try_new(req) else { return Err(symbolic) };
    let ok = symbolic
        .factorize_numeric_llt::<f64>(
            &mut values,
            a,
            Side::Lower,
            LltRegularization { dynamic_regularization_delta: 0.0, dynamic_regularization_epsilon: 0.0 },
            par,
            MemStack::new(&mut buf),
            Default::default(),
        )
        .is_ok();
    if ok {
        Ok(Factor { symbolic, values })
    } else {
        Err(symbolic)
    }
}

/// Nearest visible bone(s) of the point `x` (unit frame). `dist` is `(b,)` scratch.
fn nearest_visible_bone(x: DVec3, bones: &[(DVec3, DVec3)], rays: Option<&RayMesh>, dist: &mut [f64]) -> Source {
    let b = bones.len();
    for (j, (h, t)) in bones.iter().enumerate() {
        dist[j] = closest_point_on_segment(x, *h, *t).1;
    }
    let mut src = Source { bones: [u32::MAX; MAX_TIES], count: 0, dist: 0.0, nearest: 0, nearest_dist: f64::INFINITY };
    // Walk the bones in increasing (distance, index) order without sorting.
    let mut prev = (f64::NEG_INFINITY, usize::MAX);
    let mut first: Option<f64> = None;
    for step in 0..b {
        let mut cur = (f64::INFINITY, usize::MAX);
        for (j, &d) in dist.iter().enumerate() {
            let after_prev = d > prev.0 || (d == prev.0 && (prev.1 == usize::MAX || j > prev.1));
            if after_prev && (d < cur.0 || (d == cur.0 && j < cur.1)) {
                cur = (d, j);
            }
        }
        if cur.1 == usize::MAX {
            break;
        }
        if step == 0 {
            src.nearest = cur.1 as u32;
            src.nearest_dist = cur.0;
        }
        if let Some(d0) = first {
            if cur.0 > d0 * TIE_RATIO + 1e-12 || src.count as usize == MAX_TIES {
                break;
            }
        }
        if first.is_none() && step >= MAX_VISIBILITY_TESTS {
            break;
        }
        if is_visible(x, bones[cur.1], cur.0, rays) {
            if first.is_none() {
                first = Some(cur.0);
                src.dist = cur.0;
            }
            src.bones[src.count as usize] = cur.1 as u32;
            src.count += 1;
        }
        prev = cur;
    }
    src
}

/// Is the straight segment from the bone's closest point to `x` free of the surface?
/// The segment starts at the bone and stops at `(1 - 1e-4) d - 1e-6` so the faces around
/// the vertex itself do not count.
fn is_visible(x: DVec3, bone: (DVec3, DVec3), d: f64, rays: Option<&RayMesh>) -> bool {
    let Some(rays) = rays else { return true };
    let stop = (1.0 - 1e-4) - 1e-6 / d.max(1e-300);
    if !(stop > 0.0) {
        return true;
    }
    let (t, _) = closest_point_on_segment(x, bone.0, bone.1);
    let from = bone.0 + (bone.1 - bone.0) * t;
    let to = from + (x - from) * stop;
    !rays.segment_blocked(Vec3::from(from.as_vec3()), Vec3::from(to.as_vec3()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::primitives::{bone_chain, capped_cylinder};

    #[test]
    fn cylinder_chain_basic() {
        let (v, t) = capped_cylinder(0.2, 2.0, 21, 16);
        let (h, tl, _) = bone_chain(2.0, 4);
        let (inf, rep) = heat_weights(&v, &t, &h, &tl, &HeatOptions::default(), None).unwrap();
        assert_eq!(inf.n(), v.len());
        assert_eq!(rep.pieces, 1);
        assert_eq!(rep.fallback_pieces, 0);
        assert!(!rep.factorization_failed);
        for i in 0..inf.n() {
            let (idx, w) = inf.row(i);
            assert!(idx[0] >= 0);
            assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-5);
        }
    }
}

#[cfg(test)]
mod visibility_tests {
    use super::*;

    /// A bone outside the mesh that is nearer than the inner bone but hidden behind a wall
    /// must not be chosen; with visibility off it is.
    #[test]
    fn hidden_bone_is_skipped() {
        let v: Vec<[f32; 3]> = (0..8)
            .map(|i| [(i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32])
            .collect();
        let q = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]];
        let t: Vec<[u32; 3]> = q.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
        let rm = RayMesh::new(&v, &t);
        let bones = [
            (DVec3::new(1.2, 0.5, 0.2), DVec3::new(1.2, 0.5, 0.8)), // outside, nearer
            (DVec3::new(0.5, 0.5, 0.2), DVec3::new(0.5, 0.5, 0.8)), // inside
        ];
        let mut scratch = vec![0.0; 2];
        let p = DVec3::new(0.9, 0.5, 0.5);
        let s = nearest_visible_bone(p, &bones, Some(&rm), &mut scratch);
        assert_eq!((s.count, s.bones[0], s.nearest), (1, 1, 0));
        assert!((s.dist - 0.4).abs() < 1e-9);
        let s = nearest_visible_bone(p, &bones, None, &mut scratch);
        assert_eq!((s.count, s.bones[0]), (1, 0));
        // Equidistant bones tie.
        let tie = [bones[1], (DVec3::new(0.5, 0.5, 0.8), DVec3::new(0.5, 0.5, 0.2))];
        let s = nearest_visible_bone(p, &tie, Some(&rm), &mut scratch);
        assert_eq!((s.count, s.bones[0], s.bones[1]), (2, 0, 1));
    }
}
