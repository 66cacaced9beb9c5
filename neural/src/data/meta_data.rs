//! Meta-training data: synthetic subjects and outfits of the training split (never the
//! evaluation subjects, the unseen outfit or the held-out clips), each posed along the training
//! clips, with the exact pose-dependent canonical clothed surface of the generator sampled into
//! oriented points (MetaAvatar's stages 1 and 2 also train on ground-truth canonical points).
//! Simulated outfits (`eval::dataset::SIMULATED_TRAIN_OUTFITS`, only when asked for) have no
//! canonical surface of their own: their garment is simulated through training clips and each
//! chosen frame's clothed surface is canonicalized by inverse skinning, as a scan's is.
//!
//! On disk (`--data DIR`): `meta-data.json` (what was generated, from which seed) and
//! `samples.bin` (float32: per sample 72 pose values, then points x (position, normal)).

use crate::data::pose_sample::PoseSample;
use crate::error::{Error, Result};
use crate::model::encoder::PoseEncoding;
use avatar_core::body::{BodyModel, BodyParams};
use avatar_core::canonical::Normalisation;
use avatar_core::eval::dataset::{SIMULATED_TRAIN_OUTFITS, TRAIN_OUTFITS, TRAIN_SUBJECT_SEEDS};
use avatar_core::eval::sampling::sample_surface_with_normals;
use avatar_core::mesh::TriMesh;
use avatar_core::motion::{MotionClip, library_split};
use avatar_core::synth::{ClothedTemplate, Outfit, PoseFeatures, canonical_surface, subject_betas};
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;

pub const DATA_FORMAT: &str = "avatar-studio-meta-data";
pub const DATA_VERSION: u32 = 1;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MetaDataConfig {
    /// The first N training subject seeds.
    pub subjects: usize,
    pub outfits: Vec<String>,
    pub poses_per_group: usize,
    pub points_per_pose: usize,
    pub seed: u64,
}

impl Default for MetaDataConfig {
    fn default() -> Self {
        MetaDataConfig {
            subjects: 24,
            outfits: TRAIN_OUTFITS.iter().map(|o| o.name().to_string()).collect(),
            poses_per_group: 12,
            points_per_pose: 2000,
            seed: 0,
        }
    }
}

/// One subject in one outfit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Group {
    pub subject: u64,
    pub outfit: String,
    pub betas: Vec<f32>,
    pub normalisation: Normalisation,
    /// Rest joints in metres.
    pub rest_joints: Vec<[f32; 3]>,
    pub first_sample: usize,
    pub samples: usize,
    /// Own data (`own_data`): the subject's folder name (`subject` is then its index).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    pub format: String,
    pub version: u32,
    pub config: MetaDataConfig,
    pub groups: Vec<Group>,
    /// Own data (`own_data`): where it came from; absent for the synthetic generator's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
}

/// Largest data set read: samples x floats per sample (4 GB of float32 would not fit in memory).
const MAX_DATA_FLOATS: usize = 1 << 28;

impl Manifest {
    /// Groups contiguous from sample 0, each with 24 finite rest joints, a plausible shape and
    /// normalisation; returns (samples, floats per sample), bounded.
    fn validate(&self) -> Result<(usize, usize)> {
        let points = self.config.points_per_pose;
        if points == 0 || points > 1_000_000 {
            return Err(Error::invalid(format!(
                "points_per_pose {points} is out of range (1 to 1000000)"
            )));
        }
        if self.groups.is_empty() {
            return Err(Error::invalid("no groups: the data set is empty"));
        }
        let mut next = 0usize;
        for (k, g) in self.groups.iter().enumerate() {
            let bad = |m: String| {
                Err(Error::invalid(format!("group {k} (subject {}, {}): {m}", g.subject, g.outfit)))
            };
            if g.first_sample != next || g.samples == 0 {
                return bad(format!(
                    "samples {}..+{} do not follow the previous group's (next sample {next})",
                    g.first_sample, g.samples
                ));
            }
            next = match next.checked_add(g.samples) {
                Some(n) => n,
                None => return bad("sample count overflows".into()),
            };
            if g.rest_joints.len() != avatar_core::body::NUM_JOINTS
                || g.rest_joints.iter().flatten().any(|v| !(v.is_finite() && v.abs() <= 10.0))
            {
                return bad(format!(
                    "rest_joints must be 24 finite points within 10 m ({} given)",
                    g.rest_joints.len()
                ));
            }
            if let Err(e) =
                g.normalisation.validate().and_then(|_| avatar_core::body::check_betas(&g.betas))
            {
                return bad(e.to_string());
            }
        }
        let per = 72 + 6 * points;
        if next.checked_mul(per).is_none_or(|n| n > MAX_DATA_FLOATS) {
            return Err(Error::invalid(format!(
                "{next} samples of {per} floats is more than this build reads"
            )));
        }
        Ok((next, per))
    }
}

pub struct MetaData {
    pub manifest: Manifest,
    /// Per sample: the pose and its canonical points and normals (normalised space).
    pub poses: Vec<BodyParams>,
    pub points: Vec<Vec<Vec3>>,
    pub normals: Vec<Vec<Vec3>>,
}

impl MetaData {
    /// Generate the data set (deterministic for a config).
    pub fn generate(body: &BodyModel, config: &MetaDataConfig) -> Result<MetaData> {
        crate::config::Check::check(config)?;
        let outfits: Vec<Outfit> = config
            .outfits
            .iter()
            .map(|n| Outfit::from_name(n))
            .collect::<avatar_core::Result<_>>()?;
        if let Some(o) = outfits
            .iter()
            .find(|o| !TRAIN_OUTFITS.contains(o) && !SIMULATED_TRAIN_OUTFITS.contains(o))
        {
            return Err(Error::invalid(format!(
                "outfit {} is reserved for evaluation; meta-training uses {:?} and the simulated {:?}",
                o.name(),
                TRAIN_OUTFITS.map(|o| o.name()),
                SIMULATED_TRAIN_OUTFITS.map(|o| o.name())
            )));
        }
        let subjects: Vec<u64> = TRAIN_SUBJECT_SEEDS.take(config.subjects).collect();
        if subjects.is_empty() || config.poses_per_group == 0 || config.points_per_pose == 0 {
            return Err(Error::invalid(
                "meta-training data needs at least one subject, pose and point",
            ));
        }
        let (train_clips, _) = library_split();
        let all_poses: Vec<BodyParams> =
            train_clips.iter().flat_map(|c| c.frames.iter().cloned()).collect();
        let jobs: Vec<(u64, Outfit)> =
            subjects.iter().flat_map(|&s| outfits.iter().map(move |&o| (s, o))).collect();
        // Per group: the group, its poses, and two point sets per pose.
        type GroupData = (Group, Vec<BodyParams>, Vec<Vec<Vec3>>, Vec<Vec<Vec3>>);
        let per_group: Vec<Result<GroupData>> = jobs
            .par_iter()
            .enumerate()
            .map(|(g, &(subject, outfit))| {
                let mut rng = ChaCha8Rng::seed_from_u64(
                    config.seed.wrapping_mul(0x9E37_79B9).wrapping_add(g as u64),
                );
                let betas = subject_betas(body, subject);
                let template = ClothedTemplate::build(body, &betas, outfit);
                let rest = body.shaped_vertices(&betas);
                let norm = Normalisation::from_body(&rest);
                let rest_joints = body.regress_joints(&rest);
                // Each sample in metres (body space), then normalised like the captures.
                let samples: Vec<OrientedSample> = if outfit.is_simulated() {
                    simulated_samples(
                        body,
                        &template,
                        &betas,
                        subject,
                        &train_clips,
                        config,
                        &mut rng,
                    )?
                } else {
                    (0..config.poses_per_group)
                        .map(|_| {
                            let mut params =
                                all_poses[rng.random_range(0..all_poses.len())].clone();
                            params.betas = betas.clone();
                            params.trans = Vec3::ZERO;
                            let bones = body.pose(&params).bones;
                            let surface =
                                canonical_surface(&template, &PoseFeatures::of(&bones), subject);
                            let mesh = TriMesh::new(surface, template.faces.clone());
                            let (p, n) = sample_surface_with_normals(
                                &mesh,
                                config.points_per_pose,
                                &mut rng,
                            )?;
                            Ok((params, p, n))
                        })
                        .collect::<Result<_>>()?
                };
                let (mut poses, mut pts, mut nrm) = (Vec::new(), Vec::new(), Vec::new());
                for (mut params, p, n) in samples {
                    pts.push(p.into_iter().map(|q| norm.to_unit(q)).collect());
                    nrm.push(n);
                    params.betas.clear();
                    params.trans = Vec3::ZERO;
                    poses.push(params);
                }
                let group = Group {
                    subject,
                    outfit: outfit.name().to_string(),
                    betas,
                    normalisation: norm,
                    rest_joints: rest_joints.iter().map(|j| j.to_array()).collect(),
                    first_sample: g * config.poses_per_group,
                    samples: config.poses_per_group,
                    name: None,
                };
                Ok((group, poses, pts, nrm))
            })
            .collect();
        let mut data = MetaData {
            manifest: Manifest {
                format: DATA_FORMAT.into(),
                version: DATA_VERSION,
                config: config.clone(),
                groups: Vec::new(),
                source: None,
            },
            poses: Vec::new(),
            points: Vec::new(),
            normals: Vec::new(),
        };
        for r in per_group {
            let (group, poses, pts, nrm) = r?;
            data.manifest.groups.push(group);
            data.poses.extend(poses);
            data.points.extend(pts);
            data.normals.extend(nrm);
        }
        Ok(data)
    }

    pub fn save(&self, dir: &Path) -> Result<()> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let mut bytes = Vec::new();
        for (i, pose) in self.poses.iter().enumerate() {
            for v in pose.pose.iter().flat_map(|a| a.to_array()) {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
            for (p, n) in self.points[i].iter().zip(&self.normals[i]) {
                for v in p.to_array().into_iter().chain(n.to_array()) {
                    bytes.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
        avatar_core::io::write_bytes_atomic(dir.join("samples.bin"), &bytes)?;
        let manifest =
            serde_json::to_vec_pretty(&self.manifest).map_err(|e| Error::invalid(e.to_string()))?;
        Ok(avatar_core::io::write_bytes_atomic(dir.join("meta-data.json"), &manifest)?)
    }

    pub fn load(dir: &Path) -> Result<MetaData> {
        let mpath = dir.join("meta-data.json");
        if std::fs::metadata(&mpath).map_err(|e| Error::io(&mpath, e))?.len() > 64 << 20 {
            return Err(Error::file(
                &mpath,
                "too large for a meta-training manifest (64 MB at most)",
            ));
        }
        let text = std::fs::read(&mpath).map_err(|e| Error::io(&mpath, e))?;
        let manifest: Manifest = serde_json::from_slice(&text)
            .map_err(|e| Error::file(&mpath, format!("bad manifest: {e}")))?;
        if manifest.format != DATA_FORMAT || manifest.version != DATA_VERSION {
            return Err(Error::file(
                &mpath,
                format!(
                    "meta-training data {:?} version {} is not supported (this build reads {DATA_FORMAT:?} version {DATA_VERSION})",
                    manifest.format, manifest.version
                ),
            ));
        }
        let (count, per) = manifest.validate().map_err(|e| e.in_file(&mpath))?;
        let spath = dir.join("samples.bin");
        // The size first: the manifest says how much to read.
        let size = std::fs::metadata(&spath).map_err(|e| Error::io(&spath, e))?.len();
        if size != (count * per * 4) as u64 {
            return Err(Error::file(
                &spath,
                format!(
                    "{size} bytes, expected {} for the {count} samples {} lists (truncated, or from another run)",
                    count * per * 4,
                    mpath.display()
                ),
            ));
        }
        let bytes = std::fs::read(&spath).map_err(|e| Error::io(&spath, e))?;
        let floats: Vec<f32> = bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect();
        if floats.iter().any(|v| !v.is_finite()) {
            return Err(Error::file(&spath, "samples contain NaN or infinity"));
        }
        let mut data =
            MetaData { manifest, poses: Vec::new(), points: Vec::new(), normals: Vec::new() };
        for chunk in floats.chunks_exact(per) {
            data.poses.push(
                BodyParams::from_flat(&chunk[..72], Vec::new(), Vec3::ZERO)
                    .map_err(|e| Error::file(&spath, e.to_string()))?,
            );
            let (p, n): (Vec<Vec3>, Vec<Vec3>) = chunk[72..]
                .chunks_exact(6)
                .map(|c| (Vec3::new(c[0], c[1], c[2]), Vec3::new(c[3], c[4], c[5])))
                .unzip();
            data.points.push(p);
            data.normals.push(n);
        }
        Ok(data)
    }

    /// Load `dir`, or generate it there first when it holds no data yet.
    pub fn load_or_generate(
        dir: &Path,
        body: &BodyModel,
        config: &MetaDataConfig,
        log: &dyn Fn(&str),
    ) -> Result<MetaData> {
        if dir.join("meta-data.json").exists() {
            let data = MetaData::load(dir)?;
            log(&format!(
                "meta-train: using the data in {} ({} samples)",
                dir.display(),
                data.len()
            ));
            return Ok(data);
        }
        log(&format!(
            "meta-train: generating {} subjects x {} outfits x {} poses into {}",
            config.subjects,
            config.outfits.len(),
            config.poses_per_group,
            dir.display()
        ));
        let data = MetaData::generate(body, config)?;
        data.save(dir)?;
        Ok(data)
    }

    pub fn len(&self) -> usize {
        self.poses.len()
    }

    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }

    /// The hypernetwork sample of sample `i` (pose input for `encoding`).
    pub fn sample(&self, i: usize, encoding: PoseEncoding) -> PoseSample {
        let g = self
            .manifest
            .groups
            .iter()
            .find(|g| (g.first_sample..g.first_sample + g.samples).contains(&i))
            .expect("sample in a group");
        let joints: [Vec3; 24] = std::array::from_fn(|j| Vec3::from_array(g.rest_joints[j]));
        PoseSample {
            pose_input: encoding.input(&self.poses[i], &joints, &g.normalisation),
            points: self.points[i].clone(),
            normals: self.normals[i].clone(),
            free_space: Vec::new(),
        }
    }
}

/// Training clips a simulated outfit's group is simulated through (each from its first frame):
/// a few, so that the garment's lag and swing come from more than one motion.
const SIMULATED_CLIPS_PER_GROUP: usize = 3;

/// One pose and its canonical points and unit normals (metres, body space).
type OrientedSample = (BodyParams, Vec<Vec3>, Vec<Vec3>);

/// A simulated outfit's samples for one subject (shaped by `betas`): `config.poses_per_group` frames drawn from
/// a few training clips, the garment simulated through each clip up to its last drawn frame,
/// each frame's clothed surface sampled into oriented points and canonicalized by inverse
/// skinning with the subject's diffused field (metres, body space), as a scan's points are.
/// Points without a root or beyond the reprojection filter are left out and the rest repeated
/// to the config's count.
fn simulated_samples(
    body: &BodyModel,
    template: &ClothedTemplate,
    betas: &[f32],
    subject: u64,
    train_clips: &[MotionClip],
    config: &MetaDataConfig,
    rng: &mut ChaCha8Rng,
) -> Result<Vec<OrientedSample>> {
    use avatar_core::canonical::{Canonicalizer, FieldOptions};
    use avatar_core::synth::cloth::{ClothConfig, simulate_garment, with_garment};
    let canonicalizer = Canonicalizer::new(body, betas, &FieldOptions::default(), None)?;
    let clips: Vec<&MotionClip> = train_clips.iter().filter(|c| !c.frames.is_empty()).collect();
    if clips.is_empty() {
        return Err(Error::invalid("no training clip to simulate a garment through"));
    }
    // Which clip and frame each sample is: a few distinct clips, frames drawn in each.
    let mut chosen: Vec<usize> = Vec::new();
    while chosen.len() < SIMULATED_CLIPS_PER_GROUP.min(clips.len()) {
        let c = rng.random_range(0..clips.len());
        if !chosen.contains(&c) {
            chosen.push(c);
        }
    }
    let picks: Vec<(usize, usize)> = (0..config.poses_per_group)
        .map(|k| {
            let c = chosen[k % chosen.len()];
            (c, rng.random_range(0..clips[c].frames.len()))
        })
        .collect();
    let mut out = Vec::with_capacity(picks.len());
    for &c in &chosen {
        let Some(last) = picks.iter().filter(|p| p.0 == c).map(|p| p.1).max() else { continue };
        let clip = clips[c];
        let poses: Vec<BodyParams> = clip.frames[..=last]
            .iter()
            .map(|p| avatar_core::eval::truth::query(p, betas))
            .collect();
        let track =
            simulate_garment(body, template, &poses, clip.fps, subject, ClothConfig::default());
        for &(_, frame) in picks.iter().filter(|p| p.0 == c) {
            let garment = track.frames.get(frame).ok_or_else(|| {
                Error::invalid(format!("the simulation of clip {} stopped early", clip.name))
            })?;
            let params = &poses[frame];
            let posed = TriMesh::new(
                with_garment(body, template, params, subject, garment),
                template.faces.clone(),
            );
            let (p, n) = sample_surface_with_normals(&posed, config.points_per_pose * 3 / 2, rng)?;
            let canonical = canonicalizer.posed_points(params, &p, &n);
            if canonical.points.is_empty() {
                return Err(Error::invalid(format!(
                    "subject {subject}, {}: no point of frame {frame} of {} canonicalized",
                    template.outfit.name(),
                    clip.name
                )));
            }
            let take = |v: &[Vec3]| -> Vec<Vec3> {
                v.iter().cycle().take(config.points_per_pose).copied().collect()
            };
            out.push((params.clone(), take(&canonical.points), take(&canonical.normals)));
        }
    }
    Ok(out)
}
