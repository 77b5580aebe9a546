//! The min-max depth quadtree of a reference's transparent fragments and
//! the ray cast through it (seed 000, Schollmeyer et al., TVCG 2017, §4.2
//! and §5.3), used by `schollmeyer-transparent`.
//!
//! Coordinates: the reference's sample grid, shifted by half a sample so
//! that sample `(i, j)` covers `[i, i + 1) x [j, j + 1)` (its centre is at
//! `(i + ½, j + ½)`); a node of level `L` at index `(I, J)` covers
//! `[I·2^L, (I + 1)·2^L) x [J·2^L, (J + 1)·2^L)`.
//!
//! Rules:
//! 1. Build (once per reference, `prepare`): level 0 holds, per sample, the
//!    smallest and largest depth of its fragments (none: empty); level
//!    `L + 1` the min and max of its 2x2 children ("a series of parallel
//!    reductions ... propagates only the minimum and maximum depth of its
//!    four children"), up to [`TOP_LEVEL`] (nodes of 32x32 samples, the
//!    paper's maximum node size).
//! 2. A ray of the derived camera through a derived sample, from the
//!    derived centre of projection to the depth of the opaque surface the
//!    grid warp left there (`t_far`, infinite where none), is clipped to
//!    the reference's depth `Z > `[`NEAR`] and projected into the
//!    reference: a 2D segment along which `1/Z` is linear, then clipped to
//!    the image.
//! 3. Traversal ("inspired by the stackless height-field ray casting of
//!    Tevs et al."): start at the top level at the segment's start; at a
//!    node, the ray's depth range over the part of the segment inside the
//!    node (from the linear `1/Z` at its entry and exit) is compared with
//!    the node's range widened by the extrusion (rule 4). No overlap: move
//!    to the node's exit and, if that crosses into another parent, go up
//!    one level ("ascend one level whenever the ray start advances to a
//!    boundary which is also a boundary between nodes one level above").
//!    Overlap: descend to the child holding the current position, or, at
//!    a leaf, test its fragments and move to its exit. Every node examined
//!    is one *cell visited* (the work the paper's Fig. 7b colour-codes).
//! 4. A fragment at depth `Z_f` is a box `[Z_f (1 − κ), Z_f (1 + κ)]` over
//!    its sample ("we extrude each fragment slightly in depth and intersect
//!    the resulting box"); the ray hits it if its depth range over the
//!    sample overlaps the box. The crossing depth is the ray's depth
//!    closest to `Z_f` within the sample.
//! 5. Hits come in ray order; a hit whose crossing depth lies within the
//!    box thickness of the last kept hit is the same surface seen in a
//!    neighbouring sample and is dropped ("we make sure that the ray does
//!    not hit any other fragment within the thickness of the box"). The
//!    walk stops early when the kept hits' accumulated opacity reaches
//!    the threshold.
//!
//! [`brute_force`] walks every sample the segment crosses, with the same
//! rules 2, 4 and 5: the quadtree must find exactly its hits
//! (`tests/methods_schollmeyer.rs`).

use crate::trace::layers::{Fragment, FragmentLayer};
use glam::{DVec2, DVec3};
use postwarp_rtl::Camera;

/// The top level of the quadtree (nodes of 2^5 = 32 samples a side).
pub const TOP_LEVEL: usize = 5;
/// Nearest reference depth a ray is followed at (scene units).
pub const NEAR: f64 = 1e-4;
/// Nudge past a node boundary (samples) to find the next node.
const NUDGE: f64 = 1e-7;
/// Far end of a ray that never meets an opaque surface and does not
/// recede in the reference (scene units).
const FAR: f64 = 1e6;

/// One level: width, height (nodes) and each node's (min, max) depth.
type Level = (usize, usize, Vec<(f32, f32)>);

/// Per-sample depth ranges and their reductions (rule 1).
#[derive(Clone, Debug)]
pub struct MinMaxQuadtree {
    /// Levels 0 to `TOP_LEVEL`.
    levels: Vec<Level>,
}

const EMPTY: (f32, f32) = (f32::INFINITY, f32::NEG_INFINITY);

impl MinMaxQuadtree {
    /// Rule 1 for `layer`.
    pub fn build(layer: &FragmentLayer) -> MinMaxQuadtree {
        let (w, h) = (layer.width as usize, layer.height as usize);
        let base: Vec<(f32, f32)> =
            (0..w * h).map(|i| layer.at(i).iter().fold(EMPTY, |(lo, hi), f| (lo.min(f.z), hi.max(f.z)))).collect();
        let mut levels = vec![(w, h, base)];
        for _ in 0..TOP_LEVEL {
            let (pw, ph, prev) = levels.last().expect("level 0");
            let (nw, nh) = (pw.div_ceil(2), ph.div_ceil(2));
            let mut next = vec![EMPTY; nw * nh];
            for y in 0..*ph {
                for x in 0..*pw {
                    let (lo, hi) = prev[y * pw + x];
                    let n = &mut next[(y / 2) * nw + x / 2];
                    *n = (n.0.min(lo), n.1.max(hi));
                }
            }
            levels.push((nw, nh, next));
        }
        MinMaxQuadtree { levels }
    }

    fn node(&self, level: usize, i: i64, j: i64) -> (f32, f32) {
        let (w, h, v) = &self.levels[level];
        if i < 0 || j < 0 || i >= *w as i64 || j >= *h as i64 { EMPTY } else { v[j as usize * w + i as usize] }
    }
}

/// A fragment a ray hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Reference sample index.
    pub sample: usize,
    /// Slot of the fragment in the sample (0 = nearest).
    pub slot: usize,
    /// The fragment.
    pub fragment: Fragment,
    /// Crossing depth in the reference (rule 4).
    pub ref_depth: f64,
    /// Depth of the crossing point in the derived camera.
    pub derived_depth: f64,
}

/// What one ray cast found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cast {
    /// Hits kept (rule 5), in ray order.
    pub hits: Vec<Hit>,
    /// Quadtree nodes examined (rule 3); samples examined for
    /// [`brute_force`].
    pub cells_visited: u64,
}

/// The ray of rule 2, in the reference: the 2D segment (shifted sample
/// coordinates) and `1/Z` at its ends.
#[derive(Clone, Copy, Debug)]
pub struct Segment {
    start: DVec2,
    /// Unit direction (zero for a point).
    dir: DVec2,
    /// Length (samples).
    len: f64,
    inv_z0: f64,
    inv_z1: f64,
    /// The derived ray and the reference camera, to place crossings.
    origin: DVec3,
    ray: DVec3,
    reference: Camera,
}

impl Segment {
    /// Rule 2: the derived ray `origin + t·ray` (`ray` with derived
    /// camera-space z = 1, so `t` is the derived depth), `t` in `(0,
    /// t_far]`, seen by `reference` (its sample grid); `None` if no part of
    /// it is in front of the reference and inside its image.
    pub fn new(origin: DVec3, ray: DVec3, t_far: f64, reference: &Camera) -> Option<Segment> {
        let q = reference.pose.orientation.inverse();
        let a = q * (origin - reference.pose.position);
        let b = q * ray;
        let (mut t0, mut t1) = (0.0f64, t_far);
        if b.z > 0.0 {
            t0 = t0.max((NEAR - a.z) / b.z);
        } else if b.z < 0.0 {
            t1 = t1.min((NEAR - a.z) / b.z);
        } else if a.z <= NEAR {
            return None;
        }
        if t1.is_infinite() && b.z <= 0.0 {
            t1 = FAR;
        }
        if t1.partial_cmp(&t0) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        let k = reference.intrinsics;
        let screen = |p: DVec3| DVec2::new(k.fx * p.x / p.z + k.cx + 0.5, k.fy * p.y / p.z + k.cy + 0.5);
        let p0 = a + b * t0;
        let s0 = screen(p0);
        let (s1, inv_z1) = if t1.is_infinite() {
            (DVec2::new(k.fx * b.x / b.z + k.cx + 0.5, k.fy * b.y / b.z + k.cy + 0.5), 0.0)
        } else {
            let p1 = a + b * t1;
            (screen(p1), 1.0 / p1.z)
        };
        let inv_z0 = 1.0 / p0.z;
        // Clip to the image [0, W] x [0, H] (Liang-Barsky on u in [0, 1]).
        let d = s1 - s0;
        let (w, h) = (k.width as f64, k.height as f64);
        let (mut u0, mut u1) = (0.0f64, 1.0f64);
        for (p, q) in [(-d.x, s0.x), (d.x, w - s0.x), (-d.y, s0.y), (d.y, h - s0.y)] {
            if p == 0.0 {
                if q < 0.0 {
                    return None;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    u0 = u0.max(r);
                } else {
                    u1 = u1.min(r);
                }
            }
        }
        if u1 < u0 || !u0.is_finite() || !u1.is_finite() {
            return None;
        }
        let start = s0 + d * u0;
        let end = s0 + d * u1;
        let lerp = |u: f64| inv_z0 + (inv_z1 - inv_z0) * u;
        let len = (end - start).length();
        let dir = if len > 0.0 { (end - start) / len } else { DVec2::ZERO };
        Some(Segment { start, dir, len, inv_z0: lerp(u0), inv_z1: lerp(u1), origin, ray, reference: *reference })
    }

    fn at(&self, s: f64) -> DVec2 {
        self.start + self.dir * s
    }

    fn inv_z(&self, s: f64) -> f64 {
        if self.len > 0.0 { self.inv_z0 + (self.inv_z1 - self.inv_z0) * (s / self.len) } else { self.inv_z0 }
    }

    /// The ray's reference depth range over `[sa, sb]` (a point segment:
    /// its whole range).
    fn z_range(&self, sa: f64, sb: f64) -> (f64, f64) {
        let (a, b) = if self.len > 0.0 { (self.inv_z(sa), self.inv_z(sb)) } else { (self.inv_z0, self.inv_z1) };
        let (lo, hi) = (a.min(b), a.max(b));
        (1.0 / hi, if lo > 0.0 { 1.0 / lo } else { f64::INFINITY })
    }

    /// Exit parameter from the axis-aligned cell `[x0, x0 + size) x [y0,
    /// y0 + size)` holding the point at `s`.
    fn exit(&self, x0: f64, y0: f64, size: f64) -> f64 {
        let mut e = self.len;
        for (o, d, lo) in [(self.start.x, self.dir.x, x0), (self.start.y, self.dir.y, y0)] {
            if d > 0.0 {
                e = e.min((lo + size - o) / d);
            } else if d < 0.0 {
                e = e.min((lo - o) / d);
            }
        }
        e
    }

    /// Derived depth of the ray where it is at reference depth `z` near
    /// screen point `p` (shifted sample coordinates).
    fn derived_depth(&self, p: DVec2, z: f64) -> f64 {
        let x = self.reference.unproject(p.x - 0.5, p.y - 0.5, z);
        // The derived depth of the point on the ray nearest to x.
        (x - self.origin).dot(self.ray) / self.ray.length_squared()
    }
}

/// Rule 4 at sample `(i, j)` for the segment part `span`: its hits.
fn test_sample(
    seg: &Segment,
    layer: &FragmentLayer,
    (i, j): (i64, i64),
    span: (f64, f64),
    kappa: f64,
    out: &mut Vec<Hit>,
) {
    let (sa, sb) = span;
    if i < 0 || j < 0 || i >= layer.width as i64 || j >= layer.height as i64 {
        return;
    }
    let sample = j as usize * layer.width as usize + i as usize;
    let (za, zb) = seg.z_range(sa, sb);
    let mid = seg.at(0.5 * (sa + sb));
    for (slot, f) in layer.at(sample).iter().enumerate() {
        let z = f.z as f64;
        if zb >= z * (1.0 - kappa) && za <= z * (1.0 + kappa) {
            let cross = z.clamp(za, zb);
            out.push(Hit {
                sample,
                slot,
                fragment: *f,
                ref_depth: cross,
                derived_depth: seg.derived_depth(mid, cross),
            });
        }
    }
}

/// Rule 5 over `found` (one sample's hits at a time, in ray order): append
/// to `kept`; returns false once the accumulated opacity reaches
/// `threshold`.
fn keep(found: &mut Vec<Hit>, kept: &mut Vec<Hit>, opacity: &mut f64, kappa: f64, threshold: f64) -> bool {
    found.sort_by(|a, b| a.derived_depth.total_cmp(&b.derived_depth).then(a.slot.cmp(&b.slot)));
    for h in found.drain(..) {
        if let Some(last) = kept.last() {
            if (h.ref_depth - last.ref_depth).abs() <= kappa * (h.ref_depth + last.ref_depth) {
                continue;
            }
        }
        kept.push(h);
        *opacity = 1.0 - (1.0 - *opacity) * (1.0 - h.fragment.alpha as f64);
        if *opacity >= threshold {
            return false;
        }
    }
    true
}

/// Rules 3–5: cast `seg` through `tree` over `layer`.
pub fn cast(seg: &Segment, tree: &MinMaxQuadtree, layer: &FragmentLayer, kappa: f64, threshold: f64) -> Cast {
    let mut c = Cast::default();
    let (mut found, mut opacity) = (Vec::new(), 0.0);
    let widen = |(lo, hi): (f32, f32)| (lo as f64 * (1.0 - kappa), hi as f64 * (1.0 + kappa));
    let mut level = TOP_LEVEL;
    let mut s = 0.0;
    while s <= seg.len {
        let p = seg.at((s + NUDGE).min(seg.len));
        let size = (1u64 << level) as f64;
        let (i, j) = ((p.x / size).floor(), (p.y / size).floor());
        let exit = seg.exit(i * size, j * size, size);
        c.cells_visited += 1;
        let (lo, hi) = widen(tree.node(level, i as i64, j as i64));
        let (za, zb) = seg.z_range(s, exit.max(s));
        if zb >= lo && za <= hi {
            if level > 0 {
                level -= 1;
                continue;
            }
            test_sample(seg, layer, (i as i64, j as i64), (s, exit.max(s)), kappa, &mut found);
            if !keep(&mut found, &mut c.hits, &mut opacity, kappa, threshold) {
                break;
            }
        }
        if exit >= seg.len {
            break;
        }
        // Ascend one level when the move crosses into another parent.
        if level < TOP_LEVEL {
            let q = seg.at((exit + NUDGE).min(seg.len));
            let parent = 2.0 * size;
            if (q.x / parent).floor() != (p.x / parent).floor() || (q.y / parent).floor() != (p.y / parent).floor() {
                level += 1;
            }
        }
        s = exit;
    }
    c
}

/// Rules 2, 4 and 5 by walking every sample along `seg` (no quadtree):
/// the reference the quadtree cast is tested against.
pub fn brute_force(seg: &Segment, layer: &FragmentLayer, kappa: f64, threshold: f64) -> Cast {
    let mut c = Cast::default();
    let (mut found, mut opacity) = (Vec::new(), 0.0);
    let mut s = 0.0;
    while s <= seg.len {
        let p = seg.at((s + NUDGE).min(seg.len));
        let (i, j) = (p.x.floor(), p.y.floor());
        let exit = seg.exit(i, j, 1.0);
        c.cells_visited += 1;
        test_sample(seg, layer, (i as i64, j as i64), (s, exit.max(s)), kappa, &mut found);
        if !keep(&mut found, &mut c.hits, &mut opacity, kappa, threshold) || exit >= seg.len {
            break;
        }
        s = exit;
    }
    c
}
