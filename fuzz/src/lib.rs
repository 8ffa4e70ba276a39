//! Structured inputs for the fuzz targets: meshes, skeletons and numbers built from the
//! fuzzer's bytes with the `arbitrary` crate, so that most inputs pass the core's checks and
//! reach its solvers, and some are hostile: coordinates at 1e±30, NaN and infinity, every point
//! at one place, one triangle repeated, faces flipped, parents in a cycle, indices past the end.
//!
//! Each target (`fuzz_targets/`) calls one area's public entry points and checks what they
//! promise when they succeed (weights in range, rows summing to 1, every vertex weighted); an
//! error is a fine answer to bad input, a panic, a hang or an allocation past the fuzzer's
//! memory limit is a finding. Sizes are capped so that each run takes milliseconds.

use arbitrary::{Result, Unstructured};
use miniskeleton_core::primitives::{bone_chain, capped_cylinder};
use miniskeleton_core::weights::Influences;

/// A coordinate or a parameter: mostly a multiple of 1/8 in [-4, 4], sometimes a power of ten
/// up to 1e±38 (either sign), sometimes any `f32` bit pattern (NaN, infinity, subnormal).
pub fn number(u: &mut Unstructured) -> Result<f32> {
    Ok(match u.int_in_range(0u8..=15)? {
        0 => f32::from_bits(u.arbitrary()?),
        1 => {
            let sign = if u.arbitrary()? { -1.0 } else { 1.0 };
            sign * 10f32.powi(u.int_in_range(-38..=38)?)
        }
        _ => u.int_in_range(-32i8..=32)? as f32 / 8.0,
    })
}

/// A positive number: mostly ordinary (1/8 .. 4), sometimes tiny or huge, rarely hostile.
pub fn positive(u: &mut Unstructured) -> Result<f32> {
    Ok(match u.int_in_range(0u8..=15)? {
        0 => number(u)?,
        1 => 10f32.powi(u.int_in_range(-38..=38)?),
        _ => u.int_in_range(1u8..=32)? as f32 / 8.0,
    })
}

/// `default` most of the time, else `value(u)`: options stay mostly valid, so the solvers run.
pub fn or_default<T>(
    u: &mut Unstructured,
    default: T,
    value: impl FnOnce(&mut Unstructured) -> Result<T>,
) -> Result<T> {
    if u.ratio(3u8, 4)? {
        Ok(default)
    } else {
        value(u)
    }
}

pub fn point(u: &mut Unstructured) -> Result<[f32; 3]> {
    Ok([number(u)?, number(u)?, number(u)?])
}

/// A triangle mesh (vertices `(n, 3)`, triangles `(m, 3)`).
#[derive(Debug, Clone, Default)]
pub struct Mesh {
    pub vertices: Vec<[f32; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

/// Most vertices and triangles of a generated mesh (each run stays short).
pub const MAX_VERTICES: usize = 4096;
pub const MAX_TRIANGLES: usize = 8192;

/// A vertex index: almost always one of the `n` vertices, rarely anything (past the end).
fn index(u: &mut Unstructured, n: usize) -> Result<u32> {
    if n == 0 || u.ratio(1u8, 64)? {
        return u.arbitrary();
    }
    Ok(u.int_in_range(0..=n as u32 - 1)?)
}

/// A closed capped cylinder of a few rings, its size and proportions from the input.
fn cylinder(u: &mut Unstructured) -> Result<Mesh> {
    let (rings, segments) = (u.int_in_range(2usize..=24)?, u.int_in_range(3usize..=24)?);
    let (radius, height) = (positive(u)?, positive(u)?);
    let (vertices, triangles) = capped_cylinder(radius, height, rings, segments);
    Ok(Mesh { vertices, triangles })
}

/// A mesh: raw (any points, any triangles), a closed cylinder, or a few cylinders (pieces,
/// apart, touching or one inside another), then up to four hostile edits.
pub fn mesh(u: &mut Unstructured) -> Result<Mesh> {
    let mut m = match u.int_in_range(0u8..=3)? {
        0 => {
            let n = u.int_in_range(0usize..=48)?;
            let vertices = (0..n).map(|_| point(u)).collect::<Result<Vec<_>>>()?;
            let count = u.int_in_range(0usize..=96)?;
            let triangles =
                (0..count).map(|_| Ok([index(u, n)?, index(u, n)?, index(u, n)?])).collect::<Result<_>>()?;
            Mesh { vertices, triangles }
        }
        1 | 2 => cylinder(u)?,
        _ => {
            let mut all = Mesh::default();
            for _ in 0..u.int_in_range(2u8..=4)? {
                let part = cylinder(u)?;
                let offset = point(u)?;
                append(&mut all, &part, offset);
            }
            all
        }
    };
    for _ in 0..u.int_in_range(0u8..=4)? {
        edit(u, &mut m)?;
    }
    Ok(m)
}

/// `part` moved by `offset`, added to `to` as a piece of its own.
fn append(to: &mut Mesh, part: &Mesh, offset: [f32; 3]) {
    let base = to.vertices.len() as u32;
    to.vertices.extend(part.vertices.iter().map(|p| [p[0] + offset[0], p[1] + offset[1], p[2] + offset[2]]));
    to.triangles.extend(part.triangles.iter().map(|t| t.map(|i| i.wrapping_add(base))));
}

/// One hostile edit of `m`.
fn edit(u: &mut Unstructured, m: &mut Mesh) -> Result<()> {
    let n = m.vertices.len();
    match u.int_in_range(0u8..=9)? {
        // Scaled to 1e-30 .. 1e30.
        0 => {
            let s = 10f32.powi(u.int_in_range(-30..=30)?);
            m.vertices.iter_mut().flatten().for_each(|c| *c *= s);
        }
        // Moved far away.
        1 => {
            let d = point(u)?.map(|c| c * 10f32.powi(u.int_in_range(0..=30).unwrap_or(0)));
            m.vertices.iter_mut().for_each(|p| (0..3).for_each(|a| p[a] += d[a]));
        }
        // One triangle repeated many times.
        2 if !m.triangles.is_empty() => {
            let t = m.triangles[u.choose_index(m.triangles.len())?];
            let times = u.int_in_range(1usize..=MAX_TRIANGLES)?;
            m.triangles.extend(std::iter::repeat_n(t, times.min(MAX_TRIANGLES.saturating_sub(m.triangles.len()))));
        }
        // A run of triangles flipped.
        3 if !m.triangles.is_empty() => {
            let from = u.choose_index(m.triangles.len())?;
            let to = from + u.int_in_range(1..=m.triangles.len() - from)?;
            m.triangles[from..to].iter_mut().for_each(|t| t.swap(1, 2));
        }
        // A run of vertices collapsed to one point.
        4 if n > 0 => {
            let from = u.choose_index(n)?;
            let to = from + u.int_in_range(1..=n - from)?;
            let p = m.vertices[from];
            m.vertices[from..to].iter_mut().for_each(|q| *q = p);
        }
        // One coordinate hostile (NaN, infinity, huge).
        5 if n > 0 => {
            let v = u.choose_index(n)?;
            m.vertices[v][u.choose_index(3)?] = f32::from_bits(u.arbitrary()?);
        }
        // A loose vertex far away.
        6 if n < MAX_VERTICES => m.vertices.push(point(u)?.map(|c| c * 1e20)),
        // Every vertex doubled, each triangle on one copy or the other (split seams).
        7 if 2 * n <= MAX_VERTICES => {
            m.vertices.extend_from_within(..);
            for t in m.triangles.iter_mut() {
                if u.arbitrary()? {
                    *t = t.map(|i| if (i as usize) < n { i + n as u32 } else { i });
                }
            }
        }
        // Jitter.
        8 => {
            for p in m.vertices.iter_mut() {
                for c in p.iter_mut() {
                    *c += u.int_in_range(-4i8..=4)? as f32 / 64.0;
                }
            }
        }
        // Every k-th triangle kept (holes, open surfaces).
        _ => {
            let k = u.int_in_range(2usize..=4)?;
            let keep = u.choose_index(k)?;
            m.triangles = m.triangles.iter().enumerate().filter(|(i, _)| i % k != keep).map(|(_, t)| *t).collect();
        }
    }
    Ok(())
}

/// Bones: heads and tails `(b, 3)` and parents `(b,)`.
#[derive(Debug, Clone, Default)]
pub struct Bones {
    pub heads: Vec<[f32; 3]>,
    pub tails: Vec<[f32; 3]>,
    pub parents: Vec<i32>,
}

/// The box of the finite vertices (a unit box when there are none).
pub fn finite_box(vertices: &[[f32; 3]]) -> ([f32; 3], [f32; 3]) {
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in vertices.iter().filter(|p| p.iter().all(|c| c.is_finite())) {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    if lo[0] > hi[0] {
        return ([0.0; 3], [1.0; 3]);
    }
    (lo, hi)
}

/// Skeletons: a chain up the mesh's box (up to 1000 bones), a tree of points in the box, any
/// points, or every bone at one point; parents a forest, a cycle, anything, or none.
pub fn bones(u: &mut Unstructured, mesh: &Mesh) -> Result<Bones> {
    let (lo, hi) = finite_box(&mesh.vertices);
    let in_box = |u: &mut Unstructured| -> Result<[f32; 3]> {
        let mut p = [0.0; 3];
        for a in 0..3 {
            let t = u.int_in_range(0u8..=16)? as f32 / 16.0;
            p[a] = lo[a] + t * (hi[a] - lo[a]);
        }
        Ok(p)
    };
    let count = |u: &mut Unstructured| -> Result<usize> {
        Ok(if u.ratio(1u8, 32)? { u.int_in_range(1usize..=1000)? } else { u.int_in_range(0usize..=24)? })
    };
    let mut b = match u.int_in_range(0u8..=3)? {
        0 | 1 => {
            // A chain along the box's z, centred in x and y, as in the core's own tests.
            let (h, t, p) = bone_chain(1.0, count(u)?.max(1));
            let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
            let z = |c: [f32; 3]| [centre[0], centre[1], lo[2] + c[2] * (hi[2] - lo[2])];
            Bones { heads: h.into_iter().map(z).collect(), tails: t.into_iter().map(z).collect(), parents: p }
        }
        2 => {
            let n = count(u)?;
            let mut b = Bones::default();
            for i in 0..n {
                b.heads.push(in_box(u)?);
                b.tails.push(in_box(u)?);
                b.parents.push(if i == 0 { -1 } else { u.int_in_range(-1..=i as i32 - 1)? });
            }
            b
        }
        _ => {
            let n = count(u)?;
            let p = if u.arbitrary()? { point(u)? } else { in_box(u)? };
            let mut b = Bones::default();
            for i in 0..n {
                let (h, t) = if u.arbitrary()? { (p, p) } else { (point(u)?, point(u)?) };
                b.heads.push(h);
                b.tails.push(t);
                b.parents.push(i as i32 - 1);
            }
            b
        }
    };
    let n = b.heads.len();
    match u.int_in_range(0u8..=7)? {
        0 if n > 0 => b.parents = (0..n as i32).map(|i| (i + 1) % n as i32).collect(),
        1 => b.parents = (0..n).map(|_| u.arbitrary()).collect::<Result<_>>()?,
        2 => b.parents = vec![-1; n],
        _ => {}
    }
    Ok(b)
}

/// Bone names: Rigify's and Mixamo's words, sides and numbers, or any text.
pub fn names(u: &mut Unstructured, n: usize) -> Result<Vec<String>> {
    const WORDS: [&str; 24] = [
        "spine",
        "hips",
        "pelvis",
        "chest",
        "neck",
        "head",
        "jaw",
        "tail",
        "thigh",
        "shin",
        "foot",
        "toe",
        "heel",
        "upper_arm",
        "forearm",
        "hand",
        "shoulder",
        "leg",
        "arm",
        "mixamorig:LeftUpLeg",
        "mixamorig:RightFoot",
        "ear",
        "wing",
        "",
    ];
    const SIDES: [&str; 8] = ["", ".L", ".R", "_L", "_R", "Left", "Right", ".001"];
    (0..n)
        .map(|_| {
            if u.ratio(1u8, 8)? {
                return u.arbitrary::<String>();
            }
            Ok(format!("{}{}", u.choose(&WORDS)?, u.choose(&SIDES)?))
        })
        .collect()
}

/// What every successful call promises: one row per vertex, bones in range, weights in
/// [0, 1] summing to 1 on every row (`empty_ok`: rows may be empty, as `heat_sources`' are).
pub fn check_rows(inf: &Influences, n: usize, b: usize, empty_ok: bool) {
    assert_eq!(inf.n(), n, "rows");
    for v in 0..n {
        let (idx, w) = inf.row(v);
        let mut sum = 0.0f32;
        for (&j, &x) in idx.iter().zip(w) {
            assert!(j >= -1 && (j as i64) < b as i64, "vertex {v}: bone {j} of {b}");
            assert!(x.is_finite() && (0.0..=1.0 + 1e-6).contains(&x), "vertex {v}: weight {x}");
            if j >= 0 {
                sum += x;
            }
        }
        if !(empty_ok && idx[0] < 0) {
            assert!((sum - 1.0).abs() < 1e-3, "vertex {v}: weights sum to {sum} ({idx:?} {w:?})");
        }
    }
}
