//! Whether anything of the surface lies near a point: the closest-point walk that stops at
//! the first triangle within reach.

use super::{Bvh, STACK, box_distance_squared, closest_point_on_triangle, triangle_box, widened};
use glam::Vec3;

impl Bvh {
    /// Whether any point of the surface lies within `max_distance` of `q` (exclusive): the
    /// same answer as `closest_point_within(q, max_distance).is_some()`, from the same
    /// distances, but the walk stops at the first triangle within reach instead of looking for
    /// the closest.
    pub fn any_within(&self, q: Vec3, max_distance: f32) -> bool {
        let mut none = u32::MAX;
        self.any_within_from(q, max_distance, &mut none)
    }

    /// [`Bvh::any_within`] that first tries the triangle `last` found within reach (of an
    /// earlier query nearby: a mesh's next face), and keeps the one it finds there. The answer
    /// is the same whatever `last` holds.
    pub fn any_within_from(&self, q: Vec3, max_distance: f32, last: &mut u32) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let bound = max_distance * max_distance;
        if let Some(t) = self.tris.get(*last as usize)
            && closest_point_on_triangle(q, t[0], t[1], t[2]).distance_squared(q) < bound
        {
            return true;
        }
        // Boxes within the bound widened by the rounding margin, as `closest_below` opens them.
        let reach = widened(bound, self.margin(q));
        let mut stack = [0u32; STACK];
        let mut top = 0usize;
        let mut node_index = 0u32;
        loop {
            let node = &self.nodes[node_index as usize];
            if node.count > 0 {
                let start = node.first as usize;
                for i in start..start + node.count as usize {
                    let [a, b, c] = self.tris[i];
                    let (lo, hi) = triangle_box(&self.tris[i]);
                    if box_distance_squared(q, lo, hi) <= reach
                        && closest_point_on_triangle(q, a, b, c).distance_squared(q) < bound
                    {
                        *last = i as u32;
                        return true;
                    }
                }
            } else {
                let [(near, d_near), (far, d_far)] = self.children_nearer_first(node_index, q);
                if d_far <= reach {
                    stack[top] = far;
                    top += 1;
                }
                if d_near <= reach {
                    node_index = near;
                    continue;
                }
            }
            if top == 0 {
                return false;
            }
            top -= 1;
            node_index = stack[top];
        }
    }
}
