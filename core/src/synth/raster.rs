//! Z-buffer rasterizer for depth images: exact ray-plane depth per pixel (the depth of the
//! nearest triangle hit by the pixel's ray) and the id of that triangle.
//!
//! Triangles are binned into bands of rows; bands are rendered in parallel (rayon), each band
//! walking its triangles in index order, so the result is deterministic. Depth ties keep the
//! lower triangle id.

use super::camera::PinholeCamera;
use glam::{Mat4, Vec2, Vec3};
use rayon::prelude::*;

/// Marks pixels that no triangle covers.
pub const NO_TRIANGLE: u32 = u32::MAX;

const BAND_ROWS: usize = 8;

/// A rendered depth image: z along the optical axis in metres (0 = nothing) and, per pixel, the
/// triangle seen there.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthRender {
    pub width: usize,
    pub height: usize,
    pub depth: Vec<f32>,
    pub triangle: Vec<u32>,
}

impl DepthRender {
    pub fn at(&self, u: usize, v: usize) -> (f32, u32) {
        let i = v * self.width + u;
        (self.depth[i], self.triangle[i])
    }

    pub fn covered_pixels(&self) -> usize {
        self.depth.iter().filter(|&&d| d > 0.0).count()
    }
}

/// Render a triangle mesh (world coordinates) seen by `camera` placed at `camera_to_world`.
pub fn render_depth(
    camera: &PinholeCamera,
    camera_to_world: Mat4,
    positions: &[Vec3],
    faces: &[[u32; 3]],
) -> DepthRender {
    let w2c = camera_to_world.inverse();
    let cam: Vec<Vec3> = positions.iter().map(|&p| w2c.transform_point3(p)).collect();
    let (w, h) = (camera.width as usize, camera.height as usize);
    let bands = h.div_ceil(BAND_ROWS);

    // Screen-space setup of every drawable triangle, binned by band.
    struct Tri {
        id: u32,
        a: Vec3,
        n: Vec3,
        s: [Vec2; 3],
        umin: usize,
        umax: usize,
        vmin: usize,
        vmax: usize,
    }
    let mut tris = Vec::new();
    for (id, f) in faces.iter().enumerate() {
        let p = f.map(|i| cam[i as usize]);
        // Triangles reaching in front of the near plane or beyond the far plane are skipped whole
        // (the person is metres away; nothing is clipped in practice).
        if p.iter().any(|q| q.z < camera.near || q.z > camera.far) {
            continue;
        }
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        if n.length_squared() == 0.0 {
            continue;
        }
        let s = p.map(|q| camera.project(q));
        let lo = s[0].min(s[1]).min(s[2]);
        let hi = s[0].max(s[1]).max(s[2]);
        if hi.x < 0.0 || hi.y < 0.0 || lo.x > (w - 1) as f32 || lo.y > (h - 1) as f32 {
            continue;
        }
        let umin = lo.x.ceil().max(0.0) as usize;
        let vmin = lo.y.ceil().max(0.0) as usize;
        let umax = (hi.x.floor() as i64).min(w as i64 - 1);
        let vmax = (hi.y.floor() as i64).min(h as i64 - 1);
        if umax < umin as i64 || vmax < vmin as i64 {
            continue;
        }
        tris.push(Tri {
            id: id as u32,
            a: p[0],
            n,
            s,
            umin,
            umax: umax as usize,
            vmin,
            vmax: vmax as usize,
        });
    }
    let mut binned: Vec<Vec<u32>> = vec![Vec::new(); bands];
    for (k, t) in tris.iter().enumerate() {
        for b in t.vmin / BAND_ROWS..=t.vmax / BAND_ROWS {
            binned[b].push(k as u32);
        }
    }

    let mut depth = vec![0f32; w * h];
    let mut triangle = vec![NO_TRIANGLE; w * h];
    depth
        .par_chunks_mut(BAND_ROWS * w)
        .zip(triangle.par_chunks_mut(BAND_ROWS * w))
        .enumerate()
        .for_each(|(b, (dband, tband))| {
            let v0 = b * BAND_ROWS;
            let v1 = (v0 + BAND_ROWS).min(h);
            for &k in &binned[b] {
                let t = &tris[k as usize];
                let [s0, s1, s2] = t.s;
                let area = edge(s0, s1, s2);
                for v in t.vmin.max(v0)..=t.vmax.min(v1 - 1) {
                    for u in t.umin..=t.umax {
                        let q = Vec2::new(u as f32, v as f32);
                        let (e0, e1, e2) = (edge(s1, s2, q), edge(s2, s0, q), edge(s0, s1, q));
                        // Inside for either winding (the z-test picks the front surface).
                        let inside = if area > 0.0 {
                            e0 >= 0.0 && e1 >= 0.0 && e2 >= 0.0
                        } else {
                            e0 <= 0.0 && e1 <= 0.0 && e2 <= 0.0
                        };
                        if !inside {
                            continue;
                        }
                        // Exact depth: intersect the pixel ray with the triangle's plane.
                        let d = camera.ray(q.x, q.y);
                        let denom = t.n.dot(d);
                        if denom == 0.0 {
                            continue;
                        }
                        let z = t.n.dot(t.a) / denom;
                        if !(z >= camera.near && z <= camera.far) {
                            continue;
                        }
                        let i = (v - v0) * w + u;
                        if dband[i] == 0.0 || z < dband[i] || (z == dband[i] && t.id < tband[i]) {
                            dband[i] = z;
                            tband[i] = t.id;
                        }
                    }
                }
            }
        });
    DepthRender { width: w, height: h, depth, triangle }
}

/// Twice the signed area of (a, b, c) in screen space.
fn edge(a: Vec2, b: Vec2, c: Vec2) -> f32 {
    (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x)
}

/// Möller-Trumbore ray-triangle intersection: distance along `dir` or None.
pub fn ray_triangle(origin: Vec3, dir: Vec3, tri: [Vec3; 3]) -> Option<f32> {
    let e1 = tri[1] - tri[0];
    let e2 = tri[2] - tri[0];
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return None;
    }
    let inv = 1.0 / det;
    let s = origin - tri[0];
    let u = s.dot(p) * inv;
    if !(-1e-6..=1.0 + 1e-6).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = dir.dot(q) * inv;
    if v < -1e-6 || u + v > 1.0 + 1e-6 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > 0.0).then_some(t)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::synth::camera::orbit;

    /// A UV sphere (closed, outward faces).
    pub fn sphere(centre: Vec3, r: f32, rings: usize, segs: usize) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut p = vec![centre + Vec3::Y * r];
        for i in 1..rings {
            let th = std::f32::consts::PI * i as f32 / rings as f32;
            for j in 0..segs {
                let ph = 2.0 * std::f32::consts::PI * j as f32 / segs as f32;
                p.push(centre + r * Vec3::new(th.sin() * ph.cos(), th.cos(), -th.sin() * ph.sin()));
            }
        }
        p.push(centre - Vec3::Y * r);
        let mut f = Vec::new();
        let idx = |i: usize, j: usize| (1 + (i - 1) * segs + j % segs) as u32;
        for j in 0..segs {
            f.push([0, idx(1, j), idx(1, j + 1)]);
        }
        for i in 1..rings - 1 {
            for j in 0..segs {
                f.push([idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)]);
                f.push([idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)]);
            }
        }
        let last = (p.len() - 1) as u32;
        for j in 0..segs {
            f.push([last, idx(rings - 1, j + 1), idx(rings - 1, j)]);
        }
        (p, f)
    }

    #[test]
    fn depth_matches_ray_mesh_intersection_at_sample_pixels() {
        let (mut p, mut f) = sphere(Vec3::new(0.0, 0.1, 0.0), 0.4, 24, 32);
        // A second sphere partly behind the first (occlusion) and one in front of it.
        let (p2, f2) = sphere(Vec3::new(0.3, -0.2, -0.3), 0.3, 16, 24);
        let off = p.len() as u32;
        p.extend(p2);
        f.extend(f2.iter().map(|t| t.map(|i| i + off)));
        let cam = PinholeCamera::metaavatar();
        let c2w = orbit(Vec3::ZERO, 3.0, 0.7);
        let r = render_depth(&cam, c2w, &p, &f);
        assert!(r.covered_pixels() > 2000, "{}", r.covered_pixels());
        let w2c = c2w.inverse();
        let pc: Vec<Vec3> = p.iter().map(|&x| w2c.transform_point3(x)).collect();
        let mut checked = 0;
        let mut hits = 0;
        for v in (0..250).step_by(7) {
            for u in (0..250).step_by(5) {
                let dir = cam.ray(u as f32, v as f32);
                let mut best: Option<(f32, u32)> = None;
                for (k, t) in f.iter().enumerate() {
                    if let Some(s) = ray_triangle(Vec3::ZERO, dir, t.map(|i| pc[i as usize]))
                        && best.is_none_or(|(b, _)| s < b)
                    {
                        best = Some((s, k as u32));
                    }
                }
                let (d, tri) = r.at(u, v);
                match best {
                    None => assert_eq!(d, 0.0, "pixel ({u},{v}) should be empty"),
                    Some((s, k)) => {
                        // s is the distance along dir with dir.z = 1: the depth itself.
                        assert!(d > 0.0, "pixel ({u},{v}) missed the mesh (ray hits at {s})");
                        assert!((d - s).abs() < 1e-5, "pixel ({u},{v}): raster {d} vs ray {s}");
                        // The same triangle, unless the ray passes through a shared edge.
                        if tri != k {
                            let t = f[tri as usize].map(|i| pc[i as usize]);
                            let again = ray_triangle(Vec3::ZERO, dir, t)
                                .expect("raster triangle is hit by the ray");
                            assert!((again - s).abs() < 1e-5);
                        }
                        hits += 1;
                    }
                }
                checked += 1;
            }
        }
        assert!(hits > 50 && checked > hits, "{hits} hits of {checked}");
    }

    #[test]
    fn parallel_render_is_deterministic() {
        let (p, f) = sphere(Vec3::ZERO, 0.5, 20, 20);
        let cam = PinholeCamera::metaavatar();
        let a = render_depth(&cam, orbit(Vec3::ZERO, 3.0, 0.3), &p, &f);
        let b = render_depth(&cam, orbit(Vec3::ZERO, 3.0, 0.3), &p, &f);
        assert_eq!(a, b);
        // Front depth of a sphere of radius 0.5 at 3 m: 2.5 m at the centre pixel.
        let (d, _) = a.at(125, 125);
        assert!((d - 2.5).abs() < 0.01, "{d}");
    }
}
