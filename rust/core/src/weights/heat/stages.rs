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
//!      pattern, and its symbolic Cholesky analysis (AMD ordering, supernodes).
//! 4. [`bind_pieces`]: pieces where no vertex sees a bone take the nearest bone by distance;
//!    rigid pieces (see `pieces`).
//! 5. [`assemble`]: the bones that share each vertex's heat (found here, or given), and the
//!    heat `M H` of every vertex.
//! 6. [`factor`]: `L + M H` factored once, retried with more regularization.
//! 7. [`solve`]: every bone solved against the one factor, in blocks of columns
//!    ([`HeatOptions::block_bones`]), clipped to `[0, 1]`; rigid pieces and isolated vertices
//!    at 100%; symmetry; each vertex's running top k after the small-weight ramp.
//! 8. [`finish`]: each vertex's top k normalized and pruned, copied back to every input vertex.

use super::blocks::{block_weights, bone_blocks, Rows, RunningTopK};
use super::cholesky::{factor_first, symbolic_factor, Factor};
use super::pieces::{mark_sources, piece_contains_bone, piece_stats, rigid_pieces, PieceStats};
use super::reach::reach_segments;
use super::sources::{vertex_sources, Shares, Source, Ties, MAX_TIES};
use super::{BoneCurves, HeatOptions, HeatReport, HEAT_SCALE, MIN_DISTANCE, REGULARIZATION};
use crate::mesh::bones_in_frame;
use crate::mesh::cotan::{cotan_laplacian, stiffness_lower_csc, triangle_cotangents, LowerCsc};
use crate::mesh::islands::connected_components;
use crate::mesh::mirror::{mirror_map, Symmetry};
use crate::mesh::orient::{orient_faces, vertex_normals};
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

/// The inputs of one solve: the mesh and the bones, in input units.
pub(super) struct Inputs<'a> {
    pub vertices: &'a [[f32; 3]],
    pub triangles: &'a [[u32; 3]],
    pub heads: &'a [[f32; 3]],
    pub tails: &'a [[f32; 3]],
}

/// Progress callback: called with the fraction done, `false` cancels.
pub(super) type Progress<'a> = Option<&'a (dyn Fn(f32) -> bool + Sync)>;

/// Bone heat weights of `inputs`, with each vertex's heat sources found here or, when `given`,
/// taken from the caller (see [`super::heat_weights_with_sources`]).
pub(super) fn run(
    inputs: &Inputs,
    given: Option<&Influences>,
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
    let rigid = bind_pieces(&mut vis, &prep, inputs.heads.len(), &opts, &mut report);
    let heat = assemble(&prep, &vis, &matrix.mass, given, &opts, &mut report);
    clock.lap(&mut report, "assemble");
    clock.tick(0.3)?;
    let Matrix { mass, csc, symbolic, .. } = matrix;
    let llt = factor(symbolic, csc, &mass, &heat.heat, &mut report);
    clock.lap(&mut report, "factor");
    clock.tick(0.6)?;
    let rows = Rows {
        sources: &vis.sources,
        shares: &heat.shares,
        heat: &heat.heat,
        mass: &mass,
        labels: &vis.labels,
        rigid: &rigid,
    };
    let solved = solve(&prep, &rows, llt, &opts, &clock, &mut report)?;
    // "solve" is the solves and the clip alone; the blocks' other work counts in "finish".
    let bookkeeping = clock.lap_as(&mut report, "solve", solved.secs);
    let out = finish(solved.best, &prep, &vis, &opts);
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
    let opts = resolve(inputs, None, opts, &mut report)?;
    let prep = prepare(inputs, &opts, &mut report);
    let mut vis = visibility(&prep, &opts);
    bind_pieces(&mut vis, &prep, inputs.heads.len(), &opts, &mut report);
    let mut welded = Influences::empty(vis.sources.len(), MAX_TIES);
    for (v, s) in vis.sources.iter().enumerate() {
        let n = s.count as usize;
        welded.indices[v * MAX_TIES..v * MAX_TIES + n].iter_mut().zip(&s.bones).for_each(|(i, &j)| *i = j as i32);
        welded.weights[v * MAX_TIES..v * MAX_TIES + n].fill(1.0 / n as f32);
    }
    Ok(unweld(&welded, &prep.map))
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
    given: Option<&Influences>,
    opts: &'o HeatOptions,
    report: &mut HeatReport,
) -> Result<Cow<'o, HeatOptions>> {
    let Inputs { vertices, triangles, heads, tails } = *inputs;
    super::validate(vertices, triangles, heads, tails, opts)?;
    if let Some(g) = given {
        super::validate_sources(g, vertices.len(), heads.len())?;
    }
    let Some(s) = &opts.symmetry else { return Ok(Cow::Borrowed(opts)) };
    let (bone_mirror, paired, alone) = pair_side_bones_by_place(heads, tails, &s.mirror, s.axis, s.plane)?;
    report.side_bones_paired = paired;
    report.side_bones_unpaired = alone;
    let symmetry = Some(Symmetry { mirror: bone_mirror, ..s.clone() });
    Ok(Cow::Owned(HeatOptions { symmetry, ..opts.clone() }))
}

/// The mesh ready for the solve, in the unit frame.
struct Prepared {
    frame: Frame,
    /// `(b,)` head -> tail of every bone.
    bones: Vec<(DVec3, DVec3)>,
    /// `(n,)` the welded vertex of each input vertex.
    map: Vec<u32>,
    /// `(nw,)` welded positions.
    wpos: Vec<DVec3>,
    /// The triangles on welded vertices that have an area.
    tris: Vec<[u32; 3]>,
}

/// Normalize, weld, and keep the triangles that are not degenerate once welded.
fn prepare(inputs: &Inputs, opts: &HeatOptions, report: &mut HeatReport) -> Prepared {
    let frame = Frame::of_mesh(inputs.vertices, inputs.triangles);
    let pos = frame.normalize(inputs.vertices);
    let bones = bones_in_frame(&frame, inputs.heads, inputs.tails);
    let (map, wpos) = weld(&pos, opts.weld_tolerance as f64);
    drop(pos);
    report.welded_vertices = inputs.vertices.len() - wpos.len();
    let tris: Vec<[u32; 3]> = inputs
        .triangles
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
struct Visibility {
    /// The BVH of the triangles, when rays are needed (visibility, accessories or parents).
    ray_mesh: Option<RayMesh>,
    /// `(nw,)` piece of each vertex.
    labels: Vec<u32>,
    /// Triangles wound against their neighbours.
    flipped: usize,
    pieces: Vec<PieceStats>,
    /// The segments standing for the bones (several per bone on imported and bent bones), and
    /// each one's bone.
    segs: Vec<(DVec3, DVec3)>,
    owner: Vec<u32>,
    /// Per piece: does it hold a bone (computed when accessories or a second look need it).
    inside: Vec<bool>,
    /// `(nw,)` nearest visible bone(s) of each vertex, in bones.
    sources: Vec<Source>,
    /// Seconds: BVH, then the rest.
    secs: (f64, f64),
}

/// The BVH, pieces, normals, segments, inside tests and every vertex's nearest visible bone.
fn visibility(prep: &Prepared, opts: &HeatOptions) -> Visibility {
    let Prepared { frame, bones, wpos, tris, .. } = prep;
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
    drop(oriented);
    let (segs, owner) = match (&opts.parents, ray_mesh.as_ref()) {
        (Some(parents), Some(rm)) => reach_segments(rm, bones, parents, &pieces, &labels, tris),
        _ => (bones.clone(), (0..bones.len() as u32).collect()),
    };
    let (segs, owner) = match &opts.curves {
        Some(c) if !c.points.is_empty() => bend(segs, owner, bones, c, frame),
        _ => (segs, owner),
    };
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
    let sources = vertex_sources(wpos, &normals, &labels, &segs, &owner, rays, tri_piece.as_deref(), &inside);
    let secs = (t_bvh, s.elapsed().as_secs_f64());
    Visibility { ray_mesh, labels, flipped, pieces, segs, owner, inside, sources, secs }
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
    let symbolic = symbolic_factor(pattern);
    Matrix { mass: cot.mass, csc, symbolic, secs: (t_lap, s.elapsed().as_secs_f64()) }
}

/// Mark the pieces that see a bone, find the rigid pieces (see `pieces`), and give the
/// vertices of pieces that see no bone their nearest bone by distance as heat source.
/// Returns each piece's rigid bone(s).
fn bind_pieces(
    vis: &mut Visibility,
    prep: &Prepared,
    nb: usize,
    opts: &HeatOptions,
    report: &mut HeatReport,
) -> Vec<Option<Ties>> {
    let (wpos, tris) = (&prep.wpos, &prep.tris);
    mark_sources(&mut vis.pieces, &vis.labels, &vis.sources);
    let mut bone_len = vec![0.0f64; nb];
    for ((h, t), &o) in vis.segs.iter().zip(&vis.owner) {
        bone_len[o as usize] = bone_len[o as usize].max((*t - *h).length());
    }
    let accessories = opts.rigid_accessories && vis.ray_mesh.is_some();
    let area = || vertex_areas(wpos, tris);
    let (rigid, counts) = rigid_pieces(
        &vis.pieces,
        &vis.inside,
        &vis.segs,
        &vis.owner,
        &bone_len,
        accessories,
        &vis.labels,
        &vis.sources,
        &area,
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
/// its own sources, or the `given` ones summed over the input vertices welded together. `d_i`
/// is the distance to the vertex's own source (to its nearest bone when it has none); a vertex
/// with no mass or no source bone has no heat. Counts the isolated vertices.
fn assemble(
    prep: &Prepared,
    vis: &Visibility,
    mass: &[f64],
    given: Option<&Influences>,
    opts: &HeatOptions,
    report: &mut HeatReport,
) -> Heat {
    report.isolated_vertices = prep.map.iter().filter(|&&w| mass[w as usize] <= 0.0).count();
    let shares = match given {
        Some(g) => Shares::given(g, &prep.map, prep.wpos.len()),
        None => Shares::of_sources(&vis.sources),
    };
    let c = HEAT_SCALE * opts.heat_constant as f64;
    let heat: Vec<f64> = (vis.sources.par_iter().enumerate())
        .zip(mass.par_iter())
        .with_min_len(4096)
        .map(|((v, s), &m)| {
            let d = if s.count > 0 { s.dist } else { s.nearest_dist };
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

/// Solve every bone, in blocks of columns: see [`block_weights`]. Reports the progress
/// after each block and counts the mirrored vertices.
fn solve(
    prep: &Prepared,
    rows: &Rows,
    llt: Option<Factor>,
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
    let threads = rayon::current_num_threads().max(1);
    let mirror = opts.symmetry.as_ref().map(|s| &s.mirror[..]);
    let blocks = bone_blocks(b, prep.wpos.len(), opts.block_bones, threads, mirror);
    let mut best = RunningTopK::new(prep.wpos.len(), opts.max_influences.min(b));
    let (mut secs, mut done) = (0.0, 0usize);
    let sym = opts.symmetry.as_ref().zip(vm.as_deref());
    for block in &blocks {
        let (x, t) = block_weights(block, rows, llt.as_ref(), sym);
        secs += t;
        best.merge(&x, block, opts.weight_limit_start, opts.weight_limit_end);
        done += block.len();
        clock.tick(0.6 + 0.3 * done as f32 / b as f32)?;
    }
    Ok(Solved { best, secs })
}

/// Each welded vertex's top k normalized and pruned, copied to every input vertex.
fn finish(best: RunningTopK, prep: &Prepared, vis: &Visibility, opts: &HeatOptions) -> Influences {
    let welded = best.finish(opts.min_weight, &vis.sources);
    unweld(&welded, &prep.map)
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
