//! Bone heat: `heat_weights`, `heat_sources`, `heat_weights_with_sources` and
//! `heat_weights_many` on any mesh, skeleton and options, with a progress callback that may
//! cancel. When they succeed, every vertex has a row of bones in range summing to 1.
#![no_main]

use arbitrary::{Result, Unstructured};
use libfuzzer_sys::fuzz_target;
use miniskeleton_core::mesh::Symmetry;
use miniskeleton_core::weights::{heat_sources, heat_weights, heat_weights_many, heat_weights_with_sources};
use miniskeleton_core::weights::{BoneCurves, HeatOptions, Influences, MeshRef};
use miniskeleton_core::Error;
use miniskeleton_fuzz::{bones, check_rows, mesh, number, or_default, point, Bones};
use std::sync::atomic::{AtomicUsize, Ordering};

fn options(u: &mut Unstructured, b: &Bones) -> Result<HeatOptions> {
    let d = HeatOptions::default();
    let nb = b.heads.len();
    Ok(HeatOptions {
        max_influences: or_default(u, d.max_influences, |u| u.int_in_range(0..=17))?,
        min_weight: or_default(u, d.min_weight, number)?,
        visibility: u.arbitrary()?,
        weld_tolerance: or_default(u, d.weld_tolerance, number)?,
        heat_constant: or_default(u, d.heat_constant, number)?,
        symmetry: if u.ratio(1u8, 4)? {
            let mirror = (0..nb)
                .map(|j| {
                    Ok(match u.int_in_range(0u8..=3)? {
                        0 => -1,
                        1 => (nb - 1 - j) as i32,
                        2 => u.arbitrary()?,
                        _ => j as i32,
                    })
                })
                .collect::<Result<_>>()?;
            Some(Symmetry { axis: u.int_in_range(0..=3)?, plane: number(u)? as f64, mirror })
        } else {
            None
        },
        mirror_tolerance: or_default(u, d.mirror_tolerance, number)?,
        weight_limit_start: or_default(u, d.weight_limit_start, number)?,
        weight_limit_end: or_default(u, d.weight_limit_end, number)?,
        rigid_accessories: u.arbitrary()?,
        normal_distance: u.arbitrary()?,
        parents: if u.arbitrary()? { Some(b.parents.clone()) } else { None },
        curves: if u.ratio(1u8, 4)? {
            let n = u.int_in_range(0usize..=16)?;
            let points = (0..n).map(|_| point(u)).collect::<Result<_>>()?;
            let bone = (0..n).map(|_| u.int_in_range(0..=nb as u32)).collect::<Result<_>>()?;
            Some(BoneCurves { points, bone })
        } else {
            None
        },
        block_bones: or_default(u, 0, |u| u.int_in_range(0..=5))?,
    })
}

fn run(u: &mut Unstructured) -> Result<()> {
    let m = mesh(u)?;
    let b = bones(u, &m)?;
    let opts = options(u, &b)?;
    let (v, t, nb) = (&m.vertices, &m.triangles, b.heads.len());
    match u.int_in_range(0u8..=3)? {
        0 => {
            // Cancel at the k-th progress call (never when k = 0).
            let stop = u.int_in_range(0usize..=8)?;
            let calls = AtomicUsize::new(0);
            let progress = |f: f32| {
                assert!((0.0..=1.0).contains(&f), "progress {f}");
                calls.fetch_add(1, Ordering::Relaxed) + 1 != stop
            };
            match heat_weights(v, t, &b.heads, &b.tails, &opts, Some(&progress)) {
                Ok((inf, _)) => check_rows(&inf, v.len(), nb, false),
                Err(Error::Cancelled) => assert!(stop > 0, "cancelled without being asked"),
                Err(Error::Internal(e)) => panic!("internal error: {e}"),
                Err(_) => {}
            }
        }
        1 => match heat_sources(v, t, &b.heads, &b.tails, &opts) {
            Ok(inf) => check_rows(&inf, v.len(), nb, true),
            Err(Error::Internal(e)) => panic!("internal error: {e}"),
            Err(_) => {}
        },
        2 => {
            let k = u.int_in_range(1usize..=4)?;
            let mut sources = Influences::empty(v.len(), k);
            for i in 0..sources.indices.len() {
                if u.is_empty() {
                    break;
                }
                sources.indices[i] = u.int_in_range(-2..=nb as i32)?;
                sources.weights[i] = or_default(u, 1.0, number)?;
            }
            match heat_weights_with_sources(v, t, &b.heads, &b.tails, &sources, &opts, None) {
                Ok((inf, _)) => check_rows(&inf, v.len(), nb, false),
                Err(Error::Internal(e)) => panic!("internal error: {e}"),
                Err(_) => {}
            }
        }
        _ => {
            let cut = if v.is_empty() { 0 } else { u.choose_index(t.len() + 1)? };
            let meshes: Vec<MeshRef> = vec![(v, &t[..cut]), (v, &t[cut..]), (&v[..v.len() / 2], &[])];
            for (r, (mv, _)) in heat_weights_many(&meshes, &b.heads, &b.tails, &opts).iter().zip(&meshes) {
                match r {
                    Ok((inf, _)) => check_rows(inf, mv.len(), nb, false),
                    Err(Error::Internal(e)) => panic!("internal error: {e}"),
                    Err(_) => {}
                }
            }
        }
    }
    Ok(())
}

fuzz_target!(|data: &[u8]| {
    let _ = run(&mut Unstructured::new(data));
});
