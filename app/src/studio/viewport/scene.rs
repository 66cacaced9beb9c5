//! What the viewport draws: meshes with per-vertex normals, points and lines, already in world
//! space. Built by the app (`studio::scene`) whenever something shown changes.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::sync::atomic::{AtomicU64, Ordering};

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct MeshVertex {
    pub pos: [f32; 3],
    pub normal: [f32; 3],
    pub color: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct ColoredPoint {
    pub pos: [f32; 3],
    pub color: [f32; 4],
}

/// What the viewport draws: triangles with per-vertex normals and colours, points (drawn as
/// round billboards) and line segments. Built once per change; the renderer re-uploads only
/// when the generation changes.
#[derive(Debug, Default)]
pub struct Scene {
    pub generation: u64,
    pub vertices: Vec<MeshVertex>,
    pub indices: Vec<u32>,
    pub points: Vec<ColoredPoint>,
    /// Pairs of endpoints.
    pub lines: Vec<ColoredPoint>,
    /// Drawn over everything else (the skeleton).
    pub overlay_points: Vec<ColoredPoint>,
    pub overlay_lines: Vec<ColoredPoint>,
}

static GENERATION: AtomicU64 = AtomicU64::new(1);

impl Scene {
    pub fn new() -> Scene {
        Scene { generation: GENERATION.fetch_add(1, Ordering::Relaxed), ..Scene::default() }
    }

    /// Add a triangle mesh with smooth vertex normals in one colour (linear RGB).
    pub fn add_mesh(&mut self, positions: &[Vec3], faces: &[[u32; 3]], color: [f32; 3]) {
        self.add_mesh_with_normals(positions, None, faces, color);
    }

    /// Add a triangle mesh with the given unit vertex normals (an SDF's gradient), or normals
    /// from its triangles (area-weighted) when there are none.
    pub fn add_mesh_with_normals(
        &mut self,
        positions: &[Vec3],
        normals: Option<&[Vec3]>,
        faces: &[[u32; 3]],
        color: [f32; 3],
    ) {
        let owned;
        let normals = match normals {
            Some(n) if n.len() == positions.len() => n,
            _ => {
                // A vertex on no proper triangle gets "up" rather than no normal at all.
                owned = avatar_core::mesh::vertex_normals(positions, faces)
                    .into_iter()
                    .map(|n| n.normalize_or(Vec3::Y))
                    .collect::<Vec<_>>();
                &owned[..]
            }
        };
        let base = self.vertices.len() as u32;
        self.vertices.extend(positions.iter().zip(normals).map(|(p, n)| MeshVertex {
            pos: p.to_array(),
            normal: n.to_array(),
            color: [color[0], color[1], color[2], 1.0],
        }));
        self.indices.extend(faces.iter().flat_map(|f| f.map(|i| i + base)));
    }

    /// Points drawn as discs; `size` scales the viewport's point size.
    pub fn add_points(&mut self, points: &[Vec3], color: [f32; 3], size: f32) {
        self.points.extend(points.iter().map(|p| ColoredPoint {
            pos: p.to_array(),
            color: [color[0], color[1], color[2], size],
        }));
    }

    /// Points with normals, lit by a fixed key light (so that the cloud reads as a surface).
    pub fn add_lit_points(
        &mut self,
        points: &[Vec3],
        normals: &[Vec3],
        color: [f32; 3],
        size: f32,
    ) {
        let key = Vec3::new(-0.4, 0.6, 0.7).normalize();
        self.points.extend(
            points.iter().zip(normals.iter().chain(std::iter::repeat(&Vec3::Z))).map(|(p, n)| {
                let l = 0.25 + 0.75 * n.dot(key).abs();
                ColoredPoint {
                    pos: p.to_array(),
                    color: [color[0] * l, color[1] * l, color[2] * l, size],
                }
            }),
        );
    }

    /// A skeleton drawn over the meshes: bones as lines from each joint to its parent.
    pub fn add_skeleton(&mut self, joints: &[Vec3], parents: &[i32], color: [f32; 3]) {
        for (j, &p) in parents.iter().enumerate() {
            if p >= 0 {
                let c = [color[0], color[1], color[2], 1.0];
                self.overlay_lines
                    .push(ColoredPoint { pos: joints[p as usize].to_array(), color: c });
                self.overlay_lines.push(ColoredPoint { pos: joints[j].to_array(), color: c });
            }
        }
        self.overlay_points.extend(
            joints
                .iter()
                .map(|p| ColoredPoint { pos: p.to_array(), color: [1.0, 0.85, 0.35, 2.6] }),
        );
    }

    pub fn add_line(&mut self, a: Vec3, b: Vec3, color: [f32; 3]) {
        let c = [color[0], color[1], color[2], 1.0];
        self.lines.push(ColoredPoint { pos: a.to_array(), color: c });
        self.lines.push(ColoredPoint { pos: b.to_array(), color: c });
    }

    /// A ground grid on the plane y = `y`.
    pub fn add_grid(&mut self, center: Vec3, y: f32, half: f32, step: f32) {
        let n = (half / step).round() as i32;
        for i in -n..=n {
            let t = i as f32 * step;
            let c = if i == 0 { [0.16, 0.17, 0.20] } else { [0.07, 0.075, 0.09] };
            self.add_line(
                Vec3::new(center.x + t, y, center.z - half),
                Vec3::new(center.x + t, y, center.z + half),
                c,
            );
            self.add_line(
                Vec3::new(center.x - half, y, center.z + t),
                Vec3::new(center.x + half, y, center.z + t),
                c,
            );
        }
    }

    /// Bounds of everything but the lines (the grid must not change framing).
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let pts = self
            .vertices
            .iter()
            .map(|v| Vec3::from(v.pos))
            .chain(self.points.iter().map(|p| Vec3::from(p.pos)));
        let mut it = pts.peekable();
        it.peek()?;
        Some(
            it.fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(lo, hi), p| {
                (lo.min(p), hi.max(p))
            }),
        )
    }

    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
            && self.points.is_empty()
            && self.lines.is_empty()
            && self.overlay_points.is_empty()
    }
}
