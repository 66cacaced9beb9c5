//! Whether anything of the surface lies near a point: the closest-point walk that stops at
//! the first triangle within reach.

use super::{Bvh, closest_point_on_triangle};
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
        let bound = max_distance * max_distance;
        if let Some(t) = self.tris.get(*last as usize)
            && closest_point_on_triangle(q, t[0], t[1], t[2]).distance_squared(q) < bound
        {
            return true;
        }
        match self.walk_below::<true>(q, bound) {
            Some(hit) => {
                *last = self.tree_index[hit.face as usize];
                true
            }
            None => false,
        }
    }
}
