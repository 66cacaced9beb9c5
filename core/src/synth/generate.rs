//! Writing synthetic captures: a subject (the open body with seeded shape) in an outfit plays a
//! motion clip in front of a fixed depth camera, turning 45 degrees between frames (the
//! MetaAvatar protocol); depth PNGs, capture.json and the ground truth are written.

use super::camera::{PinholeCamera, look_at};
use super::cloth::{ClothConfig, GarmentTrack, simulate_garment};
use super::deform::{PoseFeatures, canonical_surface, pose_surface};
use super::ground_truth::{GT_FORMAT, GroundTruth, GtFrame, GtHeader};
use super::noise::DepthNoise;
use super::outfit::{ClothedTemplate, Outfit};
use super::raster::{NO_TRIANGLE, render_depth};
use crate::body::{BodyModel, BodyParams, blend_transform};
use crate::capture::{CaptureManifest, DEPTH_SCALE_MM, FrameRecord, write_depth_png};
use crate::error::{Error, Result};
use crate::motion::MotionClip;
use glam::{Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;

/// The person turns this much between consecutive frames (degrees).
pub const TURN_PER_FRAME_DEG: f32 = 45.0;
/// Camera distance from the body's vertical axis (metres).
pub const CAMERA_DISTANCE: f32 = 2.4;

/// Shape coefficients of subject `seed`: uniform within 60% of each direction's limits.
pub fn subject_betas(body: &BodyModel, seed: u64) -> Vec<f32> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5ab1_ec75);
    body.shape_limits
        .iter()
        .map(|&(lo, hi)| rng.random_range(0.6 * lo..=0.6 * hi.max(lo + 1e-6)))
        .collect()
}

#[derive(Debug, Clone)]
pub struct SynthJob {
    pub subject_seed: u64,
    pub outfit: Outfit,
    pub clip: MotionClip,
    /// Keep this many frames, evenly spread over the clip (`None` = all).
    pub frames: Option<usize>,
    pub turn_per_frame_deg: f32,
    pub noise: Option<DepthNoise>,
    pub noise_seed: u64,
    pub camera: PinholeCamera,
    pub write_ground_truth: bool,
    /// A simulated outfit's garment at every frame of `clip` (posed as `frame_params` poses
    /// them before the turn). `None`: simulated through `clip` from its first frame, which
    /// suits a continuous clip.
    pub garment: Option<GarmentTrack>,
}

impl SynthJob {
    pub fn new(subject_seed: u64, outfit: Outfit, clip: MotionClip) -> Self {
        SynthJob {
            subject_seed,
            outfit,
            clip,
            frames: None,
            turn_per_frame_deg: TURN_PER_FRAME_DEG,
            noise: None,
            noise_seed: 0,
            camera: PinholeCamera::metaavatar(),
            write_ground_truth: true,
            garment: None,
        }
    }

    /// The clip frames written.
    pub fn picks(&self) -> Vec<usize> {
        let n = self.clip.len();
        match self.frames {
            Some(k) if k < n && k > 0 => (0..k).map(|i| i * n / k).collect(),
            _ => (0..n).collect(),
        }
    }

    /// The turn of the `i`-th frame written, about the vertical axis through the origin
    /// (where `frame_params` keeps the root).
    pub fn turn(&self, i: usize) -> Quat {
        Quat::from_rotation_y((self.turn_per_frame_deg * i as f32).to_radians())
    }

    /// The simulated garment at every clip frame: the job's, or simulated through the clip.
    fn garment_track(&self, body: &BodyModel, template: &ClothedTemplate) -> Option<GarmentTrack> {
        if !self.outfit.is_simulated() {
            return None;
        }
        if let Some(g) = &self.garment {
            return Some(g.clone());
        }
        let betas = subject_betas(body, self.subject_seed);
        let poses: Vec<BodyParams> =
            self.clip.frames.iter().map(|p| crate::eval::truth::query(p, &betas)).collect();
        Some(simulate_garment(
            body,
            template,
            &poses,
            self.clip.fps,
            self.subject_seed,
            ClothConfig::default(),
        ))
    }

    /// The fittings of the frames written: the clip's poses, the subject's shape, turned by
    /// `turn_per_frame_deg` per frame about the root joint, horizontal drift removed.
    pub fn frame_params(&self, body: &BodyModel) -> Vec<BodyParams> {
        let betas = subject_betas(body, self.subject_seed);
        let picks = self.picks();
        let j0 = body.rest_joints(&betas)[0];
        picks
            .iter()
            .enumerate()
            .map(|(i, &f)| {
                let mut p = self.clip.frames[f].clone();
                p.betas = betas.clone();
                p.trans.x = 0.0;
                p.trans.z = 0.0;
                let turn = self.turn(i);
                p.pose[0] = (turn * Quat::from_scaled_axis(p.pose[0])).to_scaled_axis();
                p.trans = turn * (p.trans + j0) - j0;
                p
            })
            .collect()
    }
}

/// Summary of a written capture.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthReport {
    pub frames: usize,
    pub vertices: usize,
    pub depth_pixels: usize,
}

/// Generate one capture folder.
pub fn generate_capture(dir: &Path, body: &BodyModel, job: &SynthJob) -> Result<SynthReport> {
    if job.clip.is_empty() {
        return Err(Error::invalid(format!("motion clip {:?} has no frames", job.clip.name)));
    }
    std::fs::create_dir_all(dir.join("depth")).map_err(|e| Error::io(dir, e))?;
    let params = job.frame_params(body);
    let betas = params[0].betas.clone();
    let template = ClothedTemplate::build(body, &betas, job.outfit);
    let cam = job.camera;
    // A fixed camera at the height of the pelvis, looking at the body along -Z.
    let centre = Vec3::new(0.0, body.rest_joints(&betas)[0].y, 0.0);
    let c2w = look_at(centre + Vec3::new(0.0, 0.0, CAMERA_DISTANCE), centre);
    let intr = cam.intrinsics();
    let mut manifest = CaptureManifest::new(intr, DEPTH_SCALE_MM);
    manifest.fps = Some(job.clip.fps);
    let mut rng = ChaCha8Rng::seed_from_u64(job.noise_seed);
    let mut gt_frames = Vec::with_capacity(params.len());
    let mut depth_pixels = 0;
    let garment = job.garment_track(body, &template);
    if let Some(g) = &garment
        && g.frames.len() != job.clip.len()
    {
        return Err(Error::invalid(format!(
            "the simulated {} has {} frames for the {} of clip {:?}",
            job.outfit.name(),
            g.frames.len(),
            job.clip.len(),
            job.clip.name
        )));
    }
    let picks = job.picks();
    for (i, p) in params.iter().enumerate() {
        let posed_body = body.pose(p);
        let features = PoseFeatures::of(&posed_body.bones);
        let mut canonical = canonical_surface(&template, &features, job.subject_seed);
        let mut posed = pose_surface(&template, &canonical, &posed_body.bones);
        if let Some(g) = &garment {
            // The garment as simulated, turned with the person; its canonical points by
            // inverting each vertex's skinning.
            let turn = job.turn(i);
            let n = template.body_vertices;
            for (k, &q) in g.frames[picks[i]].iter().enumerate() {
                let v = n + k;
                posed[v] = turn * q;
                let m = blend_transform(&posed_body.bones.transforms, &template.weights[v]);
                canonical[v] = m.inverse().transform_point3(posed[v]);
            }
        }
        let render = render_depth(&cam, c2w, &posed, &template.faces);
        let mut visible = vec![false; posed.len()];
        for &t in &render.triangle {
            if t != NO_TRIANGLE {
                for k in template.faces[t as usize] {
                    visible[k as usize] = true;
                }
            }
        }
        let mut depth = render.depth.clone();
        if let Some(noise) = &job.noise {
            noise.apply(&mut depth, render.width, render.height, &mut rng);
        }
        depth_pixels += depth.iter().filter(|&&z| z > 0.0).count();
        let name = format!("depth/{i:06}.png");
        write_depth_png(dir.join(&name), &depth, cam.width, cam.height, DEPTH_SCALE_MM)?;
        let mut rec = FrameRecord {
            depth: name,
            mask: None,
            pose: Some(p.flat_pose()),
            shape: p.betas.clone(),
            translation: Some(p.trans.to_array()),
            camera_to_world: None,
        };
        rec.set_camera_to_world(c2w);
        manifest.frames.push(rec);
        gt_frames.push(GtFrame { posed, canonical, visible });
    }
    manifest.save(dir)?;
    let vertices = template.vertices.len();
    if job.write_ground_truth {
        let gt = GroundTruth {
            header: GtHeader {
                format: GT_FORMAT.into(),
                version: 1,
                outfit: job.outfit.name().into(),
                subject_seed: job.subject_seed,
                betas,
                clip: job.clip.name.clone(),
                num_frames: gt_frames.len(),
                num_vertices: vertices,
            },
            faces: template.faces.clone(),
            vertex_joint: template.vertex_joint.clone(),
            weights: template.weights.clone(),
            rest: template.vertices.clone(),
            frames: gt_frames,
        };
        gt.save(dir)?;
    }
    Ok(SynthReport { frames: params.len(), vertices, depth_pixels })
}
