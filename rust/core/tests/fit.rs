//! Skeleton fitting on generated tubes: centring, bends, idempotence, outside joints,
//! symmetry, fixed joints, scale, mesh checks and bad input.

use miniskeleton_core::mesh::Symmetry;
use miniskeleton_core::primitives::capped_cylinder;
use miniskeleton_core::skeleton::{fit_joints, points_inside, FitOptions};
use miniskeleton_core::Error;

type Mesh = (Vec<[f32; 3]>, Vec<[u32; 3]>);

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn norm(a: [f32; 3]) -> f32 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}
fn dist(a: [f32; 3], b: [f32; 3]) -> f32 {
    norm(sub(a, b))
}
fn unit(a: [f32; 3]) -> [f32; 3] {
    let n = norm(a);
    [a[0] / n, a[1] / n, a[2] / n]
}
fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Closed tube of radius `r` along a polyline in the XZ plane, mitred at the corners, capped
/// at both ends: one manifold piece. `per_segment` rings per segment, `s` vertices per ring.
fn tube(path: &[[f32; 3]], r: f32, per_segment: usize, s: usize) -> Mesh {
    let y = [0.0, 1.0, 0.0];
    let mut centres = Vec::new(); // (centre, tangent, scale along the miter)
    for i in 0..path.len() - 1 {
        let d = unit(sub(path[i + 1], path[i]));
        for k in 0..per_segment {
            if i > 0 && k == 0 {
                continue; // the corner ring is added below
            }
            let f = k as f32 / per_segment as f32;
            let c = [0, 1, 2].map(|a| path[i][a] + f * (path[i + 1][a] - path[i][a]));
            centres.push((c, d, d, 1.0));
        }
        let end = path[i + 1];
        if i + 2 < path.len() {
            let d2 = unit(sub(path[i + 2], path[i + 1]));
            let bis = unit([d[0] + d2[0], d[1] + d2[1], d[2] + d2[2]]);
            centres.push((end, bis, d, 1.0 / dot(bis, d)));
        } else {
            centres.push((end, d, d, 1.0));
        }
    }
    let mut v = Vec::new();
    for &(c, t, d, stretch) in &centres {
        // Ring in the plane normal to `t`; the in-plane axis of the bend (perpendicular to y)
        // is stretched by `stretch` so the tube keeps radius `r` through a mitred corner.
        let side = unit(cross(t, y));
        let side_d = unit(cross(d, y));
        let _ = side_d;
        for j in 0..s {
            let a = std::f32::consts::TAU * j as f32 / s as f32;
            let (ca, sa) = (a.cos() * r * stretch, a.sin() * r);
            v.push([c[0] + side[0] * ca + y[0] * sa, c[1] + side[1] * ca + y[1] * sa, c[2] + side[2] * ca + y[2] * sa]);
        }
    }
    let rings = centres.len();
    let mut t = Vec::new();
    let idx = |i: usize, j: usize| (i * s + j % s) as u32;
    for i in 0..rings - 1 {
        for j in 0..s {
            t.push([idx(i, j), idx(i, j + 1), idx(i + 1, j + 1)]);
            t.push([idx(i, j), idx(i + 1, j + 1), idx(i + 1, j)]);
        }
    }
    let b = v.len() as u32;
    v.push(centres[0].0);
    let e = v.len() as u32;
    v.push(centres[rings - 1].0);
    for j in 0..s {
        t.push([b, idx(0, j + 1), idx(0, j)]);
        t.push([e, idx(rings - 1, j), idx(rings - 1, j + 1)]);
    }
    (v, t)
}

/// Deterministic pseudo-random numbers in [-1, 1].
struct Rng(u32);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        self.0 as f32 / u32::MAX as f32 * 2.0 - 1.0
    }
    fn ball(&mut self, radius: f32) -> [f32; 3] {
        loop {
            let p = [self.next(), self.next(), self.next()];
            if norm(p) <= 1.0 {
                return p.map(|c| c * radius);
            }
        }
    }
}

/// Add `part`'s vertices and triangles to `mesh` (one more piece).
fn append(mesh: &mut Mesh, part: Mesh) {
    let base = mesh.0.len() as u32;
    mesh.0.extend(part.0);
    mesh.1.extend(part.1.iter().map(|f| f.map(|i| i + base)));
}

fn chain_bones(n: usize) -> Vec<[u32; 2]> {
    (0..n as u32 - 1).map(|i| [i, i + 1]).collect()
}

/// A straight limb: joints pushed sideways go back to the axis; along the axis they stay,
/// except the free end, which goes next to the cap.
#[test]
fn straight_tube_centres_perpendicular() {
    let (v, t) = capped_cylinder(0.5, 4.0, 40, 32);
    let truth: Vec<[f32; 3]> = (0..5).map(|i| [0.0, 0.0, 0.4 + 0.8 * i as f32]).collect();
    let mut rng = Rng(7);
    let start: Vec<[f32; 3]> = truth.iter().map(|p| [p[0] + 0.3 * rng.next(), p[1] + 0.3 * rng.next(), p[2]]).collect();
    // Radius 12 % of the diagonal is a body by default (a_joint_inside_a_body_is_not_dragged_to_its_centre);
    // here it is a limb.
    let opts = FitOptions { body_radius: f64::INFINITY, ..FitOptions::default() };
    let (out, rep) = fit_joints(&v, &t, &start, &chain_bones(5), &[true; 5], &opts).unwrap();
    for o in &out {
        assert!(o[0].abs() < 0.02 && o[1].abs() < 0.02, "not centred: {o:?}");
    }
    for (o, s) in out[..4].iter().zip(&start) {
        assert!((o[2] - s[2]).abs() < 0.05, "moved along the limb: {o:?} from {s:?}");
    }
    // The free end goes 0.3 radius short of the cap.
    assert!((out[4][2] - (4.0 - 0.3 * 0.5)).abs() < 0.03, "free end {:?}", out[4]);
    assert_eq!(rep.count_outside_after(), 0);
    assert_eq!((rep.open_edges, rep.nonmanifold_edges, rep.pieces), (0, 0, 1));
}

/// `max_move` caps how far a joint inside the mesh travels (fraction of the bounding-box diagonal).
#[test]
fn max_move_caps_the_fit() {
    let (v, t) = capped_cylinder(0.5, 4.0, 40, 32);
    let diag = (1.0f32 + 1.0 + 16.0).sqrt();
    let start: Vec<[f32; 3]> = (0..5).map(|i| [0.3, 0.0, 0.4 + 0.8 * i as f32]).collect();
    let opts = FitOptions { max_move: 0.02, tip: false, body_radius: f64::INFINITY, ..FitOptions::default() };
    // A loose vertex far away (no face uses it) does not widen the diagonal the cap is a
    // fraction of.
    let mut stray = v.clone();
    stray.push([400.0, 0.0, 0.0]);
    for v in [&v, &stray] {
        let (out, rep) = fit_joints(v, &t, &start, &chain_bones(5), &[true; 5], &opts).unwrap();
        for (o, s) in out.iter().zip(&start) {
            assert!(dist(*o, *s) <= 0.02 * diag * 1.001, "moved {} > cap: {o:?}", dist(*o, *s));
            assert!(o[0] < 0.3 - 0.01, "did not move toward the axis: {o:?}");
        }
        assert_eq!(rep.count_outside_after(), 0);
    }
}

/// A bent limb (L): the corner joint goes to the corner, from any side.
#[test]
fn bent_tube_corner() {
    let path = [[0.0, 0.0, 0.0], [0.0, 0.0, 2.0], [2.0, 0.0, 2.0]];
    let (v, t) = tube(&path, 0.25, 24, 24);
    let truth = [[0.0, 0.0, 0.3], [0.0, 0.0, 2.0], [1.7, 0.0, 2.0]];
    let bones = chain_bones(3);
    let diag = (4.5f32 * 4.5 + 2.5 * 2.5 + 0.25).sqrt().min(3.5);
    let mut before = 0.0;
    let mut after = 0.0;
    for seed in 1..20u32 {
        let mut rng = Rng(seed * 7919);
        let start: Vec<[f32; 3]> = truth
            .iter()
            .map(|p| {
                let d = rng.ball(0.05 * diag);
                [p[0] + d[0], p[1] + d[1], p[2] + d[2]]
            })
            .collect();
        // Radius 7 % of the diagonal is a body by default; here it is a limb.
        let opts = FitOptions { body_radius: f64::INFINITY, ..FitOptions::default() };
        let (out, rep) = fit_joints(&v, &t, &start, &bones, &[true; 3], &opts).unwrap();
        assert_eq!(rep.count_outside_after(), 0, "seed {seed}: {out:?}");
        before += dist(start[1], truth[1]);
        after += dist(out[1], truth[1]);
    }
    assert!(after < 0.35 * before, "corner error {after} vs {before} before");
}

/// Shoulders inside a torso: the chest-to-shoulder stubs (shorter than the torso is wide,
/// leaving the chest junction) give no centre line, so each shoulder stays on its arm's axis
/// instead of being dragged toward the torso's middle; with the stub rule and the do-no-harm rules
/// (FitOptions) off they are dragged.
#[test]
fn stub_bone_does_not_drag_its_joint() {
    let mut mesh = tube(&[[0.0, 0.0, 0.0], [0.0, 0.0, 2.0]], 0.5, 20, 32);
    for x in [1.0f32, -1.0] {
        append(&mut mesh, tube(&[[0.5 * x, 0.0, 1.1], [1.8 * x, 0.0, 1.1]], 0.12, 20, 16));
    }
    let (v, t) = mesh;
    // Chest on the torso's axis; per side a shoulder inside the torso at the arm's height, an
    // elbow and a wrist; a pelvis below the chest.
    let start = vec![
        [0.0, 0.0, 1.1],
        [0.4, 0.0, 1.1],
        [1.1, 0.0, 1.1],
        [1.7, 0.0, 1.1],
        [-0.4, 0.0, 1.1],
        [-1.1, 0.0, 1.1],
        [-1.7, 0.0, 1.1],
        [0.0, 0.0, 0.5],
    ];
    let bones = vec![[0, 1], [1, 2], [2, 3], [0, 4], [4, 5], [5, 6], [7, 0]];
    let movable = [false, true, true, false, true, true, false, false];
    let (out, _) = fit_joints(&v, &t, &start, &bones, &movable, &FitOptions::default()).unwrap();
    for j in [1, 4] {
        assert!(dist(out[j], start[j]) < 0.01, "shoulder {j} moved: {:?}", out[j]);
    }
    let off = FitOptions {
        stub_ratio: 0.0,
        thick_ratio: 0.0,
        agreement: 0.0,
        flat_ratio: 0.0,
        body_radius: f64::INFINITY,
        ..FitOptions::default()
    };
    let (dragged, _) = fit_joints(&v, &t, &start, &bones, &movable, &off).unwrap();
    assert!(dist(dragged[1], start[1]) > 0.05, "without the rule the torso drags it: {:?}", dragged[1]);
}

/// A bone whose only sections are slices of two unrelated parts (a thin strap above it, then a
/// thicker part below it, nothing further along: RobotExpressive's thigh) gets no centre line
/// from them: their line is tilted 65 degrees from the bone and would swing its free end (a
/// knee inside the body beyond) along the bone by the whole move cap.
#[test]
fn sections_of_two_parts_do_not_swing_a_free_end() {
    let mut mesh = tube(&[[0.05, 0.0, 0.08], [0.15, 0.0, 0.08]], 0.02, 4, 16);
    for (path, r) in [([[0.15, 0.0, -0.08], [0.225, 0.0, -0.08]], 0.03), ([[0.45, 0.0, 0.0], [0.75, 0.0, 0.0]], 0.3)] {
        append(&mut mesh, tube(&path, r, 4, 16));
    }
    let (v, t) = mesh;
    let start = vec![[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]];
    let (out, rep) = fit_joints(&v, &t, &start, &[[0, 1]], &[false, true], &FitOptions::default()).unwrap();
    assert!(!rep.outside_after[1]);
    assert!(dist(out[1], start[1]) < 1e-6, "the free end moved: {:?}", out[1]);
}

/// Fitting a fitted skeleton changes nothing beyond the tolerance.
#[test]
fn idempotent() {
    let path = [[0.0, 0.0, 0.0], [0.0, 0.0, 2.0], [1.5, 0.0, 3.0], [3.0, 0.0, 3.0]];
    let (v, t) = tube(&path, 0.3, 16, 20);
    let start = vec![[0.1, 0.05, 0.3], [0.15, -0.1, 2.0], [1.4, 0.1, 2.9], [2.7, 0.0, 3.1]];
    let bones = chain_bones(4);
    let opts = FitOptions::default();
    let (once, _) = fit_joints(&v, &t, &start, &bones, &[true; 4], &opts).unwrap();
    let (twice, _) = fit_joints(&v, &t, &once, &bones, &[true; 4], &opts).unwrap();
    let diag = 4.6;
    for (a, b) in once.iter().zip(&twice) {
        assert!(dist(*a, *b) < 2e-3 * diag, "moved again: {a:?} -> {b:?}");
    }
}

/// A limb made of two parts pushed into each other (kit-built and game models): the overlap is
/// inside, and a joint there is centred like any other, not pulled out of the buried faces.
#[test]
fn parts_pushed_into_each_other_are_one_solid() {
    let (mut v, mut t) = capped_cylinder(0.5, 2.0, 20, 32);
    let (v2, t2) = capped_cylinder(0.45, 2.0, 20, 32);
    let n = v.len() as u32;
    v.extend(v2.iter().map(|p| [p[0], p[1], p[2] + 1.5]));
    t.extend(t2.iter().map(|tri| tri.map(|i| i + n)));
    let in_overlap = [0.0, 0.0, 1.75];
    assert!(points_inside(&v, &t, &[in_overlap]).unwrap()[0]);
    let start = vec![[0.2, 0.1, 0.5], [0.15, -0.2, 1.75], [-0.1, 0.2, 3.0]];
    // A limb this thick (radius 13 % of the diagonal) is a body by default: centre it fully.
    let opts = FitOptions { tip: false, body_radius: f64::INFINITY, ..FitOptions::default() };
    let (out, rep) = fit_joints(&v, &t, &start, &chain_bones(3), &[true; 3], &opts).unwrap();
    assert_eq!(rep.pieces, 2);
    assert_eq!((rep.count_outside_before(), rep.count_outside_after()), (0, 0));
    for (o, s) in out.iter().zip(&start) {
        assert!(o[0].abs() < 0.02 && o[1].abs() < 0.02, "not centred: {o:?}");
        assert!((o[2] - s[2]).abs() < 0.05, "moved along the limb: {o:?} from {s:?}");
    }
}

/// Joints outside within reach of the surface come back inside; a joint farther outside than
/// `max_move` (a root on the ground, a pole target) and fixed joints keep their place.
#[test]
fn outside_pulled_in_far_outside_and_fixed_stay() {
    let (v, t) = capped_cylinder(0.5, 4.0, 40, 32);
    let diag = (1.0f32 + 1.0 + 16.0).sqrt();
    // 0.3, 0.3 and 0.22 outside: 7 % of the diagonal or less; then 1.5 (35 %) below the base.
    let start = vec![[0.8, 0.0, 0.5], [0.0, -0.8, 2.0], [0.5, 0.5, 3.5], [0.0, 0.0, -1.5]];
    let bones = [[0, 1], [1, 2], [3, 0]];
    let (out, rep) = fit_joints(&v, &t, &start, &bones, &[true; 4], &FitOptions::default()).unwrap();
    assert_eq!(rep.count_outside_before(), 4);
    assert_eq!(rep.outside_after, vec![false, false, false, true], "{out:?}");
    assert_eq!(rep.kept_outside, vec![false, false, false, true]);
    assert_eq!(out[3], start[3]);
    assert!(points_inside(&v, &t, &out[..3]).unwrap().iter().all(|&b| b));
    // With a cap past its distance, it is pulled in too.
    let far = FitOptions { max_move: 0.5, ..FitOptions::default() };
    let (out, rep) = fit_joints(&v, &t, &start, &bones, &[true; 4], &far).unwrap();
    assert_eq!(rep.count_outside_after(), 0, "{out:?}");
    assert!(dist(out[3], start[3]) > 0.1 * diag);
    let movable = [true, false, true, true];
    let (out, _) = fit_joints(&v, &t, &start, &bones, &movable, &FitOptions::default()).unwrap();
    assert_eq!(out[1], start[1]);
}

/// A wing (a section 15 times as wide as thick) with its bone along the leading edge: the fit
/// centres the bone across the wing's thickness but keeps it where the artist put it along the
/// wing's width; with the flat rule off, the bone is dragged toward the middle of the wing.
#[test]
fn flat_section_places_its_bone_across_it_only() {
    let (v, t) = capped_cylinder(1.0, 4.0, 40, 48);
    let v: Vec<[f32; 3]> = v.iter().map(|p| [1.5 * p[0], 0.1 * p[1], p[2]]).collect();
    let start = vec![[0.8, 0.05, 0.5], [0.8, -0.04, 2.0], [0.8, 0.04, 3.5]];
    let opts = FitOptions { tip: false, ..FitOptions::default() };
    let (out, _) = fit_joints(&v, &t, &start, &chain_bones(3), &[true; 3], &opts).unwrap();
    for (o, s) in out.iter().zip(&start) {
        assert!(o[1].abs() < 0.01, "not centred across the wing: {o:?}");
        assert!((o[0] - s[0]).abs() < 0.02 && (o[2] - s[2]).abs() < 0.02, "moved along the wing: {o:?}");
    }
    let off = FitOptions { flat_ratio: 0.0, ..opts };
    let (dragged, _) = fit_joints(&v, &t, &start, &chain_bones(3), &[true; 3], &off).unwrap();
    assert!(dragged[1][0] < 0.8 - 0.1, "without the rule the wing's middle drags it: {:?}", dragged[1]);
}

/// Inside a body (a section radius above `body_radius`) a joint off the centre (a hip in a
/// belly) keeps its place when it is within (radius - `body_radius`) of the centre, and moves
/// only that near when it is farther; in a limb (`body_radius` past the radius) it is centred.
#[test]
fn a_joint_inside_a_body_is_not_dragged_to_its_centre() {
    let (v, t) = capped_cylinder(0.35, 4.0, 40, 48);
    let diag = (0.35f32 * 0.35 * 8.0 + 16.0).sqrt();
    // Radius 0.35 is 0.085 of the diagonal: joints within (0.085 - 0.05) * diag = 0.144 stay.
    let slack = 0.35 - 0.05 * diag;
    let near = vec![[0.1, 0.0, 0.5], [0.1, 0.05, 2.0], [0.1, 0.0, 3.5]];
    let opts = FitOptions { tip: false, ..FitOptions::default() };
    let (out, _) = fit_joints(&v, &t, &near, &chain_bones(3), &[true; 3], &opts).unwrap();
    for (o, s) in out.iter().zip(&near) {
        assert!(dist(*o, *s) < 1e-5, "moved inside the body: {s:?} -> {o:?}");
    }
    let far = vec![[0.3, 0.0, 0.5], [0.3, 0.0, 2.0], [0.3, 0.0, 3.5]];
    let (out, _) = fit_joints(&v, &t, &far, &chain_bones(3), &[true; 3], &opts).unwrap();
    for o in &out {
        assert!((o[0] - slack).abs() < 0.03 && o[1].abs() < 0.01, "not moved to {slack} off the centre: {o:?}");
    }
    let limb = FitOptions { body_radius: f64::INFINITY, ..opts };
    let (out, _) = fit_joints(&v, &t, &near, &chain_bones(3), &[true; 3], &limb).unwrap();
    for o in &out {
        assert!(o[0].abs() < 0.02 && o[1].abs() < 0.02, "not centred: {o:?}");
    }
}

/// A tube of radius 0.3 along `path` and its mirror image across x = 0 (two pieces).
fn mirrored_tubes(path: &[[f32; 3]]) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let (l, lt) = tube(path, 0.3, 12, 20);
    let mut v = l.clone();
    let mut t = lt.clone();
    let base = v.len() as u32;
    v.extend(l.iter().map(|p| [-p[0], p[1], p[2]]));
    t.extend(lt.iter().map(|tr| [tr[0] + base, tr[2] + base, tr[1] + base]));
    (v, t)
}

/// Two bent limbs mirrored across x = 0 (two pieces).
fn mirrored_limbs() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    mirrored_tubes(&[[1.0, 0.0, 0.0], [1.0, 0.0, 2.0], [2.0, 0.0, 3.0]])
}

/// Two mirrored limbs: pairs end exactly mirrored, a centre joint on the plane.
#[test]
fn symmetry_exact() {
    let (v, t) = mirrored_limbs();
    // joints 0..3 left, 3..6 right (deliberately not mirrored), 6 a centre joint (outside).
    let start = vec![
        [1.1, 0.05, 0.3],
        [0.9, -0.1, 2.0],
        [1.8, 0.1, 2.9],
        [-0.95, 0.1, 0.25],
        [-1.12, 0.0, 2.1],
        [-1.9, -0.05, 2.8],
        [0.1, 0.0, 1.0],
    ];
    let bones = vec![[0, 1], [1, 2], [3, 4], [4, 5]];
    let opts = FitOptions {
        symmetry: Some(Symmetry { axis: 0, plane: 0.0, mirror: vec![3, 4, 5, 0, 1, 2, 6] }),
        ..FitOptions::default()
    };
    let (out, rep) = fit_joints(&v, &t, &start, &bones, &[true; 7], &opts).unwrap();
    for i in 0..3 {
        assert_eq!(out[i + 3], [-out[i][0], out[i][1], out[i][2]], "pair {i}");
    }
    assert_eq!(out[6][0], 0.0);
    assert_eq!(rep.pieces, 2);
    // joints of the limbs are centred
    assert!(dist(out[1], [1.0, 0.0, 2.0]) < 0.15, "{:?}", out[1]);
}

/// A left/right pair is fitted as one: where the mesh says nothing (along a straight limb) the
/// two rough joints meet halfway, rather than one side's guess being copied onto the other.
#[test]
fn symmetry_averages_a_pair_where_the_mesh_is_silent() {
    let (v, t) = mirrored_tubes(&[[1.0, 0.0, 0.0], [1.0, 0.0, 2.0]]);
    let start = vec![
        [1.05, 0.0, 0.2],
        [1.05, 0.05, 1.2],
        [0.95, 0.0, 1.8],
        [-0.95, 0.0, 0.2],
        [-1.0, -0.05, 0.8],
        [-1.05, 0.0, 1.8],
    ];
    let bones = vec![[0, 1], [1, 2], [3, 4], [4, 5]];
    let opts = FitOptions {
        symmetry: Some(Symmetry { axis: 0, plane: 0.0, mirror: vec![3, 4, 5, 0, 1, 2] }),
        ..FitOptions::default()
    };
    let (out, _) = fit_joints(&v, &t, &start, &bones, &[true; 6], &opts).unwrap();
    assert!((out[1][2] - 1.0).abs() < 0.02, "middle joints meet halfway: {:?}", out[1]);
    assert_eq!(out[4], [-out[1][0], out[1][1], out[1][2]]);
    assert!(dist(out[1], [1.0, 0.0, 1.0]) < 0.03, "{:?}", out[1]);
}

/// A torso with two arms whose joints are all given as centre-line joints (bones named without
/// a side): the arm joints lie far off the plane, so they are fitted on their own and counted,
/// not folded onto the spine; the spine still ends on the plane.
#[test]
fn symmetry_leaves_unnamed_side_joints_off_the_plane() {
    let mut mesh = tube(&[[0.0, 0.0, 0.0], [0.0, 0.0, 4.0]], 0.5, 20, 24);
    for x in [1.0f32, -1.0] {
        append(&mut mesh, tube(&[[0.3 * x, 0.0, 3.0], [1.9 * x, 0.0, 3.0]], 0.15, 12, 16));
    }
    let (v, t) = mesh;
    // A long spine (12 joints, slightly off the plane) and per side a shoulder, an elbow.
    let mut start: Vec<[f32; 3]> = (0..12).map(|i| [0.02, 0.0, 0.2 + 0.33 * i as f32]).collect();
    start.extend([[0.6, 0.0, 3.0], [1.2, 0.0, 3.0], [-0.6, 0.0, 3.0], [-1.2, 0.0, 3.0]]);
    let mut bones: Vec<[u32; 2]> = (0..11).map(|i| [i, i + 1]).collect();
    bones.extend([[8, 12], [12, 13], [8, 14], [14, 15]]);
    let opts = FitOptions {
        symmetry: Some(Symmetry { axis: 0, plane: 0.0, mirror: (0..16).collect() }),
        max_move: 0.05,
        ..FitOptions::default()
    };
    let (out, rep) = fit_joints(&v, &t, &start, &bones, &[true; 16], &opts).unwrap();
    assert_eq!(rep.off_plane_centre, 4);
    for j in 12..16 {
        assert!((out[j][0] - start[j][0]).abs() < 0.05, "arm joint {j} folded: {:?} from {:?}", out[j], start[j]);
    }
    assert!(out[..12].iter().all(|p| p[0] == 0.0), "{:?}", &out[..12]);
    assert_eq!(rep.count_outside_after(), 0);
}

/// Symmetry across a plane the rig is not mirrored in (a character facing +X fitted with X
/// symmetry) would fold left and right onto each other: a clear error, not a collapsed rig.
#[test]
fn symmetry_on_the_wrong_plane_is_an_error() {
    let (v, t) = mirrored_limbs();
    let start = vec![[1.0, 0.0, 0.3], [1.0, 0.0, 2.0], [-1.0, 0.0, 0.3], [-1.0, 0.0, 2.0]];
    let bones = vec![[0, 1], [2, 3]];
    let mirrored = |axis| FitOptions {
        symmetry: Some(Symmetry { axis, plane: 0.0, mirror: vec![2, 3, 0, 1] }),
        ..FitOptions::default()
    };
    // Mirrored in x: fine. In y each joint is 2 from its partner's image: 17 % of the diagonal each.
    assert!(fit_joints(&v, &t, &start, &bones, &[true; 4], &mirrored(0)).is_ok());
    match fit_joints(&v, &t, &start, &bones, &[true; 4], &mirrored(1)) {
        Err(Error::InvalidArgument(msg)) => assert!(msg.contains("mirror plane"), "{msg}"),
        other => panic!("expected a clear error, got {other:?}"),
    }
}

/// The report says how much of the mesh has a mirror image across the symmetry plane: all of
/// two mirrored limbs, little of the same limbs moved off the plane (where mirrored joints
/// can end outside); nothing is measured without symmetry.
#[test]
fn mirrored_surface_share_is_reported() {
    let (v, t) = mirrored_limbs();
    let start = [[1.0, 0.0, 0.3], [1.0, 0.0, 2.0], [-1.0, 0.0, 0.3], [-1.0, 0.0, 2.0]];
    let bones = [[0, 1], [2, 3]];
    let sym = FitOptions {
        symmetry: Some(Symmetry { axis: 0, plane: 0.0, mirror: vec![2, 3, 0, 1] }),
        ..FitOptions::default()
    };
    let (_, rep) = fit_joints(&v, &t, &start, &bones, &[true; 4], &sym).unwrap();
    let share = rep.mirrored_surface.unwrap();
    assert!(share > 0.99, "{share}");
    let shifted: Vec<[f32; 3]> = v.iter().map(|p| [p[0] + 0.3, p[1], p[2]]).collect();
    let (_, rep) = fit_joints(&shifted, &t, &start, &bones, &[true; 4], &sym).unwrap();
    let share = rep.mirrored_surface.unwrap();
    assert!(share < 0.5, "{share}");
    let (_, rep) = fit_joints(&v, &t, &start, &bones, &[true; 4], &FitOptions::default()).unwrap();
    assert_eq!(rep.mirrored_surface, None);
}

/// The result scales with the input (scale-free), at 1e-3 and 1e3.
#[test]
fn scale_free() {
    let (v, t) = capped_cylinder(0.5, 4.0, 40, 32);
    let start = vec![[0.2, 0.1, 0.5], [-0.2, 0.1, 2.0], [0.1, -0.3, 3.5]];
    let bones = chain_bones(3);
    let (ref_out, _) = fit_joints(&v, &t, &start, &bones, &[true; 3], &FitOptions::default()).unwrap();
    for s in [1e-3f32, 1e3] {
        let vs: Vec<[f32; 3]> = v.iter().map(|p| p.map(|c| c * s)).collect();
        let js: Vec<[f32; 3]> = start.iter().map(|p| p.map(|c| c * s)).collect();
        let (out, _) = fit_joints(&vs, &t, &js, &bones, &[true; 3], &FitOptions::default()).unwrap();
        for (a, b) in out.iter().zip(&ref_out) {
            assert!(dist(a.map(|c| c / s), *b) < 1e-3, "scale {s}: {a:?} vs {b:?}");
        }
    }
}

/// Open meshes and pieces are counted; bad input is a clear error, never a panic.
#[test]
fn mesh_checks_and_errors() {
    let (v, t) = capped_cylinder(0.5, 4.0, 10, 16);
    let open: Vec<[u32; 3]> = t[..t.len() - 16].to_vec(); // drop the top fan... partly
    let j = vec![[0.0, 0.0, 1.0], [0.0, 0.0, 2.0]];
    let (_, rep) = fit_joints(&v, &open, &j, &[[0, 1]], &[true; 2], &FitOptions::default()).unwrap();
    assert!(rep.open_edges > 0);

    let opts = FitOptions::default();
    assert!(matches!(fit_joints(&v, &[], &j, &[[0, 1]], &[true; 2], &opts), Err(Error::EmptyMesh(_))));
    let mut vn = v.clone();
    vn[3][1] = f32::NAN;
    assert!(matches!(fit_joints(&vn, &t, &j, &[[0, 1]], &[true; 2], &opts), Err(Error::NonFinite { .. })));
    let jn = vec![[0.0, f32::INFINITY, 1.0], [0.0, 0.0, 2.0]];
    assert!(matches!(fit_joints(&v, &t, &jn, &[[0, 1]], &[true; 2], &opts), Err(Error::NonFinite { .. })));
    assert!(matches!(fit_joints(&v, &t, &j, &[[0, 2]], &[true; 2], &opts), Err(Error::InvalidArgument(_))));
    assert!(matches!(fit_joints(&v, &t, &j, &[[1, 1]], &[true; 2], &opts), Err(Error::InvalidArgument(_))));
    assert!(matches!(fit_joints(&v, &t, &j, &[[0, 1]], &[true; 3], &opts), Err(Error::Shape(_))));
    assert!(matches!(fit_joints(&v, &t, &[], &[], &[], &opts), Err(Error::NoBones(_))));
    let deg = vec![[0u32, 0, 1]];
    assert!(matches!(fit_joints(&v, &deg, &j, &[[0, 1]], &[true; 2], &opts), Err(Error::EmptyMesh(_))));
    let bad_move = FitOptions { max_move: 0.0, ..opts.clone() };
    assert!(matches!(fit_joints(&v, &t, &j, &[[0, 1]], &[true; 2], &bad_move), Err(Error::InvalidArgument(_))));
    let bad_sym = FitOptions { symmetry: Some(Symmetry { axis: 3, plane: 0.0, mirror: vec![0, 1] }), ..opts.clone() };
    assert!(matches!(fit_joints(&v, &t, &j, &[[0, 1]], &[true; 2], &bad_sym), Err(Error::InvalidArgument(_))));
    // A joint with no bone and coincident joints are fine.
    let (out, _) =
        fit_joints(&v, &t, &[[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.2, 0.1, 2.0]], &[[0, 1]], &[true; 3], &opts).unwrap();
    assert!(out.iter().all(|p| p.iter().all(|c| c.is_finite())));
}
