//! The true clothed surface of one subject in one outfit at a frame of a clip. For most
//! outfits it is a function of the pose alone; a simulated garment's surface depends on the
//! motion before the frame, so its clips are simulated once, from their first frame, and
//! looked up by (clip, frame).

use crate::body::{BodyModel, BodyParams};
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::motion::MotionClip;
use crate::synth::cloth::{ClothConfig, GarmentTrack, simulate_garment, with_garment};
use crate::synth::{ClothedTemplate, PoseFeatures, canonical_surface, pose_surface};
use rayon::prelude::*;
use std::collections::HashMap;

/// An evaluation pose of a subject: its shape, the root over the origin (x and z).
pub fn query(p: &BodyParams, betas: &[f32]) -> BodyParams {
    let mut q = p.clone();
    q.betas = betas.to_vec();
    q.trans.x = 0.0;
    q.trans.z = 0.0;
    q
}

/// The ground-truth clothed mesh of one pose, for outfits whose surface depends on the pose
/// alone (a simulated garment takes its rest-shape fallback here: use `OutfitTruth`).
pub fn ground_truth_mesh(
    body: &BodyModel,
    template: &ClothedTemplate,
    params: &BodyParams,
    subject: u64,
) -> TriMesh {
    let bones = body.pose(params).bones;
    let canonical = canonical_surface(template, &PoseFeatures::of(&bones), subject);
    TriMesh::new(pose_surface(template, &canonical, &bones), template.faces.clone())
}

/// The truth of one subject in one outfit, with its simulated garment's tracks.
pub struct OutfitTruth<'a> {
    body: &'a BodyModel,
    template: &'a ClothedTemplate,
    subject: u64,
    /// Per clip name: the garment through the clip (simulated outfits only).
    tracks: HashMap<String, GarmentTrack>,
}

impl<'a> OutfitTruth<'a> {
    /// Simulates the garment through each of `clips` when the outfit is simulated (each clip
    /// from its first frame, posed as `query` poses it).
    pub fn new(
        body: &'a BodyModel,
        template: &'a ClothedTemplate,
        subject: u64,
        betas: &[f32],
        clips: &[&MotionClip],
    ) -> OutfitTruth<'a> {
        let tracks = if template.outfit.is_simulated() {
            clips
                .par_iter()
                .map(|c| {
                    let poses: Vec<BodyParams> = c.frames.iter().map(|p| query(p, betas)).collect();
                    let track = simulate_garment(
                        body,
                        template,
                        &poses,
                        c.fps,
                        subject,
                        ClothConfig::default(),
                    );
                    (c.name.clone(), track)
                })
                .collect()
        } else {
            HashMap::new()
        };
        OutfitTruth { body, template, subject, tracks }
    }

    /// The simulated garment at a frame of a clip (`None` for outfits that are not simulated).
    pub fn garment(&self, clip: &str, frame: usize) -> Result<Option<&[glam::Vec3]>> {
        if !self.template.outfit.is_simulated() {
            return Ok(None);
        }
        self.tracks
            .get(clip)
            .and_then(|t| t.frames.get(frame))
            .map(|g| Some(g.as_slice()))
            .ok_or_else(|| {
                Error::invalid(format!(
                    "no simulated {} for frame {frame} of clip {clip:?}",
                    self.template.outfit.name()
                ))
            })
    }

    /// The true mesh at frame `frame` of `clip`, posed at `params` (that frame's query pose).
    pub fn mesh(&self, clip: &str, frame: usize, params: &BodyParams) -> Result<TriMesh> {
        Ok(match self.garment(clip, frame)? {
            Some(g) => TriMesh::new(
                with_garment(self.body, self.template, params, self.subject, g),
                self.template.faces.clone(),
            ),
            None => ground_truth_mesh(self.body, self.template, params, self.subject),
        })
    }
}
