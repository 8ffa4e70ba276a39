//! Connected pieces of the welded mesh, for the robustness rules of [`crate::weights::heat`]: each
//! piece's geometry (bounding box, area, enclosed volume, closed or not), whether a bone lies
//! inside it (ray parity), and which pieces are bound rigidly to one bone.
//!
//! Inside test ([`piece_contains_bone`]): a bone is inside a piece when at least 3 of 5 points
//! along it (head, quarters, tail) are, so a fingertip poking into a held prop does not count;
//! a point is inside when rays along a majority of fixed generic directions cross the piece's
//! own triangles an odd number of times: 2 of 3 directions for a closed piece (every edge used
//! an even number of times), 4 of 7 for an open one, for which parity is unreliable: a hole
//! spoils only the rays that leave through it, so a sleeve or a hand open at the wrist still
//! holds its bones, while a shell or a sheet (armour plate, eyelid) holds none.
//!
//! Rigid accessories ([`rigid_pieces`], [`HeatOptions::rigid_accessories`]): among the pieces
//! no larger than half the skeleton's bbox diagonal,
//! - if no piece holds a bone (the mesh is a prop, e.g. a held carrot), all pieces move as one
//!   rigid body on the bone nearest to their common centre of mass;
//! - otherwise every piece that holds no bone, except the largest one (by area), is rigid on
//!   the bone nearest to its own centre of mass (an eye, a button, a helmet) when that bone
//!   owns it: at least [`OWNED_SHARE`] of its area is nearest that bone as well. A piece that
//!   spans several bones, most of it nearer to others (a wing membrane along an arm chain, a
//!   cape, a fin), is solved by heat like the body, from each vertex's nearest visible bone, so
//!   its weights blend along those bones.
//!
//! The centre of mass is that of the enclosed volume for closed pieces, else of the area.
//! Exact ties (a piece on the mirror plane between a left and a right bone) share equally.
//! With or without accessories, a piece that sees no bone and is no larger than its nearest
//! bone is rigid on that bone; a larger one takes every vertex's nearest bone by distance as
//! its heat source.
//!
//! [`HeatOptions::rigid_accessories`]: crate::weights::heat::HeatOptions::rigid_accessories

use super::sources::{nearest_bones, Segments, Source, Ties};
use crate::mesh::visibility::RayMesh;
use glam::{DVec3, Vec3};

/// Fixed generic directions of the ray-parity inside test: the first 3 for closed pieces
/// (majority 2 of 3), all 7 for open ones (majority 4 of 7, see the module doc).
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
/// An accessory is rigid on the bone nearest its centre only when at least this share of its
/// area is nearest that bone too (see the module doc).
const OWNED_SHARE: f64 = 0.5;

/// Geometry of one connected piece (welded, unit frame).
#[derive(Clone, Debug)]
pub(crate) struct PieceStats {
    /// Has a vertex with positive mass (a usable triangle).
    pub(crate) active: bool,
    /// Some vertex sees a bone.
    pub(crate) sees: bool,
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
    pub(crate) fn size(&self) -> f64 {
        if self.hi.x >= self.lo.x {
            (self.hi - self.lo).length()
        } else {
            0.0
        }
    }

    /// Centre of mass: of the enclosed volume for a closed piece with a volume, else of the
    /// surface area, else of the bounding box.
    pub(crate) fn centre(&self) -> DVec3 {
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
/// 0 exactly when, up to hash collisions, every edge occurs an even number of times); a piece
/// is active when it has a triangle (`tris` holds non-degenerate ones only, so its vertices
/// have mass).
/// Visibility and the nearest bone come later, from [`mark_sources`].
pub(crate) fn piece_stats(labels: &[u32], npieces: usize, wpos: &[DVec3], tris: &[[u32; 3]]) -> Vec<PieceStats> {
    let mut pieces = vec![PieceStats::default(); npieces];
    for (v, &l) in labels.iter().enumerate() {
        let p = &mut pieces[l as usize];
        p.lo = p.lo.min(wpos[v]);
        p.hi = p.hi.max(wpos[v]);
    }
    let mut xor = vec![0u64; npieces];
    for t in tris {
        let l = labels[t[0] as usize] as usize;
        let p = &mut pieces[l];
        p.active = true;
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
pub(crate) fn mark_sources(pieces: &mut [PieceStats], labels: &[u32], sources: &[Source]) {
    for (s, &l) in sources.iter().zip(labels) {
        let p = &mut pieces[l as usize];
        p.sees |= s.count > 0;
        if s.nearest_dist < p.best.0 {
            p.best = (s.nearest_dist, s.nearest.bones[0]);
        }
    }
}

/// What [`rigid_pieces`] counted, for [`crate::weights::heat::HeatReport`].
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PieceCounts {
    /// Pieces with a usable triangle.
    pub(crate) pieces: usize,
    /// Of those, pieces where no vertex sees a bone.
    pub(crate) fallback: usize,
    /// Of those, pieces bound rigidly.
    pub(crate) rigid: usize,
    /// Of those, pieces with no bone inside (0 without `accessories`).
    pub(crate) boneless: usize,
    /// Of those, accessory-sized pieces solved by heat, as no one bone owns them.
    pub(crate) spanning: usize,
}

/// Per piece bound to `rigid[i]`: the share of its area (`area`, per vertex) whose nearest
/// bone by distance (`sources[v].nearest`, `labels[v]` its piece) is one of those bones; 0
/// for the other pieces.
fn owned_shares(rigid: &[Option<Ties>], labels: &[u32], sources: &[Source], area: &[f64]) -> Vec<f64> {
    let mut owned = vec![0.0f64; rigid.len()];
    let mut total = vec![0.0f64; rigid.len()];
    for ((&l, s), &a) in labels.iter().zip(sources).zip(area) {
        let Some(t) = &rigid[l as usize] else { continue };
        total[l as usize] += a;
        let near = &s.nearest.bones[..s.nearest.count as usize];
        if t.bones[..t.count as usize].iter().any(|b| near.contains(b)) {
            owned[l as usize] += a;
        }
    }
    owned.iter().zip(&total).map(|(&o, &t)| if t > 0.0 { o / t } else { 0.0 }).collect()
}

/// Per welded vertex: its piece (`labels`), its heat sources, and its area (`area()`, made
/// only when needed).
pub(crate) struct VertexPieces<'a> {
    pub(crate) labels: &'a [u32],
    pub(crate) sources: &'a [Source],
    pub(crate) area: &'a dyn Fn() -> Vec<f64>,
}

/// The object of each piece (`groups` `(pieces,)`) and, when faces decide it, whether each
/// piece's object holds a bone (`holds` `(pieces,)`).
#[derive(Clone, Copy)]
pub(crate) struct PieceObjects<'a> {
    pub(crate) groups: &'a [u32],
    pub(crate) holds: Option<&'a [bool]>,
}

/// The bone(s) each piece is bound to rigidly, `None` for pieces solved by heat (the rules
/// are in the module doc; `objects.groups` `(pieces,)` is the object of each piece, a prop
/// being an object whose pieces hold no bone, or with `objects.holds` `(pieces,)`, whose
/// pieces' object holds none; one object when all are equal). `accessories`: apply the
/// accessory rules (`inside[i]`: piece `i` holds a bone; `vertices`, per welded vertex its
/// piece, its sources and its area, for the owner test); with or without them, a piece that
/// sees no bone and is no larger than its nearest bone (`bone_len`, per bone, of the segments
/// `bones`) is rigid on that bone.
pub(crate) fn rigid_pieces(
    pieces: &[PieceStats],
    inside: &[bool],
    bones: Segments,
    bone_len: &[f64],
    accessories: bool,
    vertices: VertexPieces,
    objects: PieceObjects,
) -> (Vec<Option<Ties>>, PieceCounts) {
    let (Segments { segs, owner }, PieceObjects { groups, holds }) = (bones, objects);
    let VertexPieces { labels, sources, area } = vertices;
    let npieces = pieces.len();
    let mut rigid: Vec<Option<Ties>> = vec![None; npieces];
    let mut counts = PieceCounts::default();
    if accessories {
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for (h, t) in segs {
            lo = lo.min(h.min(*t));
            hi = hi.max(h.max(*t));
        }
        let max_size = ACCESSORY_SIZE * (hi - lo).length();
        let active: Vec<usize> = (0..npieces).filter(|&i| pieces[i].active).collect();
        counts.boneless = active.iter().filter(|&&i| !inside[i]).count();
        let largest = active.iter().copied().max_by(|&a, &b| pieces[a].area.total_cmp(&pieces[b].area));
        // Props: objects whose pieces all hold no bone, one rigid body each.
        let mut objects: Vec<u32> = active.iter().map(|&i| groups[i]).collect();
        objects.sort_unstable();
        objects.dedup();
        let mut prop = vec![false; npieces];
        for g in objects {
            let members: Vec<usize> = active.iter().copied().filter(|&i| groups[i] == g).collect();
            let union = members.iter().fold(PieceStats::default(), |u, &i| u.merged(&pieces[i]));
            let boneless = match holds {
                Some(h) => members.iter().all(|&i| !h[i]),
                None => members.iter().all(|&i| !inside[i]),
            };
            if boneless && union.size() <= max_size {
                let ties = nearest_bones(union.centre(), segs).owned(owner);
                for &i in &members {
                    rigid[i] = Some(ties);
                    prop[i] = true;
                }
            }
        }
        let candidates: Vec<usize> = (active.iter().copied())
            .filter(|&i| !prop[i] && !inside[i] && Some(i) != largest && pieces[i].size() <= max_size)
            .collect();
        for &i in &candidates {
            rigid[i] = Some(nearest_bones(pieces[i].centre(), segs).owned(owner));
        }
        if !candidates.is_empty() {
            // Rigid only when that bone owns the piece; one spanning several bones is solved.
            let share = owned_shares(&rigid, labels, sources, &area());
            for &i in &candidates {
                if share[i] < OWNED_SHARE {
                    rigid[i] = None;
                    counts.spanning += 1;
                }
            }
        }
    }
    for (i, p) in pieces.iter().enumerate() {
        if !p.active {
            continue;
        }
        counts.pieces += 1;
        if !p.sees {
            counts.fallback += 1;
            if rigid[i].is_none() && p.size() <= bone_len[p.best.1 as usize] {
                rigid[i] = Some(Ties::one(p.best.1));
            }
        }
        counts.rigid += rigid[i].is_some() as usize;
    }
    (rigid, counts)
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
pub(crate) fn piece_contains_bone(
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
