//! Bounding-volume hierarchy over a triangle mesh: closest point on the surface
//! (point-to-triangle distance, the Df metric) and ray casting (first hit or every hit).
//!
//! Built once per mesh by the surface area heuristic (binned over the triangles' centroids;
//! below `SAH_DEPTH` levels, median splits along the centroids' longest axis), at most
//! `LEAF_SIZE` triangles a leaf. Queries are read-only, so one `Bvh` can be shared between
//! threads. Their answers do not depend on the tree's shape: of equally near triangles (or
//! hits at the same ray parameter) the lowest face index wins, and subtrees are pruned only
//! beyond the rounding of a distance, so every query answers as a brute-force search would.

use super::TriMesh;
use build::build_node;
use glam::Vec3;

const LEAF_SIZE: usize = 4;

/// Levels split by the surface area heuristic, which may split off a few triangles a level;
/// deeper, median splits (at most 40 more levels for up to 2^40 triangles).
const SAH_DEPTH: usize = 48;
/// Deep enough for any tree this builds.
const STACK: usize = SAH_DEPTH + 48;

#[derive(Debug, Clone, Copy)]
struct Node {
    min: Vec3,
    max: Vec3,
    /// Leaf: first triangle. Interior: index of the right child (the left one is next).
    first: u32,
    /// Leaf: number of triangles (> 0). Interior: 0.
    count: u32,
}

/// A BVH over the faces of one mesh (positions are copied: the mesh may be dropped).
#[derive(Debug, Clone)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// Triangles in tree order.
    tris: Vec<[Vec3; 3]>,
    /// Original face index of each triangle in tree order.
    face_ids: Vec<u32>,
    /// Tree order of each original face (the inverse of `face_ids`).
    tree_index: Vec<u32>,
    /// The largest coordinate magnitude of any corner: the scale of the rounding of a
    /// distance or a ray parameter (`Bvh::margin`).
    scale: f32,
}

/// Closest point of the surface to a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClosestHit {
    pub point: Vec3,
    pub distance: f32,
    /// Index into the mesh's faces.
    pub face: u32,
}

/// A ray-triangle intersection at `origin + t * dir`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    pub t: f32,
    pub face: u32,
    /// Barycentric coordinates of the hit: point = (1-u-v) a + u b + v c.
    pub u: f32,
    pub v: f32,
    /// Whether the ray enters through the front side (against the face normal).
    pub front: bool,
}

impl Bvh {
    /// Build over every face of `mesh`. An empty mesh gives an empty tree whose queries
    /// return `None`.
    pub fn build(mesh: &TriMesh) -> Bvh {
        Self::from_triangles((0..mesh.faces.len()).map(|f| mesh.triangle(f)).collect())
    }

    /// Build over a triangle soup; face ids are the indices into `tris`.
    pub fn from_triangles(tris: Vec<[Vec3; 3]>) -> Bvh {
        let n = tris.len();
        let mut order: Vec<u32> = (0..n as u32).collect();
        let centroids: Vec<Vec3> = tris.iter().map(|t| (t[0] + t[1] + t[2]) / 3.0).collect();
        let bounds: Vec<(Vec3, Vec3)> = tris.iter().map(triangle_box).collect();
        let mut nodes = Vec::with_capacity(2 * n / LEAF_SIZE + 1);
        if n > 0 {
            build_node(&bounds, &centroids, &mut order, 0, 0, &mut nodes);
        }
        let sorted: Vec<[Vec3; 3]> = order.iter().map(|&i| tris[i as usize]).collect();
        let mut tree_index = vec![0u32; n];
        for (position, &face) in order.iter().enumerate() {
            tree_index[face as usize] = position as u32;
        }
        let scale = scale_of(&sorted);
        Bvh { nodes, tris: sorted, face_ids: order, tree_index, scale }
    }

    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    pub fn num_triangles(&self) -> usize {
        self.tris.len()
    }

    /// Bounds of the whole mesh, `None` when empty.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        self.nodes.first().map(|n| (n.min, n.max))
    }

    /// Closest point on the surface to `q`, `None` for an empty mesh.
    pub fn closest_point(&self, q: Vec3) -> Option<ClosestHit> {
        self.closest_point_within(q, f32::INFINITY)
    }

    /// Closest point on the surface within `max_distance` of `q` (exclusive).
    pub fn closest_point_within(&self, q: Vec3, max_distance: f32) -> Option<ClosestHit> {
        self.closest_below(q, max_distance * max_distance)
    }

    /// [`Bvh::closest_point`] with a hint: `face` (a mesh face index, ideally the closest face
    /// of a nearby earlier query: the same point a Gauss-Newton step before) bounds the search
    /// by its distance, so subtrees farther than it are never opened. The answer is the one
    /// [`Bvh::closest_point`] gives, bit for bit, whatever face the hint names: the closest
    /// triangles lie within the bound, and of them the lowest face index wins either way. A
    /// hint out of range is ignored.
    pub fn closest_point_hinted(&self, q: Vec3, face: u32) -> Option<ClosestHit> {
        let Some(&i) = self.tree_index.get(face as usize) else {
            return self.closest_point(q);
        };
        let [a, b, c] = self.tris[i as usize];
        let d = closest_point_on_triangle(q, a, b, c).distance(q);
        // Above the hint's own distance by more than the rounding of a box's or a triangle's
        // distance can hide (the leaf of the closest triangle must stay open); a non-finite
        // distance bounds nothing.
        let bound = (d + self.margin(q)).powi(2);
        self.closest_below(q, if bound.is_finite() { bound } else { f32::INFINITY })
    }

    /// More than the rounding of a distance (or a ray parameter along a unit direction)
    /// between `q` and any triangle or box of this tree can be: 64 units in the last place of
    /// the largest coordinate involved. Subtrees are pruned only beyond it, so that the answer
    /// does not depend on the tree's shape.
    fn margin(&self, q: Vec3) -> f32 {
        64.0 * f32::EPSILON * self.scale.max(q.abs().max_element()).max(f32::MIN_POSITIVE)
    }

    /// The closest point whose squared distance is below `bound` (exclusive): of the triangles
    /// at the least squared distance (as computed), the one with the lowest face index, so the
    /// answer is that of a brute-force search whatever the tree's shape.
    fn closest_below(&self, q: Vec3, bound: f32) -> Option<ClosestHit> {
        self.walk_below::<false>(q, bound)
    }

    /// The walk of [`Bvh::closest_below`]; with `FIRST`, it returns the first triangle it
    /// meets below `bound` (`Bvh::any_within`: whether there is one, not which is closest).
    fn walk_below<const FIRST: bool>(&self, q: Vec3, bound: f32) -> Option<ClosestHit> {
        if self.nodes.is_empty() {
            return None;
        }
        let margin = self.margin(q);
        // A node is opened while its box lies within `reach`: the best squared distance so far
        // widened by the rounding margin.
        let reach_of = |d2: f32| {
            let r = (d2.sqrt() + margin).powi(2);
            if r.is_nan() { f32::INFINITY } else { r }
        };
        let mut best_d2 = bound;
        let mut reach = reach_of(bound);
        let mut best: Option<(Vec3, u32)> = None; // point, face index
        // Nodes to visit and their boxes' squared distances (measured when pushed).
        let mut stack = [(0u32, 0f32); STACK];
        let mut top = 0usize;
        let mut node_index = 0u32;
        loop {
            let node = &self.nodes[node_index as usize];
            if node.count > 0 {
                let start = node.first as usize;
                for i in start..start + node.count as usize {
                    let [a, b, c] = self.tris[i];
                    // The triangle's box first: cheaper than the exact distance, and most
                    // of a leaf's triangles lie beyond reach.
                    let (lo, hi) = triangle_box(&self.tris[i]);
                    if box_distance_squared(q, lo, hi) > reach {
                        continue;
                    }
                    let p = closest_point_on_triangle(q, a, b, c);
                    let d2 = p.distance_squared(q);
                    let face = self.face_ids[i];
                    let better =
                        d2 < best_d2 || (d2 == best_d2 && best.is_some_and(|(_, f)| face < f));
                    if better {
                        if FIRST {
                            return Some(ClosestHit { point: p, distance: d2.sqrt(), face });
                        }
                        best_d2 = d2;
                        reach = reach_of(d2);
                        best = Some((p, face));
                    }
                }
            } else {
                let (l, r) = (node_index + 1, node.first);
                let (left, right) = (&self.nodes[l as usize], &self.nodes[r as usize]);
                let dl = box_distance_squared(q, left.min, left.max);
                let dr = box_distance_squared(q, right.min, right.max);
                let (near, d_near, far, d_far) =
                    if dl <= dr { (l, dl, r, dr) } else { (r, dr, l, dl) };
                if d_far <= reach {
                    stack[top] = (far, d_far);
                    top += 1;
                }
                if d_near <= reach {
                    node_index = near;
                    continue;
                }
            }
            // Pop the next node that can still hold the best distance.
            loop {
                if top == 0 {
                    return best.map(|(point, face)| ClosestHit {
                        point,
                        distance: best_d2.sqrt(),
                        face,
                    });
                }
                top -= 1;
                let (candidate, d) = stack[top];
                if d <= reach {
                    node_index = candidate;
                    break;
                }
            }
        }
    }

    /// Nearest intersection of the ray `origin + t dir` with `t` in `(t_min, t_max)`.
    /// Both sides of every triangle are hit; `front` tells which.
    pub fn ray_cast(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Option<RayHit> {
        let mut best: Option<RayHit> = None;
        self.traverse_ray(origin, dir, t_min, t_max, |bvh, i, limit| {
            let [a, b, c] = bvh.tris[i];
            let face = bvh.face_ids[i];
            match ray_triangle(origin, dir, a, b, c) {
                // Of hits at the same parameter, the lowest face index (as a brute force).
                Some((t, u, v, front))
                    if t > t_min
                        && (t < limit || (t == limit && best.is_some_and(|h| face < h.face))) =>
                {
                    best = Some(RayHit { t, face, u, v, front });
                    t
                }
                _ => limit,
            }
        });
        best
    }

    /// Every intersection of the ray with `t` in `(t_min, t_max)`, sorted by `t`.
    pub fn ray_hits(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Vec<RayHit> {
        let mut hits = Vec::new();
        self.traverse_ray(origin, dir, t_min, t_max, |bvh, i, limit| {
            let [a, b, c] = bvh.tris[i];
            if let Some((t, u, v, front)) = ray_triangle(origin, dir, a, b, c)
                && t > t_min
                && t < t_max
            {
                hits.push(RayHit { t, face: bvh.face_ids[i], u, v, front });
            }
            limit
        });
        hits.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.face.cmp(&b.face)));
        hits
    }

    /// Walk every leaf whose box the ray enters before the current limit; `visit` tests one
    /// triangle and returns the (possibly shrunk) limit.
    fn traverse_ray<F>(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32, mut visit: F)
    where
        F: FnMut(&Bvh, usize, f32) -> f32,
    {
        if self.nodes.is_empty() {
            return;
        }
        let inv = Vec3::ONE / dir; // infinities are handled by the slab test
        // Boxes are tested with the range widened by the rounding of a hit's parameter, so
        // that which triangles are met does not depend on the tree's shape.
        let slack = self.margin(origin) / dir.length().max(f32::MIN_POSITIVE);
        let widen = |t: f32, sign: f32| t + sign * (slack + 4.0 * f32::EPSILON * t.abs());
        let mut limit = t_max;
        let mut stack = [0u32; STACK];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            if !ray_box(origin, inv, node, widen(t_min, -1.0), widen(limit, 1.0)) {
                continue;
            }
            if node.count > 0 {
                let start = node.first as usize;
                for i in start..start + node.count as usize {
                    limit = visit(self, i, limit);
                }
            } else {
                stack[top] += 1; // left child follows its parent
                stack[top + 1] = node.first;
                top += 2;
            }
        }
    }
}

fn box_distance_squared(q: Vec3, min: Vec3, max: Vec3) -> f32 {
    let d = (min - q).max(q - max).max(Vec3::ZERO);
    d.length_squared()
}

/// A triangle's box: its corners' least and greatest coordinates.
fn triangle_box([a, b, c]: &[Vec3; 3]) -> (Vec3, Vec3) {
    (a.min(*b).min(*c), a.max(*b).max(*c))
}

/// Slab test: does the ray meet the box for some t in [t_min, t_max]?
fn ray_box(origin: Vec3, inv: Vec3, node: &Node, t_min: f32, t_max: f32) -> bool {
    let (mut near, mut far) = (t_min, t_max);
    for a in 0..3 {
        let (t0, t1) = ((node.min[a] - origin[a]) * inv[a], (node.max[a] - origin[a]) * inv[a]);
        if t0.is_nan() || t1.is_nan() {
            // 0 * inf: a ray parallel to this slab with its origin on one of the slab's planes
            // (marching-cubes vertices lie on grid planes, and so do their boxes' faces). It
            // stays on the plane: inside the slab for every t.
            continue;
        }
        near = near.max(t0.min(t1));
        far = far.min(t0.max(t1));
    }
    near <= far
}

/// Two-sided ray/triangle intersection (edge-plane determinant form): returns
/// (t, u, v, front) where front means the ray travels against the face normal.
pub fn ray_triangle(
    origin: Vec3,
    dir: Vec3,
    a: Vec3,
    b: Vec3,
    c: Vec3,
) -> Option<(f32, f32, f32, bool)> {
    let e1 = b - a;
    let e2 = c - a;
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det.abs() < f32::MIN_POSITIVE {
        return None;
    }
    let inv_det = 1.0 / det;
    let s = origin - a;
    let u = s.dot(p) * inv_det;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = dir.dot(q) * inv_det;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv_det;
    // det > 0 means dir . (e1 x e2) < 0: the ray runs against the normal (front side).
    Some((t, u, v, det > 0.0))
}

/// The largest finite coordinate magnitude of any corner (`Bvh::scale`).
fn scale_of(tris: &[[Vec3; 3]]) -> f32 {
    tris.iter()
        .flatten()
        .map(|p| p.abs().max_element())
        .filter(|m| m.is_finite())
        .fold(0f32, f32::max)
}

/// Closest point to `p` on the triangle (a, b, c), by the Voronoi region of `p`
/// (vertex, edge or face). Degenerate triangles fall back to the closest edge point.
pub fn closest_point_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let t = d1 / (d1 - d3);
        return a + ab * t;
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let t = d2 / (d2 - d6);
        return a + ac * t;
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return b + (c - b) * t;
    }
    let denom = va + vb + vc;
    if !(denom.abs() > f32::MIN_POSITIVE) {
        // Degenerate (collinear) triangle: nearest of the three edges.
        return [segment_closest(p, a, b), segment_closest(p, b, c), segment_closest(p, c, a)]
            .into_iter()
            .min_by(|x, y| x.distance_squared(p).total_cmp(&y.distance_squared(p)))
            .unwrap_or(a);
    }
    let v = vb / denom;
    let w = vc / denom;
    a + ab * v + ac * w
}

fn segment_closest(p: Vec3, a: Vec3, b: Vec3) -> Vec3 {
    let d = b - a;
    let len2 = d.length_squared();
    if len2 <= 0.0 {
        return a;
    }
    a + d * ((p - a).dot(d) / len2).clamp(0.0, 1.0)
}

mod build;
mod refit;
#[cfg(test)]
mod tests;
mod within;
