//! The off-surface points of the IGR loss, drawn the same way by the static fit (`fit`) and the
//! meta-model's fit (`hyper_fit`): half uniform in the cube [-1, 1]^3, half near a surface point
//! (a Gaussian offset of `near_sigma`), then the free-space samples at the end.

use glam::Vec3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// What to draw: `count` points, the last `free_space` (at most `count`) of them from
/// `outside` when it has any.
pub struct OffSurface<'a> {
    /// The surface points the near samples start from (not empty when some are drawn).
    pub surface: &'a [Vec3],
    /// Points known to be outside the body (free space); may be empty.
    pub outside: &'a [Vec3],
    pub count: usize,
    pub free_space: usize,
    pub near_sigma: f32,
}

impl OffSurface<'_> {
    /// How many of the points are free-space samples (they come last).
    pub fn free(&self) -> usize {
        if self.outside.is_empty() { 0 } else { self.free_space.min(self.count) }
    }

    /// Append the points to `out` and return how many are free-space samples. Point k (below the
    /// free-space tail) is uniform when k is even and near the surface when odd; the random
    /// numbers are drawn in this order, point by point (a fit's seed gives the same points).
    pub fn draw(&self, rng: &mut ChaCha8Rng, out: &mut Vec<Vec3>) -> usize {
        let free = self.free();
        out.reserve(self.count);
        for k in 0..self.count {
            let p = if k >= self.count - free {
                self.outside[rng.random_range(0..self.outside.len())]
            } else if k % 2 == 0 {
                Vec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                )
            } else {
                let p = self.surface[rng.random_range(0..self.surface.len())];
                p + Vec3::new(gauss(rng), gauss(rng), gauss(rng)) * self.near_sigma
            };
            out.push(p);
        }
        free
    }
}

/// A standard normal sample (Box-Muller). Not core's `synth::noise::gaussian`: that one draws
/// u1 as `random::<f32>()`, this one as `random_range(1e-7..1.0)`, so the two streams differ
/// and every seeded fit and meta-model would change if one replaced the other.
pub(crate) fn gauss(rng: &mut ChaCha8Rng) -> f32 {
    let u1: f32 = rng.random_range(1e-7..1.0);
    let u2: f32 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (std::f32::consts::TAU * u2).cos()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn free_space_points_come_last_and_near_points_stay_near() {
        let surface = [Vec3::new(0.5, 0.0, 0.0)];
        let outside = [Vec3::splat(0.9), Vec3::splat(-0.9)];
        let spec = OffSurface {
            surface: &surface,
            outside: &outside,
            count: 10,
            free_space: 3,
            near_sigma: 0.01,
        };
        let mut out = vec![Vec3::ZERO];
        let free = spec.draw(&mut ChaCha8Rng::seed_from_u64(1), &mut out);
        assert_eq!((free, out.len()), (3, 11));
        let off = &out[1..];
        assert!(off[7..].iter().all(|p| outside.contains(p)));
        assert!(off[..7].iter().step_by(2).all(|p| p.abs().max_element() <= 1.0));
        assert!(off[1..7].iter().step_by(2).all(|p| p.distance(surface[0]) < 0.1), "{off:?}");
        let none = OffSurface { outside: &[], ..spec };
        assert_eq!(none.draw(&mut ChaCha8Rng::seed_from_u64(1), &mut Vec::new()), 0);
    }
}
