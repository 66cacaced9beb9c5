//! A studio's own data (`avatar_core::own_data`: subjects, outfits, capture folders and
//! clothed scans with their fittings) made into meta-training data: every capture frame and
//! every scan becomes one sample of its subject-outfit group, its oriented points canonicalized
//! by inverse skinning as a fit's are. A capture's frames are its depth points (chosen over the
//! take as `fit` chooses them, canonicalized with the 2 cm filter); a scan's are points sampled
//! on the whole mesh with its face normals, canonicalized with the scan's fitting. Each sample
//! keeps `points_per_pose` of them, drawn with a seeded generator, in the group's normalised
//! cube (the group's shape: its first item's fitting). An item that fails here (no usable
//! frame, a scan whose points do not canonicalize) is skipped by name like a refused one.

use crate::data::capture_points::{CapturePoints, FrameCount};
use crate::data::meta_data::{
    DATA_FORMAT, DATA_VERSION, Group, Manifest, MetaData, MetaDataConfig,
};
use crate::error::Result;
use avatar_core::body::{BodyModel, BodyParams};
use avatar_core::canonical::{Canonicalizer, FieldCache, FieldOptions, Normalisation};
use avatar_core::capture::open::load_body_model;
use avatar_core::eval::sampling::sample_surface_with_normals;
use avatar_core::own_data::check::load_scan_item;
use avatar_core::own_data::{Discovery, Item, ItemKind, Refused};
use glam::Vec3;
use rand::seq::index::sample as sample_indices;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;

#[derive(Debug, Clone, PartialEq)]
pub struct OwnDataOptions {
    /// Canonical points kept per sample (the synthetic data's 2,000 by default).
    pub points_per_pose: usize,
    /// The most frames taken from one capture (chosen over the take).
    pub frames_per_capture: usize,
    pub seed: u64,
    /// Where the items' skinning fields are cached.
    pub field_cache: FieldCache,
}

impl Default for OwnDataOptions {
    fn default() -> Self {
        OwnDataOptions {
            points_per_pose: 2000,
            frames_per_capture: 12,
            seed: 0,
            field_cache: FieldCache::none(),
        }
    }
}

/// Prepared own data: the samples, and the items left out (refused by discovery or failed here).
pub struct OwnData {
    pub data: MetaData,
    pub items_used: usize,
    pub skipped: Vec<Refused>,
}

/// One item's samples: its fittings' body and shape, and per frame the pose and the canonical
/// oriented points in metres.
struct ItemSamples {
    body: Arc<BodyModel>,
    betas: Vec<f32>,
    frames: Vec<(BodyParams, Vec<Vec3>, Vec<Vec3>)>,
}

/// A sample keeps at least this share of `points_per_pose` canonical points (drawn with
/// replacement up to the count), or it is left out.
const MIN_POINT_SHARE: f32 = 0.25;

/// Canonicalize every accepted item of `found` into meta-training data. Errors only when no
/// item gives a sample; failed items are added to `skipped` (with discovery's refusals).
pub fn prepare(
    found: &Discovery,
    options: &OwnDataOptions,
    log: &mut dyn FnMut(&str),
) -> Result<OwnData> {
    crate::config::Check::check(options)?;
    let mut skipped = found.refused.clone();
    let mut groups = Vec::new();
    let (mut poses, mut points, mut normals) = (Vec::new(), Vec::new(), Vec::new());
    let mut subjects: Vec<&str> = Vec::new();
    let mut outfits: Vec<String> = Vec::new();
    let mut items_used = 0;
    for (g, group) in found.groups.iter().enumerate() {
        let mut shape: Option<(Normalisation, Vec<[f32; 3]>, Vec<f32>)> = None;
        let first_sample = poses.len();
        log(&format!(
            "canonicalizing {} / {} ({} items)",
            group.subject,
            group.outfit,
            group.items.len()
        ));
        for (k, item) in group.items.iter().enumerate() {
            let samples = match item_samples(item, options) {
                Ok(s) => s,
                Err(e) => {
                    skipped.push(Refused::of(&item.path, &e));
                    continue;
                }
            };
            let (norm, _, _) = shape.get_or_insert_with(|| {
                let rest = samples.body.shaped_vertices(&samples.betas);
                let joints = samples.body.regress_joints(&rest);
                (
                    Normalisation::from_body(&rest),
                    joints.iter().map(|j| j.to_array()).collect(),
                    samples.betas.clone(),
                )
            });
            let mut rng = ChaCha8Rng::seed_from_u64(
                options.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ ((g as u64) << 32) ^ k as u64,
            );
            let before = poses.len();
            let mut thin = 0;
            for (mut params, p, n) in samples.frames {
                let Some((p, n)) = resample(&p, &n, options.points_per_pose, &mut rng) else {
                    thin += 1;
                    continue;
                };
                points.push(p.into_iter().map(|q| norm.to_unit(q)).collect());
                normals.push(n);
                params.betas.clear();
                params.trans = Vec3::ZERO;
                poses.push(params);
            }
            if poses.len() == before {
                skipped.push(Refused {
                    path: item.path.clone(),
                    reason: format!(
                        "no frame kept {:.0} % of {} canonical points ({thin} frames too thin): does the fitting describe the item?",
                        MIN_POINT_SHARE * 100.0,
                        options.points_per_pose
                    ),
                });
                continue;
            }
            items_used += 1;
        }
        let Some((normalisation, rest_joints, betas)) = shape else { continue };
        if poses.len() == first_sample {
            continue;
        }
        if !subjects.contains(&group.subject.as_str()) {
            subjects.push(&group.subject);
        }
        if !outfits.contains(&group.outfit) {
            outfits.push(group.outfit.clone());
        }
        let subject = subjects.iter().position(|s| *s == group.subject).unwrap_or(0) as u64;
        groups.push(Group {
            subject,
            outfit: group.outfit.clone(),
            betas,
            normalisation,
            rest_joints,
            first_sample,
            samples: poses.len() - first_sample,
            name: Some(group.subject.clone()),
        });
    }
    if groups.is_empty() {
        return Err(avatar_core::Error::file(
            &found.root,
            format!("no usable item: {} refused or skipped", skipped.len()),
        )
        .into());
    }
    let config = MetaDataConfig {
        subjects: subjects.len(),
        outfits,
        poses_per_group: groups.iter().map(|g| g.samples).max().unwrap_or(0),
        points_per_pose: options.points_per_pose,
        seed: options.seed,
    };
    let manifest = Manifest {
        format: DATA_FORMAT.into(),
        version: DATA_VERSION,
        config,
        groups,
        source: Some(format!(
            "own data in {} ({items_used} items, {} skipped), fingerprint {}",
            found.root.display(),
            skipped.len(),
            fingerprint(found, options)
        )),
    };
    Ok(OwnData { data: MetaData { manifest, poses, points, normals }, items_used, skipped })
}

/// What the samples are made from: every item's files (path, size, modification time), the
/// refused ones too, and the options, as a SHA-256. Prepared samples saved with it are reused
/// while it is unchanged (a resumed run skips the canonicalization).
pub fn fingerprint(found: &Discovery, options: &OwnDataOptions) -> String {
    let mut text = format!(
        "{} {} {} {}\n",
        crate::data::meta_data::DATA_VERSION,
        options.points_per_pose,
        options.frames_per_capture,
        options.seed
    );
    let mut stamp = |p: &std::path::Path| {
        let m = std::fs::metadata(p).ok();
        let time = m
            .as_ref()
            .and_then(|m| m.modified().ok())
            .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok().map(|d| d.as_nanos()));
        text += &format!("{}\t{:?}\t{time:?}\n", p.display(), m.map(|m| m.len()));
    };
    for item in found.groups.iter().flat_map(|g| &g.items) {
        match &item.kind {
            ItemKind::Capture { .. } => stamp(&item.path.join(avatar_core::capture::MANIFEST_FILE)),
            ItemKind::Scan { fitting, .. } => {
                stamp(&item.path);
                stamp(fitting);
            }
        }
        if let Some(b) = &item.body_file {
            stamp(b);
        }
    }
    for r in &found.refused {
        stamp(&r.path);
    }
    crate::model::model_file::sha256_hex(text.as_bytes())
}

/// `n` of the points (without replacement when there are enough, else with), or `None` when
/// fewer than [`MIN_POINT_SHARE`] of `n` are there.
fn resample(
    points: &[Vec3],
    normals: &[Vec3],
    n: usize,
    rng: &mut ChaCha8Rng,
) -> Option<(Vec<Vec3>, Vec<Vec3>)> {
    let have = points.len();
    if have == 0 || (have as f32) < MIN_POINT_SHARE * n as f32 {
        return None;
    }
    let picks: Vec<usize> = if have >= n {
        let mut v = sample_indices(rng, have, n).into_vec();
        v.sort_unstable();
        v
    } else {
        (0..n).map(|k| if k < have { k } else { rng.random_range(0..have) }).collect()
    };
    Some((picks.iter().map(|&i| points[i]).collect(), picks.iter().map(|&i| normals[i]).collect()))
}

fn item_samples(item: &Item, options: &OwnDataOptions) -> Result<ItemSamples> {
    match &item.kind {
        ItemKind::Capture { .. } => {
            let count = FrameCount { at_least: 1, at_most: options.frames_per_capture };
            let capture = CapturePoints::open_with(&item.path, count, None, &options.field_cache)?;
            let norm = capture.normalisation;
            let frames = capture
                .frames
                .iter()
                .map(|f| {
                    let metres = f.points.iter().map(|p| norm.from_unit(*p)).collect();
                    (f.params.clone(), metres, f.normals.clone())
                })
                .collect();
            Ok(ItemSamples { body: Arc::new(capture.body), betas: capture.betas, frames })
        }
        ItemKind::Scan { fitting, .. } => {
            let body = load_body_model(item.body_file.as_deref(), "named in subject.json")?;
            let (mesh, params) =
                load_scan_item(&item.path, fitting, &body, item.body_file.is_some())?;
            let canon = Canonicalizer::new(
                &body,
                &params.betas,
                &FieldOptions::default(),
                options.field_cache.dir(),
            )?;
            // A quarter more than kept: the 2 cm filter drops points where the scan leaves the
            // skinning's reach (hair, a loose hem).
            let mut rng = ChaCha8Rng::seed_from_u64(options.seed ^ 0x5ca7);
            let n = options.points_per_pose + options.points_per_pose / 4;
            let (p, nrm) = sample_surface_with_normals(&mesh, n, &mut rng)?;
            let c = canon.posed_points(&params, &p, &nrm);
            let betas = params.betas.clone();
            drop(canon);
            Ok(ItemSamples { body, betas, frames: vec![(params, c.points, c.normals)] })
        }
    }
}
