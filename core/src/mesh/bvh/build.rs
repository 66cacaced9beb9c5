//! The tree's build: the surface area heuristic over binned centroids, median splits below
//! `SAH_DEPTH` levels.

use super::{LEAF_SIZE, Node, SAH_DEPTH};
use glam::Vec3;

/// `bounds`: each triangle's box.
pub(super) fn build_node(
    bounds: &[(Vec3, Vec3)],
    centroids: &[Vec3],
    order: &mut [u32],
    offset: usize,
    depth: usize,
    nodes: &mut Vec<Node>,
) -> usize {
    let (mut min, mut max) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    let (mut cmin, mut cmax) = (min, max);
    for &i in order.iter() {
        let (lo, hi) = bounds[i as usize];
        min = min.min(lo);
        max = max.max(hi);
        let c = centroids[i as usize];
        cmin = cmin.min(c);
        cmax = cmax.max(c);
    }
    let index = nodes.len();
    nodes.push(Node { min, max, first: offset as u32, count: order.len() as u32 });
    let extent = cmax - cmin;
    // NaN extents (corrupt positions) compare false and end in a leaf.
    if order.len() <= LEAF_SIZE || !(extent.max_element() > 0.0) {
        return index;
    }
    let mid = if depth < SAH_DEPTH {
        sah_split(bounds, centroids, order, cmin, extent)
    } else {
        median_split(centroids, order, extent)
    };
    let (left, right) = order.split_at_mut(mid);
    build_node(bounds, centroids, left, offset, depth + 1, nodes);
    let right_index = build_node(bounds, centroids, right, offset + mid, depth + 1, nodes);
    nodes[index].first = right_index as u32;
    nodes[index].count = 0;
    index
}

const BINS: usize = 8;

/// The median of `order` along the centroids' longest axis (`extent`): `order` reordered
/// about it, and its index.
fn median_split(centroids: &[Vec3], order: &mut [u32], extent: Vec3) -> usize {
    let axis = extent.max_position();
    let mid = order.len() / 2;
    order.select_nth_unstable_by(mid, |&a, &b| {
        centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis])
    });
    mid
}

/// Half the surface area of a box.
fn area(min: Vec3, max: Vec3) -> f32 {
    let d = (max - min).max(Vec3::ZERO);
    d.x * d.y + d.y * d.z + d.z * d.x
}

/// The split of `order` (reordered in place; the index of the first of the right half)
/// whose halves' box areas weighted by their triangles are least, binned by the triangles'
/// centroids along each axis (the surface area heuristic).
fn sah_split(
    bounds: &[(Vec3, Vec3)],
    centroids: &[Vec3],
    order: &mut [u32],
    cmin: Vec3,
    extent: Vec3,
) -> usize {
    let scale = Vec3::select(extent.cmpgt(Vec3::ZERO), BINS as f32 / extent, Vec3::ZERO);
    let bin_of = |c: Vec3| -> [usize; 3] {
        let b = ((c - cmin) * scale).to_array();
        b.map(|x| (x as usize).min(BINS - 1))
    };
    let empty = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    let mut count = [[0usize; BINS]; 3];
    let mut boxes = [[empty; BINS]; 3];
    for &i in order.iter() {
        let (lo, hi) = bounds[i as usize];
        for (axis, b) in bin_of(centroids[i as usize]).into_iter().enumerate() {
            count[axis][b] += 1;
            let bx = &mut boxes[axis][b];
            *bx = (bx.0.min(lo), bx.1.max(hi));
        }
    }
    let mut best = (f32::INFINITY, 0usize, 0usize); // cost, axis, first bin of the right half
    for axis in 0..3 {
        if !(extent[axis] > 0.0) {
            continue;
        }
        // Right-to-left sweep of the areas and counts, then left to right.
        let mut right_area = [0f32; BINS];
        let mut right_count = [0usize; BINS];
        let (mut r, mut rc) = (empty, 0);
        for b in (1..BINS).rev() {
            r = (r.0.min(boxes[axis][b].0), r.1.max(boxes[axis][b].1));
            rc += count[axis][b];
            right_area[b] = area(r.0, r.1);
            right_count[b] = rc;
        }
        let (mut l, mut lc) = (empty, 0);
        for b in 1..BINS {
            l = (l.0.min(boxes[axis][b - 1].0), l.1.max(boxes[axis][b - 1].1));
            lc += count[axis][b - 1];
            if lc == 0 || right_count[b] == 0 {
                continue;
            }
            let cost = area(l.0, l.1) * lc as f32 + right_area[b] * right_count[b] as f32;
            if cost < best.0 {
                best = (cost, axis, b);
            }
        }
    }
    if !best.0.is_finite() {
        // Every centroid in one bin.
        return median_split(centroids, order, extent);
    }
    let (_, axis, boundary) = best;
    let mut mid = 0;
    for k in 0..order.len() {
        if bin_of(centroids[order[k] as usize])[axis] < boundary {
            order.swap(k, mid);
            mid += 1;
        }
    }
    mid
}
