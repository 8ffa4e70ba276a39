//! Add Motion's core: `detect_roles` on any skeleton and names, then `motion_clip` of any
//! motion, parameters and skin, and `posed_points` of its frames. When they succeed: roles that name
//! bones of the rig, a clip of finite unit rotations.
#![no_main]

use arbitrary::{Result, Unstructured};
use libfuzzer_sys::fuzz_target;
use miniskeleton_core::motion::{detect_roles, motion_clip, posed_points, GaitParams, Motion, Skeleton, Skin};
use miniskeleton_core::Error;
use miniskeleton_fuzz::{bones, mesh, names, number, or_default};

fn run(u: &mut Unstructured) -> Result<()> {
    // The bones of a mesh-sized box; the mesh's vertices are the skin.
    let m = mesh(u)?;
    let b = bones(u, &m)?;
    let n = b.heads.len();
    let mut names = names(u, n)?;
    if u.ratio(1u8, 16)? {
        names.pop();
    }
    let roles = match detect_roles(&Skeleton::new(&b.heads, &b.tails, &b.parents, &names)) {
        Ok(r) => r,
        Err(Error::Internal(e)) => panic!("internal error: {e}"),
        Err(_) => return Ok(()),
    };
    let in_rig = |j: usize| assert!(j < n, "role bone {j} of {n}");
    in_rig(roles.root);
    in_rig(roles.head);
    roles.spine.iter().chain(&roles.neck).chain(&roles.tail).copied().for_each(in_rig);
    roles.legs.iter().chain(&roles.arms).flat_map(|l| l.bones.iter().copied()).for_each(in_rig);
    // Rest matrices (row-major 3x3): identity, or anything.
    let rest: Vec<[f32; 9]> = (0..n)
        .map(|_| {
            let mut r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
            if u.ratio(1u8, 8)? {
                for x in r.iter_mut() {
                    *x = number(u)?;
                }
            }
            Ok(r)
        })
        .collect::<Result<_>>()?;
    let d = GaitParams::default();
    let params = GaitParams {
        motion: *u.choose(&[Motion::HeadShake, Motion::Walk, Motion::Run])?,
        fps: or_default(u, d.fps, number)?,
        cycles: or_default(u, d.cycles, number)?,
        duration: or_default(u, d.duration, number)?,
        amplitude: or_default(u, d.amplitude, number)?,
        stride: or_default(u, d.stride, number)?,
        speed: or_default(u, d.speed, number)?,
        root_motion: u.arbitrary()?,
    };
    // Each skin point owned by a bone of the rig, by none (-1), or rarely by anything.
    let owners: Vec<i32> = (0..m.vertices.len())
        .map(|_| if u.ratio(1u8, 32)? { u.arbitrary() } else { Ok(u.int_in_range(-1..=n as i32 - 1)?) })
        .collect::<Result<_>>()?;
    let skin = if u.ratio(1u8, 4)? { Skin::NONE } else { Skin { points: &m.vertices, bones: &owners } };
    let clip = match motion_clip(&Skeleton::new(&b.heads, &b.tails, &b.parents, &[]), &rest, &roles, &params, &skin) {
        Ok(c) => c,
        Err(Error::Internal(e)) => panic!("internal error: {e}"),
        Err(_) => return Ok(()),
    };
    assert_eq!(clip.rotations.len(), clip.frames * clip.bone_count);
    for q in &clip.rotations {
        let len = q.iter().map(|c| c * c).sum::<f32>().sqrt();
        assert!((len - 1.0).abs() < 1e-3, "rotation {q:?}");
    }
    let frame = u.choose_index(clip.frames.max(1))?.min(clip.frames.saturating_sub(1));
    if clip.frames > 0 {
        let local = &clip.rotations[frame * n..(frame + 1) * n];
        let locations = if clip.locations.is_empty() { &[][..] } else { &clip.locations[frame * n..(frame + 1) * n] };
        let offset = clip.root_offset.get(frame).copied().unwrap_or([0.0; 3]);
        let (h, t) = posed_points(&b.heads, &b.tails, &b.parents, &rest, local, locations, offset);
        assert_eq!((h.len(), t.len()), (n, n));
    }
    Ok(())
}

fuzz_target!(|data: &[u8]| {
    let _ = run(&mut Unstructured::new(data));
});
