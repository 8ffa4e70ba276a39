//! Skeleton fitting: move rough joints to the middle of the mesh around them.
//!
//! A rigger places joints by eye; they end up off-centre or outside the surface. Here every
//! bone gets a *centre line*: at a few points along the bone the mesh is cut by the plane
//! perpendicular to the bone, the point is moved to the centre of that cross-section (the
//! least-squares point of the chord midpoints of rays cast in the plane, iterated to its fixed
//! point: the exact centre of a circle or ellipse), and a line is fitted through the centres
//! (perpendicular offset linear in the bone parameter). A joint then goes to the point nearest
//! to the centre lines of its bones (their intersection at a bend; along a straight chain, where
//! the mesh says nothing about the position along the limb, it keeps its own position), and
//! the process repeats until nothing moves. Sampling inside the bones rather than at the joint
//! keeps junctions (a shoulder sitting inside the torso) from pulling a joint into the body,
//! and a stub bone leaving a junction (shorter than its sections are wide: pelvis to hip, chest
//! to shoulder) has no centre line at all, since its sections are slices of the body it lies in.
//!
//! Do no harm: a rough joint must not end farther from its place than it started. So a joint
//! moves only where its lines are trustworthy: a bone far shorter than its part is thick has no
//! line (`thick_ratio`), a flat section places its bone across its short axis only
//! (`flat_ratio`), a junction needs lines from two of its bones, two or more lines must agree
//! on a point (`agreement`), in a body (radius above `body_radius`) a joint moves only until it
//! is within (radius - `body_radius`) of its lines' point, and a joint farther than `max_move`
//! outside the mesh (a root on the ground, a pole target) keeps its place.
//!
//! Inside/outside is decided by ray parity (crossings of the union of the pieces along
//! several fixed directions, majority vote), so it is reliable on closed pieces and
//! approximate on open ones. Joints still outside at the end are pulled to the middle of the
//! nearest chord of the mesh.
//!
//! Everything runs in the unit frame of the mesh (bounding-box diagonal 1, see
//! [`crate::mesh::Frame`]), so tolerances are scale-free. The sections, centre lines and
//! inside tests are in `sections.rs`; their rays read a mesh of parts pushed into each other
//! (kit-built and game models) as their union ([`Solid::hits`]).
//!
//! See also: `symmetry.rs` (mirror maps), Baran & Popovic 2007 (Pinocchio's embedding also
//! centres joints in the medial surface; this is a much simpler local version).
//! Known limits: a joint of a straight limb keeps its position along the limb; parity is
//! unreliable on meshes with large holes.

use crate::mesh::mirror::mirror_point;
pub use crate::mesh::mirror::Symmetry;
use crate::mesh::solid::Solid;
use crate::mesh::{to_dvec, validate_mesh, Frame};
use crate::skeleton::sections::{centre_line, inside, pull_inside, Line, LineOptions};
use crate::{Error, Result};
use glam::{DMat3, DVec3};
use rayon::prelude::*;

/// Most chord directions per cross-section (far past any gain; bounds the work and memory).
pub const MAX_RAYS: usize = 1024;
/// Most cross-sections per bone.
pub const MAX_SAMPLES: usize = 1024;

/// Options of [`fit_joints`].
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// Mirrored pairs end exactly mirrored, centre-line joints on the plane.
    /// [`Symmetry::mirror`] is `(j,)`: the mirror joint of each joint, itself for centre-line
    /// joints, -1 for a joint with no partner (a side joint whose mirror is missing: fitted on
    /// its own). A centre-line joint farther than `max_move` from the plane is fitted on its
    /// own too.
    pub symmetry: Option<Symmetry>,
    /// Lines (chord directions) per cross-section, 3 ..= [`MAX_RAYS`].
    pub rays: usize,
    /// Cross-sections per bone, 1 ..= [`MAX_SAMPLES`], evenly spread over the inner 60 % of the bone.
    pub samples: usize,
    /// Maximum rounds (centre lines, then joints).
    pub rounds: usize,
    /// Stop when no joint moves more than this (fraction of the bounding-box diagonal).
    pub tolerance: f64,
    /// A joint moves along a direction only if its bones' centre lines pin it down there
    /// more than this (eigenvalue of the summed line projectors, per line; 1 - cos of the bend
    /// angle for two lines, so 0.05 trusts bends sharper than ~18 degrees).
    pub stiffness: f64,
    /// Put free limb ends (a bone's tail with no other bone) one local radius short of the tip
    /// of the mesh beyond them, where the medial axis of a rounded end stops.
    pub tip: bool,
    /// A bone leaving a junction (a joint with 3 or more bones) whose thinnest cross-section
    /// has a radius above this fraction of its length is a stub inside a body part (pelvis to
    /// hip, chest to shoulder) and gives its joints no centre line: sections across a torso
    /// would drag a hip or shoulder toward the torso's middle. Chains (a spine, a thick tail)
    /// are not junctions and keep their lines. 0 disables. Default 0.5 (the section is wider
    /// than the bone is long).
    pub stub_ratio: f64,
    /// A joint moves at most this far while fitting (fraction of the bounding-box diagonal; the
    /// final pull inside may add more): how rough the input skeleton is assumed to be. Large
    /// moves are where the centre lines of body sections mislead junction joints.
    pub max_move: f64,
    /// A bone needs at least this many usable cross-sections (or all `samples`, if fewer) for a
    /// centre line. One section pins a point, not a direction: when the bone's other sections
    /// are slices of another part (an upper leg whose top runs into a torso), following the
    /// bone's own direction through that one point lets its joints drift round after round.
    pub min_sections: usize,
    /// A cross-section more than this many times as long as it is wide (a wing, a flat tail, a
    /// flattened body) places its bone across its short axis only: along the long axis its centre
    /// is the middle of the whole flat part (a wing's middle, not its leading-edge bone), so the
    /// bone keeps its offset there. 0 disables. Default 3.
    pub flat_ratio: f64,
    /// Any bone (not only a stub leaving a junction, see `stub_ratio`) whose thinnest
    /// cross-section has a radius above this multiple of its length gives no centre line: a short
    /// bone deep in a thick part (a spine link in a belly, a jaw in a head) is cut into slices of
    /// the whole part, whose centre is not where the artist puts the bone. 0 disables.
    /// Default 1.5.
    pub thick_ratio: f64,
    /// A joint with two or more centre lines moves only when the point nearest to them lies
    /// within this many local radii of each line (the lines agree on a place); lines that miss
    /// each other by more come from sections of different parts (a hip's thigh line and a
    /// belly's spine line), and the joint keeps its place. 0 disables. Default 1.
    pub agreement: f64,
    /// Parts whose radius is above this (fraction of the bounding-box diagonal) are bodies (a
    /// torso, a head): there the artist's joint may lie off the centre of the sections (a hip
    /// in a belly, a shoulder in a chest), so a joint moves toward its lines' point only until
    /// it is within (radius - `body_radius`) of it, and a joint already that near keeps its
    /// place. Limbs thinner than this are centred fully. `f64::INFINITY` disables. Default 0.05
    /// (a human's torso and head are bodies, its arms and legs limbs).
    pub body_radius: f64,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            symmetry: None,
            rays: 12,
            samples: 5,
            rounds: 12,
            tolerance: 1e-4,
            stiffness: 0.05,
            tip: true,
            stub_ratio: 0.5,
            max_move: 0.12,
            min_sections: 2,
            flat_ratio: 3.0,
            thick_ratio: 1.5,
            agreement: 1.0,
            body_radius: 0.05,
        }
    }
}

/// What [`fit_joints`] did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FitReport {
    /// `(j,)` joint was outside the mesh before / after fitting (ray parity).
    pub outside_before: Vec<bool>,
    pub outside_after: Vec<bool>,
    /// `(j,)` movable joint that started farther than `max_move` outside the mesh and kept its
    /// place (a root on the ground, a pole target).
    pub kept_outside: Vec<bool>,
    /// Rounds run.
    pub rounds: usize,
    /// Largest joint displacement, input units.
    pub max_move: f64,
    /// Mesh checks (after welding coincident vertices): boundary edges (one triangle),
    /// non-manifold edges (more than two), connected pieces.
    pub open_edges: usize,
    pub nonmanifold_edges: usize,
    pub pieces: usize,
    /// With symmetry: the share of the mesh's vertices (at most [`MIRROR_SAMPLES`], evenly
    /// spread) whose mirror image across the plane lies within [`MIRROR_NEAR`] of the surface;
    /// 1 for a mirror-symmetric mesh, low for a posed scan or a mesh off the plane, where
    /// mirrored joints can end outside. `None` without symmetry.
    pub mirrored_surface: Option<f64>,
    /// With symmetry: joints given as centre-line joints (their own mirror) that lie farther
    /// than `max_move` from the plane, and were fitted without symmetry (see [`fit_joints`]).
    pub off_plane_centre: usize,
}

impl FitReport {
    pub fn count_outside_before(&self) -> usize {
        self.outside_before.iter().filter(|&&o| o).count()
    }
    pub fn count_outside_after(&self) -> usize {
        self.outside_after.iter().filter(|&&o| o).count()
    }
}

/// With symmetry, the joints may have to move at most this far on average (fraction of the
/// diagonal) to meet their mirror images; farther, and the plane is not the rig's own (a
/// character facing +X, an armature origin off the body), so the fit refuses.
const MIRROR_MISMATCH: f64 = 0.1;
/// Vertices sampled for [`FitReport::mirrored_surface`].
pub const MIRROR_SAMPLES: usize = 4096;
/// A mirrored vertex this close to the surface (fraction of the diagonal) has a mirror image.
pub const MIRROR_NEAR: f64 = 0.01;
/// Hits closer than this (unit frame) along one ray count once (shared edges report twice).
pub(crate) const DEDUP: f32 = 1e-6;
/// Vertices this close (unit frame) are one: pieces and mesh checks are taken after welding.
pub(crate) const WELD: f64 = 1e-6;
/// Eigenvalues (ascending) and unit eigenvectors of a symmetric 3x3 matrix (faer's
/// self-adjoint eigendecomposition); `None` if it does not converge (a non-finite matrix).
fn sym_eigen(m: DMat3) -> Option<([f64; 3], [DVec3; 3])> {
    let a = faer::Mat::<f64>::from_fn(3, 3, |r, c| m.col(c)[r]);
    let evd = a.self_adjoint_eigen(faer::Side::Lower).ok()?;
    let (s, u) = (evd.S(), evd.U());
    Some((std::array::from_fn(|k| s[k]), std::array::from_fn(|k| DVec3::new(u[(0, k)], u[(1, k)], u[(2, k)]))))
}

/// Mesh checks in the unit frame: (open edges, non-manifold edges, pieces) after welding.
fn topology(unit: &[DVec3], triangles: &[[u32; 3]]) -> (usize, usize, usize) {
    let (map, welded) = crate::mesh::weld::weld(unit, WELD);
    let tris: Vec<[u32; 3]> = triangles
        .iter()
        .map(|t| t.map(|i| map[i as usize]))
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
        .collect();
    let mut edges: Vec<(u32, u32)> = tris
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect();
    edges.par_sort_unstable();
    let (mut open, mut nonmanifold) = (0, 0);
    let mut i = 0;
    while i < edges.len() {
        let mut j = i;
        while j < edges.len() && edges[j] == edges[i] {
            j += 1;
        }
        match j - i {
            1 => open += 1,
            2 => {}
            _ => nonmanifold += 1,
        }
        i = j;
    }
    // Pieces among the vertices that triangles use.
    let (labels, _) = crate::mesh::islands::connected_components(welded.len(), &tris);
    let mut used = vec![false; welded.len()];
    for t in &tris {
        for &i in t {
            used[i as usize] = true;
        }
    }
    let mut seen = std::collections::HashSet::new();
    for (v, &l) in labels.iter().enumerate() {
        if used[v] {
            seen.insert(l);
        }
    }
    (open, nonmanifold, seen.len())
}

/// Which of `points` `(p, 3)` lie inside the closed mesh (`vertices` `(n, 3)`, `triangles`
/// `(m, 3)`, same unit), by ray parity with a majority vote over 7 directions. `(p,)` bools.
/// Errors as [`validate_mesh`] with faces required.
pub fn points_inside(vertices: &[[f32; 3]], triangles: &[[u32; 3]], points: &[[f32; 3]]) -> Result<Vec<bool>> {
    validate_mesh(vertices, triangles, true)?;
    let frame = Frame::of_mesh(vertices, triangles);
    let unit: Vec<[f32; 3]> = frame.normalize(vertices).iter().map(|p| p.as_vec3().to_array()).collect();
    let rm = Solid::new(&unit, triangles, WELD, DEDUP);
    Ok(points.par_iter().map(|p| p.iter().all(|c| c.is_finite()) && inside(&rm, frame.to_unit(*p))).collect())
}

/// Fit joints into a mesh.
///
/// Inputs (one common space, any unit):
/// * `vertices` `(n, 3)`, `triangles` `(m, 3)`: the mesh (several pieces allowed; closed
///   pieces give reliable inside tests).
/// * `joints` `(j, 3)`: joint positions; a joint shared by several bones appears once.
/// * `bones` `(b, 2)`: `[head joint, tail joint]` per bone (indices into `joints`, distinct).
///   A joint's direction comes from its bones; a joint with no bone is only pulled inside.
/// * `movable` `(j,)`: joints that may move (the others stay, but their bones still count).
/// * `opts`: see [`FitOptions`].
///
/// Output: `(joints (j, 3), report)`. Joints end at the point nearest the centre lines of their
/// bones (see the module's "do no harm" rules for when they keep their place); joints outside
/// the mesh at the end are pulled to the middle of the nearest chord, except those that
/// started farther than `opts.max_move` outside ([`FitReport::kept_outside`]);
/// with symmetry, mirrored pairs are exact mirror images and centre-line joints lie on the
/// plane, except centre-line joints farther than `opts.max_move` from it, which are fitted on
/// their own ([`FitReport::off_plane_centre`]). Fitting an already fitted skeleton changes it
/// by at most about `opts.tolerance`.
///
/// Errors: `EmptyMesh` (no vertices, no triangles, only degenerate triangles), `NonFinite`
/// (mesh or joints), `BadIndex`, `NoBones` (no joints), `Shape` (`movable` or mirror length),
/// `InvalidArgument` (bone index out of range or head == tail, symmetry axis > 2, bad option).
pub fn fit_joints(
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
    joints: &[[f32; 3]],
    bones: &[[u32; 2]],
    movable: &[bool],
    opts: &FitOptions,
) -> Result<(Vec<[f32; 3]>, FitReport)> {
    // Everything is checked before the solid is built; fit_in checks the joints and the
    // symmetry again for its other caller, Auto Rig.
    validate_mesh(vertices, triangles, true)?;
    validate(joints, bones, movable, opts)?;
    let frame = Frame::of_mesh(vertices, triangles);
    if let Some(s) = &opts.symmetry {
        Mirror::new(s, joints.len(), &frame)?;
    }
    let unit_v = frame.normalize(vertices);
    let unit: Vec<[f32; 3]> = unit_v.iter().map(|p| p.as_vec3().to_array()).collect();
    // Both are mostly serial (weld, components, parry's BVH build): side by side they take the
    // time of the longer.
    let ((open_edges, nonmanifold_edges, pieces), rm) =
        rayon::join(|| topology(&unit_v, triangles), || Solid::new(&unit, triangles, WELD, DEDUP));
    let (out, report) =
        fit_in(&Fitted { frame, unit_v: &unit_v, unit: &unit, solid: &rm }, joints, bones, movable, opts)?;
    Ok((out, FitReport { open_edges, nonmanifold_edges, pieces, ..report }))
}

/// A mesh prepared for [`fit_in`]: its frame, its vertices in the frame's unit coordinates
/// (`f64` and `f32`) and the solid built on them with [`WELD`] and [`DEDUP`].
pub(crate) struct Fitted<'a> {
    pub frame: Frame,
    pub unit_v: &'a [DVec3],
    pub unit: &'a [[f32; 3]],
    pub solid: &'a Solid,
}

/// [`fit_joints`] on a mesh already prepared (a caller that holds its solid: Auto Rig), joints
/// in the mesh's input units; the report's mesh checks (open and non-manifold edges, pieces)
/// are left at 0.
pub(crate) fn fit_in(
    mesh: &Fitted,
    joints: &[[f32; 3]],
    bones: &[[u32; 2]],
    movable: &[bool],
    opts: &FitOptions,
) -> Result<(Vec<[f32; 3]>, FitReport)> {
    validate(joints, bones, movable, opts)?;
    let Fitted { frame, unit_v, unit, solid: rm } = *mesh;
    let nj = joints.len();
    let mut sym = opts.symmetry.as_ref().map(|s| Mirror::new(s, nj, &frame)).transpose()?;
    let mut p: Vec<DVec3> = joints.iter().map(|j| frame.to_unit(*j)).collect();
    let off_plane_centre = sym.as_mut().map_or(0, |m| m.free_far_centre(&p, opts.max_move));
    if let (Some(m), Some(s)) = (&sym, &opts.symmetry) {
        m.check_plane(&p, s.plane)?;
    }
    if rm.rays.triangle_count() == 0 {
        return Err(Error::EmptyMesh("every triangle of the mesh is degenerate".into()));
    }

    let mirrored_surface = sym.as_ref().map(|m| mirrored_share(&rm.rays, unit, m.axis, m.plane));
    let mut incident: Vec<Vec<usize>> = vec![Vec::new(); nj];
    for (e, b) in bones.iter().enumerate() {
        incident[b[0] as usize].push(e);
        incident[b[1] as usize].push(e);
    }
    let outside_before: Vec<bool> = p.par_iter().map(|q| !inside(rm, *q)).collect();
    // A joint farther outside than a rough joint can be from its place (`max_move` from the
    // nearest point inside) was put there on purpose (a root on the ground, a pole target, a
    // tail tip past the mesh): it keeps its place.
    let kept_outside: Vec<bool> = (0..nj)
        .into_par_iter()
        .map(|j| {
            if !outside_before[j] || !movable[j] {
                return false;
            }
            let others = incident[j].iter().map(|&e| p[(bones[e][0] + bones[e][1]) as usize - j]);
            pull_inside(rm, p[j], None, &toward(unit_v, p[j], others))
                .is_none_or(|c| (c - p[j]).length() > opts.max_move)
        })
        .collect();
    let movable_in: Vec<bool> = movable.iter().zip(&kept_outside).map(|(&m, &f)| m && !f).collect();
    let movable = &movable_in[..];
    let start = p.clone();
    let symmetrize = |p: &mut Vec<DVec3>| {
        if let Some(m) = &sym {
            m.symmetrize(p, movable);
        }
    };

    let line_opts = LineOptions {
        rays: opts.rays,
        min_sections: opts.min_sections,
        samples: opts.samples,
        stub_ratio: opts.stub_ratio,
        tip: opts.tip,
        flat_ratio: opts.flat_ratio,
        thick_ratio: opts.thick_ratio,
    };
    let fractions: Vec<f64> = (0..opts.samples)
        .map(|s| if opts.samples == 1 { 0.5 } else { 0.2 + 0.6 * s as f64 / (opts.samples - 1) as f64 })
        .collect();
    let mut rounds = 0;
    symmetrize(&mut p);
    // Each bone's centre line depends only on its two joints: kept from the last round for the
    // bones whose joints did not move (a rig's joints settle, and a hair strand outside the
    // mesh never moves: a 4022-bone rig recast every line of every round).
    let mut lines: Vec<Option<Line>> = Vec::new();
    let mut lines_at: Vec<DVec3> = Vec::new();
    for _ in 0..opts.rounds {
        rounds += 1;
        // 1. Centre line per bone.
        lines = bones
            .par_iter()
            .enumerate()
            .map(|(e, b)| {
                let (a, t) = (p[b[0] as usize], p[b[1] as usize]);
                if !lines_at.is_empty() && lines_at[b[0] as usize] == a && lines_at[b[1] as usize] == t {
                    return lines[e].clone();
                }
                let junction = incident[b[0] as usize].len() >= 3;
                centre_line(rm, a, t, junction, &fractions, &line_opts)
            })
            .collect();
        lines_at = p.clone();
        // 2. Each joint: nearest point to its bones' centre lines, pulled to itself.
        let mut next = p.clone();
        for j in (0..nj).filter(|&j| movable[j]) {
            let free_end = incident[j].len() == 1 && bones[incident[j][0]][1] as usize == j;
            let mine: Vec<&Line> = incident[j].iter().filter_map(|&e| lines[e].as_ref()).collect();
            // A junction (3 or more bones) held by one line would follow a single limb into the
            // body part it joins.
            if incident[j].len() >= 3 && mine.len() < 2 {
                continue;
            }
            if let Some(c) = place_joint(p[j], &mine, free_end, opts) {
                next[j] = c;
            }
        }
        // Never wander off: a rough joint is near its place (MAX_MOVE of the diagonal).
        for (q, q0) in next.iter_mut().zip(&start) {
            let d = *q - *q0;
            if d.length() > opts.max_move {
                *q = *q0 + d * (opts.max_move / d.length());
            }
        }
        symmetrize(&mut next);
        let step = p.iter().zip(&next).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
        p = next;
        if step < opts.tolerance {
            break;
        }
    }

    // 3. Joints still outside: middle of the nearest chord (centre-line joints stay on the plane).
    let outside: Vec<bool> = p.par_iter().map(|q| !inside(rm, *q)).collect();
    let pulled: Vec<Option<DVec3>> = (0..nj)
        .into_par_iter()
        .map(|j| {
            if !outside[j] || !movable[j] {
                return None;
            }
            let plane = sym.as_ref().and_then(|m| (m.mirror[j] == Some(j)).then_some(m.axis));
            let others = incident[j].iter().map(|&e| p[(bones[e][0] + bones[e][1]) as usize - j]);
            pull_inside(rm, p[j], plane, &toward(unit_v, p[j], others))
        })
        .collect();
    for j in 0..nj {
        if let Some(c) = pulled[j] {
            p[j] = c;
        }
    }
    if let Some(m) = &sym {
        for j in 0..nj {
            let Some(k) = m.mirror[j] else { continue };
            if k != j && movable[j] && pulled[j].is_some() && pulled[k].is_none() {
                // The pulled side wins; its partner follows exactly.
                if movable[k] {
                    p[k] = mirror_point(p[j], m.axis, m.plane);
                }
            }
        }
        symmetrize(&mut p);
    }
    let outside_after: Vec<bool> = p.par_iter().map(|q| !inside(rm, *q)).collect();

    let mut out: Vec<[f32; 3]> = p
        .iter()
        .zip(joints)
        .zip(movable)
        .map(|((q, j), &mv)| if mv { frame.from_unit(*q).as_vec3().to_array() } else { *j })
        .collect();
    if let (Some(s), Some(m)) = (&opts.symmetry, &sym) {
        exact_mirrors(&mut out, s, &m.mirror, movable);
    }
    let max_move = out.iter().zip(joints).map(|(a, b)| (to_dvec(*a) - to_dvec(*b)).length()).fold(0.0, f64::max);
    let report = FitReport {
        outside_before,
        outside_after,
        kept_outside,
        rounds,
        max_move,
        open_edges: 0,
        nonmanifold_edges: 0,
        pieces: 0,
        mirrored_surface,
        off_plane_centre,
    };
    Ok((out, report))
}

/// Check the joints, bones and options of [`fit_joints`] (its errors but the mesh's and the
/// symmetry's).
fn validate(joints: &[[f32; 3]], bones: &[[u32; 2]], movable: &[bool], opts: &FitOptions) -> Result<()> {
    let nj = joints.len();
    if nj == 0 {
        return Err(Error::NoBones("no joints to fit".into()));
    }
    let bad = crate::mesh::count_non_finite(joints);
    if bad > 0 {
        return Err(Error::NonFinite { what: "joint", count: bad });
    }
    if movable.len() != nj {
        return Err(Error::Shape(format!("{} movable flags for {nj} joints", movable.len())));
    }
    for (i, b) in bones.iter().enumerate() {
        if b[0] as usize >= nj || b[1] as usize >= nj || b[0] == b[1] {
            return Err(Error::InvalidArgument(format!(
                "bone {i} joins joints {} and {}, but there are {nj} joints (and they must differ)",
                b[0], b[1]
            )));
        }
    }
    if !(3..=MAX_RAYS).contains(&opts.rays)
        || !(1..=MAX_SAMPLES).contains(&opts.samples)
        || !(opts.stiffness > 0.0)
        || !(opts.tolerance > 0.0)
        || !(opts.max_move > 0.0)
        || !(opts.stub_ratio >= 0.0)
        || !(opts.flat_ratio >= 0.0)
        || !(opts.thick_ratio >= 0.0)
        || !(opts.agreement >= 0.0)
        || !(opts.body_radius >= 0.0)
    {
        return Err(Error::InvalidArgument(format!(
            "fit options: rays 3..={MAX_RAYS}, samples 1..={MAX_SAMPLES}, stiffness > 0, tolerance > 0, \
                 max_move > 0, stub_ratio, flat_ratio, thick_ratio, agreement and body_radius >= 0"
        )));
    }
    Ok(())
}

/// [`Symmetry`] in the unit frame: the axis, the plane's coordinate on it, and each joint's
/// mirror partner where the pair agrees both ways (itself for centre-line joints).
struct Mirror {
    axis: usize,
    plane: f64,
    mirror: Vec<Option<usize>>,
}

impl Mirror {
    fn new(s: &Symmetry, nj: usize, frame: &Frame) -> Result<Mirror> {
        if s.axis > 2 {
            return Err(Error::InvalidArgument(format!("symmetry axis must be 0, 1 or 2, got {}", s.axis)));
        }
        if s.mirror.len() != nj {
            return Err(Error::Shape(format!("{} mirror indices for {nj} joints", s.mirror.len())));
        }
        if !s.plane.is_finite() {
            return Err(Error::NonFinite { what: "symmetry plane", count: 1 });
        }
        let raw: Vec<Option<usize>> =
            s.mirror.iter().map(|&m| (m >= 0 && (m as usize) < nj).then_some(m as usize)).collect();
        // Only keep pairs that agree both ways; the others are free.
        let mirror: Vec<Option<usize>> = (0..nj).map(|i| raw[i].filter(|&m| raw[m] == Some(i))).collect();
        Ok(Mirror { axis: s.axis, plane: (s.plane - frame.centre[s.axis]) / frame.diagonal, mirror })
    }

    /// Centre-line joints (their own mirror) farther than `max_move` from the plane become free
    /// and are counted: the fit never moves a rough joint that far, so such a joint is a side
    /// joint whose bones' names carry no side (an arm named "upper_arm"), and pulling it onto
    /// the plane would fold the limb into the body's middle.
    fn free_far_centre(&mut self, p: &[DVec3], max_move: f64) -> usize {
        let mut freed = 0;
        for (j, m) in self.mirror.iter_mut().enumerate() {
            if *m == Some(j) && (p[j][self.axis] - self.plane).abs() > max_move {
                *m = None;
                freed += 1;
            }
        }
        freed
    }

    /// Refuse a plane the joints `p` are far from mirrored across (see [`MIRROR_MISMATCH`]);
    /// `input_plane` names it in the error.
    fn check_plane(&self, p: &[DVec3], input_plane: f64) -> Result<()> {
        // Half the distance to the mirror image's partner: how far symmetrizing moves a joint.
        let moves: Vec<f64> = (0..p.len())
            .filter_map(|i| self.mirror[i].map(|m| 0.5 * (p[i] - mirror_point(p[m], self.axis, self.plane)).length()))
            .collect();
        let mean = moves.iter().sum::<f64>() / moves.len().max(1) as f64;
        if mean > MIRROR_MISMATCH {
            return Err(Error::InvalidArgument(format!(
                "symmetry: the joints are far from mirror images across {} = {input_plane}: each would move {:.0} % of \
                 the mesh size on average to meet its mirror (at most {:.0} % expected). Is that the \
                 character's mirror plane? Fit without symmetry",
                ["x", "y", "z"][self.axis],
                100.0 * mean,
                100.0 * MIRROR_MISMATCH
            )));
        }
        Ok(())
    }

    /// Movable paired joints to the mean of themselves and their partner's mirror image (the
    /// image alone when the partner is fixed), centre-line joints onto the plane.
    fn symmetrize(&self, p: &mut [DVec3], movable: &[bool]) {
        let old = p.to_vec();
        for i in 0..p.len() {
            let Some(m) = self.mirror[i] else { continue };
            if !movable[i] {
                continue;
            }
            p[i] = if m == i {
                let mut q = old[i];
                q[self.axis] = self.plane;
                q
            } else if movable[m] {
                (old[i] + mirror_point(old[m], self.axis, self.plane)) * 0.5
            } else {
                mirror_point(old[m], self.axis, self.plane)
            };
        }
    }
}

/// Where a joint at `p` goes: least squares to its bones' centre `lines`, only along the
/// directions they pin down (eigenvalue of the summed projectors above `opts.stiffness`); along
/// the others (a straight limb) it keeps its place, which makes the fit a fixed point
/// (idempotent). Two or more lines must agree: the point must lie within `opts.agreement` local
/// radii of each. In a part thicker than `opts.body_radius` the joint moves only until it is
/// within (radius - `body_radius`) of that point: in a body the artist's joint may lie that
/// far off the centre of the sections (a hip in a belly, a shoulder in a chest). A limb's `free_end` (a bone's tail and nothing
/// else) goes to its line's tip when there is one. `None` without a line, when the lines
/// disagree, or for a non-finite result.
fn place_joint(p: DVec3, lines: &[&Line], free_end: bool, opts: &FitOptions) -> Option<DVec3> {
    let mut m = DMat3::ZERO;
    let mut rhs = DVec3::ZERO;
    for line in lines {
        let u = line.dir;
        let proj = DMat3::IDENTITY - DMat3::from_cols(u * u.x, u * u.y, u * u.z);
        m += proj;
        rhs += proj * line.head;
    }
    let last = lines.last()?;
    let g = rhs - m * p;
    let (vals, vecs) = sym_eigen(m)?;
    let mut c = p;
    for k in 0..3 {
        if vals[k] > opts.stiffness {
            c += vecs[k] * (vecs[k].dot(g) / vals[k]);
        }
    }
    if opts.agreement > 0.0 && lines.len() >= 2 && lines.iter().any(|l| off_line(c, l) > opts.agreement * l.radius) {
        return None;
    }
    let thick = lines.iter().map(|l| l.radius).fold(0.0, f64::max);
    let slack = (thick - opts.body_radius).max(0.0);
    let d = c - p;
    c = if d.length() <= slack { p } else { p + d * (1.0 - slack / d.length()) };
    if let (true, Some(t)) = (free_end, last.tip) {
        c = t;
    }
    c.is_finite().then_some(c)
}

/// Distance of `c` from the line `l`.
fn off_line(c: DVec3, l: &Line) -> f64 {
    let rel = c - l.head;
    (rel - l.dir * rel.dot(l.dir)).length()
}

/// Points a joint at `p` outside the mesh may be pulled toward: the 24 nearest vertices
/// (brute force: few joints are outside) and the joints at the other ends of its bones.
fn toward(unit_v: &[DVec3], p: DVec3, others: impl Iterator<Item = DVec3>) -> Vec<DVec3> {
    let mut near: Vec<(f64, DVec3)> = unit_v.iter().map(|v| ((*v - p).length_squared(), *v)).collect();
    let k = near.len().min(24);
    if k > 0 && k < near.len() {
        near.select_nth_unstable_by(k - 1, |a, b| a.0.total_cmp(&b.0));
    }
    near[..k].iter().map(|x| x.1).chain(others).collect()
}

/// Exact mirror images in input units (the unit frame round trip is not exact): centre-line
/// joints onto `s.plane`, each movable pair's second joint the image of its first (of the fixed
/// one when its partner cannot move).
fn exact_mirrors(out: &mut [[f32; 3]], s: &Symmetry, mirror: &[Option<usize>], movable: &[bool]) {
    for j in 0..out.len() {
        let Some(m) = mirror[j] else { continue };
        if !movable[j] {
            continue;
        }
        if m == j {
            out[j][s.axis] = s.plane as f32;
        } else if j < m || !movable[m] {
            let mut q = out[if movable[m] { j } else { m }];
            q[s.axis] = (2.0 * s.plane - q[s.axis] as f64) as f32;
            if movable[m] {
                out[m] = q;
            } else {
                out[j] = q;
            }
        }
    }
}

/// Share of the (unit-frame) vertices, at most [`MIRROR_SAMPLES`] evenly strided, whose mirror
/// image across `plane` on `axis` lies within [`MIRROR_NEAR`] of the surface.
fn mirrored_share(rm: &crate::mesh::visibility::RayMesh, unit: &[[f32; 3]], axis: usize, plane: f64) -> f64 {
    let picks: Vec<&[f32; 3]> = unit.iter().step_by(unit.len().div_ceil(MIRROR_SAMPLES).max(1)).collect();
    let near = picks
        .par_iter()
        .filter(|q| rm.near_surface(mirror_point(to_dvec(***q), axis, plane).as_vec3(), MIRROR_NEAR as f32))
        .count();
    near as f64 / picks.len().max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eigen_decomposes() {
        let m = DMat3::from_cols(DVec3::new(2.0, 1.0, 0.0), DVec3::new(1.0, 2.0, 0.5), DVec3::new(0.0, 0.5, 1.0));
        let (vals, vecs) = sym_eigen(m).unwrap();
        for k in 0..3 {
            assert!((m * vecs[k] - vecs[k] * vals[k]).length() < 1e-9, "{k}: {vals:?}");
            assert!((vecs[k].length() - 1.0).abs() < 1e-9);
        }
    }
}
