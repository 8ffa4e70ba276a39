//! Geodesic voxel binding: Dionne & de Lasa, "Geodesic Voxel Binding for Production Character
//! Meshes", SCA 2013 (Maya's "Geodesic Voxel" bind), made to work on the same real meshes as
//! bone heat.
//!
//! This module holds the entry points, their options and report. [`voxel_weights`] runs inside
//! heat's solve: heat's stages prepare the mesh (unit frame, welding, the segments standing for
//! the bones, pieces, normals, rigid accessories and props), this module's stages (`stages`)
//! voxelize the whole character (`grid`), measure every bone's geodesic distance through the
//! solid (`geodesic`) and turn the distances into heat sources by the falloff, and heat's solve
//! is the smoothing pass; then symmetry and the influence cap, as heat's.

mod geodesic;
mod grid;
mod stages;

use crate::mesh::mirror::Symmetry;
use crate::weights::heat::stages::{prepared_and_seen, run, Given, Inputs, Prepared, Provided, Visibility};
use crate::weights::heat::{BoneCurves, HeatOptions, HeatReport};
use crate::weights::influence::Influences;
use crate::{Error, Result};
use std::sync::Mutex;

/// Default [`VoxelOptions::resolution`]: voxels along the longest side.
pub const RESOLUTION: usize = 64;
/// Default [`VoxelOptions::falloff`].
pub const FALLOFF: f32 = 0.002;

/// Options of [`voxel_weights`].
#[derive(Debug, Clone, PartialEq)]
pub struct VoxelOptions {
    /// Voxels along the longest side of the mesh's bounding box (16..=1024). Default
    /// [`RESOLUTION`].
    pub resolution: usize,
    /// Width of the falloff, relative to the distance (0..=1): a bone whose ranked geodesic
    /// distance is `r` shares a vertex's heat by `exp(-(r - r_min) / (falloff r_min))` of the
    /// nearest bone's (`r_min`). 0 gives the nearest bone alone. Default [`FALLOFF`].
    pub falloff: f32,
    /// Bones kept per vertex (>= 1; the result has min(this, bones) columns). Default 4.
    pub max_influences: usize,
    /// Pruning threshold relative to the kept total, as heat's. Default 1e-3.
    pub min_weight: f32,
    /// Weld distance, relative to the bbox diagonal (>= 0). Default 1e-5.
    pub weld_tolerance: f32,
    /// Left/right symmetry, as heat's [`HeatOptions::symmetry`].
    pub symmetry: Option<Symmetry>,
    /// Matching tolerance for mirrored vertex positions, relative to the bbox diagonal (>= 0).
    /// Default 1e-3.
    pub mirror_tolerance: f32,
    /// `(b,)` parent of each bone for imported rigs, as heat's [`HeatOptions::parents`].
    pub parents: Option<Vec<i32>>,
    /// Bent bones, as heat's [`HeatOptions::curves`].
    pub curves: Option<BoneCurves>,
    /// `(n,)` the object of each vertex when the mesh is several objects stacked: an object
    /// whose pieces hold no bone (a held prop) is bound rigidly, as a whole, to the bone
    /// nearest its centre. `None`: one object. Default `None`.
    pub objects: Option<Vec<u32>>,
}

impl Default for VoxelOptions {
    fn default() -> Self {
        VoxelOptions {
            resolution: RESOLUTION,
            falloff: FALLOFF,
            max_influences: 4,
            min_weight: 1e-3,
            weld_tolerance: 1e-5,
            symmetry: None,
            mirror_tolerance: 1e-3,
            parents: None,
            curves: None,
            objects: None,
        }
    }
}

impl VoxelOptions {
    /// The options of the heat solve that smooths the weights.
    fn heat(&self) -> HeatOptions {
        HeatOptions {
            max_influences: self.max_influences,
            min_weight: self.min_weight,
            // A vertex's nearest visible bone leads; the geodesic distances rank the rest and
            // stand in where a vertex sees no bone.
            visibility: true,
            weld_tolerance: self.weld_tolerance,
            symmetry: self.symmetry.clone(),
            mirror_tolerance: self.mirror_tolerance,
            parents: self.parents.clone(),
            curves: self.curves.clone(),
            ..HeatOptions::default()
        }
    }
}

/// What [`voxel_weights`] did, for the operator's report.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct VoxelReport {
    /// The grid's size in voxels (x, y, z), padding included.
    pub grid: [usize; 3],
    /// Solid voxels: inside or on the surface.
    pub solid_voxels: usize,
    /// Bones whose segments pass through no solid voxel (they reach in from the nearest ones).
    pub outside_bones: usize,
    /// Seconds of the voxel stages: "voxelize", "geodesic", "falloff".
    pub timings: Vec<(&'static str, f64)>,
    /// The solve's report (pieces, rigid pieces, welding, flipped faces, symmetry, timings).
    pub heat: HeatReport,
}

/// Skinning weights by geodesic voxel binding (Dionne & de Lasa 2013).
///
/// Inputs: `vertices` `(n, 3)` and `triangles` `(m, 3)` of the whole character (every mesh,
/// stacked; [`VoxelOptions::objects`] tells them apart), bone `heads` / `tails` `(b, 3)` in the
/// same unit (any); `opts`; `progress(fraction)`, `false` cancels.
/// Outputs: [`Influences`] `(n, min(max_influences, b))`, every row non-empty and summing to 1,
/// and a [`VoxelReport`].
///
/// Method:
/// 1. voxelize the character, all pieces together: a voxel is inside when, along two of the
///    three axes, the first face seen from it (ahead or behind) is a back face, and every voxel
///    a triangle overlaps is solid (open, self-intersecting and nested pieces, thin shells);
/// 2. every bone's segments (heat's: the spans of imported rigs, bent bones) seed the voxels
///    they pass through; one multi-label Dijkstra sweep gives every solid voxel its
///    [`stages::VOXEL_LABELS`] nearest bones by the length of a 26-connected path through the
///    solid; parts no bone reaches continue through the air;
/// 3. each vertex's distance to a bone is the least over the eight voxels around it of the
///    voxel's distance plus the way to the vertex; bones are ranked by Blender's
///    normal-weighted distance on it, a vertex's nearest visible bone (heat's, when it sees
///    one) first and the bones ranked nearer that it does not see dropped;
/// 4. falloff: the nearest bones share the vertex's heat by `exp(-(r - r_min) / (falloff
///    r_min))`;
/// 5. smoothing: heat's screened solve on the surface, `(L + M H) w_j = M H s_j` with `s_j`
///    those shares and `H = 4 / d^2`: `d` is heat's (the ranked distance) where the vertex
///    sees a bone; where it sees none, its geodesic distance, with part of the heat (between
///    heat's none and a full source); heat's rigid accessories and props (per object),
///    symmetry, small-weight ramp and top-k.
///
/// The paper weighs the distances directly, `w = 1 / ((1 - a) d + a d^2)^2`; on the real models
/// of `testkit/eval_weights.py` that spreads every vertex over its nearest bones (a round head
/// over all four of q_Cat's) and deforms 3 to 10 times more than heat, so the distances here
/// choose the sources and heat's solve shapes the falloff (see docs/weights.md).
///
/// Limits: parts closer than a voxel merge (raise the resolution); the sweep's 26-connected
/// paths are up to 8 % longer than straight ones; the cost grows with the solid's volume
/// (resolution cubed on a round body).
///
/// Errors: those of [`heat_weights`](crate::weights::heat_weights), a resolution outside
/// 16..=1024 or a falloff outside 0..=1, `objects` of another length, [`Error::Cancelled`].
pub fn voxel_weights(
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
    heads: &[[f32; 3]],
    tails: &[[f32; 3]],
    opts: &VoxelOptions,
    progress: Option<&(dyn Fn(f32) -> bool + Sync)>,
) -> Result<(Influences, VoxelReport)> {
    validate(opts)?;
    let report = Mutex::new(VoxelReport::default());
    let provide = |prep: &Prepared, vis: &Visibility, tick: &dyn Fn(f32) -> Result<()>| -> Result<Provided> {
        let mut r = VoxelReport::default();
        let cancelled = || tick(0.5).is_err();
        let solid = stages::solid(prep, vis, opts.resolution, &mut r, &cancelled)?;
        tick(0.8)?;
        let clock = std::time::Instant::now();
        let near = stages::vertex_distances(prep, vis, &solid, stages::VOXEL_LABELS);
        let out = stages::sources(&near, vis, opts.falloff, solid.grid.step);
        r.timings.push(("falloff", clock.elapsed().as_secs_f64()));
        *report.lock().unwrap_or_else(|p| p.into_inner()) = r;
        Ok(out)
    };
    let inputs = Inputs { vertices, triangles, heads, tails, objects: opts.objects.as_deref() };
    let (inf, heat) = run(&inputs, Given::Provided(&provide), &opts.heat(), progress)?;
    let mut report = report.into_inner().unwrap_or_else(|p| p.into_inner());
    report.heat = heat;
    Ok((inf, report))
}

/// Debug and evaluation: each input vertex's `k` nearest bones by geodesic distance through the
/// voxel solid ([`VoxelDistances`]). All else as [`voxel_weights`].
pub fn voxel_distances(
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
    heads: &[[f32; 3]],
    tails: &[[f32; 3]],
    k: usize,
    opts: &VoxelOptions,
) -> Result<VoxelDistances> {
    validate(opts)?;
    if k == 0 {
        return Err(Error::InvalidArgument("k must be >= 1".into()));
    }
    let inputs = Inputs { vertices, triangles, heads, tails, objects: opts.objects.as_deref() };
    let (prep, vis) = prepared_and_seen(&inputs, &opts.heat())?;
    let solid = stages::solid(&prep, &vis, opts.resolution, &mut VoxelReport::default(), &|| false)?;
    let near = stages::vertex_distances(&prep, &vis, &solid, k);
    let row = |w: usize| w * k..(w + 1) * k;
    let mut out = VoxelDistances { k, ..Default::default() };
    for &w in &prep.map {
        out.bones.extend_from_slice(&near.bone[row(w as usize)]);
        out.geodesic.extend_from_slice(&near.geodesic[row(w as usize)]);
        out.euclid.extend_from_slice(&near.euclid[row(w as usize)]);
        out.cos.extend_from_slice(&near.cos[row(w as usize)]);
    }
    Ok(out)
}

/// See [`voxel_distances`]: per input vertex `k` slots, `(n * k,)` each: the bones (`-1`
/// unused), ascending by their geodesic distance, their straight-line distance (both in units
/// of the mesh's bounding-box diagonal), and the cosine between the vertex normal and the
/// direction from the bone.
#[derive(Debug, Clone, Default)]
pub struct VoxelDistances {
    pub k: usize,
    pub bones: Vec<i32>,
    pub geodesic: Vec<f32>,
    pub euclid: Vec<f32>,
    pub cos: Vec<f32>,
}

/// Check the options of the voxel stages (the rest is heat's to check).
fn validate(opts: &VoxelOptions) -> Result<()> {
    if !(16..=1024).contains(&opts.resolution) {
        return Err(Error::InvalidArgument(format!("resolution must be in 16..=1024, got {}", opts.resolution)));
    }
    if !(opts.falloff.is_finite() && (0.0..=1.0).contains(&opts.falloff)) {
        return Err(Error::InvalidArgument(format!("falloff must be in [0, 1], got {}", opts.falloff)));
    }
    Ok(())
}
