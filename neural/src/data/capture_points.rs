//! A capture made ready for fitting: its frames canonicalized by inverse skinning (diffused
//! skinning field, Broyden root finding, the 2 cm reprojection filter), normalised to the
//! canonical [-1, 1]^3 cube, with each frame's pose kept for the hypernetwork; and PINA's
//! off-surface sign prior from the canonical body's SDF.

use crate::data::pose_sample::PoseSample;
use crate::error::{Error, Result};
use crate::model::encoder::PoseEncoding;
use avatar_core::body::{BodyModel, BodyParams, NUM_JOINTS};
use avatar_core::canonical::{
    Canonicalizer, FieldCache, FieldOptions, Normalisation, ShellOptions, SkinningField,
    shell_samples,
};
use avatar_core::capture::{
    CaptureFrame, CaptureOptions, CaptureSource, FrameChoice, FreeSpaceOptions, free_space_samples,
};
use avatar_core::mesh::TriMesh;
use avatar_core::mesh::sdf_grid::{SdfGrid, SdfGridOptions};
use avatar_core::mesh::signed_distance::SignedDistance;
use glam::Vec3;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// One frame's canonical points (normalised space) with normals, and its body pose.
pub struct FramePoints {
    /// The frame's index in the capture's manifest.
    pub index: usize,
    pub params: BodyParams,
    pub points: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    /// Whether root finding found each point more than one root (`CanonicalFrame::ambiguous`;
    /// empty: not known, every point counts as ambiguous). Pose refinement's rounds solve the
    /// others from their root for the given pose.
    pub ambiguous: Vec<bool>,
    /// Free-space evidence (normalised canonical space): points on the camera rays in front
    /// of the measured depth, which must be outside the avatar.
    pub free_space: Vec<Vec3>,
    /// Outside constraints a little behind loose clothing (normalised canonical space,
    /// [`shell_samples_of`]); redrawn when pose refinement moves the points.
    pub shells: Vec<Vec3>,
}

pub struct CapturePoints {
    /// The fittings' body model: the open body or the user's SMPL model.
    pub body: BodyModel,
    /// The SMPL file `body` came from (`None`: the open body).
    pub body_file: Option<PathBuf>,
    pub betas: Vec<f32>,
    /// The shaped body in the rest pose (canonical space, metres).
    pub rest: Vec<Vec3>,
    /// Its signed distance, built once: the sign prior, the shell samples and the avatars'
    /// garment skinning share it.
    pub rest_sdf: Arc<SignedDistance>,
    /// The same on a grid ([`rest_sign_grid`]), for the sign prior's many queries (`None` for
    /// a body without faces: the prior then knows nothing).
    pub rest_sign: Option<Arc<SdfGrid>>,
    pub field: SkinningField,
    pub field_cells: usize,
    pub normalisation: Normalisation,
    pub frames: Vec<FramePoints>,
    /// Frames in the capture (its manifest), of which `frames` were chosen.
    pub capture_frames: usize,
    /// Points dropped by the 2 cm filter or with no converged root.
    pub dropped: usize,
    pub warnings: Vec<String>,
}

impl FramePoints {
    /// Every outside constraint of the frame: free space, then the shells.
    pub fn outside(&self) -> Vec<Vec3> {
        [self.free_space.as_slice(), &self.shells].concat()
    }
}

/// Every frame's shell samples (metres, canonical space): behind its canonical `points`
/// (metres) with their `normals`, clear of the rest body (`body`: its signed distance) and of
/// all frames' points.
/// Seeded per frame.
pub fn shell_samples_of(
    body: &SignedDistance,
    points: &[Vec<Vec3>],
    normals: &[&[Vec3]],
    options: &ShellOptions,
) -> Vec<Vec<Vec3>> {
    let Ok(observed) = avatar_core::mesh::point_index::PointIndex::new(&points.concat()) else {
        return vec![Vec::new(); points.len()];
    };
    points
        .iter()
        .zip(normals)
        .enumerate()
        .map(|(k, (p, n))| {
            shell_samples(
                p,
                n,
                body,
                &observed,
                &ShellOptions { seed: options.seed ^ k as u64, ..*options },
            )
        })
        .collect()
}

/// The sign prior's thresholds (metres): beyond this outside the rest body the SDF must be
/// positive...
const PRIOR_OUTSIDE: f32 = 0.35;
/// ...and this deep inside it negative.
const PRIOR_INSIDE: f32 = 0.03;

/// The rest body's signed distance on grids for the sign prior: every 2 cm within 10 cm of the
/// surface, every 5 cm out to 45 cm. A training step asks the prior of 8,000 off-surface
/// points, and a closest-point query each cost 3.5 s of the demo's 57 s fit. Only which side
/// of the prior's two thresholds a point lies on is read, and the grids move a threshold's
/// surface by under a centimetre (0.1 % of the points of the body's box change side:
/// `avatar_core::mesh::sdf_grid`'s tests). Built per fit, in about 0.2 s.
pub fn rest_sign_grid(rest_body: &TriMesh) -> Option<Arc<SdfGrid>> {
    let options = SdfGridOptions { fine_cell: 0.02, band: 0.1, coarse_cell: 0.05, reach: 0.45 };
    SdfGrid::new(rest_body, &options).map(Arc::new)
}

/// Frames with fewer canonical points are skipped (with a warning).
const MIN_FRAME_POINTS: usize = 50;

/// How many of a capture's usable frames a fit takes: the first `at_most`, refused when fewer
/// than `at_least` are usable (or than the capture has, when it has fewer).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameCount {
    pub at_least: usize,
    pub at_most: usize,
}

impl FrameCount {
    /// `fit`'s default: up to 32 usable frames, refused under 8. Pose refinement cannot see the
    /// error the frames' fittings share (it is also a change of the avatar's shape), and that
    /// error averages down as 1 / sqrt(frames): fittings off by 5 deg / 2 cm cost the tight
    /// outfit +22 % Chamfer-L2 against exact fittings with 8 frames, -2.7 % with 32, the dress
    /// +27 % and +12.8 %; the fit takes a quarter (tight) to a half (dress) longer
    /// (docs/results.md).
    pub const DEFAULT: FrameCount = FrameCount::up_to(32);

    /// Up to `n` usable frames, refused under 8 (under `n` when it is smaller): the studio's
    /// fit panel, whose number is the most it takes.
    pub const fn up_to(n: usize) -> FrameCount {
        FrameCount { at_least: if n < 8 { n } else { 8 }, at_most: n }
    }

    /// Exactly `n` usable frames (`fit --frames N`).
    pub fn exactly(n: usize) -> FrameCount {
        FrameCount { at_least: n, at_most: n }
    }
}

impl CapturePoints {
    /// Canonicalize `frames` usable frames of the capture in `dir` (all of them when it has
    /// no more; else chosen over the whole capture: [`CapturePoints::open_with`]), the
    /// skinning field taken from `field_cache` when it is there.
    pub fn open(dir: &Path, frames: usize, field_cache: &FieldCache) -> Result<CapturePoints> {
        Self::open_with(dir, FrameCount::exactly(frames), None, field_cache)
    }

    /// Like [`CapturePoints::open`], for a range of frame counts, with `body_model` (an SMPL
    /// npz) replacing the body model the capture names (`fit --body-model`). The frames are
    /// chosen over the whole capture ([`FrameChoice`]: spread over the poses, the views of the
    /// body and the time; every frame when the capture has no more than asked) and only the
    /// chosen ones are read; a frame that cannot be used is replaced by the next of the choice.
    pub fn open_with(
        dir: &Path,
        count: FrameCount,
        body_model: Option<&Path>,
        field_cache: &FieldCache,
    ) -> Result<CapturePoints> {
        let (frames, at_least) =
            (count.at_most.max(1), count.at_least.clamp(1, count.at_most.max(1)));
        let options = CaptureOptions {
            body_model: body_model.map(Path::to_path_buf),
            ..CaptureOptions::default()
        };
        let source = CaptureSource::open(dir, &options)?;
        let mut choice = FrameChoice::new(&source.manifest);
        let mut capture = source.into_capture(Vec::new(), Vec::new());
        capture.read_chosen(&mut choice, frames, &options)?;
        if capture.frames.is_empty() {
            return Err(capture.no_usable_frame().into());
        }
        // Too few usable frames is refused here already, before the skinning field is built.
        let opened: Vec<usize> = capture.frames.iter().map(|f| f.index).collect();
        avatar_core::capture::plausibility::require_usable_frames(
            &capture,
            at_least,
            &opened,
            &[],
        )?;
        // The shape of the earliest frame read (every frame's, for a capture with one subject).
        let first = capture.frames.iter().min_by_key(|f| f.index).expect("a usable frame");
        let betas = first.params.betas.clone();
        let field_options = FieldOptions::default();
        let body = capture.body.clone();
        let canon = Canonicalizer::new(&body, &betas, &field_options, field_cache.dir())?;
        let cache_warning = canon.cache_warning.clone();
        let norm = canon.normalisation;
        let mut out = Vec::new();
        let mut dropped = 0;
        // A frame skipped here is replaced by the next one of the choice.
        let (mut used, mut skipped, mut skip_warnings) = (Vec::new(), Vec::new(), Vec::new());
        // A frame's canonical points and free-space samples (none for a frame to be skipped).
        let canonicalize = |f: &CaptureFrame| {
            let c = canon.frame(f);
            if c.points.len() < MIN_FRAME_POINTS {
                return (c, Vec::new());
            }
            let free = free_space_samples(
                &f.points,
                f.camera_center(),
                &FreeSpaceOptions {
                    seed: FreeSpaceOptions::default().seed ^ f.index as u64,
                    ..FreeSpaceOptions::default()
                },
            );
            let free_space = canon.free_space(f, &free).iter().map(|p| norm.to_unit(*p)).collect();
            (c, free_space)
        };
        let mut next = 0;
        loop {
            if out.len() >= frames {
                break;
            }
            if next == capture.frames.len() {
                let want = next + frames - out.len();
                capture.read_chosen(&mut choice, want, &options)?;
                if next == capture.frames.len() {
                    break;
                }
            }
            // The frames still wanted, each canonicalized on its own (side by side), then
            // taken in order: each adds at most one, so all of them are taken or skipped.
            let batch = &capture.frames[next..capture.frames.len().min(next + frames - out.len())];
            next += batch.len();
            let done: Vec<_> = batch.par_iter().map(canonicalize).collect();
            for (f, (c, free_space)) in batch.iter().zip(done) {
                dropped += c.dropped + c.unsolved;
                if c.points.len() < MIN_FRAME_POINTS {
                    skip_warnings.push(format!(
                        "{}: frame {}: only {} canonical points survived; skipped",
                        dir.display(),
                        f.index,
                        c.points.len()
                    ));
                    skipped.push((
                        f.index,
                        format!("only {} canonical points survived", c.points.len()),
                    ));
                    continue;
                }
                used.push(f.index);
                out.push(FramePoints {
                    index: f.index,
                    params: f.params.clone(),
                    points: c.points.iter().map(|p| norm.to_unit(*p)).collect(),
                    normals: c.normals,
                    ambiguous: c.ambiguous,
                    free_space,
                    shells: Vec::new(),
                });
            }
        }
        // In the take's order (with every frame chosen, the capture's own order).
        out.sort_by_key(|f| f.index);
        used.sort_unstable();
        let mut warnings: Vec<String> = capture.warnings.iter().map(|w| w.to_string()).collect();
        // Most frames without depth near the body: the one-line reason (units, camera, axes).
        warnings.extend(capture.diagnose());
        warnings.extend(cache_warning);
        warnings.extend(skip_warnings);
        // Fewer usable frames than asked (and than the capture has) is an error naming them.
        avatar_core::capture::plausibility::require_usable_frames(
            &capture, at_least, &used, &skipped,
        )?;
        let total: usize = out.iter().map(|f| f.points.len()).sum();
        if total < 100 {
            return Err(Error::invalid(format!(
                "{}: only {total} canonical points survived; cannot fit an avatar",
                dir.display()
            )));
        }
        let rest_mesh = capture.body.mesh(canon.rest.clone());
        let mut capture = CapturePoints {
            body: capture.body.as_ref().clone(),
            body_file: capture.body_file.clone(),
            betas,
            rest_sdf: Arc::new(SignedDistance::new(&rest_mesh)),
            rest_sign: rest_sign_grid(&rest_mesh),
            rest: canon.rest.clone(),
            field: canon.field,
            field_cells: field_options.cells_along_height,
            normalisation: norm,
            frames: out,
            capture_frames: capture.manifest.frames.len(),
            dropped,
            warnings,
        };
        capture.add_shell_samples(&ShellOptions::default());
        capture.drop_free_space_inside_body();
        Ok(capture)
    }

    /// Which frames the fit takes, in one line: "32 of the capture's 3000 frames, chosen over
    /// the whole take: 0, 94, ...".
    pub fn choice_summary(&self) -> String {
        let list: Vec<String> = self.frames.iter().map(|f| f.index.to_string()).collect();
        let how = if self.frames.len() < self.capture_frames {
            "chosen over the whole take"
        } else {
            "every frame"
        };
        format!(
            "frames: {} of the capture's {} ({how}): {}",
            self.frames.len(),
            self.capture_frames,
            list.join(", ")
        )
    }

    /// Free-space samples whose canonical position the sign prior calls inside the body are
    /// wrong roots of the inverse skinning (near joints the map folds): they are dropped.
    fn drop_free_space_inside_body(&mut self) {
        let signs: Vec<Vec<f32>> = {
            let prior = self.sign_prior();
            self.frames.iter().map(|f| prior(&f.free_space)).collect()
        };
        for (frame, signs) in self.frames.iter_mut().zip(signs) {
            let kept = frame
                .free_space
                .iter()
                .zip(&signs)
                .filter(|(_, s)| **s >= 0.0)
                .map(|(p, _)| *p)
                .collect();
            frame.free_space = kept;
        }
    }

    /// Outside constraints a little behind loose clothing (`canonical::shell`): without them
    /// a skirt is fitted as a solid bell whose inner wall lies centimetres inside the cloth.
    fn add_shell_samples(&mut self, options: &ShellOptions) {
        let norm = self.normalisation;
        let metric: Vec<Vec<Vec3>> = self
            .frames
            .iter()
            .map(|f| f.points.iter().map(|p| norm.from_unit(*p)).collect())
            .collect();
        let normals: Vec<&[Vec3]> = self.frames.iter().map(|f| f.normals.as_slice()).collect();
        let shells = shell_samples_of(&self.rest_sdf, &metric, &normals, options);
        for (frame, samples) in self.frames.iter_mut().zip(shells) {
            frame.shells = samples.iter().map(|p| norm.to_unit(*p)).collect();
        }
    }

    /// The subject's rest joints (metres).
    pub fn rest_joints(&self) -> [Vec3; NUM_JOINTS] {
        self.body.regress_joints(&self.rest)
    }

    /// Every frame as one hypernetwork sample (its pose input for `encoding`).
    pub fn pose_samples(&self, encoding: PoseEncoding) -> Vec<PoseSample> {
        let joints = self.rest_joints();
        self.frames
            .iter()
            .map(|f| PoseSample {
                pose_input: encoding.input(&f.params, &joints, &self.normalisation),
                points: f.points.clone(),
                normals: f.normals.clone(),
                free_space: f.outside(),
            })
            .collect()
    }

    pub fn num_points(&self) -> usize {
        self.frames.iter().map(|f| f.points.len()).sum()
    }

    /// PINA's off-surface prior for normalised points: far outside the canonical body (beyond
    /// 35 cm, so beyond any clothing) the SDF must be positive, 3 cm inside the body negative,
    /// elsewhere unknown (0). It removes the spurious surfaces a SIREN grows where no depth
    /// point constrains it, on the sides the camera never saw.
    /// Read from the rest body's distance grid ([`rest_sign_grid`]).
    pub fn sign_prior(&self) -> impl Fn(&[Vec3]) -> Vec<f32> + Sync + '_ {
        let body = self.rest_sign.clone();
        let norm = self.normalisation;
        move |unit: &[Vec3]| {
            let Some(body) = &body else { return vec![0.0; unit.len()] };
            unit.iter()
                .map(|q| match body.at(norm.from_unit(*q)) {
                    d if d > PRIOR_OUTSIDE => 1.0,
                    d if d < -PRIOR_INSIDE => -1.0,
                    _ => 0.0,
                })
                .collect()
        }
    }
}
