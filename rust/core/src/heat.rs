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

use crate::cotan::{cotan_laplacian, stiffness_lower_csc, triangle_cotangents};
use crate::idw::bones_in_frame;
use crate::influence::{top_k_row, Influences};
use crate::islands::connected_components;
use crate::mesh::{count_non_finite, validate_bones, validate_mesh, Frame};
use crate::orient::orient_faces;
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
    /// `(b,)` mirror bone of each bone (itself for centre bones, -1 for a side bone with no
    /// partner, left unaveraged); must be an involution.
    pub bone_mirror: Vec<i32>,
    /// Matching tolerance for mirrored vertex positions, relative to the bbox diagonal.
    pub tolerance: f32,
}

/// Options of [`heat_weights`].
#[derive(Debug, Clone, PartialEq)]
pub struct HeatOptions {
    /// Bones kept per vertex (>= 1; the result has min(this, bones) columns). Default 4.
    pub max_influences: usize,
    /// Pruning threshold relative to the kept total, see
    /// [`top_k_normalized`](crate::influence::top_k_normalized). Default 1e-3.
    pub min_weight: f32,
    /// Ray-cast visibility test (Pinocchio). `false`: the nearest bone is always used. Default true.
    pub visibility: bool,
    /// Weld distance, relative to the bbox diagonal (>= 0). Default 1e-5.
    pub weld_tolerance: f32,
    /// Heat constant `c` in `H = HEAT_SCALE c / d^2` (> 0). Default 1 (Pinocchio's and
    /// Blender's `C_WEIGHT`; see [`HEAT_SCALE`]).
    pub heat_constant: f32,
    /// Optional symmetric averaging. Default `None`.
    pub symmetry: Option<Symmetry>,
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
    /// inside the mesh (see [`crate::reach`]), plus head -> tail when a child starts there;
    /// a bone with no such segment inside (a root on the ground) keeps head -> tail.
    /// Default `None`: every bone is head -> tail, as in Blender.
    pub parents: Option<Vec<i32>>,
    /// Bent bones (Blender's B-Bones, whose rest shape is a curve): each such bone is the
    /// polyline head -> its points -> tail in the solve, as Blender's bone heat splits a
    /// B-Bone into its segments. Replaces the bone's other segments. Default `None`.
    pub curves: Option<BoneCurves>,
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
            weight_limit_start: WEIGHT_LIMIT_START,
            weight_limit_end: WEIGHT_LIMIT_END,
            rigid_accessories: true,
            normal_distance: true,
            parents: None,
            curves: None,
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
    /// The first Cholesky attempt failed and a larger regularization was needed.
    pub regularized: bool,
    /// Every Cholesky attempt failed: nearest-bone weights were returned instead.
    pub factorization_failed: bool,
    /// Wall-clock seconds per stage, in order: "prepare" (validate, normalize, weld, faces),
    /// "bvh|laplacian+symbolic" (wall time of two overlapped tasks, followed by their own
    /// durations: "bvh"; "laplacian" = pieces, cotangents, normals, sparse pattern; "symbolic"),
    /// "rays" (nearest visible bone), "assemble", "factor", "solve", "finish" (clip, rigid,
    /// symmetry, top-k), "total".
    pub timings: Vec<(&'static str, f64)>,
}

/// Factor of the heat term that reproduces Blender's discretization with its `C_WEIGHT = 1`:
/// Blender scales the cotangent Laplacian rows by `0.5 / (2 A_i)` (its vertex area sums twice
/// the mixed Voronoi area `A_i`), i.e. it solves `(L + 4 A H) w = 4 A H p` where we write
/// `(L + M H) w = M H p`. Less diffusion than Pinocchio's `c = 1`; measured closer to the
/// artists' weights on the real models of `bench/eval_weights.py`.
pub const HEAT_SCALE: f64 = 4.0;
/// Relative distance within which two visible bones tie (Pinocchio uses 1.0001).
pub const TIE_RATIO: f64 = 1.0001;
/// Default [`HeatOptions::weight_limit_start`] (Blender's `WEIGHT_LIMIT_START`).
pub const WEIGHT_LIMIT_START: f32 = 0.05;
/// Default [`HeatOptions::weight_limit_end`] (Blender's `WEIGHT_LIMIT_END`).
pub const WEIGHT_LIMIT_END: f32 = 0.025;
/// Fixed generic directions of the ray-parity inside test: the first 3 for closed pieces
/// (majority 2 of 3), all 7 for open ones (majority 4 of 7, see [`heat_weights`]).
const PARITY_DIRS: [[f32; 3]; 7] = [
    [0.48, 0.62, 0.62],
    [-0.70, 0.31, 0.64],
    [0.21, -0.89, 0.40],
    [-0.37, -0.52, -0.77],
    [0.83, 0.12, -0.54],
    [-0.15, 0.95, -0.27],
    [-0.91, -0.33, 0.25],
];
/// Positions along a bone (fractions head -> tail) tested by the inside test; a bone is
/// inside a piece when at least [`BONE_INSIDE_SAMPLES`] of them are.
const BONE_SAMPLES: [f64; 5] = [0.0, 0.25, 0.5, 0.75, 1.0];
/// See [`BONE_SAMPLES`]: a majority, so a fingertip poking into a held prop does not count.
const BONE_INSIDE_SAMPLES: usize = 3;
/// An accessory is at most this fraction of the skeleton's bbox diagonal.
const ACCESSORY_SIZE: f64 = 0.5;
/// Distance (unit frame) under which a child's head counts as starting at a bone's tail or head.
const REACH_TOLERANCE: f64 = 1e-5;
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
    /// Nearest bone(s) by distance, ignoring visibility (ties within [`TIE_RATIO`], lowest
    /// indices first, so a vertex on a symmetric rig's mirror plane shares a left/right pair),
    /// and their distance.
    nearest: Ties,
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
/// bone; factor `L + M H` once and solve all bones; clip to `[0, 1]`; rigid pieces;
/// symmetry; small-weight ramp ([`weight_limit`]), top-k and normalization per vertex; copy
/// back to every input vertex.
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
    let (ls, le) = (opts.weight_limit_start, opts.weight_limit_end);
    if !(ls.is_finite() && le.is_finite() && 0.0 <= le && le <= ls && ls < 1.0) {
        return Err(Error::InvalidArgument(format!(
            "weight limits must satisfy 0 <= end <= start < 1, got start {ls}, end {le}"
        )));
    }
    let b = heads.len();
    if let Some(s) = &opts.symmetry {
        validate_bone_mirror(&s.bone_mirror, b)?;
        if s.axis > 2 || !(s.tolerance.is_finite() && s.tolerance >= 0.0) {
            return Err(Error::InvalidArgument("symmetry axis must be 0..=2 and tolerance >= 0".into()));
        }
    }
    if let Some(parents) = &opts.parents {
        crate::reach::validate_parents(parents, b)?;
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

    // 3-5. The BVH of the triangles (for visibility) is built on one thread while the other
    //      finds the pieces, the cotangent stiffness and mass, the normals, the sparse pattern
    //      and its symbolic Cholesky analysis (AMD ordering + supernodes); then every vertex
    //      looks for its nearest visible bone on all threads.
    let need_rays = opts.visibility || opts.rigid_accessories || opts.parents.is_some();
    let ((ray_mesh, t_bvh), ((labels, npieces), oriented, cot, normals, csc, mut symbolic, t_lap, t_sym)) = rayon::join(
        || {
            let s = Instant::now();
            let ray_mesh = need_rays.then(|| {
                let wpos32: Vec<[f32; 3]> = wpos.iter().map(|p| p.as_vec3().to_array()).collect();
                RayMesh::new(&wpos32, &tris)
            });
            (ray_mesh, s.elapsed().as_secs_f64())
        },
        || {
            let s = Instant::now();
            let pieces = connected_components(nw, &tris);
            let cot = cotan_laplacian(&wpos, &tris);
            let oriented = orient_faces(nw, &tris);
            let normals = if opts.normal_distance {
                vertex_normals(&wpos, &oriented.0, &pieces.0, pieces.1)
            } else {
                vec![DVec3::ZERO; nw]
            };
            let csc = stiffness_lower_csc(nw, &cot.edges);
            let t_lap = s.elapsed().as_secs_f64();
            let s = Instant::now();
            let pattern = SymbolicSparseColMatRef::new_checked(nw, nw, &csc.col_ptr, None, &csc.row_idx);
            let symbolic = symbolic_factor(pattern);
            (pieces, oriented, cot, normals, csc, symbolic, t_lap, s.elapsed().as_secs_f64())
        },
    );
    let symbolic_mat = SymbolicSparseColMatRef::new_checked(nw, nw, &csc.col_ptr, None, &csc.row_idx);
    lap(&mut report, "bvh|laplacian+symbolic");
    report.timings.extend([("bvh", t_bvh), ("laplacian", t_lap), ("symbolic", t_sym)]);
    let mass = &cot.mass;
    report.flipped_faces = oriented.1;
    let mut pieces = piece_stats(&labels, npieces, &wpos, &oriented.0, mass);
    drop(oriented);
    // The segments standing for the bones (several per bone on imported rigs), and each
    // segment's bone; sources below are in bones.
    let (segs, owner) = match (&opts.parents, ray_mesh.as_ref()) {
        (Some(parents), Some(rm)) => reach_segments(rm, &bones, parents, &pieces, &labels, &tris),
        _ => (bones.clone(), (0..b as u32).collect()),
    };
    let (segs, owner) = match &opts.curves {
        Some(c) if !c.points.is_empty() => bend(segs, owner, &bones, c, &frame),
        _ => (segs, owner),
    };
    let mut bone_len = vec![0.0f64; b];
    for ((h, t), &o) in segs.iter().zip(&owner) {
        bone_len[o as usize] = bone_len[o as usize].max((*t - *h).length());
    }
    // Which pieces hold a bone (see the doc): for rigid accessories, and on a mesh in several
    // pieces for the second look through a vertex's own piece (see `Sight`).
    let rays = ray_mesh.as_ref().filter(|_| opts.visibility);
    let inside: Vec<bool> = match ray_mesh.as_ref() {
        Some(rm) if opts.rigid_accessories || (npieces > 1 && rays.is_some()) => (0..npieces)
            .into_par_iter()
            .map(|i| pieces[i].active && piece_contains_bone(rm, i as u32, &pieces[i], &segs, &labels, &tris))
            .collect(),
        _ => vec![false; npieces],
    };
    let tri_piece: Option<Vec<u32>> = (npieces > 1).then(|| tris.iter().map(|t| labels[t[0] as usize]).collect());
    let mut sources: Vec<Source> = Vec::with_capacity(nw);
    wpos.par_iter()
        .with_min_len(256)
        .zip(normals.par_iter())
        .zip(labels.par_iter())
        .map_init(
            || vec![0.0f64; 2 * segs.len()],
            |dist, ((x, n), &piece)| {
                let whole = rays.map(|rays| Sight { rays, tri_piece: None, piece, normal: *n });
                let s = nearest_visible_bone(*x, *n, &segs, whole, dist);
                if s.count > 0 || tri_piece.is_none() || !inside[piece as usize] {
                    return s.owned(&owner);
                }
                let own = rays.map(|rays| Sight { rays, tri_piece: tri_piece.as_deref(), piece, normal: *n });
                nearest_visible_bone(*x, *n, &segs, own, dist).owned(&owner)
            },
        )
        .collect_into_vec(&mut sources);
    mark_sources(&mut pieces, &labels, &sources);
    lap(&mut report, "rays");
    tick(0.2)?;

    // 6. Pieces: fallback and rigid accessories; isolated vertices.
    let c = HEAT_SCALE * opts.heat_constant as f64;
    let mut rigid: Vec<Option<Ties>> = vec![None; npieces];
    // Accessories (see the doc of `heat_weights`).
    if opts.rigid_accessories && ray_mesh.is_some() {
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for (h, t) in &segs {
            lo = lo.min(h.min(*t));
            hi = hi.max(h.max(*t));
        }
        let max_size = ACCESSORY_SIZE * (hi - lo).length();
        let active: Vec<usize> = (0..npieces).filter(|&i| pieces[i].active).collect();
        report.boneless_pieces = active.iter().filter(|&&i| !inside[i]).count();
        let largest = active.iter().copied().max_by(|&a, &b| pieces[a].area.total_cmp(&pieces[b].area));
        let union = active.iter().fold(PieceStats::default(), |u, &i| u.merged(&pieces[i]));
        if !active.is_empty() && active.iter().all(|&i| !inside[i]) && union.size() <= max_size {
            // A prop (the whole mesh holds no bone): one rigid body on one bone.
            let ties = nearest_bones(union.centre(), &segs).owned(&owner);
            for &i in &active {
                rigid[i] = Some(ties);
            }
        } else {
            for &i in &active {
                if !inside[i] && Some(i) != largest && pieces[i].size() <= max_size {
                    rigid[i] = Some(nearest_bones(pieces[i].centre(), &segs).owned(&owner));
                }
            }
        }
    }
    for (i, p) in pieces.iter_mut().enumerate() {
        if !p.active {
            continue;
        }
        report.pieces += 1;
        if !p.sees {
            report.fallback_pieces += 1;
            if rigid[i].is_none() && p.size() <= bone_len[p.best.1 as usize] {
                rigid[i] = Some(Ties::one(p.best.1));
            }
        }
        report.rigid_pieces += rigid[i].is_some() as usize;
    }
    // Fallback sources: nearest bone by distance for vertices of pieces that see nothing.
    sources.par_iter_mut().zip(labels.par_iter()).with_min_len(1024).for_each(|(s, &l)| {
        if !pieces[l as usize].sees {
            s.bones = s.nearest.bones;
            s.count = s.nearest.count;
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
            // One block of columns per worker, all solved at once: faer's supernodal solve
            // is BLAS-3 in the right-hand sides (a triangular solve and a matmul per supernode
            // on the whole block), so wider blocks stream the factor fewer times and run the
            // dense kernels more efficiently (measured at 206k vertices / 40 bones on 2
            // threads: 2 rounds of 10 columns per worker 0.32-0.34 s, 1 round of 20 0.27 s,
            // 40 columns in one call with faer's own parallelism 0.59 s).
            let chunk = b.div_ceil(threads).max(1) * threads;
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

    // 9. Rigid pieces and isolated vertices: 100% to one bone (or shared by exact ties).
    for v in 0..nw {
        let ties = if mass[v] <= 0.0 { Some(sources[v].nearest) } else { rigid[labels[v] as usize] };
        if let Some(t) = ties {
            for j in 0..b {
                x[j * nw + v] = 0.0;
            }
            for &j in &t.bones[..t.count as usize] {
                x[j as usize * nw + v] = 1.0 / t.count as f64;
            }
        }
    }

    // 10. Symmetry (mirror plane: input coordinate 0 on the axis).
    if let Some(s) = &opts.symmetry {
        let plane = -frame.centre[s.axis] / frame.diagonal;
        let vm = mirror_map(&wpos, s.axis, plane, s.tolerance as f64)?;
        symmetrize_columns(&mut x, nw, &vm, &s.bone_mirror);
        report.mirrored_vertices = map.iter().filter(|&&w| vm[w as usize] >= 0).count();
    }

    // 11. Top-k per welded vertex, then copy to every input vertex.
    let mut welded = Influences::empty(nw, opts.max_influences.min(b));
    let k = welded.k;
    welded.indices.par_chunks_mut(k).zip(welded.weights.par_chunks_mut(k)).enumerate().with_min_len(1024).for_each(
        |(v, (idx, w))| {
            let mut used = top_k_row(|j| weight_limit(x[j * nw + v] as f32, ls, le), b, opts.min_weight, idx, w);
            if used == 0 {
                // Every weight fell below the ramp (many equal bones): keep them unramped.
                used = top_k_row(|j| x[j * nw + v] as f32, b, opts.min_weight, idx, w);
            }
            if used == 0 {
                idx[0] = sources[v].nearest.bones[0] as i32;
                w[0] = 1.0;
            }
        },
    );
    drop(x);
    let mut out = Influences::empty(vertices.len(), k);
    out.indices.par_chunks_mut(k).zip(out.weights.par_chunks_mut(k)).zip(map.par_iter()).with_min_len(1024).for_each(
        |((idx, w), &m)| {
            let (si, sw) = welded.row(m as usize);
            idx.copy_from_slice(si);
            w.copy_from_slice(sw);
        },
    );
    lap(&mut report, "finish");
    report.timings.push(("total", t0.elapsed().as_secs_f64()));
    tick(1.0)?;
    Ok((out, report))
}

/// Unit area-weighted vertex normals (zero for vertices in no triangle), oriented outward
/// per piece: a piece whose signed volume is negative has its normals flipped.
fn vertex_normals(wpos: &[DVec3], tris: &[[u32; 3]], labels: &[u32], npieces: usize) -> Vec<DVec3> {
    let mut n = vec![DVec3::ZERO; wpos.len()];
    let mut vol = vec![0.0f64; npieces];
    let mut lo = vec![DVec3::splat(f64::INFINITY); npieces];
    for (v, &l) in labels.iter().enumerate() {
        lo[l as usize] = lo[l as usize].min(wpos[v]);
    }
    for t in tris {
        let [a, b, c] = t.map(|i| wpos[i as usize]);
        let f = (b - a).cross(c - a);
        for &i in t {
            n[i as usize] += f;
        }
        let r = lo[labels[t[0] as usize] as usize];
        vol[labels[t[0] as usize] as usize] += (a - r).dot((b - r).cross(c - r));
    }
    n.par_iter_mut().zip(labels.par_iter()).with_min_len(4096).for_each(|(n, &l)| {
        let s = if vol[l as usize] < 0.0 { -1.0 } else { 1.0 };
        *n = (*n * s).normalize_or_zero();
    });
    n
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

/// Blender's small-weight ramp (`heat_limit_weight`): 0 below `end`, linear from 0 to
/// `start` on `[end, start)`, identity above; non-positive and NaN give 0.
#[inline]
pub fn weight_limit(w: f32, start: f32, end: f32) -> f32 {
    if !(w > 0.0) || w < end {
        0.0
    } else if w < start {
        start * (w - end) / (start - end)
    } else {
        w
    }
}

/// Up to [`MAX_TIES`] bones sharing one role equally.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Ties {
    bones: [u32; MAX_TIES],
    count: u8,
}

impl Ties {
    fn one(j: u32) -> Ties {
        Ties { bones: [j, u32::MAX, u32::MAX, u32::MAX], count: 1 }
    }

    /// Segment indices mapped to their bones (`owner`), duplicates merged.
    fn owned(self, owner: &[u32]) -> Ties {
        let (bones, count) = owned_ties(self.bones, self.count, owner);
        Ties { bones, count }
    }
}

/// The first `count` segment indices of `ties` mapped through `owner`, duplicates merged,
/// order kept; `u32::MAX` padded.
fn owned_ties(ties: [u32; MAX_TIES], count: u8, owner: &[u32]) -> ([u32; MAX_TIES], u8) {
    let mut out = [u32::MAX; MAX_TIES];
    let mut n = 0u8;
    for &j in &ties[..count as usize] {
        let o = owner[j as usize];
        if !out[..n as usize].contains(&o) {
            out[n as usize] = o;
            n += 1;
        }
    }
    (out, n)
}

impl Source {
    /// The same source in bones: segment indices mapped through `owner` (ties of one bone's
    /// segments merged).
    fn owned(self, owner: &[u32]) -> Source {
        let (bones, count) = owned_ties(self.bones, self.count, owner);
        Source { bones, count, nearest: self.nearest.owned(owner), ..self }
    }
}

/// The bone(s) nearest to the point `p` (ties within [`TIE_RATIO`], lowest indices first).
fn nearest_bones(p: DVec3, bones: &[(DVec3, DVec3)]) -> Ties {
    let d: Vec<f64> = bones.iter().map(|(h, t)| closest_point_on_segment(p, *h, *t).1).collect();
    least(&d)
}

/// The indices of the least of the distances `d` (ties within [`TIE_RATIO`], lowest first; 0
/// when there is none).
fn least(d: &[f64]) -> Ties {
    let best = d.iter().copied().fold(f64::INFINITY, f64::min);
    let mut out = Ties { bones: [u32::MAX; MAX_TIES], count: 0 };
    for (j, &dj) in d.iter().enumerate() {
        if dj <= best * TIE_RATIO + 1e-12 && (out.count as usize) < MAX_TIES {
            out.bones[out.count as usize] = j as u32;
            out.count += 1;
        }
    }
    if out.count == 0 {
        out = Ties::one(0);
    }
    out
}

/// Geometry of one connected piece (welded, unit frame).
#[derive(Clone, Debug)]
struct PieceStats {
    /// Has a vertex with positive mass (a usable triangle).
    active: bool,
    /// Some vertex sees a bone.
    sees: bool,
    lo: DVec3,
    hi: DVec3,
    /// Nearest (distance, bone) over the piece's vertices, ignoring visibility.
    best: (f64, u32),
    area: f64,
    /// Sum of triangle area times centroid.
    area_moment: DVec3,
    /// Signed enclosed volume and its first moment (meaningful when closed).
    volume: f64,
    volume_moment: DVec3,
    /// Every edge is used by an even number of the piece's triangles.
    closed: bool,
}

impl Default for PieceStats {
    fn default() -> Self {
        PieceStats {
            active: false,
            sees: false,
            lo: DVec3::splat(f64::INFINITY),
            hi: DVec3::splat(f64::NEG_INFINITY),
            best: (f64::INFINITY, 0),
            area: 0.0,
            area_moment: DVec3::ZERO,
            volume: 0.0,
            volume_moment: DVec3::ZERO,
            closed: true,
        }
    }
}

impl PieceStats {
    /// Bounding-box diagonal.
    fn size(&self) -> f64 {
        if self.hi.x >= self.lo.x {
            (self.hi - self.lo).length()
        } else {
            0.0
        }
    }

    /// Centre of mass: of the enclosed volume for a closed piece with a volume, else of the
    /// surface area, else of the bounding box.
    fn centre(&self) -> DVec3 {
        if self.closed && self.volume.abs() > 1e-9 * self.area.powf(1.5) {
            self.volume_moment / self.volume
        } else if self.area > 0.0 {
            self.area_moment / self.area
        } else {
            0.5 * (self.lo + self.hi)
        }
    }

    /// Two pieces as one body (volume terms of closed pieces do not depend on the reference
    /// point, so they add).
    fn merged(&self, o: &PieceStats) -> PieceStats {
        PieceStats {
            active: self.active || o.active,
            sees: self.sees || o.sees,
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
            best: if o.best.0 < self.best.0 { o.best } else { self.best },
            area: self.area + o.area,
            area_moment: self.area_moment + o.area_moment,
            volume: self.volume + o.volume,
            volume_moment: self.volume_moment + o.volume_moment,
            closed: self.closed && o.closed,
        }
    }
}

/// Per-piece geometry: bbox, area, volume, closedness (an XOR of hashed edges per piece is
/// 0 exactly when, up to hash collisions, every edge occurs an even number of times).
/// Visibility and the nearest bone come later, from [`mark_sources`].
fn piece_stats(labels: &[u32], npieces: usize, wpos: &[DVec3], tris: &[[u32; 3]], mass: &[f64]) -> Vec<PieceStats> {
    let mut pieces = vec![PieceStats::default(); npieces];
    for (v, &l) in labels.iter().enumerate() {
        let p = &mut pieces[l as usize];
        p.active |= mass[v] > 0.0;
        p.lo = p.lo.min(wpos[v]);
        p.hi = p.hi.max(wpos[v]);
    }
    let mut xor = vec![0u64; npieces];
    for t in tris {
        let l = labels[t[0] as usize] as usize;
        let p = &mut pieces[l];
        let r = 0.5 * (p.lo + p.hi);
        let [a, b, c] = t.map(|i| wpos[i as usize]);
        let area = 0.5 * (b - a).cross(c - a).length();
        p.area += area;
        p.area_moment += area * (a + b + c) / 3.0;
        let vol = (a - r).dot((b - r).cross(c - r)) / 6.0;
        p.volume += vol;
        p.volume_moment += vol * (r + a + b + c) / 4.0;
        for k in 0..3 {
            let (i, j) = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
            xor[l] ^= splitmix64(((i as u64) << 32) | j as u64);
        }
    }
    for (p, x) in pieces.iter_mut().zip(xor) {
        p.closed = x == 0;
    }
    pieces
}

/// Per piece: does some vertex see a bone, and which bone is nearest to it.
fn mark_sources(pieces: &mut [PieceStats], labels: &[u32], sources: &[Source]) {
    for (s, &l) in sources.iter().zip(labels) {
        let p = &mut pieces[l as usize];
        p.sees |= s.count > 0;
        if s.nearest_dist < p.best.0 {
            p.best = (s.nearest_dist, s.nearest.bones[0]);
        }
    }
}

/// The segments standing for the bones on an imported rig (see [`HeatOptions::parents`]):
/// per bone, its spans to children ([`crate::reach::child_segments`]) that lie inside a
/// piece of the mesh (as in [`piece_contains_bone`]), plus head -> tail when a child starts
/// at the tail or no span is inside. Returns `(segments, bone of each segment)`.
fn reach_segments(
    rm: &RayMesh,
    bones: &[(DVec3, DVec3)],
    parents: &[i32],
    pieces: &[PieceStats],
    labels: &[u32],
    tris: &[[u32; 3]],
) -> (Vec<(DVec3, DVec3)>, Vec<u32>) {
    let heads: Vec<DVec3> = bones.iter().map(|s| s.0).collect();
    let tails: Vec<DVec3> = bones.iter().map(|s| s.1).collect();
    let (spans, tail_child) = crate::reach::child_segments(&heads, &tails, parents, REACH_TOLERANCE);
    let inside: Vec<bool> = spans
        .par_iter()
        .map(|&(j, c)| {
            let seg = [(heads[j], c)];
            pieces.iter().enumerate().any(|(i, p)| p.active && piece_contains_bone(rm, i as u32, p, &seg, labels, tris))
        })
        .collect();
    let (mut segs, mut owner) = (Vec::new(), Vec::new());
    for j in 0..bones.len() {
        let mine: Vec<DVec3> =
            spans.iter().zip(&inside).filter(|(s, &ins)| s.0 == j && ins).map(|(s, _)| s.1).collect();
        if mine.is_empty() || tail_child[j] {
            segs.push(bones[j]);
            owner.push(j as u32);
        }
        for c in mine {
            segs.push((heads[j], c));
            owner.push(j as u32);
        }
    }
    (segs, owner)
}

#[inline]
fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Does some bone lie inside piece `piece`? A bone is inside when at least
/// [`BONE_INSIDE_SAMPLES`] of its [`BONE_SAMPLES`] are, and a point is inside when the rays
/// from it along a majority of [`PARITY_DIRS`] (3 for a closed piece, 7 for an open one)
/// cross the piece's own triangles an odd number of times.
fn piece_contains_bone(
    rm: &RayMesh,
    piece: u32,
    stats: &PieceStats,
    bones: &[(DVec3, DVec3)],
    labels: &[u32],
    tris: &[[u32; 3]],
) -> bool {
    let ndirs = if stats.closed { 3 } else { 7 };
    let dirs: Vec<Vec3> = PARITY_DIRS[..ndirs].iter().map(|d| Vec3::from_array(*d).normalize()).collect();
    let pad = DVec3::splat(1e-6);
    let (lo, hi) = (stats.lo - pad, stats.hi + pad);
    let own = |k: u32| labels[tris[k as usize][0] as usize] == piece;
    bones.iter().any(|(h, t)| {
        let mut count = 0;
        for (n, &s) in BONE_SAMPLES.iter().enumerate() {
            if count + (BONE_SAMPLES.len() - n) < BONE_INSIDE_SAMPLES {
                break;
            }
            let p = *h + (*t - *h) * s;
            if p.cmpge(lo).all() && p.cmple(hi).all() && rm.odd_parity_count(p.as_vec3(), &dirs, 1e-4, own) > ndirs / 2
            {
                count += 1;
            }
        }
        count >= BONE_INSIDE_SAMPLES
    })
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
// The Err hands the symbolic factorization back for a retry; boxing it would allocate on the
// out-of-memory path (and `Factor`, the Ok side, is as large anyway).
#[allow(clippy::result_large_err)]
fn numeric_factor(
    symbolic: SymbolicCholesky<usize>,
    a: SparseColMatRef<'_, usize, f64>,
) -> std::result::Result<Factor, SymbolicCholesky<usize>> {
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

/// Nearest visible bone(s) of the point `x` (unit frame) with unit normal `normal` (zero:
/// none). `scratch` is `(2 b,)`.
///
/// Bones are ranked by the normal-weighted distance `d / ((cos + 1.001) / 2)` (Blender's bone
/// heat), `cos` the cosine between the normal and the direction from the bone's closest point
/// to `x`: a bone behind the surface keeps its distance, one beside it counts double, one in
/// front of it (outside the body) is all but excluded. The heat source uses that distance too.
/// `nearest` is the nearest bone by plain distance.
fn nearest_visible_bone(
    x: DVec3,
    normal: DVec3,
    bones: &[(DVec3, DVec3)],
    sight: Option<Sight>,
    scratch: &mut [f64],
) -> Source {
    let b = bones.len();
    let (dist, euclid) = scratch.split_at_mut(b);
    let mut src =
        Source { bones: [u32::MAX; MAX_TIES], count: 0, dist: 0.0, nearest: Ties::one(0), nearest_dist: f64::INFINITY };
    for (j, (h, t)) in bones.iter().enumerate() {
        let (s, d) = closest_point_on_segment(x, *h, *t);
        euclid[j] = d;
        dist[j] = d;
        if d > 0.0 && normal != DVec3::ZERO {
            let cos = (x - (*h + (*t - *h) * s)).dot(normal) / d;
            dist[j] = d / (0.5 * (cos + 1.001));
        }
        src.nearest_dist = src.nearest_dist.min(d);
    }
    src.nearest = least(euclid);
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
        if let Some(d0) = first {
            if cur.0 > d0 * TIE_RATIO + 1e-12 || src.count as usize == MAX_TIES {
                break;
            }
        }
        if first.is_none() && step >= MAX_VISIBILITY_TESTS {
            break;
        }
        if is_visible(x, bones[cur.1], euclid[cur.1], sight) {
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
fn is_visible(x: DVec3, bone: (DVec3, DVec3), d: f64, sight: Option<Sight>) -> bool {
    let Some(Sight { rays, tri_piece, piece, normal }) = sight else { return true };
    let stop = (1.0 - 1e-4) - 1e-6 / d.max(1e-300);
    if !(stop > 0.0) {
        return true;
    }
    let (t, _) = closest_point_on_segment(x, bone.0, bone.1);
    let from = bone.0 + (bone.1 - bone.0) * t;
    let to = from + (x - from) * stop;
    match tri_piece {
        // Through its own piece a vertex sees only bones behind its surface, inside the piece.
        Some(tp) => {
            (x - from).dot(normal) >= 0.0
                && !rays.segment_blocked_where(from.as_vec3(), to.as_vec3(), |k| tp[k as usize] == piece)
        }
        None => !rays.segment_blocked(from.as_vec3(), to.as_vec3()),
    }
}

/// What a vertex's visibility test looks through: every triangle of the mesh, or only those
/// of the vertex's own piece (`tri_piece[k]`, the piece of triangle `k`, equal to `piece`).
/// A vertex of a mesh in several pieces that sees no bone through the whole mesh looks again
/// through its own piece: a coat or an armour layer in the same object as the body sees no
/// bone through the body beneath it, bar a few vertices where a bone's end pokes out, and heat
/// from those few spread over the whole layer (a creature's coat bound to its hands, feet and
/// tail tip, as by Blender's Ctrl+P). Vertices that see a bone keep it, so parts pushed into
/// each other still hide bones from each other as before. Only pieces that hold a bone (as
/// for rigid accessories) look again, so a piece beside the body with no bone in it still sees
/// none, and through its own piece a vertex sees only bones behind its surface (against its
/// outward `normal`, unless that is zero).
#[derive(Clone, Copy)]
struct Sight<'a> {
    rays: &'a RayMesh,
    tri_piece: Option<&'a [u32]>,
    piece: u32,
    normal: DVec3,
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
        let v: Vec<[f32; 3]> = (0..8).map(|i| [(i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32]).collect();
        let q = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]];
        let t: Vec<[u32; 3]> = q.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
        let rm = RayMesh::new(&v, &t);
        let bones = [
            (DVec3::new(1.2, 0.5, 0.2), DVec3::new(1.2, 0.5, 0.8)), // outside, nearer
            (DVec3::new(0.5, 0.5, 0.2), DVec3::new(0.5, 0.5, 0.8)), // inside
        ];
        let mut scratch = vec![0.0; 4];
        let p = DVec3::new(0.9, 0.5, 0.5);
        let whole = Some(Sight { rays: &rm, tri_piece: None, piece: 0, normal: DVec3::ZERO });
        let s = nearest_visible_bone(p, DVec3::ZERO, &bones, whole, &mut scratch);
        assert_eq!((s.count, s.bones[0], s.nearest), (1, 1, Ties::one(0)));
        assert!((s.dist - 0.4).abs() < 1e-9);
        let s = nearest_visible_bone(p, DVec3::ZERO, &bones, None, &mut scratch);
        assert_eq!((s.count, s.bones[0]), (1, 0));
        // Equidistant bones tie.
        let tie = [bones[1], (DVec3::new(0.5, 0.5, 0.8), DVec3::new(0.5, 0.5, 0.2))];
        let s = nearest_visible_bone(p, DVec3::ZERO, &tie, whole, &mut scratch);
        assert_eq!((s.count, s.bones[0], s.bones[1]), (2, 0, 1));
    }
}
