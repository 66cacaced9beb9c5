//! A position-based cloth solver (XPBD with small steps: many substeps, one constraint pass
//! each): stretch along the mesh's edges, bending across each inner edge (the distance
//! between the two opposite corners), tethers that keep every particle within its rest
//! distance of the nearest pinned one, gravity, damping and collision with a moving body.

use crate::mesh::TriMesh;
use crate::mesh::bvh::Bvh;
use glam::Vec3;
use std::collections::HashMap;

/// Physical settings of the cloth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClothConfig {
    /// Substeps per simulated frame (one constraint pass each).
    pub substeps: usize,
    pub gravity: Vec3,
    /// Share of the velocity lost per second (air drag and internal friction).
    pub damping_per_second: f32,
    /// XPBD compliance of the edges (m/N; 0 = inextensible).
    pub stretch_compliance: f32,
    /// XPBD compliance of the bending distances (larger = softer).
    pub bend_compliance: f32,
    /// The cloth stays this far outside the body's surface (metres).
    pub thickness: f32,
    /// Share of the tangential motion removed on contact with the body (0-1).
    pub friction: f32,
}

impl Default for ClothConfig {
    fn default() -> Self {
        ClothConfig {
            substeps: 16,
            gravity: Vec3::new(0.0, -9.81, 0.0),
            damping_per_second: 0.6,
            stretch_compliance: 1e-8,
            bend_compliance: 2e-5,
            thickness: 0.008,
            friction: 0.3,
        }
    }
}

/// A distance constraint between two particles.
#[derive(Debug, Clone, Copy)]
struct Distance {
    a: u32,
    b: u32,
    rest: f32,
}

/// The body the cloth collides with at one instant: its surface with face normals.
pub struct BodyCollider {
    bvh: Bvh,
    normals: Vec<Vec3>,
}

impl BodyCollider {
    pub fn new(body: &TriMesh) -> BodyCollider {
        BodyCollider { bvh: Bvh::build(body), normals: body.face_normals() }
    }

    /// Signed distance to the surface where it is under `reach` (negative inside), with the
    /// outward normal there.
    pub fn signed_distance(&self, p: Vec3, reach: f32) -> Option<(f32, Vec3)> {
        let hit = self.bvh.closest_point_within(p, reach)?;
        let n = self.normals[hit.face as usize];
        let d = p - hit.point;
        let outside = d.dot(n) >= 0.0;
        let out = if d.length_squared() > 1e-16 { d.normalize() } else { n };
        // Outside: away from the closest point; inside: towards it (along -d), which leads
        // back out through the surface.
        Some(if outside { (hit.distance, out) } else { (-hit.distance, -out) })
    }
}

/// The cloth's state and constraints.
pub struct Cloth {
    pub config: ClothConfig,
    pub positions: Vec<Vec3>,
    velocities: Vec<Vec3>,
    /// 0 for pinned particles (they follow `set_pins`).
    inv_mass: Vec<f32>,
    stretch: Vec<Distance>,
    bend: Vec<Distance>,
    /// Per free particle: its nearest pinned particle and their rest distance.
    tethers: Vec<Distance>,
    pinned: Vec<u32>,
}

fn edge(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

impl Cloth {
    /// A cloth whose rest shape is `rest` (its edge lengths are kept), with the listed
    /// particles pinned.
    pub fn new(rest: &TriMesh, pinned: &[u32], config: ClothConfig) -> Cloth {
        let n = rest.positions.len();
        let mut inv_mass = vec![1.0f32; n];
        for &p in pinned {
            inv_mass[p as usize] = 0.0;
        }
        // Opposite corners of each edge's faces: one for a border edge, two for an inner one.
        let mut opposite: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
        for &[a, b, c] in &rest.faces {
            for (u, v, w) in [(a, b, c), (b, c, a), (c, a, b)] {
                opposite.entry(edge(u, v)).or_default().push(w);
            }
        }
        let dist = |a: u32, b: u32| Distance {
            a,
            b,
            rest: rest.positions[a as usize].distance(rest.positions[b as usize]),
        };
        let mut keys: Vec<_> = opposite.keys().copied().collect();
        keys.sort_unstable();
        let stretch = keys.iter().map(|&(a, b)| dist(a, b)).collect();
        let bend = keys
            .iter()
            .filter_map(|k| match opposite[k].as_slice() {
                [c, d] => Some(dist(*c, *d)),
                _ => None,
            })
            .collect();
        let tethers = (0..n as u32)
            .filter(|&p| inv_mass[p as usize] > 0.0)
            .filter_map(|p| {
                pinned
                    .iter()
                    .map(|&q| dist(p, q))
                    .min_by(|x, y| x.rest.total_cmp(&y.rest))
                    .map(|d| Distance { rest: d.rest * 1.02, ..d })
            })
            .collect();
        Cloth {
            config,
            positions: rest.positions.clone(),
            velocities: vec![Vec3::ZERO; n],
            inv_mass,
            stretch,
            bend,
            tethers,
            pinned: pinned.to_vec(),
        }
    }

    pub fn pinned(&self) -> &[u32] {
        &self.pinned
    }

    /// Advance one frame of `dt` seconds: the pinned particles move linearly from where they
    /// are to `pins` (same order as the pinned list) and the cloth collides with `body`.
    pub fn step_frame(&mut self, dt: f32, pins: &[Vec3], body: Option<&BodyCollider>) {
        let c = self.config;
        let steps = c.substeps.max(1);
        let h = dt / steps as f32;
        let start: Vec<Vec3> = self.pinned.iter().map(|&p| self.positions[p as usize]).collect();
        let keep = (1.0 - c.damping_per_second).max(0.0).powf(h);
        let mut previous = self.positions.clone();
        for s in 0..steps {
            let t = (s + 1) as f32 / steps as f32;
            previous.copy_from_slice(&self.positions);
            for (k, &p) in self.pinned.iter().enumerate() {
                self.positions[p as usize] = start[k].lerp(pins[k], t);
            }
            for i in 0..self.positions.len() {
                if self.inv_mass[i] > 0.0 {
                    self.velocities[i] += c.gravity * h;
                    self.positions[i] += self.velocities[i] * h;
                }
            }
            // Collide before the constraints too, so a fast limb's push spreads through the
            // cloth within the substep instead of stretching it afterwards.
            if let Some(body) = body {
                self.collide(body, &previous);
            }
            let stretch_alpha = c.stretch_compliance / (h * h);
            let bend_alpha = c.bend_compliance / (h * h);
            for k in 0..self.stretch.len() {
                self.project(self.stretch[k], stretch_alpha, false);
            }
            for k in 0..self.bend.len() {
                self.project(self.bend[k], bend_alpha, false);
            }
            for k in 0..self.tethers.len() {
                self.project(self.tethers[k], 0.0, true);
            }
            if let Some(body) = body {
                self.collide(body, &previous);
            }
            for i in 0..self.positions.len() {
                self.velocities[i] = if self.inv_mass[i] > 0.0 {
                    (self.positions[i] - previous[i]) / h * keep
                } else {
                    (self.positions[i] - previous[i]) / h
                };
            }
        }
    }

    /// One XPBD distance projection (`alpha`: compliance over the squared step); a tether
    /// only pulls back when stretched beyond its length.
    fn project(&mut self, d: Distance, alpha: f32, tether: bool) {
        let (a, b) = (d.a as usize, d.b as usize);
        let (wa, wb) = (self.inv_mass[a], self.inv_mass[b]);
        let w = wa + wb;
        if w == 0.0 {
            return;
        }
        let delta = self.positions[a] - self.positions[b];
        let len = delta.length();
        if len < 1e-9 || (tether && len <= d.rest) {
            return;
        }
        let lambda = -(len - d.rest) / (w + alpha);
        let n = delta / len;
        self.positions[a] += n * (lambda * wa);
        self.positions[b] -= n * (lambda * wb);
    }

    /// Push particles out of the body to the cloth's thickness, with friction against the
    /// motion since the substep began.
    fn collide(&mut self, body: &BodyCollider, previous: &[Vec3]) {
        let c = self.config;
        let reach = 0.12;
        for i in 0..self.positions.len() {
            if self.inv_mass[i] == 0.0 {
                continue;
            }
            let p = self.positions[i];
            let Some((d, n)) = body.signed_distance(p, reach) else { continue };
            if d >= c.thickness {
                continue;
            }
            let mut q = p + n * (c.thickness - d);
            let moved = q - previous[i];
            let tangential = moved - n * moved.dot(n);
            q -= tangential * c.friction;
            self.positions[i] = q;
        }
    }

    /// Largest relative stretch of any edge against its rest length.
    pub fn max_strain(&self) -> f32 {
        self.stretch
            .iter()
            .map(|d| {
                let len = self.positions[d.a as usize].distance(self.positions[d.b as usize]);
                (len - d.rest).abs() / d.rest.max(1e-9)
            })
            .fold(0.0, f32::max)
    }

    /// Mean relative change of the edge lengths against their rest lengths.
    pub fn mean_strain(&self) -> f32 {
        let sum: f32 = self
            .stretch
            .iter()
            .map(|d| {
                let len = self.positions[d.a as usize].distance(self.positions[d.b as usize]);
                (len - d.rest).abs() / d.rest.max(1e-9)
            })
            .sum();
        sum / self.stretch.len().max(1) as f32
    }
}
