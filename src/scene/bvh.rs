//! A small bounding-volume hierarchy over anything with an axis-aligned box.
//!
//! Used twice: over the triangles of each mesh (in the mesh's own
//! coordinates) and over the bounded objects of a scene. Built once, top
//! down, with a binned surface-area heuristic (16 bins per axis, leaves of at
//! most [`MAX_LEAF`] primitives); traversal visits the nearer child first and
//! keeps shrinking `t_max`, so the caller's closure sees only primitives that
//! could still give a closer hit.
//!
//! Rules: building is deterministic (no randomness, ties broken by axis and
//! bin order, a stable partition), so the same primitives always give the
//! same tree. All arithmetic is `f64`. Not modelled: refitting, instancing
//! of subtrees, SIMD packets.

use glam::DVec3;

/// Largest number of primitives in a leaf.
pub const MAX_LEAF: usize = 4;
const BINS: usize = 16;
const STACK: usize = 64;

/// An axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: DVec3,
    /// Largest corner.
    pub max: DVec3,
}

impl Aabb {
    /// The empty box (union identity).
    pub const EMPTY: Aabb = Aabb { min: DVec3::splat(f64::INFINITY), max: DVec3::splat(f64::NEG_INFINITY) };

    /// The box around a set of points.
    pub fn from_points(points: impl IntoIterator<Item = DVec3>) -> Aabb {
        points.into_iter().fold(Aabb::EMPTY, |b, p| b.grow(p))
    }

    /// This box grown to contain `p`.
    pub fn grow(self, p: DVec3) -> Aabb {
        Aabb { min: self.min.min(p), max: self.max.max(p) }
    }

    /// The union of two boxes.
    pub fn union(self, o: Aabb) -> Aabb {
        Aabb { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    /// Centre point.
    pub fn centre(&self) -> DVec3 {
        0.5 * (self.min + self.max)
    }

    /// Half the surface area (0 for an empty box).
    fn half_area(&self) -> f64 {
        let e = self.max - self.min;
        if e.x < 0.0 || e.y < 0.0 || e.z < 0.0 { 0.0 } else { e.x * e.y + e.y * e.z + e.z * e.x }
    }

    /// The 8 corners.
    pub fn corners(&self) -> [DVec3; 8] {
        let (a, b) = (self.min, self.max);
        [
            DVec3::new(a.x, a.y, a.z),
            DVec3::new(b.x, a.y, a.z),
            DVec3::new(a.x, b.y, a.z),
            DVec3::new(b.x, b.y, a.z),
            DVec3::new(a.x, a.y, b.z),
            DVec3::new(b.x, a.y, b.z),
            DVec3::new(a.x, b.y, b.z),
            DVec3::new(b.x, b.y, b.z),
        ]
    }
}

/// A ray prepared for box tests: origin, direction and its reciprocal.
#[derive(Clone, Copy, Debug)]
pub struct RayBoxTest {
    origin: DVec3,
    inv_dir: DVec3,
}

impl RayBoxTest {
    /// Prepare `origin + t·dir`.
    pub fn new(origin: DVec3, dir: DVec3) -> RayBoxTest {
        RayBoxTest { origin, inv_dir: dir.recip() }
    }

    /// Entry distance into `b` if the ray meets it within `[0, t_max]`.
    fn enter(&self, min: DVec3, max: DVec3, t_max: f64) -> Option<f64> {
        let t0 = (min - self.origin) * self.inv_dir;
        let t1 = (max - self.origin) * self.inv_dir;
        let lo = t0.min(t1);
        let hi = t0.max(t1);
        // `f64::max`/`min` ignore NaN (0·∞ on a slab boundary), which is the
        // conservative choice here.
        let near = lo.x.max(lo.y).max(lo.z).max(0.0);
        let far = hi.x.min(hi.y).min(hi.z).min(t_max);
        (near <= far).then_some(near)
    }
}

#[derive(Clone, Copy, Debug)]
struct Node {
    min: DVec3,
    max: DVec3,
    /// Interior: index of the left child (right = left + 1). Leaf: first
    /// entry in `order`.
    first: u32,
    /// 0 for an interior node, else the number of primitives in the leaf.
    count: u32,
}

/// The hierarchy: nodes plus the primitive order the leaves index into.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    nodes: Vec<Node>,
    order: Vec<u32>,
}

impl Bvh {
    /// Build over `boxes` (primitive `i` has box `boxes[i]`).
    pub fn build(boxes: &[Aabb]) -> Bvh {
        let mut bvh = Bvh { nodes: Vec::with_capacity(2 * boxes.len() / MAX_LEAF + 1), order: Vec::new() };
        if boxes.is_empty() {
            return bvh;
        }
        bvh.order = (0..boxes.len() as u32).collect();
        let centres: Vec<DVec3> = boxes.iter().map(Aabb::centre).collect();
        bvh.nodes.push(Node { min: DVec3::ZERO, max: DVec3::ZERO, first: 0, count: 0 });
        // Iterative build: (node index, start, end) in `order`.
        let mut work = vec![(0usize, 0usize, boxes.len())];
        while let Some((node, start, end)) = work.pop() {
            let prims = &mut bvh.order[start..end];
            let bounds = prims.iter().fold(Aabb::EMPTY, |b, &p| b.union(boxes[p as usize]));
            bvh.nodes[node].min = bounds.min;
            bvh.nodes[node].max = bounds.max;
            let split = if prims.len() <= MAX_LEAF { None } else { sah_split(prims, boxes, &centres) };
            match split {
                None => {
                    bvh.nodes[node].first = start as u32;
                    bvh.nodes[node].count = prims.len() as u32;
                }
                Some(mid) => {
                    let left = bvh.nodes.len();
                    bvh.nodes.push(Node { min: DVec3::ZERO, max: DVec3::ZERO, first: 0, count: 0 });
                    bvh.nodes.push(Node { min: DVec3::ZERO, max: DVec3::ZERO, first: 0, count: 0 });
                    bvh.nodes[node].first = left as u32;
                    bvh.nodes[node].count = 0;
                    work.push((left + 1, start + mid, end));
                    work.push((left, start, start + mid));
                }
            }
        }
        bvh
    }

    /// Visit primitives that the ray `ray` may hit closer than `t_max`,
    /// nearest subtree first. `hit(prim, t_max)` returns the distance of a
    /// hit closer than `t_max`, which then becomes the new bound. Returns the
    /// final bound (`t_max` unchanged if nothing was hit).
    pub fn closest(&self, ray: &RayBoxTest, mut t_max: f64, mut hit: impl FnMut(u32, f64) -> Option<f64>) -> f64 {
        if self.nodes.is_empty() {
            return t_max;
        }
        let root = &self.nodes[0];
        if ray.enter(root.min, root.max, t_max).is_none() {
            return t_max;
        }
        let mut stack = [0u32; STACK];
        let mut sp = 1usize;
        while sp > 0 {
            sp -= 1;
            let node = &self.nodes[stack[sp] as usize];
            if node.count > 0 {
                let first = node.first as usize;
                for &p in &self.order[first..first + node.count as usize] {
                    if let Some(t) = hit(p, t_max) {
                        t_max = t_max.min(t);
                    }
                }
                continue;
            }
            let (l, r) = (node.first as usize, node.first as usize + 1);
            let tl = ray.enter(self.nodes[l].min, self.nodes[l].max, t_max);
            let tr = ray.enter(self.nodes[r].min, self.nodes[r].max, t_max);
            // Push the farther child first so the nearer one is visited next.
            // The tree depth is bounded by the SAH build (which stops at
            // degenerate splits), but keep a guard anyway.
            match (tl, tr) {
                (Some(a), Some(b)) => {
                    let (near, far) = if b < a { (r, l) } else { (l, r) };
                    if sp + 2 <= STACK {
                        stack[sp] = far as u32;
                        stack[sp + 1] = near as u32;
                        sp += 2;
                    } else {
                        t_max = self.closest_recursive(ray, near, t_max, &mut hit);
                        t_max = self.closest_recursive(ray, far, t_max, &mut hit);
                    }
                }
                (Some(_), None) => {
                    push(&mut stack, &mut sp, l, |n| t_max = self.closest_recursive(ray, n, t_max, &mut hit))
                }
                (None, Some(_)) => {
                    push(&mut stack, &mut sp, r, |n| t_max = self.closest_recursive(ray, n, t_max, &mut hit))
                }
                (None, None) => {}
            }
        }
        t_max
    }

    /// Fallback for pathological depth (never expected in practice).
    fn closest_recursive(
        &self,
        ray: &RayBoxTest,
        node: usize,
        mut t_max: f64,
        hit: &mut impl FnMut(u32, f64) -> Option<f64>,
    ) -> f64 {
        let n = &self.nodes[node];
        if ray.enter(n.min, n.max, t_max).is_none() {
            return t_max;
        }
        if n.count > 0 {
            let first = n.first as usize;
            for &p in &self.order[first..first + n.count as usize] {
                if let Some(t) = hit(p, t_max) {
                    t_max = t_max.min(t);
                }
            }
            return t_max;
        }
        t_max = self.closest_recursive(ray, n.first as usize, t_max, hit);
        self.closest_recursive(ray, n.first as usize + 1, t_max, hit)
    }
}

fn push(stack: &mut [u32; STACK], sp: &mut usize, node: usize, mut overflow: impl FnMut(usize)) {
    if *sp < STACK {
        stack[*sp] = node as u32;
        *sp += 1;
    } else {
        overflow(node);
    }
}

/// Choose a split of `prims` by binned SAH and partition them in place
/// (stable). Returns the size of the left part, or `None` to make a leaf.
fn sah_split(prims: &mut [u32], boxes: &[Aabb], centres: &[DVec3]) -> Option<usize> {
    let cb = Aabb::from_points(prims.iter().map(|&p| centres[p as usize]));
    let extent = cb.max - cb.min;
    let n = prims.len();
    let mut best: Option<(f64, usize, usize)> = None; // (cost, axis, bin boundary)
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        let scale = BINS as f64 / extent[axis];
        let bin_of = |c: DVec3| (((c[axis] - cb.min[axis]) * scale) as usize).min(BINS - 1);
        let mut bin_box = [Aabb::EMPTY; BINS];
        let mut bin_count = [0usize; BINS];
        for &p in prims.iter() {
            let b = bin_of(centres[p as usize]);
            bin_box[b] = bin_box[b].union(boxes[p as usize]);
            bin_count[b] += 1;
        }
        // Sweep from the right to get suffix areas/counts.
        let mut right_area = [0.0; BINS];
        let mut right_count = [0usize; BINS];
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for b in (1..BINS).rev() {
            acc = acc.union(bin_box[b]);
            cnt += bin_count[b];
            right_area[b] = acc.half_area();
            right_count[b] = cnt;
        }
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for b in 1..BINS {
            acc = acc.union(bin_box[b - 1]);
            cnt += bin_count[b - 1];
            if cnt == 0 || right_count[b] == 0 {
                continue;
            }
            let cost = acc.half_area() * cnt as f64 + right_area[b] * right_count[b] as f64;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, b));
            }
        }
    }
    let parent_area = prims.iter().fold(Aabb::EMPTY, |b, &p| b.union(boxes[p as usize])).half_area();
    match best {
        Some((cost, axis, boundary)) => {
            // Leaf cost: one intersection per primitive; traversal ~ 1.
            if n <= 2 * MAX_LEAF && cost >= parent_area * n as f64 {
                return None;
            }
            let scale = BINS as f64 / extent[axis];
            let is_left = |p: u32| {
                let c = centres[p as usize];
                ((((c[axis] - cb.min[axis]) * scale) as usize).min(BINS - 1)) < boundary
            };
            Some(stable_partition(prims, is_left))
        }
        None => {
            // All centres coincide: split in the middle of the list so the
            // tree stays shallow.
            if n <= MAX_LEAF { None } else { Some(n / 2) }
        }
    }
}

fn stable_partition(prims: &mut [u32], is_left: impl Fn(u32) -> bool) -> usize {
    let (left, right): (Vec<u32>, Vec<u32>) = prims.iter().partition(|&&p| is_left(p));
    let mid = left.len();
    prims[..mid].copy_from_slice(&left);
    prims[mid..].copy_from_slice(&right);
    mid
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_boxes(n: usize) -> Vec<Aabb> {
        (0..n)
            .map(|i| {
                let c = DVec3::new((i % 10) as f64 * 2.0, (i / 10 % 10) as f64 * 2.0, (i / 100) as f64 * 2.0);
                Aabb { min: c - 0.5, max: c + 0.5 }
            })
            .collect()
    }

    #[test]
    fn every_primitive_is_in_exactly_one_leaf() {
        let boxes = unit_boxes(537);
        let bvh = Bvh::build(&boxes);
        let mut seen = vec![0; boxes.len()];
        for n in bvh.nodes.iter().filter(|n| n.count > 0) {
            for &p in &bvh.order[n.first as usize..(n.first + n.count) as usize] {
                seen[p as usize] += 1;
                assert!(boxes[p as usize].min.cmpge(n.min).all() && boxes[p as usize].max.cmple(n.max).all());
            }
        }
        assert!(seen.iter().all(|&s| s == 1));
    }

    #[test]
    fn closest_finds_the_same_box_as_brute_force() {
        let boxes = unit_boxes(300);
        let bvh = Bvh::build(&boxes);
        let origin = DVec3::new(-3.0, 1.1, 0.3);
        for k in 0..50 {
            let dir = DVec3::new(1.0, 0.1 * (k as f64 - 25.0) / 25.0, 0.05 * (k % 7) as f64);
            let ray = RayBoxTest::new(origin, dir);
            let brute =
                boxes.iter().filter_map(|b| ray.enter(b.min, b.max, f64::INFINITY)).fold(f64::INFINITY, f64::min);
            let got = bvh.closest(&ray, f64::INFINITY, |p, t_max| {
                ray.enter(boxes[p as usize].min, boxes[p as usize].max, t_max)
            });
            assert_eq!(got, brute, "ray {k}");
        }
    }

    #[test]
    fn identical_boxes_still_build() {
        let boxes = vec![Aabb { min: DVec3::ZERO, max: DVec3::ONE }; 100];
        let bvh = Bvh::build(&boxes);
        assert!(bvh.nodes.len() > 1);
        assert_eq!(bvh.order.len(), 100);
    }
}
