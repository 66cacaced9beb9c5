//! Kinect-like depth corruption, seeded: depth-dependent Gaussian noise, quantisation, and
//! holes (dropout at depth edges, random blobs).
//!
//! Presets:
//! - `kinect_v1` (structured light): axial noise sigma(z) = 1.2 mm + 1.9 mm (z - 0.4 m)^2
//!   (Nguyen, Izadi, Lovell 2012), disparity quantisation of 1/8 px that gives a depth step of
//!   2.85e-3 z^2 (2.6 cm at 3 m).
//! - `kinect_v2` (time of flight, the default of `--noise`): sigma(z) = 1.5 mm + 0.5 mm z^2,
//!   no disparity steps; both drop 60% of the pixels at depth edges and punch 0-3 holes.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DepthNoise {
    /// Constant part of the axial standard deviation (metres).
    pub sigma_base: f32,
    /// Quadratic part: sigma += sigma_quad * (z - sigma_z0)^2.
    pub sigma_quad: f32,
    pub sigma_z0: f32,
    /// Inverse-depth quantisation step (1/m): depth steps of `disparity_step * z^2`; 0 = off.
    pub disparity_step: f32,
    /// Probability of dropping a pixel at a depth edge (next to background or a jump).
    pub edge_dropout: f32,
    /// Depth jump (metres) between 4-neighbours that counts as an edge.
    pub edge_jump: f32,
    /// Up to this many random blob holes per frame.
    pub max_blobs: u32,
    /// Blob radius range in pixels.
    pub blob_radius: (f32, f32),
}

impl DepthNoise {
    pub fn kinect_v1() -> Self {
        DepthNoise {
            sigma_base: 0.0012,
            sigma_quad: 0.0019,
            sigma_z0: 0.4,
            disparity_step: 2.85e-3,
            edge_dropout: 0.6,
            edge_jump: 0.05,
            max_blobs: 3,
            blob_radius: (1.5, 4.0),
        }
    }

    pub fn kinect_v2() -> Self {
        DepthNoise {
            sigma_base: 0.0015,
            sigma_quad: 0.0005,
            sigma_z0: 0.0,
            disparity_step: 0.0,
            ..Self::kinect_v1()
        }
    }

    pub fn preset(name: &str) -> Option<Self> {
        match name {
            "kinect_v1" => Some(Self::kinect_v1()),
            "kinect_v2" => Some(Self::kinect_v2()),
            _ => None,
        }
    }

    pub fn sigma(&self, z: f32) -> f32 {
        let d = z - self.sigma_z0;
        self.sigma_base + self.sigma_quad * d * d
    }

    /// Corrupt a depth image in place (0 = no measurement stays 0).
    pub fn apply(&self, depth: &mut [f32], width: usize, height: usize, rng: &mut ChaCha8Rng) {
        // Holes first, decided on the clean image: edges.
        let clean = depth.to_vec();
        let at = |u: isize, v: isize| -> f32 {
            if u < 0 || v < 0 || u >= width as isize || v >= height as isize {
                0.0
            } else {
                clean[v as usize * width + u as usize]
            }
        };
        for v in 0..height {
            for u in 0..width {
                let z = clean[v * width + u];
                if z == 0.0 {
                    continue;
                }
                let (ui, vi) = (u as isize, v as isize);
                let is_edge = [(1, 0), (-1, 0), (0, 1), (0, -1)].iter().any(|&(du, dv)| {
                    let n = at(ui + du, vi + dv);
                    n == 0.0 || (n - z).abs() > self.edge_jump
                });
                // Draw for every valid pixel so the stream does not depend on the edge layout.
                let r: f32 = rng.random();
                if is_edge && r < self.edge_dropout {
                    depth[v * width + u] = 0.0;
                }
            }
        }
        // Blobs centred on valid pixels.
        let valid: Vec<usize> = (0..depth.len()).filter(|&i| clean[i] > 0.0).collect();
        let blobs = if self.max_blobs == 0 || valid.is_empty() {
            0
        } else {
            rng.random_range(0..=self.max_blobs)
        };
        for _ in 0..blobs {
            let c = valid[rng.random_range(0..valid.len())];
            let (cu, cv) = ((c % width) as f32, (c / width) as f32);
            let (r0, r1) = self.blob_radius;
            let ra = rng.random_range(r0..=r1);
            let rb = rng.random_range(r0..=r1);
            let ang: f32 = rng.random_range(0.0..std::f32::consts::PI);
            let (s, co) = ang.sin_cos();
            let reach = ra.max(rb).ceil() as isize;
            for dv in -reach..=reach {
                for du in -reach..=reach {
                    let (x, y) = (du as f32 * co + dv as f32 * s, -du as f32 * s + dv as f32 * co);
                    if (x / ra).powi(2) + (y / rb).powi(2) <= 1.0 {
                        let (u, v) = (cu as isize + du, cv as isize + dv);
                        if u >= 0 && v >= 0 && (u as usize) < width && (v as usize) < height {
                            depth[v as usize * width + u as usize] = 0.0;
                        }
                    }
                }
            }
        }
        // Axial noise and quantisation on what is left.
        for z in depth.iter_mut() {
            let g = gaussian(rng);
            if *z == 0.0 {
                continue;
            }
            let mut d = *z + g * self.sigma(*z);
            if self.disparity_step > 0.0 {
                let inv = (1.0 / d / self.disparity_step).round() * self.disparity_step;
                d = 1.0 / inv;
            }
            *z = d.max(1e-3);
        }
    }
}

/// Standard normal sample (Box-Muller; deterministic given the generator).
pub fn gaussian(rng: &mut ChaCha8Rng) -> f32 {
    let u1: f32 = rng.random::<f32>().max(1e-12);
    let u2: f32 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f32::consts::PI * u2).cos()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn plane(z: f32) -> Vec<f32> {
        // A 60 x 60 square of depth z inside a 100 x 100 image.
        let mut d = vec![0f32; 100 * 100];
        for v in 20..80 {
            for u in 20..80 {
                d[v * 100 + u] = z;
            }
        }
        d
    }

    #[test]
    fn noise_statistics_follow_the_model_and_are_seeded() {
        let n = DepthNoise { edge_dropout: 0.0, max_blobs: 0, ..DepthNoise::kinect_v2() };
        let mut d = plane(3.0);
        n.apply(&mut d, 100, 100, &mut ChaCha8Rng::seed_from_u64(1));
        let vals: Vec<f32> = d.iter().copied().filter(|&z| z > 0.0).collect();
        assert_eq!(vals.len(), 3600);
        let mean = vals.iter().sum::<f32>() / vals.len() as f32;
        let sd = (vals.iter().map(|z| (z - mean).powi(2)).sum::<f32>() / vals.len() as f32).sqrt();
        let expected = n.sigma(3.0);
        assert!((mean - 3.0).abs() < 3.0 * expected / 60.0 + 1e-4, "mean {mean}");
        assert!((sd / expected - 1.0).abs() < 0.1, "sd {sd} vs {expected}");
        let mut again = plane(3.0);
        n.apply(&mut again, 100, 100, &mut ChaCha8Rng::seed_from_u64(1));
        assert_eq!(d, again);
    }

    #[test]
    fn kinect_v1_quantises_depth_in_steps_of_z_squared() {
        let n = DepthNoise {
            sigma_base: 0.0,
            sigma_quad: 0.0,
            edge_dropout: 0.0,
            max_blobs: 0,
            ..DepthNoise::kinect_v1()
        };
        let mut d = plane(3.0);
        n.apply(&mut d, 100, 100, &mut ChaCha8Rng::seed_from_u64(2));
        let z = d[50 * 100 + 50];
        let step = n.disparity_step * 9.0;
        assert!((z - 3.0).abs() <= step / 2.0 + 1e-4 && (z - 3.0).abs() > 1e-6, "{z}");
    }

    #[test]
    fn holes_appear_at_edges_and_in_blobs() {
        let n = DepthNoise {
            sigma_base: 0.0,
            sigma_quad: 0.0,
            max_blobs: 3,
            ..DepthNoise::kinect_v2()
        };
        let mut lost_edges = 0;
        let mut lost_inside = 0;
        for seed in 0..10 {
            let mut d = plane(2.0);
            n.apply(&mut d, 100, 100, &mut ChaCha8Rng::seed_from_u64(seed));
            for v in 20..80 {
                for u in 20..80 {
                    if d[v * 100 + u] == 0.0 {
                        if u == 20 || u == 79 || v == 20 || v == 79 {
                            lost_edges += 1
                        } else {
                            lost_inside += 1
                        }
                    }
                }
            }
            assert!(
                d.iter().enumerate().all(|(i, &z)| z == 0.0 || plane(2.0)[i] > 0.0),
                "no depth appears from nothing"
            );
        }
        // 236 edge pixels a frame, 60% dropped: about 1400 over 10 frames.
        assert!((1100..1700).contains(&lost_edges), "{lost_edges}");
        assert!(lost_inside > 50, "{lost_inside}");
    }
}
