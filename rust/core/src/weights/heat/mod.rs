//! Bone heat weights: Baran & Popovic 2007, "Automatic Rigging and Animation of 3D
//! Characters" (Pinocchio), made robust for real-world meshes.
//!
//! This module holds the entry points, their options and report; [`heat_weights`] runs the
//! stages of `stages` in order, and the stages with rules of their own have their own modules:
//! `sources` (each vertex's nearest visible bones), `pieces` (per-piece geometry, the inside
//! test, rigid pieces), `reach` (the spans of imported rigs' bones), `cholesky` (factor and
//! solves), `dissection` (the factor's order on large meshes), `sparse_solve` (solves of
//! sparse right-hand sides), `blocks` (the bones solved in blocks of columns, each vertex's running top k), and
//! [`crate::mesh::orient`] (winding and outward normals).

mod blocks;
pub(crate) mod cholesky;
mod dissection;
mod memory;
pub(crate) mod pieces;
pub(crate) mod reach;
mod sources;
mod sparse_solve;
pub(crate) mod stages;

use crate::error::caught;
pub use crate::mesh::mirror::Symmetry;
use crate::mesh::{count_non_finite, validate_bones, validate_mesh};
use crate::skeleton::validate_parents;
pub use crate::weights::influence::weight_limit;
use crate::weights::influence::Influences;
use crate::weights::symmetry::validate_bone_mirror;
use crate::{Error, Result};
pub use memory::heat_peak_bytes;
pub use memory::BLOCK_BYTES;
use rayon::prelude::*;
use stages::{run, sources_found, Given, Inputs};

/// Options of [`heat_weights`].
#[derive(Debug, Clone, PartialEq)]
pub struct HeatOptions {
    /// Bones kept per vertex (>= 1; the result has min(this, bones) columns), cut continuously
    /// ([`cut_continuously`](crate::weights::influence::cut_continuously)). Default 4.
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
    ///
    /// [`pair_side_bones_by_place`]: crate::weights::symmetry::pair_side_bones_by_place
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
    /// nearest to its centre when that bone owns it (most of the piece is nearest that bone);
    /// a piece spanning several bones (a wing membrane) is solved by heat. The rules are in the
    /// doc of the `pieces` module. Default true.
    pub rigid_accessories: bool,
    /// Rank bones by Blender's normal-weighted distance `d / ((cos + 1.001) / 2)`, `cos` between
    /// the vertex's outward normal and the direction from the bone, instead of the plain
    /// distance (see the `sources` module). Default true.
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
    /// with 160 bones). The weights do not depend on it. Default 0.
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
    /// (no bone inside and owned by one bone, see [`HeatOptions::rigid_accessories`]) and
    /// fallback pieces no larger than their nearest bone.
    pub rigid_pieces: usize,
    /// Pieces with no bone inside them (0 when the test is off).
    pub boneless_pieces: usize,
    /// Of those, pieces small enough for accessories but solved by heat, as no one bone owns
    /// them (a wing membrane along an arm chain; see [`HeatOptions::rigid_accessories`]).
    pub spanning_pieces: usize,
    /// Input vertices merged into another one by welding (`n - welded count`).
    pub welded_vertices: usize,
    /// Triangles wound against their neighbours (flipped normals), turned for the normals and
    /// volumes only ([`orient_faces`]); the input is not changed.
    ///
    /// [`orient_faces`]: crate::mesh::orient::orient_faces
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
    ///
    /// [`pair_side_bones_by_place`]: crate::weights::symmetry::pair_side_bones_by_place
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

/// Bone heat skinning weights (Baran & Popovic 2007, "Automatic Rigging and Animation of 3D
/// Characters"), as Blender's "With Automatic Weights".
///
/// Inputs: `vertices` `(n, 3)` and `triangles` `(m, 3)` (indices into `vertices`); bone `heads`
/// and `tails` `(b, 3)`, in the same unit (any); `opts`; `progress(fraction)`, called from the
/// calling thread, `false` cancels.
/// Outputs: [`Influences`] `(n, min(opts.max_influences, b))`, every row non-empty and summing
/// to 1, and a [`HeatReport`].
///
/// Method: on the welded surface, bone `j`'s weights solve `(L + M H) w_j = M H p_j` (`L` the
/// cotangent stiffness, `M` the lumped mass), `p_j,i = 1` when `j` is the nearest bone vertex
/// `i` sees through the mesh (near-ties share), `H_ii = HEAT_SCALE c / d_i^2` with `d_i` that
/// distance; one sparse Cholesky factor serves every bone; then clip, Blender's small-weight
/// ramp, top k cut continuously (a bone leaving the top k fades out rather than dropping its
/// weight at once, see [`cut_continuously`](crate::weights::influence::cut_continuously)),
/// normalize.
///
/// Limits: heat flows along the surface only, so pieces do not blend with each other (small
/// ones with no bone inside are rigid, see [`HeatOptions::rigid_accessories`]); sight is a
/// straight line, so a vertex deep in a fold may take a farther bone, and a piece that sees no
/// bone takes the nearest ones ([`HeatReport::fallback_pieces`]); if the factorization fails,
/// the weights are the sources' ([`HeatReport::factorization_failed`]).
///
/// Errors: empty mesh, non-finite values ([`Error::NonFinite`]), bad indices, no bones, invalid
/// options, [`Error::Cancelled`]; never on bad geometry (degenerate faces, bones outside).
pub fn heat_weights(
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
    heads: &[[f32; 3]],
    tails: &[[f32; 3]],
    opts: &HeatOptions,
    progress: Option<&(dyn Fn(f32) -> bool + Sync)>,
) -> Result<(Influences, HeatReport)> {
    run(&Inputs { vertices, triangles, heads, tails, objects: None }, Given::Found, opts, progress)
}

/// [`heat_weights`] with the heat sources given by the caller: a debug and evaluation entry
/// point, to measure the method apart from its choice of sources.
///
/// `sources` `(n, k)`: per input vertex, the bones that share its heat and their amounts
/// (`-1` / 0 unused), as fractions of the row's sum; the rows of input vertices welded into
/// one add up; an empty row holds no heat. All else is as in [`heat_weights`], the distance in
/// `H_ii` included (the vertex's own: to its nearest visible bone, else its nearest bone).
/// With the sources of [`heat_sources`] the weights are those of [`heat_weights`], bit for bit.
///
/// Errors: those of [`heat_weights`]; [`Error::Shape`] for `sources` of another row count,
/// [`Error::InvalidArgument`] for a bone out of range or an amount negative or not finite.
pub fn heat_weights_with_sources(
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
    heads: &[[f32; 3]],
    tails: &[[f32; 3]],
    sources: &Influences,
    opts: &HeatOptions,
    progress: Option<&(dyn Fn(f32) -> bool + Sync)>,
) -> Result<(Influences, HeatReport)> {
    run(&Inputs { vertices, triangles, heads, tails, objects: None }, Given::Rows(sources), opts, progress)
}

/// The heat sources [`heat_weights`] finds, for [`heat_weights_with_sources`] (debug and
/// evaluation): per input vertex, its nearest visible bone and near-ties (in a piece that sees
/// no bone, its nearest bones by distance), sharing equally, as top-k rows `(n, 4)`; an empty
/// row where the vertex sees no bone but its piece does. Errors: as [`heat_weights`].
pub fn heat_sources(
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
    heads: &[[f32; 3]],
    tails: &[[f32; 3]],
    opts: &HeatOptions,
) -> Result<Influences> {
    sources_found(&Inputs { vertices, triangles, heads, tails, objects: None }, opts)
}

/// A mesh by reference: (vertices, triangles).
pub type MeshRef<'a> = (&'a [[f32; 3]], &'a [[u32; 3]]);

/// [`heat_weights`] of several independent meshes with the same bones and options, one mesh
/// per rayon task. For many small meshes (a figure kit-built of separate objects) one call per
/// mesh spends more in set-up and in crossing into the thread pool than in solving; here both
/// cores stay busy.
///
/// Inputs: `meshes` `[(vertices (n_k, 3), triangles (m_k, 3))]`; the rest as [`heat_weights`].
/// Output: one result per mesh, in order: result `k` is mesh `k`'s. A mesh fails alone: its
/// entry holds its error ([`heat_weights`]' errors), or [`Error::Internal`] with the message
/// of a panic in its solve, and every other mesh still gets its weights.
pub fn heat_weights_many(
    meshes: &[MeshRef<'_>],
    heads: &[[f32; 3]],
    tails: &[[f32; 3]],
    opts: &HeatOptions,
) -> Vec<Result<(Influences, HeatReport)>> {
    each_mesh(meshes, |v, t| heat_weights(v, t, heads, tails, opts, None))
}

/// `solve` of each mesh, one rayon task per mesh, a panic caught as that mesh's
/// [`Error::Internal`] (a panic in one rayon task would otherwise unwind through the whole
/// batch and lose every mesh's result).
fn each_mesh<T: Send>(
    meshes: &[MeshRef<'_>],
    solve: impl Fn(&[[f32; 3]], &[[u32; 3]]) -> Result<T> + Sync,
) -> Vec<Result<T>> {
    meshes.par_iter().map(|&(v, t)| caught(|| solve(v, t))).collect()
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
    validate_rig(
        vertices.len(),
        heads.len(),
        opts.symmetry.as_ref(),
        opts.mirror_tolerance,
        opts.parents.as_deref(),
        opts.curves.as_ref(),
    )
}

/// Check the options that describe the rig, shared by heat and [`crate::weights::voxel`]: the
/// symmetry (bone mirror map, axis, plane, tolerance), the parents and the bent bones' curves
/// of `b` bones; `n` vertices and `b` bones must fit in `u32`.
pub(crate) fn validate_rig(
    n: usize,
    b: usize,
    symmetry: Option<&Symmetry>,
    mirror_tolerance: f32,
    parents: Option<&[i32]>,
    curves: Option<&BoneCurves>,
) -> Result<()> {
    if let Some(s) = symmetry {
        validate_bone_mirror(&s.mirror, b)?;
        if s.axis > 2 || !s.plane.is_finite() {
            return Err(Error::InvalidArgument("symmetry axis must be 0..=2 and its plane finite".into()));
        }
        if !(mirror_tolerance.is_finite() && mirror_tolerance >= 0.0) {
            return Err(Error::InvalidArgument("mirror tolerance must be >= 0".into()));
        }
    }
    if let Some(parents) = parents {
        validate_parents(parents, b)?;
    }
    if let Some(c) = curves {
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
    if u32::try_from(b).is_err() || u32::try_from(n).is_err() {
        return Err(Error::InvalidArgument("too many bones or vertices (limit 2^32 - 1)".into()));
    }
    Ok(())
}

/// Check the caller's heat sources of [`heat_weights_with_sources`]: `n` rows, bone indices
/// in `-1..b`, amounts finite and not negative.
fn validate_sources(sources: &Influences, n: usize, b: usize) -> Result<()> {
    if sources.n() != n || sources.weights.len() != sources.indices.len() {
        return Err(Error::Shape(format!("sources for {} vertices, but the mesh has {n}", sources.n())));
    }
    if let Some(&j) = sources.indices.iter().find(|&&j| j < -1 || j as i64 >= b as i64) {
        return Err(Error::InvalidArgument(format!("source bone {j}, but there are {b} bones")));
    }
    if let Some(&a) = sources.weights.iter().find(|&&a| !(a.is_finite() && a >= 0.0)) {
        return Err(Error::InvalidArgument(format!("source amounts must be finite and >= 0, got {a}")));
    }
    Ok(())
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

    /// A panic while solving one mesh of a batch fails that mesh alone: its entry is
    /// `Error::Internal` with the panic's message, and the others have the weights they get
    /// when solved one by one. Before, the panic unwound out of the rayon batch and every
    /// mesh's result was lost. The panic is forced in the batch's own per-mesh runner, the
    /// one `heat_weights_many` uses, on the third of five real meshes.
    #[test]
    fn a_panic_in_one_mesh_of_a_batch_fails_that_mesh_alone() {
        let (h, tl, _) = bone_chain(2.0, 3);
        let meshes: Vec<_> = (0..5).map(|k| capped_cylinder(0.2, 2.0, 5 + k, 8)).collect();
        let refs: Vec<MeshRef> = meshes.iter().map(|(v, t)| (&v[..], &t[..])).collect();
        let opts = HeatOptions::default();
        let doomed = meshes[2].0.len();
        let out = each_mesh(&refs, |v, t| {
            assert!(v.len() != doomed, "a bug in mesh of {} vertices", v.len());
            heat_weights(v, t, &h, &tl, &opts, None)
        });
        assert_eq!(out.len(), 5);
        assert_eq!(out[2].as_ref().unwrap_err(), &Error::Internal(format!("a bug in mesh of {doomed} vertices")));
        for k in [0, 1, 3, 4] {
            let (inf, _) = out[k].as_ref().unwrap();
            let (one, _) = heat_weights(refs[k].0, refs[k].1, &h, &tl, &opts, None).unwrap();
            assert_eq!((&inf.indices, &inf.weights), (&one.indices, &one.weights), "mesh {k}");
        }
        let all = heat_weights_many(&refs, &h, &tl, &opts);
        assert!(all.iter().all(|r| r.is_ok()));
    }
}
