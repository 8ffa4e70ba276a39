//! Auto Rig: a skeleton for a bare mesh of a character (a biped or a quadruped standing on its
//! legs, a legless chain, a winged body), following Rigify's metarig conventions.
//!
//! [`auto_rig`] takes a mesh (any number of pieces, +Z up, standing on its feet, facing any
//! horizontal direction, left/right symmetric or nearly so) and returns named bones with their
//! parents. The stages are private:
//! - `voxels`: the solid as voxels and each voxel's depth (distance transform);
//! - `centreline`: the centre-line tree of the voxels (TEASAR), whose leaves are the
//!   extremities;
//! - `body`: which leaves are feet, hands, head and tail, and the facing; legs count only when
//!   they hold the body up;
//! - `section`: how flat the solid is across a path (a leg is a tube, a wing's membrane a sheet);
//! - `symmetry`: the solid's vertical mirror plane, for bodies without legs;
//! - `axial`: a legless or winged body read along its spine (ends, wings, side chains);
//! - `line`: a path of the tree as a polyline (heights, tube starts, bends);
//! - `embed`: the template's joints along the tree's paths, with Rigify's names; `chain`: those
//!   of the Chain and Winged templates; `appendages`: a head's ears, horns and antennae.
//!
//! Why a voxel centre line: it reads a mesh in many pieces (eyes, teeth, clothes, a hat) as one
//! solid without any repair, costs a few Dijkstra passes on a coarse grid whatever the vertex
//! count, and its paths already run through the middle of every limb, where joints belong.
//! Pinocchio's embedding (Baran & Popovic 2007) fits a template by discrete optimisation over
//! sphere centres; its named limbs come out of the same kind of extremity analysis done here by
//! geometry alone.
//!
//! Known limits: limbs touching the body (arms against the sides) merge with it and are not
//! found; a character not standing upright on its feet is refused; fingers are not rigged.

mod appendages;
mod axial;
mod body;
mod bones;
mod centreline;
mod chain;
mod embed;
mod line;
mod parts;
mod section;
mod symmetry;
mod voxels;

pub use parts::Template;

use crate::mesh::solid::Solid;
use crate::mesh::{validate_mesh, Frame};
use crate::skeleton::fit::{self, Fitted};
use crate::{Error, Result};
use glam::{DVec3, Vec3};

/// Grid resolution limits (voxels along the longest side).
pub const MIN_RESOLUTION: usize = 16;
pub const MAX_RESOLUTION: usize = 512;

/// Options of [`auto_rig`].
#[derive(Debug, Clone, PartialEq)]
pub struct AutoRigOptions {
    pub template: Template,
    /// The way the character faces (horizontal part used), or `None` to find it from the mesh.
    pub forward: Option<[f64; 3]>,
    /// Voxels along the longest side of the bounding box, [`MIN_RESOLUTION`] ..= [`MAX_RESOLUTION`].
    pub resolution: usize,
}

impl Default for AutoRigOptions {
    fn default() -> Self {
        AutoRigOptions { template: Template::Auto, forward: None, resolution: 96 }
    }
}

/// One bone, input units.
#[derive(Debug, Clone, PartialEq)]
pub struct RigBone {
    pub name: String,
    pub head: [f32; 3],
    pub tail: [f32; 3],
    /// Index of the parent in the list (parents come first), or -1.
    pub parent: i32,
    /// The head sits on the parent's tail.
    pub connected: bool,
}

/// The skeleton [`auto_rig`] made.
#[derive(Debug, Clone, PartialEq)]
pub struct AutoRig {
    /// The template built: [`Template::Biped`], [`Template::Quadruped`], [`Template::Chain`] or
    /// [`Template::Winged`].
    pub template: Template,
    /// Why that template, read from the shape ("4 legs hold the body up", "wings spread 2.1
    /// times its height, 2 legs hold the body up", "asked for", ...).
    pub reason: String,
    pub bones: Vec<RigBone>,
    /// The facing found (or given): unit, horizontal.
    pub forward: [f64; 3],
    /// The character's left (`up x forward`), the side of the `.L` bones.
    pub left: [f64; 3],
    /// A tail was rigged (quadruped: Rigify's `spine.003` .. `spine`; chain and winged:
    /// `spine.002` .. `spine`).
    pub tail: bool,
    /// The centre-line tree the bones were laid along: points `(c, 3)` (input units) and edges
    /// `(e, 2)`, for display and diagnosis.
    pub centre_points: Vec<[f32; 3]>,
    pub centre_edges: Vec<[u32; 2]>,
}

/// Rig a bare mesh.
///
/// Inputs: `vertices` `(n, 3)`, `triangles` `(m, 3)`, [`AutoRigOptions`].
/// Output: [`AutoRig`], bones in Rigify's metarig order and names (`basic_human`: spine ..
/// spine.006, thigh/shin/foot/toe/heel.02, shoulder/upper_arm/forearm/hand; `basic_quadruped`:
/// spine.004 .. spine.011, a tail spine.003 .. spine, thigh/shin/foot/toe, shoulder and
/// front_thigh/front_shin/front_foot/front_toe; both with a pair of ears ear.L/ear.L.001 from
/// the head when the head has them, as on Rigify's horse; `shark` for Chain, `bird` for Winged:
/// see `chain.rs`).
/// Errors: an empty or non-finite mesh, a resolution out of range, a mesh enclosing no volume,
/// and [`Error::Unsuitable`] for a shape the templates do not fit (no ground contact, not
/// standing, too few feet, no head, a round blob, no wings for Winged).
pub fn auto_rig(vertices: &[[f32; 3]], triangles: &[[u32; 3]], opts: &AutoRigOptions) -> Result<AutoRig> {
    validate_mesh(vertices, triangles, true)?;
    if !(MIN_RESOLUTION..=MAX_RESOLUTION).contains(&opts.resolution) {
        return Err(Error::InvalidArgument(format!(
            "resolution must be {MIN_RESOLUTION} ..= {MAX_RESOLUTION}, got {}",
            opts.resolution
        )));
    }
    let forward = match opts.forward {
        Some(f) if f.iter().any(|c| !c.is_finite()) => {
            return Err(Error::InvalidArgument("the facing direction has NaN or infinite values".into()))
        }
        Some(f) if DVec3::new(f[0], f[1], 0.0).length() < 1e-9 => {
            return Err(Error::InvalidArgument("the facing direction must have a horizontal part".into()))
        }
        f => f.map(DVec3::from_array),
    };
    let frame = Frame::of_mesh(vertices, triangles);
    let mut used = vec![false; vertices.len()];
    for t in triangles {
        for &i in t {
            used[i as usize] = true;
        }
    }
    let unit: Vec<DVec3> = vertices.iter().zip(&used).filter(|(_, &u)| u).map(|(p, _)| frame.to_unit(*p)).collect();
    let unit_all: Vec<[f32; 3]> = vertices.iter().map(|p| frame.to_unit(*p).as_vec3().to_array()).collect();
    let lo = unit.iter().fold(DVec3::INFINITY, |a, p| a.min(*p));
    let hi = unit.iter().fold(DVec3::NEG_INFINITY, |a, p| a.max(*p));
    let solid = Solid::new(&unit_all, triangles, fit::WELD, fit::DEDUP);
    let vox = voxels::Voxels::new(&solid, lo, hi, opts.resolution);
    let tree = centreline::centre_tree(&vox).ok_or_else(|| {
        Error::Unsuitable("the mesh encloses no volume (a flat or open surface?): Auto Rig needs a solid body".into())
    })?;
    let body = body::find_body(&tree, &vox, &unit, opts.template, forward)?;
    // Settling the joints fits them in this frame, on this solid.
    let unit_v: Vec<DVec3> = unit_all.iter().map(|p| Vec3::from_array(*p).as_dvec3()).collect();
    let frame_unit = Frame { centre: DVec3::ZERO, diagonal: 1.0 };
    let mesh = Fitted { frame: frame_unit, unit_v: &unit_v, unit: &unit_all, solid: &solid };
    let bones = embed::embed(&tree, &vox, &body, &unit, &mesh);
    let out = |p: DVec3| frame.from_unit(p).as_vec3().to_array();
    Ok(AutoRig {
        template: body.template,
        bones: bones
            .iter()
            .map(|b| RigBone {
                name: b.name.clone(),
                head: out(b.head),
                tail: out(b.tail),
                parent: b.parent.map_or(-1, |p| p as i32),
                connected: b.connected,
            })
            .collect(),
        forward: body.forward.to_array(),
        left: body.left.to_array(),
        tail: match body.template {
            Template::Quadruped => bones.iter().any(|b| b.name == "spine.003"),
            Template::Chain | Template::Winged => bones.iter().any(|b| b.name == "spine.002"),
            _ => false,
        },
        reason: body.reason.clone(),
        centre_points: tree.pos.iter().map(|p| out(*p)).collect(),
        centre_edges: (0..tree.pos.len())
            .flat_map(|a| tree.adj[a].iter().filter(move |&&b| a < b).map(move |&b| [a as u32, b as u32]))
            .collect(),
    })
}
