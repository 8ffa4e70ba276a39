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
//! vertices are welded (split seams), degenerate faces dropped, flipped faces turned for the
//! normals (consistent winding per piece), a vertex hidden from every bone by another
//! piece (a coat over the body) looks through its own piece only, pieces that see no bone use
//! the nearest bone by distance, pieces with no bone inside them (eyes, buttons, a held
//! prop) become rigid accessories, isolated vertices take their nearest bone, and the
//! factorization retries with more regularization and finally falls back to nearest-bone
//! weights instead of failing. Small weights are dropped with Blender's continuous ramp.
//!
//! This module holds the options, the report and the order of the steps; the steps with
//! their own rules are in their own modules: `sources` (each vertex's nearest visible
//! bones), `pieces` (per-piece geometry, the inside test, rigid pieces), `reach`
//! (the spans of imported rigs' bones), `cholesky` (factor and solves), `blocks` (the bones
//! solved in blocks of columns, each vertex's running top k), and [`crate::mesh::orient`] (winding
//! and outward normals).

mod blocks;
mod cholesky;
mod pieces;
pub(crate) mod reach;
mod sources;

use crate::mesh::bones_in_frame;
use crate::mesh::cotan::{cotan_laplacian, stiffness_lower_csc, triangle_cotangents};
use crate::mesh::islands::connected_components;
use crate::mesh::mirror::mirror_map;
pub use crate::mesh::mirror::Symmetry;
use crate::mesh::orient::{orient_faces, vertex_normals};
use crate::mesh::visibility::RayMesh;
use crate::mesh::weld::weld;
use crate::mesh::{count_non_finite, validate_bones, validate_mesh, Frame};
use crate::skeleton::validate_parents;
pub use crate::weights::influence::weight_limit;
use crate::weights::influence::Influences;
use crate::weights::symmetry::{pair_side_bones_by_place, validate_bone_mirror};
use crate::{Error, Result};
pub use blocks::BLOCK_BYTES;
use blocks::{block_weights, bone_blocks, Rows, RunningTopK};
use cholesky::{factor_first, symbolic_factor};
use faer::sparse::SymbolicSparseColMatRef;
use glam::DVec3;
use pieces::{mark_sources, piece_contains_bone, piece_stats, rigid_pieces};
use rayon::prelude::*;
use reach::reach_segments;
use sources::heat_sources;
use std::time::Instant;

/// Options of [`heat_weights`].
#[derive(Debug, Clone, PartialEq)]
pub struct HeatOptions {
    /// Bones kept per vertex (>= 1; the result has min(this, bones) columns). Default 4.
    pub max_influences: usize,
    /// Pruning threshold relative to the kept total, see
    /// [`top_k_normalized`](crate::weights::influence::top_k_normalized). Default 1e-3.
    pub min_weight: f32,
    /// Ray-cast visibility test (Pinocchio). `false`: the nearest bone is always used. Default true.
    pub visibility: bool,
    /// Weld distance, relative to the bbox diagonal (>= 0). Default 1e-5.
    pub weld_tolerance: f32,
    /// Heat constant `c` in `H = HEAT_SCALE c / d^2` (> 0). Default 1 (Pinocchio's and
    /// Blender's `C_WEIGHT`; see [`HEAT_SCALE`]).
    pub heat_constant: f32,
    /// Optional symmetric averaging: the weights of mirrored vertices are averaged across
    /// [`Symmetry::plane`] (input units), [`Symmetry::mirror`] giving each bone's mirror bone
    /// (`(b,)`, itself for centre bones, -1 for a side bone with no partner, left unaveraged;
    /// an involution). A "centre" bone off the plane is paired by place or left unaveraged
    /// ([`pair_side_bones_by_place`]). Default `None`.
    pub symmetry: Option<Symmetry>,
    /// Matching tolerance for mirrored vertex positions, relative to the bbox diagonal (>= 0).
    /// Default 1e-3.
    pub mirror_tolerance: f32,
    /// Small-weight ramp (Blender's bone heat): a solved weight `w < weight_limit_end` becomes
    /// 0, one in `[weight_limit_end, weight_limit_start)` becomes
    /// `weight_limit_start (w - end) / (start - end)` (continuous, from 0 up to `start`), larger
    /// ones are kept; rows are then normalized. `0 <= end <= start < 1`; `start = end = 0`
    /// disables it. Defaults 0.05 and 0.025 (Blender's `WEIGHT_LIMIT_START` / `_END`).
    pub weight_limit_start: f32,
    /// See [`weight_limit_start`](Self::weight_limit_start). Default 0.025.
    pub weight_limit_end: f32,
    /// Bind accessory pieces rigidly: a piece of the welded mesh with no bone inside it (an
    /// eye, a button, a held prop), no larger than half the skeleton, goes 100% to the bone
    /// nearest to its centre; see [`heat_weights`]. Default true.
    pub rigid_accessories: bool,
    /// Rank bones by Blender's normal-weighted distance (see [`heat_weights`]) instead of the
    /// plain distance. Default true.
    pub normal_distance: bool,
    /// `(b,)` parent of each bone (`-1` for roots), for rigs imported from glTF or FBX,
    /// whose tails Blender invents: when given, a bone whose children start away from its
    /// tail is represented by the segments from its head to those children's heads that lie
    /// inside the mesh (see `reach`), plus head -> tail when a child starts there;
    /// a bone with no such segment inside (a root on the ground) keeps head -> tail, and a
    /// bone with no children also continues its parent's line into the mesh.
    /// Default `None`: every bone is head -> tail, as in Blender.
    pub parents: Option<Vec<i32>>,
    /// Bent bones (Blender's B-Bones, whose rest shape is a curve): each such bone is the
    /// polyline head -> its points -> tail in the solve, as Blender's bone heat splits a
    /// B-Bone into its segments. Replaces the bone's other segments. Default `None`.
    pub curves: Option<BoneCurves>,
    /// Most bones solved at once (their weights are held densely, vertices x bones `f64`); 0
    /// picks the block by a memory budget ([`BLOCK_BYTES`]: one block up to 206k vertices
    /// with 300 bones). The weights do not depend on it. Default 0.
    pub block_bones: usize,
}

/// Interior points of bent bones, see [`HeatOptions::curves`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BoneCurves {
    /// The points, in the vertices' coordinates; each bone's in order from head to tail.
    pub points: Vec<[f32; 3]>,
    /// `(p,)` the bone of each point (`< bones`).
    pub bone: Vec<u32>,
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
            mirror_tolerance: 1e-3,
            weight_limit_start: WEIGHT_LIMIT_START,
            weight_limit_end: WEIGHT_LIMIT_END,
            rigid_accessories: true,
            normal_distance: true,
            parents: None,
            curves: None,
            block_bones: 0,
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
    /// Pieces bound rigidly (100%) to one bone (shared only on an exact tie): accessories
    /// (no bone inside, see [`heat_weights`]) and fallback pieces no larger than their
    /// nearest bone.
    pub rigid_pieces: usize,
    /// Pieces with no bone inside them (0 when the test is off).
    pub boneless_pieces: usize,
    /// Input vertices merged into another one by welding (`n - welded count`).
    pub welded_vertices: usize,
    /// Triangles wound against their neighbours (flipped normals), turned for the normals and
    /// volumes only ([`orient_faces`]); the input is not changed.
    pub flipped_faces: usize,
    /// Vertices in no usable triangle (bound 100% to their nearest bone).
    pub isolated_vertices: usize,
    /// With symmetry: input vertices whose (welded) position has a mirror twin, or lies on the
    /// plane; only these are averaged. Far below `n` means the mesh is not symmetric across
    /// the plane (or the plane is not the character's). 0 without symmetry.
    pub mirrored_vertices: usize,
    /// With symmetry: bones given as centre bones that lie off the plane (side bones whose
    /// names carry no side), paired with their mirror image by place, or left unpaired and
    /// not averaged ([`pair_side_bones_by_place`]).
    pub side_bones_paired: usize,
    pub side_bones_unpaired: usize,
    /// The first Cholesky attempt failed and a larger regularization was needed.
    pub regularized: bool,
    /// Every Cholesky attempt failed: nearest-bone weights were returned instead.
    pub factorization_failed: bool,
    /// Wall-clock seconds per stage, in order: "prepare" (validate, normalize, weld, faces),
    /// "visibility|matrix" (wall time of two chains run side by side, followed by their own
    /// durations: "bvh", then "rays" = pieces, normals and every vertex's nearest visible bone;
    /// "laplacian" = cotangents, mass and sparse pattern, then "symbolic" = the Cholesky
    /// analysis), "assemble", "factor", "solve" (the solves and the clip),
    /// "finish" (right-hand sides, rigid pieces, symmetry, top-k, copy back), "total".
    pub timings: Vec<(&'static str, f64)>,
}

/// Factor of the heat term that reproduces Blender's discretization with its `C_WEIGHT = 1`:
/// Blender scales the cotangent Laplacian rows by `0.5 / (2 A_i)` (its vertex area sums twice
/// the mixed Voronoi area `A_i`), i.e. it solves `(L + 4 A H) w = 4 A H p` where we write
/// `(L + M H) w = M H p`. Less diffusion than Pinocchio's `c = 1`, and closer to the artists'
/// weights on the real models of `bench/eval_weights.py`.
pub const HEAT_SCALE: f64 = 4.0;
pub use sources::{MAX_VISIBILITY_TESTS, TIE_RATIO};
/// Default [`HeatOptions::weight_limit_start`] (Blender's `WEIGHT_LIMIT_START`).
pub const WEIGHT_LIMIT_START: f32 = 0.05;
/// Default [`HeatOptions::weight_limit_end`] (Blender's `WEIGHT_LIMIT_END`).
pub const WEIGHT_LIMIT_END: f32 = 0.025;
/// Minimum vertex-to-bone distance used in `H = c / d^2`, in bbox diagonals.
pub const MIN_DISTANCE: f64 = 1e-5;
/// Diagonal regularizations tried in turn: `A_ii += r (L_ii + M_ii)`.
const REGULARIZATION: [f64; 3] = [1e-10, 1e-6, 1e-3];

/// Bone heat skinning weights (Baran & Popovic 2007).
///
/// Inputs: `vertices` `(n, 3)` and `triangles` `(m, 3)` of the mesh, bone `heads` / `tails`
/// `(b, 3)` in the same (any) unit, `opts`, and an optional `progress(fraction in [0, 1])`
/// callback called a handful of times from the calling thread; returning `false` cancels.
/// Output: `(influences, report)`: [`Influences`] with `n` rows, every row non-empty and
/// summing to 1, and a [`HeatReport`].
///
/// Steps: validate; normalize to the unit frame ([`Frame::of_mesh`]: a stray loose vertex
/// sets no tolerance); weld within `weld_tolerance`; drop degenerate faces; pieces;
/// cotangent `L` and lumped `M` (f64); vertex normals from consistently wound faces
/// ([`orient_faces`], outward by the sign of each piece's volume); the segments standing for
/// the bones (head -> tail, or with `opts.parents` the spans of [`HeatOptions::parents`]);
/// per vertex the nearest visible bone (the bone of the nearest visible segment) among its
/// [`MAX_VISIBILITY_TESTS`] nearest (the segment from the bone's closest point to the
/// vertex, stopped just short of the vertex, crosses no triangle; a vertex that sees none
/// of a piece holding a bone looks again through that piece's triangles only, at bones behind
/// its surface;
/// ties within [`TIE_RATIO`] share); fallback pieces and isolated vertices use the nearest
/// bone; factor `L + M H` once and solve all bones (in blocks, [`HeatOptions::block_bones`]);
/// clip to `[0, 1]`; rigid pieces; symmetry; small-weight ramp ([`weight_limit`]), top-k and
/// normalization per vertex; copy back to every input vertex.
///
/// Rigid accessories (`opts.rigid_accessories`): a bone is *inside* a piece when at least 3 of
/// 5 points along it (head, quarters, tail) are, so a fingertip poking into a held prop does
/// not count; a point is inside when rays along a majority of fixed generic directions cross
/// the piece's own triangles an odd number of times: 2 of 3 directions for a closed piece
/// (every edge used an even number of times), 4 of 7 for an open one, for which parity is
/// unreliable: a hole spoils only the rays that leave through it, so a sleeve or a hand open
/// at the wrist still holds its bones, while a shell or a sheet (armour plate, eyelid) holds
/// none. Then, with pieces no larger than half the skeleton's bbox diagonal:
/// - if no piece holds a bone (the mesh is a prop, e.g. a held carrot), all pieces move as
///   one rigid body on the bone nearest to their common centre of mass;
/// - otherwise every piece that holds no bone, except the largest one (by area), is rigid on
///   the bone nearest to its own centre of mass.
///
/// The centre of mass is that of the enclosed volume for closed pieces, else of the area.
/// Exact ties (a piece on the mirror plane between a left and a right bone) share equally.
/// A piece that sees no bone and is no larger than its nearest bone is rigid as well.
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

    // 1. Validate; bones given as centre bones that lie off the plane are side bones.
    validate(vertices, triangles, heads, tails, opts)?;
    let b = heads.len();
    let resolved;
    let opts = match &opts.symmetry {
        Some(s) => {
            let (bone_mirror, paired, alone) = pair_side_bones_by_place(heads, tails, &s.mirror, s.axis, s.plane)?;
            report.side_bones_paired = paired;
            report.side_bones_unpaired = alone;
            let symmetry = Some(Symmetry { mirror: bone_mirror, ..s.clone() });
            resolved = HeatOptions { symmetry, ..opts.clone() };
            &resolved
        }
        None => opts,
    };
    tick(0.0)?;

    // 2. Normalize, weld, clean faces.
    let frame = Frame::of_mesh(vertices, triangles);
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

    lap(&mut report, "prepare");
    tick(0.05)?;

    // 3-5. Two chains side by side. One thread assembles the cotangent stiffness and its
    //      sparse pattern, then runs the symbolic Cholesky analysis of that pattern (AMD
    //      ordering + supernodes, one thread). The other builds the BVH of the triangles, finds
    //      the pieces and the normals, then every vertex's nearest visible bone (all threads
    //      once the first chain is done): the rays need the BVH and the pieces, not the matrix.
    let need_rays = opts.visibility || opts.rigid_accessories || opts.parents.is_some();
    #[allow(clippy::type_complexity)]
    let ((ray_mesh, labels, flipped, mut pieces, segs, owner, inside, mut sources, t_bvh, t_rays), matrix) =
        rayon::join(
            || {
                let s = Instant::now();
                let ray_mesh = need_rays.then(|| {
                    let wpos32: Vec<[f32; 3]> = wpos.iter().map(|p| p.as_vec3().to_array()).collect();
                    RayMesh::new(&wpos32, &tris)
                });
                let t_bvh = s.elapsed().as_secs_f64();
                let s = Instant::now();
                let (labels, npieces) = connected_components(nw, &tris);
                let (oriented, flipped) = orient_faces(nw, &tris);
                let normals = if opts.normal_distance {
                    vertex_normals(&wpos, &oriented, &labels, npieces)
                } else {
                    vec![DVec3::ZERO; nw]
                };
                let pieces = piece_stats(&labels, npieces, &wpos, &oriented);
                drop(oriented);
                // The segments standing for the bones (several per bone on imported rigs), and
                // each segment's bone; sources below are in bones.
                let (segs, owner) = match (&opts.parents, ray_mesh.as_ref()) {
                    (Some(parents), Some(rm)) => reach_segments(rm, &bones, parents, &pieces, &labels, &tris),
                    _ => (bones.clone(), (0..b as u32).collect()),
                };
                let (segs, owner) = match &opts.curves {
                    Some(c) if !c.points.is_empty() => bend(segs, owner, &bones, c, &frame),
                    _ => (segs, owner),
                };
                // Which pieces hold a bone (see the doc): for rigid accessories, and on a mesh in
                // several pieces for the second look through a vertex's own piece (see
                // `sources::heat_sources`).
                let rays = ray_mesh.as_ref().filter(|_| opts.visibility);
                let inside: Vec<bool> = match ray_mesh.as_ref() {
                    Some(rm) if opts.rigid_accessories || (npieces > 1 && rays.is_some()) => (0..npieces)
                        .into_par_iter()
                        .map(|i| {
                            pieces[i].active && piece_contains_bone(rm, i as u32, &pieces[i], &segs, &labels, &tris)
                        })
                        .collect(),
                    _ => vec![false; npieces],
                };
                let tri_piece: Option<Vec<u32>> =
                    (npieces > 1).then(|| tris.iter().map(|t| labels[t[0] as usize]).collect());
                let sources =
                    heat_sources(&wpos, &normals, &labels, &segs, &owner, rays, tri_piece.as_deref(), &inside);
                let t_rays = s.elapsed().as_secs_f64();
                (ray_mesh, labels, flipped, pieces, segs, owner, inside, sources, t_bvh, t_rays)
            },
            || {
                let s = Instant::now();
                let cot = cotan_laplacian(&wpos, &tris);
                let csc = stiffness_lower_csc(nw, &cot.edges);
                let t_lap = s.elapsed().as_secs_f64();
                let s = Instant::now();
                let pattern = SymbolicSparseColMatRef::new_checked(nw, nw, &csc.col_ptr, None, &csc.row_idx);
                let symbolic = symbolic_factor(pattern);
                (cot, csc, symbolic, t_lap, s.elapsed().as_secs_f64())
            },
        );
    let (cot, csc, symbolic, t_lap, t_sym) = matrix;
    lap(&mut report, "visibility|matrix");
    report.timings.extend([("bvh", t_bvh), ("rays", t_rays), ("laplacian", t_lap), ("symbolic", t_sym)]);
    let symbolic_mat = SymbolicSparseColMatRef::new_checked(nw, nw, &csc.col_ptr, None, &csc.row_idx);
    let mass = &cot.mass;
    report.flipped_faces = flipped;
    mark_sources(&mut pieces, &labels, &sources);
    let mut bone_len = vec![0.0f64; b];
    for ((h, t), &o) in segs.iter().zip(&owner) {
        bone_len[o as usize] = bone_len[o as usize].max((*t - *h).length());
    }
    tick(0.2)?;

    // 6. Pieces: fallback and rigid accessories; isolated vertices.
    let accessories = opts.rigid_accessories && ray_mesh.is_some();
    let (rigid, counts) = rigid_pieces(&pieces, &inside, &segs, &owner, &bone_len, accessories);
    report.pieces = counts.pieces;
    report.fallback_pieces = counts.fallback;
    report.rigid_pieces = counts.rigid;
    report.boneless_pieces = counts.boneless;
    // Fallback sources: nearest bone by distance for vertices of pieces that see nothing.
    sources.par_iter_mut().zip(labels.par_iter()).with_min_len(1024).for_each(|(s, &l)| {
        if !pieces[l as usize].sees {
            s.bones = s.nearest.bones;
            s.count = s.nearest.count;
            s.dist = s.nearest_dist;
        }
    });
    report.isolated_vertices = (0..vertices.len()).filter(|&v| mass[map[v] as usize] <= 0.0).count();

    // 7. Assemble A = L + M H (+ regularization); the right-hand sides M H P are made per
    //    block of bones below.
    let c = HEAT_SCALE * opts.heat_constant as f64;
    let heat: Vec<f64> = sources
        .par_iter()
        .zip(mass.par_iter())
        .with_min_len(4096)
        .map(|(s, &m)| if m > 0.0 && s.count > 0 { m * c / s.dist.max(MIN_DISTANCE).powi(2) } else { 0.0 })
        .collect();
    drop(cot.edges);
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

    // 8. Factor once.
    let llt = symbolic.and_then(|s| factor_first(s, symbolic_mat, &REGULARIZATION, values_for));
    report.regularized = matches!(llt, Some((_, attempt)) if attempt > 0);
    report.factorization_failed = llt.is_none();
    lap(&mut report, "factor");
    tick(0.6)?;

    // 9-11. Per block of bones (all of them unless the dense block would pass BLOCK_BYTES):
    //       solve (or, if the factorization failed, the nearest-bone sources), clip, rigid
    //       pieces and isolated vertices, symmetry, and merge into each vertex's top k.
    let vm = match &opts.symmetry {
        Some(s) => Some(mirror_map(
            &wpos,
            s.axis,
            (s.plane - frame.centre[s.axis]) / frame.diagonal,
            opts.mirror_tolerance as f64,
        )?),
        None => None,
    };
    if let Some(vm) = &vm {
        report.mirrored_vertices = map.iter().filter(|&&w| vm[w as usize] >= 0).count();
    }
    let threads = rayon::current_num_threads().max(1);
    let blocks = bone_blocks(b, nw, opts.block_bones, threads, opts.symmetry.as_ref().map(|s| &s.mirror[..]));
    let mut best = RunningTopK::new(nw, opts.max_influences.min(b));
    let (mut t_solve, mut done) = (0.0, 0usize);
    let sym = opts.symmetry.as_ref().zip(vm.as_deref());
    for block in &blocks {
        let rows = Rows { sources: &sources, heat: &heat, mass, labels: &labels, rigid: &rigid };
        let (x, secs) = block_weights(block, &rows, llt.as_ref().map(|f| &f.0), sym);
        t_solve += secs;
        best.merge(&x, block, opts.weight_limit_start, opts.weight_limit_end);
        done += block.len();
        tick(0.6 + 0.3 * done as f32 / b as f32)?;
    }
    drop(llt);
    // "solve" is the solves and the clip alone; the blocks' other work counts in "finish".
    lap(&mut report, "solve");
    let bookkeeping = report.timings.last().map_or(0.0, |t| t.1) - t_solve;
    if let Some(t) = report.timings.last_mut() {
        t.1 = t_solve;
    }

    // 12. Normalize each vertex's top k, then copy to every input vertex.
    let welded = best.finish(opts.min_weight, &sources);
    let out = unweld(&welded, &map);
    lap(&mut report, "finish");
    if let Some(t) = report.timings.last_mut() {
        t.1 += bookkeeping;
    }
    report.timings.push(("total", t0.elapsed().as_secs_f64()));
    tick(1.0)?;
    Ok((out, report))
}

/// A mesh by reference: (vertices, triangles).
pub type MeshRef<'a> = (&'a [[f32; 3]], &'a [[u32; 3]]);

/// [`heat_weights`] of several independent meshes with the same bones and options, one mesh
/// per rayon task, one result per mesh (a bad mesh fails alone). For many small meshes (a
/// figure kit-built of separate objects) one call per mesh spends more in set-up and in
/// crossing into the thread pool than in solving; here both cores stay busy.
pub fn heat_weights_many(
    meshes: &[MeshRef<'_>],
    heads: &[[f32; 3]],
    tails: &[[f32; 3]],
    opts: &HeatOptions,
) -> Vec<Result<(Influences, HeatReport)>> {
    meshes.par_iter().map(|(v, t)| heat_weights(v, t, heads, tails, opts, None)).collect()
}

/// Check the inputs and options of [`heat_weights`].
fn validate(
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
    heads: &[[f32; 3]],
    tails: &[[f32; 3]],
    opts: &HeatOptions,
) -> Result<()> {
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
    let (ls, le) = (opts.weight_limit_start, opts.weight_limit_end);
    if !(ls.is_finite() && le.is_finite() && 0.0 <= le && le <= ls && ls < 1.0) {
        return Err(Error::InvalidArgument(format!(
            "weight limits must satisfy 0 <= end <= start < 1, got start {ls}, end {le}"
        )));
    }
    let b = heads.len();
    if let Some(s) = &opts.symmetry {
        validate_bone_mirror(&s.mirror, b)?;
        if s.axis > 2 || !s.plane.is_finite() {
            return Err(Error::InvalidArgument("symmetry axis must be 0..=2 and its plane finite".into()));
        }
        if !(opts.mirror_tolerance.is_finite() && opts.mirror_tolerance >= 0.0) {
            return Err(Error::InvalidArgument("mirror tolerance must be >= 0".into()));
        }
    }
    if let Some(parents) = &opts.parents {
        validate_parents(parents, b)?;
    }
    if let Some(c) = &opts.curves {
        if c.points.len() != c.bone.len() {
            return Err(Error::Shape(format!("{} curve points but {} curve bones", c.points.len(), c.bone.len())));
        }
        if let Some(&j) = c.bone.iter().find(|&&j| j as usize >= b) {
            return Err(Error::InvalidArgument(format!("curve point of bone {j}, but there are {b} bones")));
        }
        let bad = count_non_finite(&c.points);
        if bad > 0 {
            return Err(Error::NonFinite { what: "curve point", count: bad });
        }
    }
    if u32::try_from(b).is_err() || u32::try_from(vertices.len()).is_err() {
        return Err(Error::InvalidArgument("too many bones or vertices (limit 2^32 - 1)".into()));
    }
    Ok(())
}

/// The rows of `welded` copied to every input vertex (`map[i]`: the welded vertex of input `i`).
fn unweld(welded: &Influences, map: &[u32]) -> Influences {
    let k = welded.k;
    let mut out = Influences::empty(map.len(), k);
    out.indices.par_chunks_mut(k).zip(out.weights.par_chunks_mut(k)).zip(map.par_iter()).with_min_len(1024).for_each(
        |((idx, w), &m)| {
            let (si, sw) = welded.row(m as usize);
            idx.copy_from_slice(si);
            w.copy_from_slice(sw);
        },
    );
    out
}

/// `segs` / `owner` with every bent bone's segments replaced by its polyline head -> points
/// -> tail (points in input coordinates, moved into `frame`).
fn bend(
    segs: Vec<(DVec3, DVec3)>,
    owner: Vec<u32>,
    bones: &[(DVec3, DVec3)],
    curves: &BoneCurves,
    frame: &Frame,
) -> (Vec<(DVec3, DVec3)>, Vec<u32>) {
    let mut bent = vec![false; bones.len()];
    for &j in &curves.bone {
        bent[j as usize] = true;
    }
    let (mut out, mut out_owner): (Vec<_>, Vec<_>) =
        segs.into_iter().zip(owner).filter(|&(_, o)| !bent[o as usize]).unzip();
    for (j, &(head, tail)) in bones.iter().enumerate().filter(|&(j, _)| bent[j]) {
        let mut from = head;
        let inner = curves.points.iter().zip(&curves.bone).filter(|&(_, &o)| o as usize == j);
        for to in inner.map(|(&p, _)| frame.to_unit(p)).chain(std::iter::once(tail)) {
            out.push((from, to));
            out_owner.push(j as u32);
            from = to;
        }
    }
    (out, out_owner)
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

    /// A vertex whose every weight falls below the small-weight ramp keeps its solved weights
    /// (normalized), not its nearest bone alone: with the ramp raised to [0.8, 0.9), the ring
    /// at the joint of a two-bone chain (about 0.5 each) stays shared.
    #[test]
    fn a_row_entirely_below_the_ramp_keeps_its_solved_weights() {
        let (v, t) = capped_cylinder(0.2, 2.0, 21, 16);
        let (h, tl, _) = bone_chain(2.0, 2);
        let opts = HeatOptions { weight_limit_start: 0.9, weight_limit_end: 0.8, ..Default::default() };
        let (inf, _) = heat_weights(&v, &t, &h, &tl, &opts, None).unwrap();
        let mut ring = 0;
        for (i, p) in v.iter().enumerate().filter(|(_, p)| (p[2] - 1.0).abs() < 0.02 && p[0].hypot(p[1]) > 0.1) {
            let (idx, w) = inf.row(i);
            assert!(w[0] < 0.75 && w[1] > 0.25 && idx[1] >= 0, "vertex {i} at {p:?}: {idx:?} {w:?}");
            ring += 1;
        }
        assert_eq!(ring, 16);
        // Away from the joint the ramp leaves one bone, as Blender's does.
        let far = v.iter().position(|p| p[2] < 0.3 && p[0].hypot(p[1]) > 0.1).unwrap();
        assert_eq!(inf.row(far).1[0], 1.0);
    }
}
