//! Mesh inputs the add-on reads from files and scenes: welding (`weld_points`), Catmull-Clark
//! limit positions of any polygons, which meshes touch along a seam, and tails from joints.
//! When they succeed: a weld map into the welded points, one limit position per vertex, one
//! group per mesh.
#![no_main]

use arbitrary::{Result, Unstructured};
use libfuzzer_sys::fuzz_target;
use miniskeleton_core::mesh::weld::weld_points;
use miniskeleton_core::mesh::{limit_positions, touching_meshes};
use miniskeleton_core::skeleton::{joint_tails, validate_parents};
use miniskeleton_core::Error;
use miniskeleton_fuzz::{bones, mesh, number, or_default};

fn run(u: &mut Unstructured) -> Result<()> {
    let m = mesh(u)?;
    let n = m.vertices.len();
    match u.int_in_range(0u8..=3)? {
        0 => {
            let points: Vec<[f64; 3]> = m.vertices.iter().map(|p| p.map(|c| c as f64)).collect();
            let (map, welded) = weld_points(&points, number(u)? as f64);
            assert_eq!(map.len(), n);
            assert!(map.iter().all(|&w| (w as usize) < welded.len()));
        }
        1 => {
            // Polygons of 1..=6 corners over the mesh's triangles' vertices (or any indices).
            let mut sizes = Vec::new();
            let mut corners = Vec::new();
            let flat: Vec<u32> = m.triangles.iter().flatten().copied().collect();
            let mut at = 0;
            while at < flat.len() {
                let s = u.int_in_range(1usize..=6)?.min(flat.len() - at);
                sizes.push(s as u32);
                corners.extend_from_slice(&flat[at..at + s]);
                at += s;
            }
            if u.ratio(1u8, 16)? {
                sizes.push(u.arbitrary()?);
            }
            match limit_positions(&m.vertices, &sizes, &corners, u.arbitrary()?) {
                Ok(p) => assert_eq!(p.len(), n),
                Err(Error::Internal(e)) => panic!("internal error: {e}"),
                Err(_) => {}
            }
        }
        2 => {
            let meshes = or_default(u, 3, |u| u.int_in_range(0usize..=8))?;
            let mesh_of = (0..n).map(|_| u.int_in_range(0..=meshes as u32)).collect::<Result<Vec<_>>>()?;
            let tolerance = or_default(u, 1e-5, |u| Ok(number(u)? as f64))?;
            let shared = or_default(u, 3, |u| u.int_in_range(0usize..=5))?;
            match touching_meshes(&m.vertices, &mesh_of, meshes, &m.triangles, tolerance, shared) {
                Ok(g) => assert_eq!(g.len(), meshes),
                Err(Error::Internal(e)) => panic!("internal error: {e}"),
                Err(_) => {}
            }
        }
        _ => {
            let b = bones(u, &m)?;
            // Its callers pass a checked forest (its documented precondition).
            if validate_parents(&b.parents, b.heads.len()).is_ok() {
                let t = joint_tails(&b.heads, &b.tails, &b.parents);
                assert_eq!(t.len(), b.heads.len());
            }
        }
    }
    Ok(())
}

fuzz_target!(|data: &[u8]| {
    let _ = run(&mut Unstructured::new(data));
});
