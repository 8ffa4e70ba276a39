//! Cross-sections of a solid mesh, for fitting joints: the centre of the section by a plane,
//! a bone's centre line through its sections' centres, the medial end of a rounded limb tip,
//! and the nearest point inside.
//!
//! A section's centre is the least-squares point of the midpoints of chords cast in the plane,
//! iterated to its fixed point (the exact centre of a circle or an ellipse); a bone's centre
//! line is a weighted least-squares line through the centres of its sections. Everything is in
//! the unit frame of the mesh ([`crate::mesh::Frame`]); rays see the union of the mesh's
//! pieces ([`Solid::hits`]). Used by `fit.rs`.

use crate::mesh::solid::Solid;
use glam::DVec3;

/// A free limb end goes this many local radii short of the tip of the mesh beyond it.
const TIP_MARGIN: f64 = 0.3;
/// Joints pulled inside go this far (unit frame) past the surface, at most half the chord.
const PULL_DEPTH: f64 = 0.005;

/// A centre line tilted more than this (degrees) from its bone is not the bone's limb: sections
/// across a limb that far off are cut nearly lengthwise (twice as long as wide at 60 degrees),
/// and such a tilt comes from sections of unrelated parts (a thin strap, then a hip), whose
/// line swings a joint along the bone.
const MAX_TILT_DEG: f64 = 60.0;

/// Rays never need to be longer than this in the unit frame (the mesh fits in diagonal 1).
const FAR: f32 = 4.0;

/// How [`centre_line`] samples and accepts a bone's sections.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LineOptions {
    /// Chord directions per cross-section (>= 3).
    pub rays: usize,
    /// Fewest sections a line needs (clamped to `1..=samples`).
    pub min_sections: usize,
    /// Cross-sections per bone.
    pub samples: usize,
    /// A stub leaving a junction whose thinnest section is wider than this times its length has
    /// no line; 0 turns the test off.
    pub stub_ratio: f64,
    /// Find where a free end's rounded tip stops.
    pub tip: bool,
    /// A section longer than this times its width places the bone across its short axis only;
    /// 0 turns the test off.
    pub flat_ratio: f64,
    /// Any bone whose thinnest section is wider than this times its length has no line; 0 turns
    /// the test off.
    pub thick_ratio: f64,
}

/// Where the ray from `p` along `dir` enters or leaves the mesh (the union of its pieces).
pub(crate) fn hits(solid: &Solid, p: DVec3, dir: DVec3) -> Vec<f32> {
    solid.hits(p.as_vec3(), dir.as_vec3(), FAR)
}

/// Ray-parity inside test in the unit frame ([`Solid::inside`]: inside some piece).
pub fn inside(solid: &Solid, p: DVec3) -> bool {
    solid.inside(p, FAR)
}

/// Two unit vectors completing `d` (unit) to an orthonormal basis.
fn basis(d: DVec3) -> (DVec3, DVec3) {
    let a = if d.x.abs() < 0.6 {
        DVec3::X
    } else if d.y.abs() < 0.6 {
        DVec3::Y
    } else {
        DVec3::Z
    };
    let u = d.cross(a).normalize();
    (u, d.cross(u))
}

/// Move `q` (unit frame) to the centre of the mesh cross-section by the plane through `q` with
/// normal `d` (unit). `None` when the point is outside and no chord in the plane reaches in.
fn centre_in_plane(rm: &Solid, q0: DVec3, d: DVec3, lines: usize, reach: f64) -> Option<(DVec3, f64)> {
    let (u, v) = basis(d);
    let dirs: Vec<DVec3> = (0..lines)
        .map(|k| {
            let a = std::f64::consts::PI * (k as f64 + 0.5) / lines as f64;
            u * a.cos() + v * a.sin()
        })
        .collect();
    let mut q = q0;
    let mut moved_in = false;
    let mut radius = 0.0;
    for _ in 0..24 {
        let mut chords = Vec::with_capacity(lines); // (w, forward first hit, backward first hit)
        let mut odd = 0;
        let mut entries: Vec<(f64, DVec3)> = Vec::new(); // (entry distance, chord midpoint) if outside
        for &w in &dirs {
            let f = hits(rm, q, w);
            let b = hits(rm, q, -w);
            odd += (f.len() % 2) + (b.len() % 2);
            if let (Some(&hf), Some(&hb)) = (f.first(), b.first()) {
                chords.push((w, hf as f64, hb as f64));
            }
            for (h, s) in [(&f, 1.0), (&b, -1.0)] {
                if h.len() >= 2 {
                    entries.push((h[0] as f64, q + w * s * (h[0] as f64 + h[1] as f64) * 0.5));
                }
            }
        }
        if 2 * odd <= 2 * lines {
            // Outside: jump to the middle of the nearest chord in the plane, once.
            if moved_in {
                return None;
            }
            let best = entries.iter().filter(|e| e.0 <= reach).min_by(|a, b| a.0.total_cmp(&b.0))?;
            q = best.1;
            moved_in = true;
            continue;
        }
        if chords.is_empty() {
            return Some((q, radius));
        }
        let mut half: Vec<f64> = chords.iter().map(|c| 0.5 * (c.1 + c.2)).collect();
        half.sort_by(|a, b| a.total_cmp(b));
        let r_med = half[half.len() / 2];
        radius = r_med;
        // Least squares: sum_k (w_k . delta - s_k)^2 over the chords not escaping into
        // another part of the body (longer than 3x the median half-chord).
        let (mut a11, mut a12, mut a22, mut b1, mut b2) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for &(w, hf, hb) in &chords {
            if 0.5 * (hf + hb) > 3.0 * r_med {
                continue;
            }
            let s = 0.5 * (hf - hb);
            let (wu, wv) = (w.dot(u), w.dot(v));
            a11 += wu * wu;
            a12 += wu * wv;
            a22 += wv * wv;
            b1 += s * wu;
            b2 += s * wv;
        }
        let det = a11 * a22 - a12 * a12;
        if !(det > 1e-12) {
            return Some((q, radius));
        }
        let (x, y) = ((a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det);
        let mut delta = u * x + v * y;
        let len = delta.length();
        if len > 0.5 * r_med {
            delta *= 0.5 * r_med / len;
        }
        q += delta;
        if delta.length() < 1e-7 {
            break;
        }
    }
    Some((q, radius))
}

/// The long axis of the section through `c` (normal `d`, unit) and its elongation, by `lines`
/// chords through `c`: the eigenvectors of the second moment of the chords' ends (`sum l^2 w
/// w^T`, `l^2` the squared distances to the surface both ways along `w`), the elongation the
/// square root of the eigenvalues' ratio (3 for an ellipse three times as long as wide).
/// `None` when a direction has no chord (a degenerate section).
fn section_shape(rm: &Solid, c: DVec3, d: DVec3, lines: usize) -> Option<(DVec3, f64)> {
    let (u, v) = basis(d);
    let (mut m11, mut m12, mut m22) = (0.0, 0.0, 0.0);
    for k in 0..lines {
        let a = std::f64::consts::PI * (k as f64 + 0.5) / lines as f64;
        let (wu, wv) = (a.cos(), a.sin());
        let w = u * wu + v * wv;
        let (Some(&hf), Some(&hb)) = (hits(rm, c, w).first(), hits(rm, c, -w).first()) else { continue };
        let l2 = (hf as f64).powi(2) + (hb as f64).powi(2);
        m11 += l2 * wu * wu;
        m12 += l2 * wu * wv;
        m22 += l2 * wv * wv;
    }
    let tr = 0.5 * (m11 + m22);
    let disc = (0.25 * (m11 - m22).powi(2) + m12 * m12).sqrt();
    let (big, small) = (tr + disc, tr - disc);
    if !(small > 1e-18) {
        return None;
    }
    // Eigenvector of the larger eigenvalue, in (u, v).
    let e = if m12.abs() > 1e-18 {
        (big - m22, m12)
    } else if m11 >= m22 {
        (1.0, 0.0)
    } else {
        (0.0, 1.0)
    };
    let long = (u * e.0 + v * e.1).normalize_or_zero();
    Some((long, (big / small).sqrt()))
}

/// Nearest point inside the mesh: middle of the nearest chord along rays over the sphere (or,
/// with `plane = Some(axis)`, over the circle of directions with no `axis` component).
pub(crate) fn pull_inside(rm: &Solid, p: DVec3, plane: Option<usize>, toward: &[DVec3]) -> Option<DVec3> {
    let n = 96;
    let mut best: Option<(f64, DVec3)> = None;
    // Rays toward the nearest surface points first (thin parts slip between sphere directions),
    // then over the sphere.
    let extra: Vec<DVec3> = toward
        .iter()
        .map(|&t| {
            // Aim a little off the vertex itself: a ray through a vertex or edge can report
            // one crossing twice and break the chord pairing.
            let jitter = DVec3::new((t.x * 1e4).sin(), (t.y * 1e4 + 1.0).sin(), (t.z * 1e4 + 2.0).sin());
            let mut w = t + jitter * 1e-4 - p;
            if let Some(axis) = plane {
                w[axis] = 0.0;
            }
            w.normalize_or_zero()
        })
        .filter(|w| *w != DVec3::ZERO)
        .collect();
    for i in 0..n + extra.len() {
        let w = if i >= n {
            extra[i - n]
        } else {
            match plane {
                None => {
                    // Fibonacci sphere.
                    let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
                    let r = (1.0 - z * z).max(0.0).sqrt();
                    let a = i as f64 * 2.399_963_229_728_653;
                    DVec3::new(r * a.cos(), r * a.sin(), z)
                }
                Some(axis) => {
                    let a = std::f64::consts::TAU * i as f64 / n as f64;
                    let (u, v) = basis(DVec3::AXES[axis]);
                    u * a.cos() + v * a.sin()
                }
            }
        };
        let h = hits(rm, p, w);
        let mut k = 0;
        // Pairs (entry, exit) along the ray; the first whose middle tests inside.
        while k + 1 < h.len() {
            let (t0, t1) = (h[k] as f64, h[k + 1] as f64);
            if best.as_ref().is_none_or(|b| t0 < b.0) {
                // Just past the entry (a long chord may run through a whole body part).
                let c = p + w * (t0 + (0.5 * (t1 - t0)).min(PULL_DEPTH));
                if inside(rm, c) {
                    best = Some((t0, c));
                    break;
                }
            }
            k += 2;
        }
    }
    best.map(|b| b.1)
}

/// A bone's centre line: a point at the head, the unit direction, and for a limb's free end
/// where the medial axis of its rounded tip stops.
#[derive(Clone)]
pub(crate) struct Line {
    /// A point of the line, next to the bone's head.
    pub head: DVec3,
    /// Unit direction, head to tail.
    pub dir: DVec3,
    /// Where the medial axis of a free end's rounded tip stops.
    pub tip: Option<DVec3>,
    /// The local radius of the limb around the line (unit frame): its sections' radii, weighted
    /// as the line's fit weighs them.
    pub radius: f64,
}

/// The centre line of the bone from joint `a` to joint `t` (unit frame): cross-sections at
/// `fractions` along it, kept when their centre is within the section reach of the bone, then
/// a weighted least-squares line of their offsets (weights `1 / r^2`: thin sections, the limb
/// itself, outweigh sections through the body it joins). `None` with too few sections
/// ([`LineOptions::min_sections`]), for a stub leaving a `junction` ([`LineOptions::stub_ratio`]),
/// or for a line tilted more than [`MAX_TILT_DEG`] from the bone.
pub(crate) fn centre_line(
    rm: &Solid,
    a: DVec3,
    t: DVec3,
    junction: bool,
    fractions: &[f64],
    opts: &LineOptions,
) -> Option<Line> {
    let axis = t - a;
    let len = axis.length();
    if !(len > 1e-9) {
        return None;
    }
    let d = axis / len;
    let reach = (0.5 * len).clamp(0.03, 0.1);
    let mut pts = Vec::new();
    for &s in fractions {
        let q = a + axis * s;
        if let Some((c, r)) = centre_in_plane(rm, q, d, opts.rays, reach) {
            let off = c - q;
            let mut off = off - d * off.dot(d);
            // A flat section (a wing, a flat tail) says where the bone lies across it, not
            // along it: the middle of its long axis is the middle of the whole flat part.
            if opts.flat_ratio > 0.0 {
                if let Some((long, aspect)) = section_shape(rm, c, d, opts.rays) {
                    if aspect > opts.flat_ratio {
                        off -= long * off.dot(long);
                    }
                }
            }
            if off.length() > reach {
                continue; // a section of some other part of the body
            }
            pts.push((s, off, r));
        }
    }
    // Too few sections (see `min_sections`): no centre line.
    if pts.len() < opts.min_sections.clamp(1, opts.samples) {
        return None;
    }
    // A stub branching off a junction (shorter than its thinnest section is wide: the link
    // from a pelvis to a hip, from a chest to a shoulder) lies inside a body part; its
    // sections are slices of that body, so it has no centre line.
    let thinnest = pts.iter().map(|x| x.2).fold(f64::INFINITY, f64::min);
    if junction && opts.stub_ratio > 0.0 && thinnest > opts.stub_ratio * len {
        return None;
    }
    // Any bone far shorter than its part is thick (a spine link in a belly, a jaw in a head):
    // its sections are slices of the whole part, whose centre is not the bone's place.
    if opts.thick_ratio > 0.0 && thinnest > opts.thick_ratio * len {
        return None;
    }
    let ws: Vec<f64> = pts.iter().map(|x| 1.0 / (x.2 * x.2).max(1e-8)).collect();
    let wsum: f64 = ws.iter().sum();
    let sm = pts.iter().zip(&ws).map(|(x, w)| x.0 * w).sum::<f64>() / wsum;
    let om = pts.iter().zip(&ws).map(|(x, w)| x.1 * *w).sum::<DVec3>() / wsum;
    let sxx: f64 = pts.iter().zip(&ws).map(|(x, w)| w * (x.0 - sm) * (x.0 - sm)).sum();
    let beta = if sxx > 1e-12 * wsum {
        pts.iter().zip(&ws).map(|(x, w)| x.1 * (w * (x.0 - sm))).sum::<DVec3>() / sxx
    } else {
        DVec3::ZERO
    };
    if beta.length() > len * MAX_TILT_DEG.to_radians().tan() {
        return None;
    }
    let alpha = om - beta * sm;
    let head = a + alpha;
    let tail = t + alpha + beta;
    let dir = (tail - head).normalize_or_zero();
    if dir == DVec3::ZERO {
        return None;
    }
    let s_last = pts.last().map(|x| x.0).unwrap_or(0.0);
    let tip = if opts.tip && s_last >= 0.5 { free_tip(rm, head, tail, dir, s_last, opts.rays) } else { None };
    let radius = pts.iter().zip(&ws).map(|(x, w)| x.2 * w).sum::<f64>() / wsum;
    Some(Line { head, dir, tip, radius })
}

/// Free end: from the centre of the section at `s_last` along the line `head` -> `tail`, the
/// medial axis of a rounded end stops [`TIP_MARGIN`] local radii short of the tip.
fn free_tip(rm: &Solid, head: DVec3, tail: DVec3, dir: DVec3, s_last: f64, rays: usize) -> Option<DVec3> {
    let x0 = head + (tail - head) * s_last;
    let (x0, r) = centre_in_plane(rm, x0, dir, rays, 0.0)?;
    let f = *hits(rm, x0, dir).first()? as f64;
    let remaining = (1.0 - s_last) * (tail - head).length();
    (r > 0.0 && f > r && f < remaining + 3.0 * r).then(|| x0 + dir * (f - TIP_MARGIN * r))
}
