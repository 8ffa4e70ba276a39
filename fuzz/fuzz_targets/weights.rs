//! Nearest-bone (bilinear) and inverse-distance weights, and linear blend skinning with any
//! weights and bone matrices. When they succeed: rows of bones in range summing to 1, and
//! posed points for every vertex.
#![no_main]

use arbitrary::{Result, Unstructured};
use libfuzzer_sys::fuzz_target;
use miniskeleton_core::posing::lbs;
use miniskeleton_core::weights::{bilinear_weights, idw_weights, BilinearOptions, Falloff, IdwOptions};
use miniskeleton_core::Error;
use miniskeleton_fuzz::{bones, check_rows, mesh, number, or_default};

fn run(u: &mut Unstructured) -> Result<()> {
    let m = mesh(u)?;
    let b = bones(u, &m)?;
    let (v, nb) = (&m.vertices, b.heads.len());
    let k = or_default(u, 4, |u| u.int_in_range(0..=17))?;
    let result = match u.int_in_range(0u8..=2)? {
        0 => {
            let falloff = if u.arbitrary()? {
                Falloff::Gaussian { sigma: if u.arbitrary()? { Some(number(u)?) } else { None } }
            } else {
                Falloff::InversePower { power: number(u)? }
            };
            let opts =
                BilinearOptions { nearest: or_default(u, 3, |u| u.int_in_range(0..=20))?, falloff, max_influences: k };
            bilinear_weights(v, &b.heads, &b.tails, &b.parents, &opts)
        }
        1 => {
            let opts = IdwOptions {
                power: or_default(u, 2.0, number)?,
                max_influences: k,
                epsilon: or_default(u, 1e-4, number)?,
            };
            idw_weights(v, &b.heads, &b.tails, &opts)
        }
        _ => {
            let k = u.int_in_range(0usize..=5)?;
            let len = if u.ratio(1u8, 8)? { u.int_in_range(0..=v.len() * k + 1)? } else { v.len() * k };
            let indices = (0..len).map(|_| u.int_in_range(-2..=nb as i32)).collect::<Result<Vec<_>>>()?;
            let weights = (0..len).map(|_| or_default(u, 0.25, number)).collect::<Result<Vec<_>>>()?;
            let mats = (0..nb)
                .map(|_| {
                    let mut m = [[0.0f32; 4]; 4];
                    for (r, row) in m.iter_mut().enumerate() {
                        for (c, x) in row.iter_mut().enumerate() {
                            *x = or_default(u, if r == c { 1.0 } else { 0.0 }, number)?;
                        }
                    }
                    Ok(m)
                })
                .collect::<Result<Vec<_>>>()?;
            match lbs(v, &indices, &weights, k, &mats) {
                Ok(p) => assert_eq!(p.len(), v.len()),
                Err(Error::Internal(e)) => panic!("internal error: {e}"),
                Err(_) => {}
            }
            return Ok(());
        }
    };
    match result {
        Ok(inf) => check_rows(&inf, v.len(), nb, false),
        Err(Error::Internal(e)) => panic!("internal error: {e}"),
        Err(_) => {}
    }
    Ok(())
}

fuzz_target!(|data: &[u8]| {
    let _ = run(&mut Unstructured::new(data));
});
