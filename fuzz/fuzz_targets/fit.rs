//! Fit Skeleton (`fit_joints`) and the inside test (`points_inside`) on any mesh, joints,
//! bones and options. When they succeed: one finite joint per joint, one answer per point.
#![no_main]

use arbitrary::{Result, Unstructured};
use libfuzzer_sys::fuzz_target;
use miniskeleton_core::mesh::Symmetry;
use miniskeleton_core::skeleton::{fit_joints, points_inside, FitOptions};
use miniskeleton_core::Error;
use miniskeleton_fuzz::{bones, mesh, number, or_default};

fn run(u: &mut Unstructured) -> Result<()> {
    let m = mesh(u)?;
    let b = bones(u, &m)?;
    // Joints: every head, then every tail; bones join them (or any pair, sometimes out of range).
    let joints: Vec<[f32; 3]> = b.heads.iter().chain(&b.tails).copied().collect();
    let nj = joints.len() as u32;
    let mut pairs: Vec<[u32; 2]> = (0..b.heads.len() as u32).map(|i| [i, i + b.heads.len() as u32]).collect();
    if u.ratio(1u8, 4)? {
        for p in pairs.iter_mut() {
            *p = [u.int_in_range(0..=nj)?, u.int_in_range(0..=nj)?];
        }
    }
    if u.ratio(1u8, 8)? {
        let inside = points_inside(&m.vertices, &m.triangles, &joints);
        match inside {
            Ok(i) => assert_eq!(i.len(), joints.len()),
            Err(Error::Internal(e)) => panic!("internal error: {e}"),
            Err(_) => {}
        }
        return Ok(());
    }
    let mut movable: Vec<bool> = (0..joints.len()).map(|_| u.arbitrary()).collect::<Result<_>>()?;
    if u.ratio(1u8, 16)? {
        movable.pop();
    }
    let d = FitOptions::default();
    let symmetry = if u.ratio(1u8, 4)? {
        let mut mirror = Vec::with_capacity(joints.len());
        for j in 0..joints.len() {
            mirror.push(if u.arbitrary()? { j as i32 } else { u.int_in_range(-1..=nj as i32)? });
        }
        Some(Symmetry { axis: u.int_in_range(0..=3)?, plane: number(u)? as f64, mirror })
    } else {
        None
    };
    let mut opts = FitOptions {
        symmetry,
        rays: or_default(u, d.rays, |u| u.int_in_range(0..=1100))?,
        samples: or_default(u, d.samples, |u| u.int_in_range(0..=1100))?,
        rounds: or_default(u, d.rounds, |u| u.int_in_range(0..=40))?,
        tolerance: or_default(u, d.tolerance, |u| Ok(number(u)? as f64))?,
        stiffness: or_default(u, d.stiffness, |u| Ok(number(u)? as f64))?,
        tip: u.arbitrary()?,
        stub_ratio: or_default(u, d.stub_ratio, |u| Ok(number(u)? as f64))?,
        max_move: or_default(u, d.max_move, |u| Ok(number(u)? as f64))?,
        min_sections: or_default(u, d.min_sections, |u| u.int_in_range(0..=8))?,
        flat_ratio: or_default(u, d.flat_ratio, |u| Ok(number(u)? as f64))?,
        thick_ratio: or_default(u, d.thick_ratio, |u| Ok(number(u)? as f64))?,
        agreement: or_default(u, d.agreement, |u| Ok(number(u)? as f64))?,
        body_radius: or_default(u, d.body_radius, |u| Ok(number(u)? as f64))?,
    };
    // The work grows as rays x samples x bones x rounds: past this budget a long run is the work
    // asked for (576 rays x 571 sections a bone took a minute under the sanitizer; 12 rays x 384
    // sections x 5 bones x 12 rounds, 36 s), not a hang.
    let work = [opts.samples, pairs.len(), opts.rounds.max(1)].iter().fold(opts.rays, |w, &k| w.saturating_mul(k));
    if work > 1 << 16 {
        (opts.rays, opts.samples, opts.rounds) = (d.rays, d.samples, d.rounds);
    }
    match fit_joints(&m.vertices, &m.triangles, &joints, &pairs, &movable, &opts) {
        Ok((out, report)) => {
            assert_eq!(out.len(), joints.len());
            assert!(out.iter().flatten().all(|c| c.is_finite()), "non-finite joint");
            assert_eq!(report.outside_after.len(), joints.len());
        }
        Err(Error::Internal(e)) => panic!("internal error: {e}"),
        Err(_) => {}
    }
    Ok(())
}

fuzz_target!(|data: &[u8]| {
    let _ = run(&mut Unstructured::new(data));
});
