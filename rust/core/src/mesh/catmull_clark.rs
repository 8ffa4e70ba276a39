//! Catmull-Clark limit positions of a polygon mesh's vertices: where each vertex of a cage lies
//! on the smooth surface a Subdivision Surface modifier shows. Blender's Ctrl+P With Automatic
//! Weights weights a subdivided cage at these positions, and heat there is closer to heat on
//! the subdivided surface itself than heat on the cage.
//!
//! One Catmull-Clark step (Catmull & Clark 1978) around each vertex, then the limit mask of the
//! all-quad neighbourhood that step leaves (Halstead, Kass & DeRose 1993):
//! `limit = (n² V' + 4 Σ E_j + Σ F_i) / (n (n + 5))`, where `V' = (Q + 2 R + (n - 3) v) / n` is
//! the refined vertex, `E_j` its `n` edge points and `F_i` its `n` face points. Boundary vertices
//! follow the boundary's cubic B-spline, `(a + 4 v + b) / 6`. Blender evaluates the same surface
//! with OpenSubdiv, which is much slower here: it builds patches for the whole mesh, and a cap
//! of a few hundred sides takes it minutes.

use glam::DVec3;

use crate::mesh::{count_non_finite, to_dvec};
use crate::{Error, Result};

/// Limit positions `(n, 3)` of `vertices` under Catmull-Clark subdivision of the polygons
/// `face_sizes` `(f,)` (corners per face) and `face_vertices` (their vertex indices, face after
/// face, `sum(face_sizes)` of them).
///
/// `keep_corners`: a boundary vertex of a single face stays put (Blender's "Keep Corners"
/// boundary smoothing); otherwise it follows the boundary curve ("All"). Creases are not read.
/// Left where they are: loose vertices, and vertices where the surface is not a manifold (an
/// edge of three or more faces, a face using the vertex twice, boundary fans meeting at it).
/// Faces of fewer than 3 corners are ignored.
///
/// Errors: `Shape` (the face sizes do not add up), `InvalidArgument` (an index past the
/// vertices), `NonFinite`.
pub fn limit_positions(
    vertices: &[[f32; 3]],
    face_sizes: &[u32],
    face_vertices: &[u32],
    keep_corners: bool,
) -> Result<Vec<[f32; 3]>> {
    let total: u64 = face_sizes.iter().map(|&s| s as u64).sum();
    if face_sizes.len() >= u32::MAX as usize {
        return Err(Error::InvalidArgument("too many faces (limit 2^32 - 2)".into()));
    }
    if total != face_vertices.len() as u64 {
        return Err(Error::Shape(format!(
            "face sizes add up to {total} corners, but {} face vertices were given",
            face_vertices.len()
        )));
    }
    let n = vertices.len();
    if let Some(&bad) = face_vertices.iter().find(|&&v| v as usize >= n) {
        return Err(Error::InvalidArgument(format!("a face refers to vertex {bad}, but the mesh has {n} vertices")));
    }
    let bad = count_non_finite(vertices);
    if bad > 0 {
        return Err(Error::NonFinite { what: "vertex", count: bad });
    }
    let p: Vec<DVec3> = vertices.iter().map(|&v| to_dvec(v)).collect();

    // Face points (centroids), and per vertex: incident faces and the sum of their points.
    let mut faces = vec![0u32; n];
    let mut sum_f = vec![DVec3::ZERO; n];
    let mut manifold = vec![true; n];
    let mut seen = vec![0u32; n]; // 1 + the last face that used each vertex
    let mut centroid = Vec::with_capacity(face_sizes.len());
    let mut edges: Vec<(u32, u32, u32)> = Vec::with_capacity(face_vertices.len());
    let mut start = 0usize;
    for (f, &size) in face_sizes.iter().enumerate() {
        let corners = &face_vertices[start..start + size as usize];
        start += size as usize;
        if corners.len() < 3 {
            centroid.push(DVec3::ZERO);
            continue;
        }
        let c = corners.iter().map(|&v| p[v as usize]).sum::<DVec3>() / corners.len() as f64;
        centroid.push(c);
        for (k, &v) in corners.iter().enumerate() {
            let w = corners[(k + 1) % corners.len()];
            faces[v as usize] += 1;
            sum_f[v as usize] += c;
            if seen[v as usize] == f as u32 + 1 {
                manifold[v as usize] = false; // the face uses it twice
            }
            seen[v as usize] = f as u32 + 1;
            if v != w {
                edges.push((v.min(w), v.max(w), f as u32));
            }
        }
    }
    edges.sort_unstable();

    // Per vertex: edges, the sums of edge midpoints and edge points over interior edges, and
    // the other ends of boundary edges.
    let mut valence = vec![0u32; n];
    let mut sum_mid = vec![DVec3::ZERO; n];
    let mut sum_e = vec![DVec3::ZERO; n];
    let mut boundary: Vec<[u32; 2]> = vec![[u32::MAX; 2]; n];
    let mut boundary_edges = vec![0u32; n];
    for group in edges.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
        let (a, b) = (group[0].0 as usize, group[0].1 as usize);
        valence[a] += 1;
        valence[b] += 1;
        match group.len() {
            1 => {
                for (v, w) in [(a, b), (b, a)] {
                    let k = boundary_edges[v] as usize;
                    if k < 2 {
                        boundary[v][k] = w as u32;
                    }
                    boundary_edges[v] += 1;
                }
            }
            2 => {
                let mid = (p[a] + p[b]) / 2.0;
                let e = (p[a] + p[b] + centroid[group[0].2 as usize] + centroid[group[1].2 as usize]) / 4.0;
                for v in [a, b] {
                    sum_mid[v] += mid;
                    sum_e[v] += e;
                }
            }
            _ => {
                manifold[a] = false;
                manifold[b] = false;
            }
        }
    }

    Ok((0..n)
        .map(|v| {
            let x = p[v];
            let limit = if faces[v] == 0 || !manifold[v] {
                x
            } else if boundary_edges[v] == 0 && faces[v] == valence[v] {
                let k = valence[v] as f64;
                let refined = (sum_f[v] / k + 2.0 * sum_mid[v] / k + (k - 3.0) * x) / k;
                (k * k * refined + 4.0 * sum_e[v] + sum_f[v]) / (k * (k + 5.0))
            } else if boundary_edges[v] == 2 && !(keep_corners && faces[v] == 1) {
                let [a, b] = boundary[v];
                (p[a as usize] + 4.0 * x + p[b as usize]) / 6.0
            } else {
                x
            };
            limit.as_vec3().to_array()
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cube `[-1, 1]^3` as six quads.
    fn cube() -> (Vec<[f32; 3]>, Vec<u32>, Vec<u32>) {
        let v: Vec<[f32; 3]> = (0..8)
            .map(|i| {
                [
                    if i & 1 == 0 { -1.0 } else { 1.0 },
                    if i & 2 == 0 { -1.0 } else { 1.0 },
                    if i & 4 == 0 { -1.0 } else { 1.0 },
                ]
            })
            .collect();
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        (v, vec![4; 6], quads.iter().flatten().copied().collect())
    }

    #[test]
    fn cube_corners_go_half_way_in() {
        // Valence 3: V' = 5/9 (1, 1, 1); limit = (9 V' + 4 (3/2) + 1) / 24 = 1/2 (1, 1, 1).
        let (v, sizes, corners) = cube();
        let limit = limit_positions(&v, &sizes, &corners, false).unwrap();
        for (a, b) in v.iter().zip(&limit) {
            for k in 0..3 {
                assert!((b[k] - a[k] / 2.0).abs() < 1e-6, "{a:?} -> {b:?}");
            }
        }
    }

    #[test]
    fn a_regular_grid_gets_the_bicubic_mask_and_its_border_the_boundary_spline() {
        // 4 x 4 vertices on z = 0 with a bump of 1 at one interior vertex: inside a regular
        // grid the limit is the bicubic B-spline's mask, (16 v + 4 Σ edge neighbours + Σ
        // diagonal ones) / 36.
        let mut v = Vec::new();
        for j in 0..4 {
            for i in 0..4 {
                v.push([i as f32, j as f32, 0.0]);
            }
        }
        v[5][2] = 1.0;
        let mut corners = Vec::new();
        for j in 0..3u32 {
            for i in 0..3u32 {
                let a = j * 4 + i;
                corners.extend([a, a + 1, a + 5, a + 4]);
            }
        }
        let limit = limit_positions(&v, &[4; 9], &corners, true).unwrap();
        // B-spline mask: centre 16/36, edge neighbours 4/36, diagonal 1/36.
        assert!((limit[5][2] - 16.0 / 36.0).abs() < 1e-6);
        assert!((limit[6][2] - 4.0 / 36.0).abs() < 1e-6);
        assert!((limit[10][2] - 1.0 / 36.0).abs() < 1e-6);
        assert!((limit[5][0] - 1.0).abs() < 1e-6 && (limit[5][1] - 1.0).abs() < 1e-6);
        // Border: the boundary's cubic B-spline, (a + 4 v + b) / 6; with keep_corners the
        // corner stays, without it the corner follows the curve too.
        assert_eq!(limit[1], [1.0, 0.0, 0.0]);
        assert_eq!(limit[0], [0.0, 0.0, 0.0]);
        // Keep Corners keeps only corners: a raised border vertex of two faces follows the curve.
        let mut raised = v.clone();
        raised[1][2] = 1.0;
        let kept = limit_positions(&raised, &[4; 9], &corners, true).unwrap();
        assert!((kept[1][2] - 4.0 / 6.0).abs() < 1e-6 && (kept[2][2] - 1.0 / 6.0).abs() < 1e-6);
        assert_eq!(kept[0], [0.0, 0.0, 0.0]);
        let smooth = limit_positions(&v, &[4; 9], &corners, false).unwrap();
        assert!((smooth[0][0] - 1.0 / 6.0).abs() < 1e-6 && (smooth[0][1] - 1.0 / 6.0).abs() < 1e-6);
    }

    #[test]
    fn loose_and_non_manifold_vertices_stay_and_bad_input_is_an_error() {
        // Three triangles on one edge (0, 1), plus a loose vertex 5.
        let v =
            vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 1.0, 0.0], [0.5, -1.0, 0.0], [0.5, 0.0, 1.0], [9.0, 9.0, 9.0]];
        let corners = [0, 1, 2, 1, 0, 3, 0, 1, 4];
        let limit = limit_positions(&v, &[3; 3], &corners, false).unwrap();
        assert_eq!(limit[0], v[0]);
        assert_eq!(limit[1], v[1]);
        assert_eq!(limit[5], v[5]);
        assert!(matches!(limit_positions(&v, &[3; 2], &corners, false), Err(Error::Shape(_))));
        assert!(matches!(limit_positions(&v, &[3], &[0, 1, 6], false), Err(Error::InvalidArgument(_))));
        let mut nan = v.clone();
        nan[2][1] = f32::NAN;
        assert!(matches!(limit_positions(&nan, &[3; 3], &corners, false), Err(Error::NonFinite { count: 1, .. })));
        // A face of two corners is ignored; no face at all leaves every vertex.
        assert_eq!(limit_positions(&v, &[2], &[0, 1], false).unwrap(), v);
        // Two edges of three faces each and two border edges at vertex 0 (four quads around it):
        // as many border edges as a border vertex has, but not a manifold; it stays.
        let mut w = v.clone();
        w.extend([[0.0, 2.0, 3.0], [0.0, 3.0, 2.0], [2.0, 3.0, 0.0], [3.0, 0.0, 2.0]]);
        let quads = [0, 1, 6, 2, 0, 1, 7, 2, 0, 1, 8, 3, 0, 2, 9, 4];
        let book = limit_positions(&w, &[4; 4], &quads, false).unwrap();
        assert_eq!(book[0], w[0]);
        // A face that uses vertex 0 twice leaves it where it is.
        let twice = limit_positions(&v, &[5], &[0, 1, 2, 0, 3], false).unwrap();
        assert_eq!(twice[0], v[0]);
        assert_ne!(twice[1], v[1]);
    }

    #[test]
    fn one_huge_polygon_follows_its_boundary() {
        // A filled circle of 200k vertices (one n-gon): every vertex is on the boundary. (Work
        // quadratic in a face's size would take minutes here.)
        let n = 200_000;
        let v: Vec<[f32; 3]> = (0..n)
            .map(|i| {
                let t = i as f32 / n as f32 * std::f32::consts::TAU;
                [t.cos(), t.sin(), 0.0]
            })
            .collect();
        let corners: Vec<u32> = (0..n as u32).collect();
        let limit = limit_positions(&v, &[n as u32], &corners, false).unwrap();
        let r = (limit[7][0].powi(2) + limit[7][1].powi(2)).sqrt();
        assert!((r - 1.0).abs() < 1e-5, "{r}");
        assert_eq!(limit_positions(&v, &[n as u32], &corners, true).unwrap(), v);
    }
}
