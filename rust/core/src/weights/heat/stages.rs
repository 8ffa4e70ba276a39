//! The stages of [`heat_weights`](super::heat_weights), each a function that returns what the
//! later ones need:
//!
//! 1. [`resolve`]: check the inputs; bones given as centre bones that lie off the mirror plane
//!    become side bones ([`pair_side_bones_by_place`]).
//! 2. [`prepare`]: the unit frame ([`Frame::of_mesh`]: a stray loose vertex sets no
//!    tolerance), coincident vertices welded within `weld_tolerance`, degenerate faces dropped.
//! 3. Two chains side by side ([`rayon::join`]): the rays need the BVH and the pieces, not the
//!    matrix, and the symbolic analysis needs the matrix's pattern only.
//!    - [`visibility`]: the BVH of the triangles; the pieces; vertex normals from consistently
//!      wound faces ([`orient_faces`], outward by the sign of each piece's volume); the
//!      segments standing for the bones (head -> tail, the spans of
//!      [`HeatOptions::parents`], the polylines of [`HeatOptions::curves`]); which pieces
//!      hold a bone; every vertex's nearest visible bone (`sources`).
//!    - [`matrix`]: the cotangent stiffness `L` and lumped mass `M` (f64), `L`'s sparse
//!      pattern, and its symbolic Cholesky analysis (supernodes; ordered by nested dissection
//!      from [`DISSECTION_MIN`] vertices, else AMD).
//! 4. [`bind_pieces`]: pieces where no vertex sees a bone take the nearest bone by distance;
//!    rigid pieces (see `pieces`).
//! 5. [`assemble`]: the bones that share each vertex's heat (found here, or given), and the
//!    heat `M H` of every vertex.
//! 6. [`factor`]: `L + M H` factored once, retried with more regularization.
//! 7. [`solve`]: every bone solved against the one factor, in blocks of columns
//!    ([`HeatOptions::block_bones`]), clipped to `[0, 1]`; rigid pieces and isolated vertices
//!    at 100%; symmetry; each vertex's running top k after the small-weight ramp.
//! 8. [`finish`]: each vertex's top k normalized and pruned, copied back to every input vertex.

use super::blocks::{block_weights, bone_blocks, Rows, RunningTopK, SourceColumns};
use super::cholesky::{factor_first, symbolic_factor, Factor};
use super::dissection::{nested_dissection, DISSECTION_MIN};
use super::memory::zeroed;
use super::pieces::{
    mark_sources, piece_contains_bone, piece_stats, rigid_pieces, PieceObjects, PieceStats, VertexPieces,
};
use super::reach::reach_segments;
use super::sources::{vertex_sources, Segments, Shares, Source, Ties, MAX_TIES};
use super::{BoneCurves, HeatOptions, HeatReport, HEAT_SCALE, MIN_DISTANCE, REGULARIZATION};
use crate::mesh::bones_in_frame;
use crate::mesh::cotan::{cotan_laplacian, stiffness_lower_csc, triangle_cotangents, LowerCsc};
use crate::mesh::facing::inside_by_faces;
use crate::mesh::islands::connected_components;
use crate::mesh::mirror::{mirror_map, Symmetry};
use crate::mesh::orient::{orient_faces, piece_volumes, vertex_normals};
use crate::mesh::visibility::RayMesh;
use crate::mesh::weld::weld;
use crate::mesh::Frame;
use crate::weights::influence::Influences;
use crate::weights::symmetry::pair_side_bones_by_place;
use crate::{Error, Result};
use faer::sparse::linalg::cholesky::SymbolicCholesky;
use faer::sparse::SymbolicSparseColMatRef;
use glam::DVec3;
use rayon::prelude::*;
use std::borrow::Cow;
use std::time::Instant;

/// The inputs of one solve: the mesh and the bones, in input units; `objects`, per input
/// vertex, the object it belongs to (a mesh of several objects: an object whose pieces hold no
/// bone is a prop, see `pieces`), `None` for one object.
pub(crate) struct Inputs<'a> {
    pub vertices: &'a [[f32; 3]],
    pub triangles: &'a [[u32; 3]],
    pub heads: &'a [[f32; 3]],
    pub tails: &'a [[f32; 3]],
    pub objects: Option<&'a [u32]>,
}

/// Where the heat sources come from.
#[derive(Clone, Copy)]
pub(crate) enum Given<'a> {
    /// Found here: each vertex's nearest visible bones.
    Found,
    /// The caller's rows, per input vertex ([`super::heat_weights_with_sources`]).
    Rows(&'a Influences),
    /// Another method's ([`crate::weights::voxel`]): from the prepared mesh, what the rays
    /// found, and a progress tick (fraction of its own work), per welded vertex the bones that
    /// share its heat and the distance in its heat term.
    Provided(&'a Provider<'a>),
}

/// See [`Given::Provided`].
pub(crate) type Provider<'a> =
    dyn Fn(&Prepared, &Visibility, &dyn Fn(f32) -> Result<()>) -> Result<Provided> + Sync + 'a;

/// What a [`Provider`] gives, per welded vertex: `rows`, the bones that share its heat and
/// their amounts (fractions of the row's sum; an empty row holds no heat); `dist`, the
/// distance in its heat term `H = HEAT_SCALE c / dist^2` (unit frame).
pub(crate) struct Provided {
    pub rows: Influences,
    pub dist: Vec<f64>,
}

/// Progress callback: called with the fraction done, `false` cancels.
pub(super) type Progress<'a> = Option<&'a (dyn Fn(f32) -> bool + Sync)>;

/// Bone heat weights of `inputs`, with each vertex's heat sources found here or, when `given`,
/// taken from the caller (see [`super::heat_weights_with_sources`]).
pub(crate) fn run(
    inputs: &Inputs,
    given: Given,
    opts: &HeatOptions,
    progress: Progress,
) -> Result<(Influences, HeatReport)> {
    let mut clock = Clock::start(progress);
    let mut report = HeatReport::default();
    let opts = resolve(inputs, given, opts, &mut report)?;
    clock.tick(0.0)?;
    let prep = prepare(inputs, &opts, &mut report);
    clock.lap(&mut report, "prepare");
    clock.tick(0.05)?;
    let (mut vis, matrix) = rayon::join(|| visibility(&prep, &opts), || matrix(&prep));
    clock.lap(&mut report, "visibility|matrix");
    let (bvh, rays, laplacian, symbolic) = (vis.secs.0, vis.secs.1, matrix.secs.0, matrix.secs.1);
    report.timings.extend([("bvh", bvh), ("rays", rays), ("laplacian", laplacian), ("symbolic", symbolic)]);
    report.flipped_faces = vis.flipped;
    clock.tick(0.2)?;
    let rigid = bind_pieces(&mut vis, &prep, inputs, &opts, &mut report);
    let provided = match given {
        Given::Provided(provide) => {
            let tick = |f: f32| clock.tick(0.2 + 0.1 * f.clamp(0.0, 1.0));
            let out = provide(&prep, &vis, &tick)?;
            clock.lap(&mut report, "provided");
            Some(out)
        }
        _ => None,
    };
    let heat = assemble(&prep, &vis, &matrix.mass, given, provided.as_ref(), &opts, &mut report);
    clock.lap(&mut report, "assemble");
    clock.tick(0.3)?;
    let Matrix { mass, csc, symbolic, .. } = matrix;
    // The solve's memory is first written by the core the factorization leaves idle (its
    // many small supernodes run one after the other).
    let (llt, work) =
        rayon::join(|| factor(symbolic, csc, &mass, &heat.heat, &mut report), || Workspace::new(&prep, &heat, &opts));
    clock.lap(&mut report, "factor");
    clock.tick(0.6)?;
    let rows = Rows {
        sources: &vis.sources,
        shares: &heat.shares,
        mass: &mass,
        labels: &vis.labels,
        rigid: &rigid,
        order: llt.as_ref().and_then(Factor::order),
    };
    let solved = solve(&prep, &rows, llt.as_ref(), work, &opts, &clock, &mut report)?;
    // "solve" is the solves and the clip alone; the blocks' other work counts in "finish".
    let bookkeeping = clock.lap_as(&mut report, "solve", solved.secs);
    let out = finish(solved.best, &prep, &rows, &opts);
    clock.lap_plus(&mut report, "finish", bookkeeping);
    report.timings.push(("total", clock.total()));
    clock.tick(1.0)?;
    Ok((out, report))
}

/// The heat sources that [`run`] finds, per input vertex: after [`prepare`], [`visibility`]
/// and [`bind_pieces`], each vertex's source bones (up to [`MAX_TIES`], sharing equally) as
/// top-k rows; a vertex that is no heat source has an empty row.
pub(super) fn sources_found(inputs: &Inputs, opts: &HeatOptions) -> Result<Influences> {
    let mut report = HeatReport::default();
    let (prep, mut vis) = prepared_and_seen(inputs, opts)?;
    bind_pieces(&mut vis, &prep, inputs, opts, &mut report);
    let mut welded = Influences::empty(vis.sources.len(), MAX_TIES);
    for (v, s) in vis.sources.iter().enumerate() {
        let n = s.count as usize;
        welded.indices[v * MAX_TIES..v * MAX_TIES + n].iter_mut().zip(&s.bones).for_each(|(i, &j)| *i = j as i32);
        welded.weights[v * MAX_TIES..v * MAX_TIES + n].fill(1.0 / n as f32);
    }
    Ok(unweld(&welded, &prep.map, None))
}

/// The first stages of [`run`] alone: the inputs checked, the mesh prepared, and what the rays
/// found (for debugging and evaluation).
pub(crate) fn prepared_and_seen(inputs: &Inputs, opts: &HeatOptions) -> Result<(Prepared, Visibility)> {
    let mut report = HeatReport::default();
    let opts = resolve(inputs, Given::Found, opts, &mut report)?;
    let prep = prepare(inputs, &opts, &mut report);
    let vis = visibility(&prep, &opts);
    Ok((prep, vis))
}

/// Wall-clock timings of the stages and the progress callback.
struct Clock<'a> {
    start: Instant,
    last: Instant,
    progress: Progress<'a>,
}

impl<'a> Clock<'a> {
    fn start(progress: Progress<'a>) -> Clock<'a> {
        let now = Instant::now();
        Clock { start: now, last: now, progress }
    }

    /// Record the seconds since the last lap as stage `name`.
    fn lap(&mut self, report: &mut HeatReport, name: &'static str) {
        self.lap_plus(report, name, 0.0);
    }

    /// Record the seconds since the last lap plus `extra` as stage `name`.
    fn lap_plus(&mut self, report: &mut HeatReport, name: &'static str, extra: f64) {
        let now = Instant::now();
        report.timings.push((name, (now - self.last).as_secs_f64() + extra));
        self.last = now;
    }

    /// Record `secs` as stage `name` and start the next lap; returns the rest of the seconds
    /// since the last lap.
    fn lap_as(&mut self, report: &mut HeatReport, name: &'static str, secs: f64) -> f64 {
        let now = Instant::now();
        report.timings.push((name, secs));
        let rest = (now - self.last).as_secs_f64() - secs;
        self.last = now;
        rest
    }

    fn total(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// Report the fraction `f` done; [`Error::Cancelled`] when the callback says stop.
    fn tick(&self, f: f32) -> Result<()> {
        match self.progress {
            Some(p) if !p(f) => Err(Error::Cancelled),
            _ => Ok(()),
        }
    }
}

/// Check the inputs, options and `given` sources; with symmetry, the options with the bones
/// given as centre bones that lie off the plane paired with their mirror image by place
/// (counted in the report).
fn resolve<'o>(
    inputs: &Inputs,
    given: Given,
    opts: &'o HeatOptions,
    report: &mut HeatReport,
) -> Result<Cow<'o, HeatOptions>> {
    let Inputs { vertices, triangles, heads, tails, objects } = *inputs;
    super::validate(vertices, triangles, heads, tails, opts)?;
    if let Given::Rows(g) = given {
        super::validate_sources(g, vertices.len(), heads.len())?;
    }
    if objects.is_some_and(|o| o.len() != vertices.len()) {
        return Err(Error::Shape(format!(
            "objects has {} entries for {} vertices",
            objects.map_or(0, |o| o.len()),
            vertices.len()
        )));
    }
    let Some(s) = &opts.symmetry else { return Ok(Cow::Borrowed(opts)) };
    let (bone_mirror, paired, alone) = pair_side_bones_by_place(heads, tails, &s.mirror, s.axis, s.plane)?;
    report.side_bones_paired = paired;
    report.side_bones_unpaired = alone;
    let symmetry = Some(Symmetry { mirror: bone_mirror, ..s.clone() });
    Ok(Cow::Owned(HeatOptions { symmetry, ..opts.clone() }))
}

/// The mesh ready for a solve, in the unit frame (shared with [`crate::weights::voxel`]).
pub(crate) struct Prepared {
    pub(crate) frame: Frame,
    /// `(b,)` head -> tail of every bone.
    pub(crate) bones: Vec<(DVec3, DVec3)>,
    /// `(n,)` the welded vertex of each input vertex.
    pub(crate) map: Vec<u32>,
    /// `(nw,)` welded positions.
    pub(crate) wpos: Vec<DVec3>,
    /// The triangles on welded vertices that have an area.
    pub(crate) tris: Vec<[u32; 3]>,
}

/// Normalize, weld, and keep the triangles that are not degenerate once welded.
fn prepare(inputs: &Inputs, opts: &HeatOptions, report: &mut HeatReport) -> Prepared {
    let prep = prepare_mesh(inputs.vertices, inputs.triangles, inputs.heads, inputs.tails, opts.weld_tolerance);
    report.welded_vertices = inputs.vertices.len() - prep.wpos.len();
    prep
}

/// The unit frame of the mesh ([`Frame::of_mesh`]), its vertices welded within
/// `weld_tolerance` (unit frame), the triangles that are not degenerate once welded, and the
/// bones in that frame.
pub(crate) fn prepare_mesh(
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
    heads: &[[f32; 3]],
    tails: &[[f32; 3]],
    weld_tolerance: f32,
) -> Prepared {
    let frame = Frame::of_mesh(vertices, triangles);
    let pos = frame.normalize(vertices);
    let bones = bones_in_frame(&frame, heads, tails);
    let (map, wpos) = weld(&pos, weld_tolerance as f64);
    drop(pos);
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
    Prepared { frame, bones, map, wpos, tris }
}

/// What the rays found: pieces, segments and every welded vertex's heat source.
pub(crate) struct Visibility {
    /// The BVH of the triangles, when rays are needed (visibility, accessories or parents).
    pub(crate) ray_mesh: Option<RayMesh>,
    /// `(nw,)` piece of each vertex.
    pub(crate) labels: Vec<u32>,
    /// The triangles consistently wound per patch ([`orient_faces`]; the same order as the
    /// prepared ones).
    pub(crate) oriented: Vec<[u32; 3]>,
    /// `(nw,)` outward unit vertex normals (zero when not needed, or off the faces).
    pub(crate) normals: Vec<DVec3>,
    /// Triangles wound against their neighbours.
    flipped: usize,
    pieces: Vec<PieceStats>,
    /// The segments standing for the bones (several per bone on imported and bent bones), and
    /// each one's bone.
    pub(crate) segs: Vec<(DVec3, DVec3)>,
    pub(crate) owner: Vec<u32>,
    /// Per piece: does it hold a bone (computed when accessories or a second look need it).
    inside: Vec<bool>,
    /// `(nw,)` nearest visible bone(s) of each vertex, in bones.
    pub(crate) sources: Vec<Source>,
    /// Seconds: BVH, then the rest.
    secs: (f64, f64),
}

/// The BVH, pieces, normals, segments, inside tests and every vertex's nearest visible bone.
fn visibility(prep: &Prepared, opts: &HeatOptions) -> Visibility {
    let Prepared { wpos, tris, .. } = prep;
    let nw = wpos.len();
    let s = Instant::now();
    let need_rays = opts.visibility || opts.rigid_accessories || opts.parents.is_some();
    let ray_mesh = need_rays.then(|| {
        let wpos32: Vec<[f32; 3]> = wpos.iter().map(|p| p.as_vec3().to_array()).collect();
        RayMesh::new(&wpos32, tris)
    });
    let t_bvh = s.elapsed().as_secs_f64();
    let s = Instant::now();
    let (labels, npieces) = connected_components(nw, tris);
    let (oriented, flipped) = orient_faces(nw, tris);
    let normals =
        if opts.normal_distance { vertex_normals(wpos, &oriented, &labels, npieces) } else { vec![DVec3::ZERO; nw] };
    let pieces = piece_stats(&labels, npieces, wpos, &oriented);
    let (segs, owner) =
        bone_segments(prep, ray_mesh.as_ref(), &pieces, &labels, opts.parents.as_deref(), opts.curves.as_ref());
    // Which pieces hold a bone: for rigid accessories, and on a mesh in several pieces for the
    // second look through a vertex's own piece (see `sources`).
    let rays = ray_mesh.as_ref().filter(|_| opts.visibility);
    let inside: Vec<bool> = match ray_mesh.as_ref() {
        Some(rm) if opts.rigid_accessories || (npieces > 1 && rays.is_some()) => (0..npieces)
            .into_par_iter()
            .map(|i| pieces[i].active && piece_contains_bone(rm, i as u32, &pieces[i], &segs, &labels, tris))
            .collect(),
        _ => vec![false; npieces],
    };
    let tri_piece: Option<Vec<u32>> = (npieces > 1).then(|| tris.iter().map(|t| labels[t[0] as usize]).collect());
    let bones = Segments { segs: &segs, owner: &owner };
    let sources = vertex_sources(wpos, &normals, &labels, bones, rays, tri_piece.as_deref(), &inside);
    let secs = (t_bvh, s.elapsed().as_secs_f64());
    Visibility { ray_mesh, labels, oriented, normals, flipped, pieces, segs, owner, inside, sources, secs }
}

/// The matrix side of the system.
struct Matrix {
    /// `(nw,)` lumped mass (0: in no usable triangle).
    mass: Vec<f64>,
    /// The cotangent stiffness `L`, lower triangle.
    csc: LowerCsc,
    /// Its symbolic Cholesky analysis (`None` if it failed).
    symbolic: Option<SymbolicCholesky<usize>>,
    /// Seconds: Laplacian, symbolic analysis.
    secs: (f64, f64),
}

/// Cotangent stiffness, mass and sparse pattern, then the symbolic analysis of that pattern.
fn matrix(prep: &Prepared) -> Matrix {
    let nw = prep.wpos.len();
    let s = Instant::now();
    let cot = cotan_laplacian(&prep.wpos, &prep.tris);
    let csc = stiffness_lower_csc(nw, &cot.edges);
    let t_lap = s.elapsed().as_secs_f64();
    let s = Instant::now();
    let pattern = SymbolicSparseColMatRef::new_checked(nw, nw, &csc.col_ptr, None, &csc.row_idx);
    let order = (nw >= DISSECTION_MIN).then(|| nested_dissection(&csc.col_ptr, &csc.row_idx, &prep.wpos));
    let symbolic = symbolic_factor(pattern, order.as_deref());
    Matrix { mass: cot.mass, csc, symbolic, secs: (t_lap, s.elapsed().as_secs_f64()) }
}

/// Mark the pieces that see a bone, find the rigid pieces (see `pieces`), and give the
/// vertices of pieces that see no bone their nearest bone by distance as heat source.
/// Returns each piece's rigid bone(s).
fn bind_pieces(
    vis: &mut Visibility,
    prep: &Prepared,
    inputs: &Inputs,
    opts: &HeatOptions,
    report: &mut HeatReport,
) -> Vec<Option<Ties>> {
    let (wpos, tris, nb) = (&prep.wpos, &prep.tris, inputs.heads.len());
    // The object of each piece: that of its first input vertex.
    let mut groups = vec![u32::MAX; vis.pieces.len()];
    if let Some(objects) = inputs.objects {
        for (i, &w) in prep.map.iter().enumerate() {
            let g = &mut groups[vis.labels[w as usize] as usize];
            if *g == u32::MAX {
                *g = objects[i];
            }
        }
    }
    mark_sources(&mut vis.pieces, &vis.labels, &vis.sources);
    let mut bone_len = vec![0.0f64; nb];
    for ((h, t), &o) in vis.segs.iter().zip(&vis.owner) {
        bone_len[o as usize] = bone_len[o as usize].max((*t - *h).length());
    }
    let accessories = opts.rigid_accessories && vis.ray_mesh.is_some();
    let area = || vertex_areas(wpos, tris);
    // Several objects (the voxel bind): pieces and objects hold bones by the faces seen.
    let held = inputs.objects.and_then(|_| held_by_faces(vis, prep, &groups));
    let (rigid, counts) = rigid_pieces(
        &vis.pieces,
        held.as_ref().map_or(&vis.inside, |h| &h.0),
        Segments { segs: &vis.segs, owner: &vis.owner },
        &bone_len,
        accessories,
        VertexPieces { labels: &vis.labels, sources: &vis.sources, area: &area },
        PieceObjects { groups: &groups, holds: held.as_ref().map(|h| &h.1[..]) },
    );
    report.pieces = counts.pieces;
    report.fallback_pieces = counts.fallback;
    report.rigid_pieces = counts.rigid;
    report.boneless_pieces = counts.boneless;
    report.spanning_pieces = counts.spanning;
    let pieces = &vis.pieces;
    vis.sources.par_iter_mut().zip(vis.labels.par_iter()).with_min_len(1024).for_each(|(s, &l)| {
        if !pieces[l as usize].sees {
            s.bones = s.nearest.bones;
            s.count = s.nearest.count;
            s.dist = s.nearest_dist;
        }
    });
    rigid
}

/// A piece or object holds bones when their segments inside it are at least this fraction of
/// its size long ([`held_by_faces`]).
const HELD_LENGTH: f64 = 0.25;

/// Which pieces and which objects hold bones by the faces seen ([`inside_by_faces`], which
/// open sleeves and nested pieces pass, where parity does not): per piece, (does it, does its
/// object). A piece or object holds bones when the length of the bones' segments inside its
/// triangles (9 points along each) is at least [`HELD_LENGTH`] of its size: a sleeve across
/// an elbow holds half of two bones, a carrot held in a fist only the fingertips. `groups`
/// `(pieces,)` is the object of each piece. `None` without rays.
fn held_by_faces(vis: &Visibility, prep: &Prepared, groups: &[u32]) -> Option<(Vec<bool>, Vec<bool>)> {
    let rays = vis.ray_mesh.as_ref()?;
    let volumes = piece_volumes(&prep.wpos, &vis.oriented, &vis.labels, groups.len());
    let normals: Vec<DVec3> = vis
        .oriented
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| prep.wpos[i as usize]);
            let s = if volumes[vis.labels[t[0] as usize] as usize] < 0.0 { -1.0 } else { 1.0 };
            (b - a).cross(c - a) * s
        })
        .collect();
    let tri_piece: Vec<u32> = prep.tris.iter().map(|t| vis.labels[t[0] as usize]).collect();
    let tri_object: Vec<u32> = tri_piece.iter().map(|&p| groups[p as usize]).collect();
    // Per key (a piece or an object) of the triangles: does it hold a bone?
    let holds = |key_of: &[u32]| -> Vec<(u32, bool)> {
        let mut boxes: Vec<(u32, DVec3, DVec3)> = Vec::new();
        let mut keys: Vec<u32> = key_of.to_vec();
        keys.sort_unstable();
        keys.dedup();
        for &k in &keys {
            boxes.push((k, DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)));
        }
        for (t, &k) in prep.tris.iter().zip(key_of) {
            let b = &mut boxes[keys.binary_search(&k).unwrap_or(0)];
            for &i in t {
                b.1 = b.1.min(prep.wpos[i as usize]);
                b.2 = b.2.max(prep.wpos[i as usize]);
            }
        }
        boxes
            .par_iter()
            .map(|&(k, lo, hi)| {
                let mut length = 0.0;
                for &(h, t) in &vis.segs {
                    let inside = (0..9).filter(|&s| {
                        let p = h + (t - h) * (s as f64 / 8.0);
                        p.cmpge(lo).all()
                            && p.cmple(hi).all()
                            && inside_by_faces(rays, &normals, p, 2.0, |tri| key_of[tri as usize] == k)
                    });
                    length += inside.count() as f64 / 9.0 * h.distance(t);
                }
                (k, length >= HELD_LENGTH * (hi - lo).length())
            })
            .collect()
    };
    let pieces = holds(&tri_piece);
    let objects = holds(&tri_object);
    let find = |list: &[(u32, bool)], k: u32| list.binary_search_by_key(&k, |e| e.0).is_ok_and(|i| list[i].1);
    Some((
        (0..groups.len() as u32).map(|p| find(&pieces, p)).collect(),
        groups.iter().map(|&g| find(&objects, g)).collect(),
    ))
}

/// `(nw,)` each welded vertex's share of the area of its triangles (a third of each).
fn vertex_areas(wpos: &[DVec3], tris: &[[u32; 3]]) -> Vec<f64> {
    let mut area = vec![0.0f64; wpos.len()];
    for t in tris {
        let [a, b, c] = t.map(|i| wpos[i as usize]);
        let third = (b - a).cross(c - a).length() / 6.0;
        for &i in t {
            area[i as usize] += third;
        }
    }
    area
}

/// The right-hand side's ingredients: which bones share each welded vertex's heat, and that
/// heat `M_ii H_ii`.
struct Heat {
    shares: Shares,
    heat: Vec<f64>,
}

/// Each vertex's heat `M_ii H_ii = M_ii HEAT_SCALE c / d_i^2` and the bones that share it:
/// its own sources, the `given` ones summed over the input vertices welded together, or the
/// `provided` ones. `d_i` is the distance to the vertex's own source (to its nearest bone when
/// it has none), or the provided one; a vertex with no mass or no source bone has no heat.
/// Counts the isolated vertices.
fn assemble(
    prep: &Prepared,
    vis: &Visibility,
    mass: &[f64],
    given: Given,
    provided: Option<&Provided>,
    opts: &HeatOptions,
    report: &mut HeatReport,
) -> Heat {
    report.isolated_vertices = prep.map.iter().filter(|&&w| mass[w as usize] <= 0.0).count();
    let nw = prep.wpos.len();
    let identity: Vec<u32>;
    let shares = match (given, provided) {
        (Given::Rows(g), _) => Shares::given(g, &prep.map, nw),
        (_, Some(p)) => {
            identity = (0..nw as u32).collect();
            Shares::given(&p.rows, &identity, nw)
        }
        _ => Shares::of_sources(&vis.sources),
    };
    let c = HEAT_SCALE * opts.heat_constant as f64;
    let heat: Vec<f64> = (vis.sources.par_iter().enumerate())
        .zip(mass.par_iter())
        .with_min_len(4096)
        .map(|((v, s), &m)| {
            let d = match provided {
                Some(p) => p.dist[v],
                None if s.count > 0 => s.dist,
                None => s.nearest_dist,
            };
            if m > 0.0 && shares.is_source(v) {
                m * c / d.max(MIN_DISTANCE).powi(2)
            } else {
                0.0
            }
        })
        .collect();
    Heat { shares, heat }
}

/// Factor `A = L + M H` (`+ r (L_ii + M_ii)` on the diagonal for the regularizations `r` tried
/// in turn; a vertex with no mass gets a unit row): the factor, or `None` when every attempt
/// fails (reported).
fn factor(
    symbolic: Option<SymbolicCholesky<usize>>,
    csc: LowerCsc,
    mass: &[f64],
    heat: &[f64],
    report: &mut HeatReport,
) -> Option<Factor> {
    let nw = mass.len();
    let pattern = SymbolicSparseColMatRef::new_checked(nw, nw, &csc.col_ptr, None, &csc.row_idx);
    let values_for = |r: f64| -> Vec<f64> {
        let mut vals = csc.values.clone();
        for v in 0..nw {
            let d = csc.diag_pos[v];
            vals[d] = if mass[v] > 0.0 { vals[d] * (1.0 + r) + heat[v] + r * mass[v] } else { 1.0 };
        }
        vals
    };
    let llt = symbolic.and_then(|s| factor_first(s, pattern, &REGULARIZATION, values_for));
    report.regularized = matches!(llt, Some((_, attempt)) if attempt > 0);
    report.factorization_failed = llt.is_none();
    llt.map(|(f, _)| f)
}

/// What [`solve`] gives: every welded vertex's running top k, and the seconds spent in the
/// solves and the clip.
struct Solved {
    best: RunningTopK,
    secs: f64,
}

/// The bones' blocks, their right-hand sides' non-zeros, the running top k and the first
/// block's memory, made before the solve.
struct Workspace {
    blocks: Vec<Vec<usize>>,
    sources: SourceColumns,
    best: RunningTopK,
    x: Vec<f64>,
}

impl Workspace {
    fn new(prep: &Prepared, heat: &Heat, opts: &HeatOptions) -> Workspace {
        let (nw, b) = (prep.wpos.len(), prep.bones.len());
        let threads = rayon::current_num_threads().max(1);
        let mirror = opts.symmetry.as_ref().map(|s| &s.mirror[..]);
        let blocks = bone_blocks(b, nw, opts.block_bones, threads, mirror);
        let first = nw * blocks.first().map_or(0, Vec::len);
        let x = zeroed(first).expect("memory for a block of right-hand sides");
        let sources = SourceColumns::new(&heat.shares, &heat.heat, b);
        Workspace { blocks, sources, best: RunningTopK::new(nw, opts.max_influences.min(b), b), x }
    }
}

/// Solve every bone, in blocks of columns: see [`block_weights`]. Reports the progress
/// after each block and counts the mirrored vertices.
fn solve(
    prep: &Prepared,
    rows: &Rows,
    llt: Option<&Factor>,
    work: Workspace,
    opts: &HeatOptions,
    clock: &Clock,
    report: &mut HeatReport,
) -> Result<Solved> {
    let b = prep.bones.len();
    let vm = match &opts.symmetry {
        Some(s) => Some(mirror_map(
            &prep.wpos,
            s.axis,
            (s.plane - prep.frame.centre[s.axis]) / prep.frame.diagonal,
            opts.mirror_tolerance as f64,
        )?),
        None => None,
    };
    if let Some(vm) = &vm {
        report.mirrored_vertices = prep.map.iter().filter(|&&w| vm[w as usize] >= 0).count();
    }
    let Workspace { blocks, sources, mut best, mut x } = work;
    let (mut secs, mut done) = (0.0, 0usize);
    // The mirror map of the blocks' rows.
    let vm = vm.map(|vm| {
        let mut of_rows = vec![-1i32; vm.len()];
        for (v, &m) in vm.iter().enumerate() {
            of_rows[rows.row(v)] = usize::try_from(m).map_or(-1, |m| rows.row(m) as i32);
        }
        of_rows
    });
    let sym = opts.symmetry.as_ref().zip(vm.as_deref());
    for block in &blocks {
        secs += block_weights(block, &sources, rows, llt, sym, &mut x);
        best.merge(&x, block, opts.weight_limit_start, opts.weight_limit_end);
        done += block.len();
        clock.tick(0.6 + 0.3 * done as f32 / b as f32)?;
    }
    Ok(Solved { best, secs })
}

/// Each welded vertex's top k normalized and pruned, copied to every input vertex.
fn finish(best: RunningTopK, prep: &Prepared, rows: &Rows, opts: &HeatOptions) -> Influences {
    let welded = best.finish(opts.max_influences.min(prep.bones.len()).max(1), opts.min_weight, rows);
    unweld(&welded, &prep.map, rows.place())
}

/// The rows of `welded` copied to every input vertex (`map[i]`: the welded vertex of input `i`,
/// in row `place[map[i]]` of `welded`, or `map[i]` without `place`).
fn unweld(welded: &Influences, map: &[u32], place: Option<&[usize]>) -> Influences {
    let k = welded.k;
    let mut out = Influences::empty(map.len(), k);
    out.indices.par_chunks_mut(k).zip(out.weights.par_chunks_mut(k)).zip(map.par_iter()).with_min_len(1024).for_each(
        |((idx, w), &m)| {
            let (si, sw) = welded.row(place.map_or(m as usize, |p| p[m as usize]));
            idx.copy_from_slice(si);
            w.copy_from_slice(sw);
        },
    );
    out
}

/// The segments standing for the bones, and the bone of each: head -> tail, or with `parents`
/// (and the mesh's rays `rm`) the spans of imported rigs' bones ([`reach_segments`]); then
/// with `curves` the polylines of bent bones ([`bend`]). `pieces` and `labels` are the welded
/// mesh's pieces (for the inside test of the spans).
pub(crate) fn bone_segments(
    prep: &Prepared,
    rm: Option<&RayMesh>,
    pieces: &[PieceStats],
    labels: &[u32],
    parents: Option<&[i32]>,
    curves: Option<&BoneCurves>,
) -> (Vec<(DVec3, DVec3)>, Vec<u32>) {
    let bones = &prep.bones;
    let (segs, owner) = match (parents, rm) {
        (Some(parents), Some(rm)) => reach_segments(rm, bones, parents, pieces, labels, &prep.tris),
        _ => (bones.clone(), (0..bones.len() as u32).collect()),
    };
    match curves {
        Some(c) if !c.points.is_empty() => bend(segs, owner, bones, c, &prep.frame),
        _ => (segs, owner),
    }
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
