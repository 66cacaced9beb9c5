//! The simulated cape's rest shape: a sheet hanging from the shoulders behind the back down
//! to the knees (`Outfit::SimCape`).

use super::{ClothedTemplate, joint::*};
use crate::body::{NUM_JOINTS, Weights};
use glam::Vec3;

/// Rows and columns of the cape's grid.
const CAPE_ROWS: usize = 28;
const CAPE_COLUMNS: usize = 25;

/// Add a cape to the template: from the collar line, 6 cm behind the back, to the knees,
/// as wide as the shoulders and curved around the back. Skinned to the upper spine at the
/// top, to the pelvis lower down (the fallback pose of a single frame; the simulation decides
/// where the cloth really goes).
pub fn add_cape(t: &mut ClothedTemplate) {
    let j = t.rest_joints;
    let top_y = j[NECK].y - 0.06;
    let bottom_y = 0.5 * (j[L_KNEE].y + j[R_KNEE].y) + 0.05;
    let half_width = 0.5 * (j[L_SHOULDER].x - j[R_SHOULDER].x).abs() + 0.06;
    // The back: the body's farthest -Z extent around the shoulder blades and hips.
    let back_z = t.body_rest[..t.body_vertices]
        .iter()
        .filter(|p| p.y > j[PELVIS].y && p.y < top_y && p.x.abs() < half_width)
        .map(|p| p.z)
        .fold(f32::MAX, f32::min);
    let cx = j[SPINE3].x;
    let base = t.vertices.len() as u32;
    for r in 0..=CAPE_ROWS {
        let h = r as f32 / CAPE_ROWS as f32;
        let y = top_y + (bottom_y - top_y) * h;
        for c in 0..CAPE_COLUMNS {
            let u = c as f32 / (CAPE_COLUMNS - 1) as f32 * 2.0 - 1.0;
            // Wrapped a little around the shoulders at the top, flat lower down.
            let wrap = 0.09 * u * u * (1.0 - h);
            let p = Vec3::new(cx + u * half_width * (1.0 + 0.25 * h), y, back_z - 0.06 + wrap);
            t.vertices.push(p);
            t.normals.push(Vec3::NEG_Z);
            let mut w: Weights = [0.0; NUM_JOINTS];
            let top = (1.0 - 2.0 * h).max(0.0);
            w[SPINE3] = top;
            w[SPINE2] = (1.0 - top) * (1.0 - h);
            w[PELVIS] = (1.0 - top) * h;
            t.weights.push(w);
            t.vertex_joint.push(if h < 0.5 { SPINE3 as u8 } else { PELVIS as u8 });
            t.cloth.push(1.0);
            t.panel.push((h, u));
        }
    }
    let idx = |r: usize, c: usize| base + (r * CAPE_COLUMNS + c) as u32;
    for r in 0..CAPE_ROWS {
        for c in 0..CAPE_COLUMNS - 1 {
            // Facing backwards (-Z), counter-clockwise seen from behind.
            t.faces.push([idx(r, c), idx(r, c + 1), idx(r + 1, c + 1)]);
            t.faces.push([idx(r, c), idx(r + 1, c + 1), idx(r + 1, c)]);
        }
    }
}
