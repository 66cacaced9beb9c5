//! `import scan`: a 3D scan of a person (OBJ: with or without normals, quads and other
//! polygons, several objects) seen by a ring of virtual depth cameras (the synthetic
//! generator's rasterizer) becomes a capture folder that `fit` takes: one frame per camera,
//! every frame with the scan's fitting. MetaAvatar's appendix G makes avatars from raw scans
//! the same way. See docs/capture-format.md.

use super::depth_png::write_depth_png;
use super::import::check_output_dir;
use super::manifest::{CaptureManifest, FrameRecord};
use crate::body::{BodyModel, BodyParams};
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::mesh::bvh::Bvh;
use crate::synth::{PinholeCamera, look_at, render_depth};
use glam::Vec3;
use std::path::Path;

/// Load every object of an OBJ file as one triangle mesh (polygons fan-triangulated; normals,
/// texture coordinates, materials, points and lines ignored).
pub fn load_scan(path: impl AsRef<Path>) -> Result<TriMesh> {
    let path = path.as_ref();
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _materials) = tobj::load_obj(path, &options).map_err(|e| match e {
        tobj::LoadError::OpenFileFailed | tobj::LoadError::ReadError => {
            match std::fs::metadata(path) {
                Err(io) => Error::io(path, io),
                Ok(_) => Error::file(path, format!("cannot read the OBJ: {e}")),
            }
        }
        other => Error::file(path, format!("not a readable OBJ scan: {other}")),
    })?;
    let mut mesh = TriMesh::default();
    for m in &models {
        let base = mesh.positions.len() as u32;
        let p = &m.mesh.positions;
        if p.len() % 3 != 0 {
            return Err(Error::file(
                path,
                format!("object '{}': positions are not triples", m.name),
            ));
        }
        mesh.positions.extend(p.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])));
        let n = (p.len() / 3) as u32;
        for tri in m.mesh.indices.chunks_exact(3) {
            if let Some(&bad) = tri.iter().find(|&&i| i >= n) {
                return Err(Error::file(
                    path,
                    format!(
                        "object '{}': face index {} out of range ({n} vertices)",
                        m.name,
                        bad + 1
                    ),
                ));
            }
            mesh.faces.push([base + tri[0], base + tri[1], base + tri[2]]);
        }
    }
    if let Some(i) = mesh.positions.iter().position(|p| !p.is_finite()) {
        return Err(Error::file(path, format!("vertex {} is not finite", i + 1)));
    }
    if mesh.faces.is_empty() {
        return Err(Error::file(
            path,
            "the OBJ has no faces: a scan must be a surface mesh, not a point cloud",
        ));
    }
    Ok(mesh)
}

/// The virtual cameras of `import scan`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanViews {
    /// Cameras on a horizontal ring around the scan, evenly spaced, the first in front (+Z).
    pub views: usize,
    /// Square image side in pixels (focal length = side, so about 53 degrees of view).
    pub resolution: u32,
}

impl Default for ScanViews {
    fn default() -> Self {
        ScanViews { views: 8, resolution: 256 }
    }
}

/// Depth PNG units per metre for rendered scans: 0.1 mm steps (up to 6.5 m).
pub const SCAN_DEPTH_SCALE: f32 = 10_000.0;
/// Scan vertices this close to the fitted body count as on it.
const ON_BODY: f32 = 0.3;

#[derive(Debug, Clone, PartialEq)]
pub struct ScanReport {
    pub vertices: usize,
    pub faces: usize,
    pub frames: usize,
    pub depth_pixels: usize,
    /// Distance of the cameras from the scan's vertical axis (metres).
    pub distance: f32,
}

/// Render `scan` (posed as `fitting`, metres, Y up) from a ring of cameras into the capture
/// folder `out`. The scan must lie on the fitted body: a scan in millimetres or centimetres,
/// or one that the fitting does not describe, is refused with the reason.
pub fn import_scan(
    scan_path: &Path,
    fitting_path: &Path,
    out: &Path,
    body: &BodyModel,
    views: &ScanViews,
) -> Result<ScanReport> {
    check_output_dir(out, &[scan_path, fitting_path])?;
    if views.views == 0 || !(16..=4096).contains(&views.resolution) {
        return Err(Error::invalid(
            "a scan needs at least 1 view and an image side of 16 to 4096 pixels",
        ));
    }
    let scan = load_scan(scan_path)?;
    let fitting = BodyParams::load_json(fitting_path)?;
    check_scan_on_body(scan_path, &scan, body, &fitting)?;
    let (lo, hi) = scan.bounds().expect("a scan with faces has bounds");
    let centre = 0.5 * (lo + hi);
    let radius = scan.positions.iter().map(|p| (*p - centre).length()).fold(0.0, f32::max);
    let side = views.resolution;
    let f = side as f32;
    // The bounding sphere fills 90 % of the half image: sin(half angle) = radius / distance.
    let half = ((0.5 * side as f32) / f).atan() * 0.9;
    let distance = radius / half.sin();
    let camera = PinholeCamera {
        fx: f,
        fy: f,
        cx: 0.5 * side as f32,
        cy: 0.5 * side as f32,
        width: side,
        height: side,
        near: 0.05,
        far: distance + 2.0 * radius,
    };
    if distance + radius > 65535.0 / SCAN_DEPTH_SCALE {
        return Err(Error::file(
            scan_path,
            format!("the scan is {:.1} m across: too large for a person (units?)", 2.0 * radius),
        ));
    }
    let intr = camera.intrinsics();
    let mut manifest = CaptureManifest::new(intr, SCAN_DEPTH_SCALE);
    let mut depth_pixels = 0;
    for k in 0..views.views {
        let azimuth = std::f32::consts::TAU * k as f32 / views.views as f32;
        let eye = centre + Vec3::new(azimuth.sin(), 0.0, azimuth.cos()) * distance;
        let c2w = look_at(eye, centre);
        let render = render_depth(&camera, c2w, &scan.positions, &scan.faces);
        depth_pixels += render.covered_pixels();
        let name = format!("depth/{k:06}.png");
        write_depth_png(out.join(&name), &render.depth, side, side, SCAN_DEPTH_SCALE)?;
        let mut rec = FrameRecord {
            depth: name,
            mask: None,
            pose: Some(fitting.flat_pose()),
            shape: fitting.betas.clone(),
            translation: Some(fitting.trans.to_array()),
            camera_to_world: None,
        };
        rec.set_camera_to_world(c2w);
        manifest.frames.push(rec);
    }
    manifest.save(out)?;
    Ok(ScanReport {
        vertices: scan.positions.len(),
        faces: scan.faces.len(),
        frames: views.views,
        depth_pixels,
        distance,
    })
}

/// Most of the scan must lie within 30 cm of the fitted body; otherwise say why.
pub(crate) fn check_scan_on_body(
    path: &Path,
    scan: &TriMesh,
    body: &BodyModel,
    fitting: &BodyParams,
) -> Result<()> {
    let posed = body.pose(fitting);
    let bvh = Bvh::build(&body.mesh(posed.vertices.clone()));
    let step = (scan.positions.len() / 2000).max(1);
    let sample: Vec<Vec3> = scan.positions.iter().step_by(step).copied().collect();
    let on = sample.iter().filter(|p| bvh.any_within(**p, ON_BODY)).count();
    if 2 * on >= sample.len() {
        return Ok(());
    }
    let (lo, hi) = scan.bounds().expect("non-empty");
    let height = hi.y - lo.y;
    let why = if height > 100.0 {
        format!("the scan is {height:.0} units tall: millimetres? (scale it to metres)")
    } else if height > 10.0 {
        format!("the scan is {height:.0} units tall: centimetres? (scale it to metres)")
    } else {
        let body_centre = posed.posed_joints()[0];
        format!(
            "the scan's centre {:.2?} is {:.2} m from the fitted pelvis {:.2?}: does the fitting describe this scan (same axes, Y up)?",
            (0.5 * (lo + hi)).to_array(),
            (0.5 * (lo + hi) - body_centre).length(),
            body_centre.to_array()
        )
    };
    Err(Error::file(
        path,
        format!(
            "only {} of {} scan vertices lie within {:.0} cm of the fitted body: {why}",
            on,
            sample.len(),
            ON_BODY * 100.0
        ),
    ))
}
