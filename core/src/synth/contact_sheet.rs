//! A contact sheet: every outfit at a few poses, shaded, in one PNG (for docs and eyeballing).

use super::camera::{PinholeCamera, look_at};
use super::deform::{PoseFeatures, canonical_surface, pose_surface};
use super::outfit::{ClothedTemplate, Outfit};
use super::raster::{NO_TRIANGLE, render_depth};
use crate::body::{BodyModel, BodyParams};
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use glam::Vec3;
use std::path::Path;

const TILE_W: u32 = 150;
const TILE_H: u32 = 210;

/// Grey Lambert shading of a mesh seen by `cam` (background white).
fn shade(cam: &PinholeCamera, eye: Vec3, target: Vec3, mesh: &TriMesh) -> Vec<u8> {
    let c2w = look_at(eye, target);
    let render = render_depth(cam, c2w, &mesh.positions, &mesh.faces);
    let normals = mesh.face_normals();
    let light = (eye - target).normalize() + Vec3::new(0.3, 0.6, 0.0);
    let light = light.normalize();
    render
        .triangle
        .iter()
        .map(|&t| {
            if t == NO_TRIANGLE {
                255
            } else {
                (40.0 + 200.0 * normals[t as usize].dot(light).abs()) as u8
            }
        })
        .collect()
}

/// Rows = outfits, columns = poses. Writes an 8-bit greyscale PNG (atomic).
pub fn write_contact_sheet(
    path: &Path,
    body: &BodyModel,
    betas: &[f32],
    outfits: &[Outfit],
    poses: &[BodyParams],
) -> Result<()> {
    let rows: Vec<Vec<TriMesh>> = outfits
        .iter()
        .map(|&outfit| {
            let template = ClothedTemplate::build(body, betas, outfit);
            poses
                .iter()
                .map(|p| {
                    let posed_body = body.pose(p);
                    let canonical =
                        canonical_surface(&template, &PoseFeatures::of(&posed_body.bones), 0);
                    TriMesh::new(
                        pose_surface(&template, &canonical, &posed_body.bones),
                        template.faces.clone(),
                    )
                })
                .collect()
        })
        .collect();
    write_mesh_sheet(path, &rows)
}

/// Any meshes on a grid of tiles (rows of equal length), each framed on its own bounding box
/// from a three-quarter view. Writes an 8-bit greyscale PNG (atomic).
pub fn write_mesh_sheet(path: &Path, rows: &[Vec<TriMesh>]) -> Result<()> {
    let cols = rows.iter().map(|r| r.len()).max().unwrap_or(0);
    let cam = PinholeCamera {
        fx: 230.0,
        fy: 230.0,
        cx: TILE_W as f32 / 2.0,
        cy: TILE_H as f32 / 2.0,
        width: TILE_W,
        height: TILE_H,
        near: 0.5,
        far: 10.0,
    };
    let (w, h) = (TILE_W * cols as u32, TILE_H * rows.len() as u32);
    let mut img = vec![255u8; (w * h) as usize];
    for (r, row) in rows.iter().enumerate() {
        for (c, mesh) in row.iter().enumerate() {
            let (lo, hi) = mesh.bounds().unwrap_or((Vec3::ZERO, Vec3::ZERO));
            let target = (lo + hi) * 0.5;
            // A three-quarter view so that panels and folds show.
            let eye = target + Vec3::new(1.2, 0.3, 2.6);
            let tile = shade(&cam, eye, target, mesh);
            for y in 0..TILE_H {
                for x in 0..TILE_W {
                    img[((r as u32 * TILE_H + y) * w + c as u32 * TILE_W + x) as usize] =
                        tile[(y * TILE_W + x) as usize];
                }
            }
        }
    }
    let buf: image::GrayImage = image::ImageBuffer::from_raw(w, h, img).expect("sized above");
    let mut bytes = Vec::new();
    buf.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .map_err(|e| Error::file(path, format!("cannot encode PNG: {e}")))?;
    crate::io::write_bytes_atomic(path, &bytes)
}

/// Meshes side by side (columns) seen from each of `views` (rows: directions from the target
/// to the eye), all framed on the first mesh's bounds so that they compare at one scale.
/// Shows what distances hide: faces seen from behind (a surface turned inside out, or the far
/// side of an open sheet) in orange, and the open border (holes, torn edges, hems) in blue.
/// Writes an RGB PNG (atomic).
pub fn write_view_sheet(path: &Path, meshes: &[TriMesh], views: &[Vec3]) -> Result<()> {
    write_view_sheet_from(path, meshes, views, 3.2)
}

/// [`write_view_sheet`] with the eye `distance` metres from the first mesh's centre (3.2 frames
/// a standing person; a head needs about 0.6).
pub fn write_view_sheet_from(
    path: &Path,
    meshes: &[TriMesh],
    views: &[Vec3],
    distance: f32,
) -> Result<()> {
    const W: u32 = 180;
    const H: u32 = 270;
    let cam = PinholeCamera {
        fx: 300.0,
        fy: 300.0,
        cx: W as f32 / 2.0,
        cy: H as f32 / 2.0,
        width: W,
        height: H,
        near: 0.05,
        far: 10.0,
    };
    let (lo, hi) = meshes.first().and_then(|m| m.bounds()).unwrap_or((Vec3::ZERO, Vec3::ZERO));
    let target = (lo + hi) * 0.5;
    let (w, h) = (W * meshes.len() as u32, H * views.len() as u32);
    let mut img = vec![255u8; (w * h * 3) as usize];
    for (r, view) in views.iter().enumerate() {
        for (c, mesh) in meshes.iter().enumerate() {
            let eye = target + view.normalize_or(Vec3::Z) * distance;
            let tile = shade_sided(&cam, eye, target, mesh);
            for y in 0..H {
                for x in 0..W {
                    // A thin grey frame separates the tiles.
                    let edge = x == 0 || y == 0;
                    let rgb = if edge { [180; 3] } else { tile[(y * W + x) as usize] };
                    let i = ((r as u32 * H + y) * w + c as u32 * W + x) as usize * 3;
                    img[i..i + 3].copy_from_slice(&rgb);
                }
            }
        }
    }
    let buf: image::RgbImage = image::ImageBuffer::from_raw(w, h, img).expect("sized above");
    let mut bytes = Vec::new();
    buf.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .map_err(|e| Error::file(path, format!("cannot encode PNG: {e}")))?;
    crate::io::write_bytes_atomic(path, &bytes)
}

/// The colour of the open border in `write_view_sheet`.
pub const BORDER_RGB: [u8; 3] = [20, 90, 255];

/// Lambert shading, front faces grey and back faces orange, with the open border drawn over
/// it where it is not hidden (RGB per pixel, background white).
fn shade_sided(cam: &PinholeCamera, eye: Vec3, target: Vec3, mesh: &TriMesh) -> Vec<[u8; 3]> {
    let c2w = look_at(eye, target);
    let render = render_depth(cam, c2w, &mesh.positions, &mesh.faces);
    let normals = mesh.face_normals();
    let light = ((eye - target).normalize() + Vec3::new(0.3, 0.6, 0.0)).normalize();
    let mut out: Vec<[u8; 3]> = render
        .triangle
        .iter()
        .map(|&t| {
            if t == NO_TRIANGLE {
                return [255; 3];
            }
            let [a, b, c] = mesh.triangle(t as usize);
            let n = normals[t as usize];
            let g = 40.0 + 200.0 * n.dot(light).abs();
            if n.dot(eye - (a + b + c) / 3.0) >= 0.0 {
                [g as u8; 3]
            } else {
                [(g * 1.0).min(255.0) as u8, (g * 0.55) as u8, (g * 0.15) as u8]
            }
        })
        .collect();
    let w2c = c2w.inverse();
    let (width, height) = (render.width as i64, render.height as i64);
    for (a, b) in crate::mesh::integrity::boundary_segments(mesh) {
        let (pa, pb) = (w2c.transform_point3(a), w2c.transform_point3(b));
        if pa.z < cam.near || pb.z < cam.near {
            continue;
        }
        let (sa, sb) = (cam.project(pa), cam.project(pb));
        let steps = (sa.distance(sb).ceil() as usize).clamp(1, 4 * (W_MAX as usize));
        for k in 0..=steps {
            let t = k as f32 / steps as f32;
            let (s, z) = (sa.lerp(sb, t), pa.z + (pb.z - pa.z) * t);
            let (u, v) = (s.x.round() as i64, s.y.round() as i64);
            if u < 0 || v < 0 || u >= width || v >= height {
                continue;
            }
            let i = (v * width + u) as usize;
            // Hidden behind another surface by more than a couple of centimetres: not drawn.
            if render.depth[i] > 0.0 && z > render.depth[i] + 0.02 {
                continue;
            }
            out[i] = BORDER_RGB;
            if u + 1 < width {
                out[i + 1] = BORDER_RGB;
            }
        }
    }
    out
}

/// Upper bound of a tile's width, for the border's step count.
const W_MAX: u32 = 1024;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn view_sheet_has_a_tile_per_mesh_and_view_and_shows_the_mesh() {
        let body = crate::body::open_body_ref();
        let mesh = body.mesh(body.pose(&BodyParams::default()).vertices);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.png");
        write_view_sheet(&path, &[mesh.clone(), mesh], &[Vec3::Z, Vec3::X]).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (360, 540));
        // The body covers part of each tile, not all of it.
        let dark = img.pixels().filter(|p| p.0[0] < 250).count() as f32 / (360.0 * 540.0);
        assert!(dark > 0.05 && dark < 0.6, "{dark}");
        // The body is closed and faces out: no border, nothing seen from behind.
        let blue = img.pixels().filter(|p| p.0 == BORDER_RGB).count();
        let orange = img.pixels().filter(|p| p.0[0] as i32 > p.0[2] as i32 + 30).count();
        assert_eq!((blue, orange), (0, 0));
    }

    #[test]
    fn view_sheet_shows_a_hole_and_an_inside_out_mesh() {
        let body = crate::body::open_body_ref();
        let mesh = body.mesh(body.pose(&BodyParams::default()).vertices);
        // Cut away the faces of the chest (front, above the navel) and turn a copy inside out.
        let (lo, hi) = mesh.bounds().unwrap();
        let mid = (lo + hi) * 0.5;
        let mut holed = mesh.clone();
        holed.faces.retain(|f| {
            let [a, b, c] = f.map(|v| mesh.positions[v as usize]);
            let p = (a + b + c) / 3.0;
            !(p.z > mid.z && p.y > mid.y + 0.1 && p.y < mid.y + 0.3 && p.x.abs() < 0.1)
        });
        let mut flipped = mesh.clone();
        flipped.faces.iter_mut().for_each(|f| f.swap(1, 2));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.png");
        write_view_sheet(&path, &[holed, flipped], &[Vec3::Z]).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        let count = |x0: u32, f: &dyn Fn(&image::Rgb<u8>) -> bool| {
            (x0..x0 + 180)
                .flat_map(|x| (0..270).map(move |y| (x, y)))
                .filter(|&(x, y)| f(img.get_pixel(x, y)))
                .count()
        };
        // The hole's rim is drawn in the first tile; the inner back of the body shows through
        // it in orange; the inside-out copy is orange all over and has no border.
        assert!(count(0, &|p| p.0 == BORDER_RGB) > 40);
        assert!(count(0, &|p| p.0[0] as i32 > p.0[2] as i32 + 30) > 20);
        assert_eq!(count(180, &|p| p.0 == BORDER_RGB), 0);
        let covered = count(180, &|p| p.0 != [255; 3] && p.0 != [180; 3]);
        assert!(count(180, &|p| p.0[0] as i32 > p.0[2] as i32 + 30) as f32 > 0.95 * covered as f32);
    }
}
