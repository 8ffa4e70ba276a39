//! Heat sources of the bone-heat solve ([`crate::weights::heat`]): for every vertex, its nearest
//! *visible* bone(s) (Baran & Popovic 2007, skin attachment: `p_j,i = 1` and `H_ii = c / d_i^2` come
//! from the nearest bone whose straight line to the vertex stays inside the mesh), ranked by
//! Blender's normal-weighted distance, with near-ties sharing, and the nearest bone by plain
//! distance for the fallbacks.

use crate::mesh::segment::{closest_point_on_segment, Segment};
use crate::mesh::visibility::RayMesh;
use crate::weights::influence::Influences;
use glam::DVec3;
use rayon::prelude::*;

/// Relative distance within which two visible bones tie (Pinocchio uses 1.0001).
pub const TIE_RATIO: f64 = 1.0001;
/// Up to this many tied bones share a vertex's heat source.
pub(crate) const MAX_TIES: usize = 4;
/// A vertex whose this many nearest bones are all hidden is treated as seeing none (bounds
/// the ray casts for bone-less pieces; Pinocchio tests every bone).
pub const MAX_VISIBILITY_TESTS: usize = 12;

/// Per welded vertex: its heat source.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Source {
    /// Nearest visible bones (ties), `u32::MAX` padded.
    pub(crate) bones: [u32; MAX_TIES],
    /// Number of valid entries of `bones`; 0 = sees no bone.
    pub(crate) count: u8,
    /// Distance to the nearest visible bone(s).
    pub(crate) dist: f64,
    /// Nearest bone(s) by distance, ignoring visibility (ties within [`TIE_RATIO`], lowest
    /// indices first, so a vertex on a symmetric rig's mirror plane shares a left/right pair),
    /// and their distance.
    pub(crate) nearest: Ties,
    pub(crate) nearest_dist: f64,
}

/// The segments standing for the bones, `segs` `(s,)` (head, tail), and each one's bone
/// (`owner` `(s,)`).
#[derive(Clone, Copy)]
pub(crate) struct Segments<'a> {
    pub(crate) segs: &'a [(DVec3, DVec3)],
    pub(crate) owner: &'a [u32],
}

/// The heat source of every welded vertex: `wpos`, outward `normals` (zero: none) and piece
/// `labels` per vertex; the segments standing for the bones (`bones`); `rays` for the visibility test (`None`: every bone is visible). A vertex that
/// sees no bone, in a mesh of several pieces (`tri_piece`, the piece of each triangle) whose
/// own piece holds a bone (`inside`), looks again through its own piece only (see [`Sight`]).
/// Returned in bones, not segments.
pub(crate) fn vertex_sources(
    wpos: &[DVec3],
    normals: &[DVec3],
    labels: &[u32],
    bones: Segments,
    rays: Option<&RayMesh>,
    tri_piece: Option<&[u32]>,
    inside: &[bool],
) -> Vec<Source> {
    let Segments { segs, owner } = bones;
    let mut sources: Vec<Source> = Vec::with_capacity(wpos.len());
    let segs: Vec<Segment> = segs.iter().map(|(h, t)| Segment::new(*h, *t)).collect();
    let segs = &segs[..];
    wpos.par_iter()
        .with_min_len(256)
        .zip(normals.par_iter())
        .zip(labels.par_iter())
        .map_init(
            || Ranking::new(segs.len()),
            |scratch, ((x, n), &piece)| {
                let whole = rays.map(|rays| Sight { rays, tri_piece: None, piece, normal: *n });
                let s = nearest_visible_bone(*x, *n, segs, whole, scratch);
                if s.count > 0 || tri_piece.is_none() || !inside[piece as usize] {
                    return s.owned(owner);
                }
                let own = rays.map(|rays| Sight { rays, tri_piece, piece, normal: *n });
                nearest_visible_bone(*x, *n, segs, own, scratch).owned(owner)
            },
        )
        .collect_into_vec(&mut sources);
    sources
}

/// Every welded vertex's heat source as the solve takes it: the bones that share the vertex's
/// heat `M_ii H_ii`, bone `bone[e]` taking `heat / divisor[e]` of it for `e` in
/// `start[v]..start[v + 1]` (no entry: the vertex is no heat source). A divisor is the row's
/// total amount over the bone's, so `k` tied bones of amount 1 each take exactly `heat / k`,
/// and rows given as shares summing to 1 take those shares.
pub(crate) struct Shares {
    start: Vec<usize>,
    bone: Vec<u32>,
    divisor: Vec<f64>,
}

impl Shares {
    /// The sources found here: each vertex's tied bones share its heat equally.
    pub(crate) fn of_sources(sources: &[Source]) -> Shares {
        Shares::from_rows(sources.iter().map(|s| s.bones[..s.count as usize].iter().map(|&j| (j, 1.0))))
    }

    /// Sources given by the caller: `given` holds `(bone, amount)` rows of input vertices
    /// (`-1` and amounts that are not positive skipped), `map` sends each input vertex to its
    /// welded vertex (of `nw`); the rows of the input vertices welded into one add up per bone.
    pub(crate) fn given(given: &Influences, map: &[u32], nw: usize) -> Shares {
        let mut rows: Vec<Vec<(u32, f64)>> = vec![Vec::new(); nw];
        for (i, &w) in map.iter().enumerate() {
            let (idx, amount) = given.row(i);
            for (&j, &a) in idx.iter().zip(amount) {
                if j >= 0 && a > 0.0 {
                    rows[w as usize].push((j as u32, a as f64));
                }
            }
        }
        for row in &mut rows {
            row.sort_by_key(|e| e.0);
            row.dedup_by(|later, kept| {
                let same = later.0 == kept.0;
                if same {
                    kept.1 += later.1;
                }
                same
            });
        }
        Shares::from_rows(rows.iter().map(|row| row.iter().copied()))
    }

    fn from_rows<R: Iterator<Item = (u32, f64)> + Clone>(rows: impl Iterator<Item = R>) -> Shares {
        let mut out = Shares { start: vec![0], bone: Vec::new(), divisor: Vec::new() };
        for row in rows {
            let total: f64 = row.clone().map(|(_, a)| a).sum();
            for (j, a) in row {
                out.bone.push(j);
                out.divisor.push(total / a);
            }
            out.start.push(out.bone.len());
        }
        out
    }

    /// Vertex `v`'s `(bone, divisor)` pairs.
    pub(crate) fn row(&self, v: usize) -> impl Iterator<Item = (u32, f64)> + '_ {
        let r = self.start[v]..self.start[v + 1];
        self.bone[r.clone()].iter().copied().zip(self.divisor[r].iter().copied())
    }

    /// Is vertex `v` a heat source (does some bone take part of its heat)?
    pub(crate) fn is_source(&self, v: usize) -> bool {
        self.start[v + 1] > self.start[v]
    }
}

/// Up to [`MAX_TIES`] bones sharing one role equally.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Ties {
    pub(crate) bones: [u32; MAX_TIES],
    pub(crate) count: u8,
}

impl Ties {
    pub(crate) fn one(j: u32) -> Ties {
        Ties { bones: [j, u32::MAX, u32::MAX, u32::MAX], count: 1 }
    }

    /// Segment indices mapped to their bones (`owner`), duplicates merged.
    pub(crate) fn owned(self, owner: &[u32]) -> Ties {
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
pub(crate) fn nearest_bones(p: DVec3, bones: &[(DVec3, DVec3)]) -> Ties {
    let d: Vec<f64> = bones.iter().map(|(h, t)| closest_point_on_segment(p, *h, *t).1).collect();
    least(d.iter().copied().enumerate()).0
}

/// The indices of the least of the `(index, distance)` pairs `d`, in increasing index (ties
/// within [`TIE_RATIO`], lowest first; 0 when there is none), and that least distance.
fn least(d: impl Iterator<Item = (usize, f64)> + Clone) -> (Ties, f64) {
    let best = d.clone().fold(f64::INFINITY, |m, (_, dj)| m.min(dj));
    let mut out = Ties { bones: [u32::MAX; MAX_TIES], count: 0 };
    for (j, dj) in d {
        if dj <= best * TIE_RATIO + 1e-12 && (out.count as usize) < MAX_TIES {
            out.bones[out.count as usize] = j as u32;
            out.count += 1;
        }
    }
    if out.count == 0 {
        out = Ties::one(0);
    }
    (out, best)
}

/// Nearest visible bone(s) of the point `x` (unit frame) with unit normal `normal` (zero:
/// none), using the per-thread `scratch`.
///
/// Bones are ranked by the normal-weighted distance `d / ((cos + 1.001) / 2)` (Blender's bone
/// heat), `cos` the cosine between the normal and the direction from the bone's closest point
/// to `x`: a bone behind the surface keeps its distance, one beside it counts double, one in
/// front of it (outside the body) is all but excluded. The heat source uses that distance too.
/// `nearest` is the nearest bone by plain distance.
///
/// This runs for every vertex and bone, so only the bones whose bounding ball comes close
/// enough to matter are measured ([`ranked_near`]); all of them when that does not settle it.
fn nearest_visible_bone(
    x: DVec3,
    normal: DVec3,
    bones: &[Segment],
    sight: Option<Sight>,
    scratch: &mut Ranking,
) -> Source {
    if let Some(limit) = ranked_near(x, normal, bones, scratch) {
        if let Some(src) = walk(x, bones, scratch, sight, limit) {
            return src;
        }
    }
    scratch.candidates.clear();
    for (j, seg) in bones.iter().enumerate() {
        (scratch.euclid[j], scratch.dist[j]) = ranked_distance(x, normal, seg);
        scratch.candidates.push(j);
    }
    walk(x, bones, scratch, sight, f64::INFINITY).expect("no limit")
}

/// Per-thread work space of [`nearest_visible_bone`]: every bone's plain and weighted distance
/// (valid for the candidates only) and the candidates, in increasing index.
pub(crate) struct Ranking {
    euclid: Vec<f64>,
    dist: Vec<f64>,
    candidates: Vec<usize>,
}

impl Ranking {
    pub(crate) fn new(bones: usize) -> Ranking {
        Ranking { euclid: vec![0.0; bones], dist: vec![0.0; bones], candidates: Vec::with_capacity(bones) }
    }
}

/// Plain and normal-weighted distance from `x` to the bone `seg` (see [`nearest_visible_bone`]):
/// `d / ((cos + 1.001) / 2)` as `2 d^2 / (r . n + 1.001 d)`, `r` the offset from the bone's
/// closest point.
#[inline]
fn ranked_distance(x: DVec3, normal: DVec3, seg: &Segment) -> (f64, f64) {
    let (_, r) = seg.offset(x);
    let d2 = r.length_squared();
    let d = d2.sqrt();
    let weighted = if normal != DVec3::ZERO && d > 0.0 { 2.0 * d2 / (r.dot(normal) + 1.001 * d) } else { d };
    (d, weighted)
}

/// Measure the bones that can be the nearest ones in either ranking (the candidates) and
/// return the weighted distance below which the ranking is complete: every other bone is
/// farther. `None` if there are no bones.
///
/// A bone is no nearer than `|x - centre| - half length` (its bounding ball), and its weighted
/// distance is at least its distance over 1.0005 (`(cos + 1.001) / 2 <= 1.0005`). The bone with
/// the nearest centre gives the bounds `U` (weighted) and `E` (plain); every bone whose ball
/// comes within `max(1.001 TIE_RATIO U, TIE_RATIO E)` (plus rounding room) is measured, which
/// covers the nearest bone and its ties in both rankings. Compared squared: no square root
/// for the bones left out.
fn ranked_near(x: DVec3, normal: DVec3, bones: &[Segment], scratch: &mut Ranking) -> Option<f64> {
    let mut best = (f64::INFINITY, usize::MAX);
    for (j, seg) in bones.iter().enumerate() {
        let c2 = seg.centre_distance_squared(x);
        scratch.dist[j] = c2;
        if c2 < best.0 {
            best = (c2, j);
        }
    }
    if best.1 == usize::MAX {
        return None;
    }
    let (e, u) = ranked_distance(x, normal, &bones[best.1]);
    // Complete up to the ties of a bone as near as U (the walk's tie test, with room to spare).
    let limit = TIE_RATIO * u * (1.0 + 1e-6) + 1e-12;
    // 1e-9: rounding of the ball distances.
    let reach = (1.001 * limit).max(TIE_RATIO * e + 1e-12) * (1.0 + 1e-9) + 1e-12;
    scratch.candidates.clear();
    for (j, seg) in bones.iter().enumerate() {
        let r = reach + seg.half_length();
        if scratch.dist[j] <= r * r {
            (scratch.euclid[j], scratch.dist[j]) = ranked_distance(x, normal, seg);
            scratch.candidates.push(j);
        }
    }
    Some(limit)
}

/// The nearest visible bone(s) among the candidates of `scratch`, walking them in increasing
/// (weighted distance, index) order without sorting; `None` if the walk would need a bone
/// farther than `limit` (the candidates are complete below it only, see [`ranked_near`]).
fn walk(x: DVec3, bones: &[Segment], scratch: &Ranking, sight: Option<Sight>, limit: f64) -> Option<Source> {
    let (cand, dist, euclid) = (&scratch.candidates[..], &scratch.dist[..], &scratch.euclid[..]);
    let (nearest, nearest_dist) = least(cand.iter().map(|&j| (j, euclid[j])));
    let mut src = Source { bones: [u32::MAX; MAX_TIES], count: 0, dist: 0.0, nearest, nearest_dist };
    let mut prev = (f64::NEG_INFINITY, usize::MAX);
    let mut first: Option<f64> = None;
    for step in 0..cand.len() {
        let mut cur = (f64::INFINITY, usize::MAX);
        for &j in cand {
            let d = dist[j];
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
                return Some(src);
            }
        }
        if first.is_none() && step >= MAX_VISIBILITY_TESTS {
            return Some(src);
        }
        if cur.0 > limit {
            return None;
        }
        if is_visible(x, bones[cur.1], euclid[cur.1], sight) {
            if first.is_none() {
                if cur.0 * TIE_RATIO + 1e-12 > limit {
                    return None; // its ties may lie beyond the limit
                }
                first = Some(cur.0);
                src.dist = cur.0;
            }
            src.bones[src.count as usize] = cur.1 as u32;
            src.count += 1;
        }
        prev = cur;
    }
    // Every candidate walked: complete unless a bone beyond them could still come next.
    (first.is_some() || limit == f64::INFINITY).then_some(src)
}

/// Is the straight segment from the bone's closest point to `x` free of the surface?
/// The segment starts at the bone and stops at `(1 - 1e-4) d - 1e-6` so the faces around
/// the vertex itself do not count.
fn is_visible(x: DVec3, bone: Segment, d: f64, sight: Option<Sight>) -> bool {
    let Some(Sight { rays, tri_piece, piece, normal }) = sight else { return true };
    let stop = (1.0 - 1e-4) - 1e-6 / d.max(1e-300);
    if !(stop > 0.0) {
        return true;
    }
    let (t, _) = bone.offset(x);
    let from = bone.a + bone.ab * t;
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
/// from those few alone would spread over the whole layer (a creature's coat bound to its
/// hands, feet and tail tip, as by Blender's Ctrl+P). Vertices that see a bone keep it, so
/// parts pushed into each other still hide bones from each other. Only pieces that hold a bone
/// (as for rigid accessories) look again, so a piece beside the body with no bone in it still
/// sees none, and through its own piece a vertex sees only bones behind its surface (against
/// its outward `normal`, unless that is zero).
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

    fn prepared(bones: &[(DVec3, DVec3)]) -> Vec<Segment> {
        bones.iter().map(|(h, t)| Segment::new(*h, *t)).collect()
    }

    /// The unit cube's surface, for ray queries.
    fn unit_cube() -> RayMesh {
        let (v, t) = crate::mesh::visibility::tests::unit_cube();
        RayMesh::new(&v, &t)
    }

    /// Given sources: the rows of input vertices welded into one add up per bone (unused slots
    /// and zero amounts skipped), and each bone takes its amount over the row's total; tied
    /// bones found here take exactly `1 / k` each.
    #[test]
    fn given_shares_add_up_over_welded_copies() {
        let given = Influences {
            k: 2,
            indices: vec![0, 2, 2, -1, 1, 0, 3, 1],
            weights: vec![0.5, 0.5, 1.0, 0.0, 1.0, 0.0, 0.25, 0.75],
        };
        // input vertices 0 and 1 weld into 0; 2 and 3 stay apart.
        let shares = Shares::given(&given, &[0, 0, 1, 2], 3);
        let rows: Vec<Vec<(u32, f64)>> = (0..3).map(|v| shares.row(v).collect()).collect();
        assert_eq!(rows, vec![vec![(0, 4.0), (2, 4.0 / 3.0)], vec![(1, 1.0)], vec![(1, 4.0 / 3.0), (3, 4.0)]]);
        let mut tied = Ties { bones: [u32::MAX; MAX_TIES], count: 3 };
        tied.bones[..3].copy_from_slice(&[4, 1, 2]);
        let none =
            Source { bones: [u32::MAX; MAX_TIES], count: 0, dist: 0.0, nearest: Ties::one(0), nearest_dist: 1.0 };
        let three = Source { bones: tied.bones, count: 3, ..none };
        let shares = Shares::of_sources(&[three, none]);
        assert_eq!(shares.row(0).collect::<Vec<_>>(), vec![(4, 3.0), (1, 3.0), (2, 3.0)]);
        assert!(shares.is_source(0) && !shares.is_source(1));
    }

    /// A bone outside the mesh that is nearer than the inner bone but hidden behind a wall
    /// must not be chosen; with visibility off it is.
    #[test]
    fn hidden_bone_is_skipped() {
        let rm = unit_cube();
        let bones = [
            (DVec3::new(1.2, 0.5, 0.2), DVec3::new(1.2, 0.5, 0.8)), // outside, nearer
            (DVec3::new(0.5, 0.5, 0.2), DVec3::new(0.5, 0.5, 0.8)), // inside
        ];
        let mut scratch = Ranking::new(2);
        let p = DVec3::new(0.9, 0.5, 0.5);
        let whole = Some(Sight { rays: &rm, tri_piece: None, piece: 0, normal: DVec3::ZERO });
        let s = nearest_visible_bone(p, DVec3::ZERO, &prepared(&bones), whole, &mut scratch);
        assert_eq!((s.count, s.bones[0], s.nearest), (1, 1, Ties::one(0)));
        assert!((s.dist - 0.4).abs() < 1e-9);
        let s = nearest_visible_bone(p, DVec3::ZERO, &prepared(&bones), None, &mut scratch);
        assert_eq!((s.count, s.bones[0]), (1, 0));
        // Equidistant bones tie.
        let tie = [bones[1], (DVec3::new(0.5, 0.5, 0.8), DVec3::new(0.5, 0.5, 0.2))];
        let s = nearest_visible_bone(p, DVec3::ZERO, &prepared(&tie), whole, &mut scratch);
        assert_eq!((s.count, s.bones[0], s.bones[1]), (2, 0, 1));
    }

    /// Through its own piece a vertex sees only bones behind its surface: a bone in front of a
    /// face of the cube, which no triangle hides, is seen through the whole mesh but not
    /// through the piece; a bone inside is seen both ways.
    #[test]
    fn through_its_own_piece_a_vertex_sees_only_bones_behind_its_surface() {
        let rm = unit_cube();
        let tri_piece = vec![0u32; 12];
        let (x, normal) = (DVec3::new(1.0, 0.5, 0.5), DVec3::X);
        let front = (DVec3::new(1.5, 0.5, 0.2), DVec3::new(1.5, 0.5, 0.8));
        let behind = (DVec3::new(0.5, 0.5, 0.2), DVec3::new(0.5, 0.5, 0.8));
        let whole = Some(Sight { rays: &rm, tri_piece: None, piece: 0, normal });
        let own = Some(Sight { rays: &rm, tri_piece: Some(&tri_piece), piece: 0, normal });
        for (bone, seen_whole, seen_own) in [(front, true, false), (behind, true, true)] {
            let seg = Segment::new(bone.0, bone.1);
            assert_eq!(is_visible(x, seg, 0.5, whole), seen_whole, "{bone:?}");
            assert_eq!(is_visible(x, seg, 0.5, own), seen_own, "{bone:?}");
        }
    }

    /// Bones fanning out from one joint (a palm's fingers) are all equally near a vertex behind
    /// it: at most [`MAX_TIES`] of them share the vertex, lowest indices first, in both rankings.
    #[test]
    fn more_ties_than_the_limit_keep_the_first() {
        let hub = DVec3::new(0.5, 0.5, 0.3);
        let fan: Vec<(DVec3, DVec3)> = (0..6)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 6.0;
                (hub, hub + DVec3::new(0.2 * a.cos(), 0.2 * a.sin(), 0.3))
            })
            .collect();
        let p = DVec3::new(0.5, 0.5, 0.1); // below the hub: every finger's nearest point is the hub
        let mut scratch = Ranking::new(fan.len());
        let rm = unit_cube();
        for sight in [None, Some(Sight { rays: &rm, tri_piece: None, piece: 0, normal: DVec3::ZERO })] {
            let s = nearest_visible_bone(p, -DVec3::Z, &prepared(&fan), sight, &mut scratch);
            assert_eq!((s.count, s.bones), (MAX_TIES as u8, [0, 1, 2, 3]));
            assert!((s.dist - 0.2 / (0.5 * 2.001)).abs() < 1e-9); // straight behind: cos = 1
            assert_eq!(s.nearest, Ties { bones: [0, 1, 2, 3], count: MAX_TIES as u8 });
        }
    }

    /// Pinocchio's ties: a bone farther than the nearest by less than [`TIE_RATIO`] (relative)
    /// shares the vertex's heat source, in both rankings (nearest visible bone, and nearest by
    /// plain distance for the fallbacks); farther by more, it does not.
    #[test]
    fn near_ties_within_the_ratio_share() {
        let rm = unit_cube();
        let whole = Some(Sight { rays: &rm, tri_piece: None, piece: 0, normal: DVec3::ZERO });
        let mut scratch = Ranking::new(2);
        let p = DVec3::new(0.9, 0.5, 0.5);
        let inner = (DVec3::new(0.5, 0.5, 0.2), DVec3::new(0.5, 0.5, 0.8)); // 0.4 away
        for (rel, count) in [(0.0, 2), (0.5 * (TIE_RATIO - 1.0), 2), (5.0 * (TIE_RATIO - 1.0), 1)] {
            let y = 0.5 - 0.4 * (1.0 + rel);
            let side = (DVec3::new(0.9, y, 0.2), DVec3::new(0.9, y, 0.8));
            let s = nearest_visible_bone(p, DVec3::ZERO, &prepared(&[inner, side]), whole, &mut scratch);
            assert_eq!((s.count, s.bones[0]), (count, 0), "relative gap {rel}");
            let t = nearest_bones(p, &[inner, side]);
            assert_eq!((t.count, t.bones[0]), (count, 0), "relative gap {rel}");
        }
    }

    /// Measuring only the bones whose bounding ball comes near enough gives exactly what
    /// measuring every bone gives: random bones (some of zero length, some sharing a joint,
    /// some outside the cube and hidden), points inside and outside, with and without normals.
    #[test]
    fn pruned_ranking_equals_measuring_every_bone() {
        let rm = unit_cube();
        let mut seed = 0x9E37_79B9_7F4A_7C15u64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut pruned_settled = 0;
        for case in 0..400 {
            let nb = 1 + case % 23;
            let hub = DVec3::new(rnd(), rnd(), rnd());
            let bones: Vec<Segment> = (0..nb)
                .map(|k| {
                    let a = if k % 4 == 0 { hub } else { DVec3::new(rnd(), rnd(), rnd()) * 1.6 - 0.3 };
                    let b = if k % 7 == 3 { a } else { a + (DVec3::new(rnd(), rnd(), rnd()) - 0.5) * 0.6 };
                    Segment::new(a, b)
                })
                .collect();
            let x = DVec3::new(rnd(), rnd(), rnd()) * 1.2 - 0.1;
            let normal = match case % 3 {
                0 => DVec3::ZERO,
                _ => (DVec3::new(rnd(), rnd(), rnd()) - 0.5).normalize(),
            };
            let sight = (case % 2 == 0).then_some(Sight { rays: &rm, tri_piece: None, piece: 0, normal });
            let mut scratch = Ranking::new(nb);
            let got = nearest_visible_bone(x, normal, &bones, sight, &mut scratch);
            scratch.candidates = (0..nb).collect();
            for (j, seg) in bones.iter().enumerate() {
                (scratch.euclid[j], scratch.dist[j]) = ranked_distance(x, normal, seg);
            }
            let want = walk(x, &bones, &scratch, sight, f64::INFINITY).unwrap();
            assert_eq!(
                (got.bones, got.count, got.dist, got.nearest, got.nearest_dist),
                (want.bones, want.count, want.dist, want.nearest, want.nearest_dist),
                "case {case}"
            );
            let limit = ranked_near(x, normal, &bones, &mut scratch).unwrap();
            pruned_settled += walk(x, &bones, &scratch, sight, limit).is_some() as usize;
        }
        // The shortcut settles most cases (else this tests only the fallback).
        assert!(pruned_settled > 300, "{pruned_settled}");
    }
}
