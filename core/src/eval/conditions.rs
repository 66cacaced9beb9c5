//! Capture conditions of the fine-tuning captures: how far they are from the clean protocol
//! camera. `clean` is MetaAvatar's protocol (exact depth, exact fittings, 45 degrees between
//! frames); `user` is a capture as users make them: Kinect-like depth noise and holes
//! (`synth::noise`), small seeded errors in the body fittings and turns other than 45 degrees.
//! The held-out poses the avatar is scored at are always the exact ones (the truth).

use crate::body::BodyParams;
use crate::capture::CaptureManifest;
use crate::error::{Error, Result};
use crate::synth::noise::{DepthNoise, gaussian};
use crate::synth::{Outfit, SynthJob};
use glam::{Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Seeded errors added to every frame's fitting (what the avatar is fine-tuned with), not to
/// the rendered depth: each joint's rotation (the root included) is pre-multiplied by a
/// rotation vector with Gaussian components of standard deviation `joint_deg / sqrt(3)` (RMS
/// angle `joint_deg`), and the translation gets a Gaussian offset of RMS length `trans_m`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FittingError {
    pub joint_deg: f32,
    pub trans_m: f32,
}

impl FittingError {
    pub const NONE: FittingError = FittingError { joint_deg: 0.0, trans_m: 0.0 };

    pub fn is_none(&self) -> bool {
        self.joint_deg == 0.0 && self.trans_m == 0.0
    }

    pub fn apply(&self, p: &mut BodyParams, rng: &mut ChaCha8Rng) {
        let per_axis = self.joint_deg.to_radians() / 3f32.sqrt();
        for r in p.pose.iter_mut() {
            let e = Vec3::new(gaussian(rng), gaussian(rng), gaussian(rng)) * per_axis;
            *r = (Quat::from_scaled_axis(e) * Quat::from_scaled_axis(*r)).to_scaled_axis();
        }
        let t =
            Vec3::new(gaussian(rng), gaussian(rng), gaussian(rng)) * (self.trans_m / 3f32.sqrt());
        p.trans += t;
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CaptureConditions {
    /// `clean` or `user` (the table's capture column).
    pub name: String,
    /// Depth corruption of the fine-tuning frames (`None` = exact depth).
    pub noise: Option<DepthNoise>,
    /// Errors added to the body fittings (serialized as `fit_error`, the key existing files use).
    #[serde(rename = "fit_error", alias = "fitting_error")]
    pub fitting_error: FittingError,
    /// The person turns by a constant angle between frames, drawn per capture uniformly from
    /// this range (degrees); the clean protocol's is (45, 45).
    pub turn_deg: (f32, f32),
}

impl CaptureConditions {
    pub fn clean() -> Self {
        CaptureConditions {
            name: "clean".into(),
            noise: None,
            fitting_error: FittingError::NONE,
            turn_deg: (45.0, 45.0),
        }
    }

    /// Kinect v2-like depth, fittings off by 3 degrees per joint and 1 cm (RMS), 30-60 degrees
    /// between frames (8 frames then cover 210-420 degrees around the person).
    pub fn user() -> Self {
        CaptureConditions {
            name: "user".into(),
            noise: Some(DepthNoise::kinect_v2()),
            fitting_error: FittingError { joint_deg: 3.0, trans_m: 0.01 },
            turn_deg: (30.0, 60.0),
        }
    }

    /// `user`, but a person who never turns their back: 3-4 degrees between frames (8 frames
    /// cover 21-32 degrees, one fixed camera in front), so what hangs at the back (a cape, a
    /// coat's tails) is seen only at its edges.
    pub fn front() -> Self {
        CaptureConditions { name: "front".into(), turn_deg: (3.0, 4.0), ..Self::user() }
    }

    /// `user`, `clean`, `front`, `noisy`, `misfit` or a comma-separated list; `noise` names the depth model of `user`
    /// (`kinect_v1`, `kinect_v2`).
    pub fn parse_list(names: &str, noise: Option<&str>) -> Result<Vec<Self>> {
        let noise = match noise {
            None => None,
            Some(n) => Some(DepthNoise::preset(n).ok_or_else(|| {
                Error::invalid(format!("unknown noise model {n:?}: use kinect_v1 or kinect_v2"))
            })?),
        };
        names
            .split(',')
            .map(|n| match n.trim() {
                "clean" => Ok(Self::clean()),
                "front" => Ok(CaptureConditions { noise: noise.or(Self::user().noise), ..Self::front() }),
                "user" => Ok(CaptureConditions { noise: noise.or(Self::user().noise), ..Self::user() }),
                // Diagnostic settings: one of the user conditions at a time.
                "noisy" => Ok(CaptureConditions { name: "noisy".into(), noise: noise.or(Self::user().noise), fitting_error: FittingError::NONE, ..Self::user() }),
                "misfit" => Ok(CaptureConditions { name: "misfit".into(), noise: None, ..Self::user() }),
                other => Err(Error::invalid(format!("unknown capture conditions {other:?}: use user, clean, front (user, never turning the back to the camera), noisy (depth noise only) or misfit (fitting errors only)"))),
            })
            .collect()
    }

    /// The random stream of this setting's captures. The diagnostic settings share `user`'s
    /// (the same noise draw, the same fitting errors, the same turn), so that each shows one of
    /// the user conditions on the same capture.
    pub fn seed_stream(&self) -> u64 {
        match self.name.as_str() {
            "clean" => 1,
            "front" => 2,
            _ => 0,
        }
    }

    /// One line for the report's header.
    pub fn describe(&self) -> String {
        let noise = match &self.noise {
            None => "exact depth".to_string(),
            Some(n) if *n == DepthNoise::kinect_v1() => "kinect_v1 depth noise and holes".into(),
            Some(n) if *n == DepthNoise::kinect_v2() => "kinect_v2 depth noise and holes".into(),
            Some(_) => "custom depth noise".into(),
        };
        let fitting = if self.fitting_error.is_none() {
            "exact fittings".to_string()
        } else {
            format!(
                "fittings off by {} deg per joint and {} cm (RMS)",
                self.fitting_error.joint_deg,
                self.fitting_error.trans_m * 100.0
            )
        };
        let (a, b) = self.turn_deg;
        let turn = if a == b {
            format!("{a} deg between frames")
        } else {
            format!("{a}-{b} deg between frames (one draw per capture)")
        };
        format!("{}: {noise}, {fitting}, {turn}", self.name)
    }

    /// Set the job's turn and depth noise for the capture with this seed.
    pub fn prepare(&self, job: &mut SynthJob, seed: u64) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7475_726e);
        let (a, b) = self.turn_deg;
        job.turn_per_frame_deg = if b > a { rng.random_range(a..=b) } else { a };
        job.noise = self.noise;
        job.noise_seed = seed;
    }

    /// Add the fitting errors to the capture written in `dir` (its `capture.json`).
    pub fn perturb_fittings(&self, dir: &Path, seed: u64) -> Result<()> {
        if self.fitting_error.is_none() {
            return Ok(());
        }
        let mut manifest = CaptureManifest::load(dir)?;
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6669_7465);
        for rec in manifest.frames.iter_mut() {
            let mut p = rec.params().map_err(|e| e.in_file(CaptureManifest::path_in(dir)))?;
            self.fitting_error.apply(&mut p, &mut rng);
            rec.pose = Some(p.flat_pose());
            rec.translation = Some(p.trans.to_array());
        }
        manifest.save(dir)
    }
}

/// The seed of one fine-tuning capture: the run's seed, the subject, the outfit and the
/// setting, mixed so that neighbouring values give unrelated streams. The outfit and the
/// setting enter by identity, not by their place in the command's lists, so a capture does not
/// change when other outfits or settings are evaluated beside it (`--outfits dress` draws the
/// full table's dress capture).
pub fn capture_seed(
    seed: u64,
    subject: u64,
    outfit: Outfit,
    conditions: &CaptureConditions,
) -> u64 {
    let mut h = seed ^ 0x9e37_79b9_7f4a_7c15;
    // The outfit's declaration order, which is `ALL_OUTFITS`' (the full preset's) order.
    for v in [subject, outfit as u64, conditions.seed_stream()] {
        h = (h ^ v).wrapping_mul(0x1000_0000_01b3).rotate_left(29);
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fitting_error_is_serialized_as_fit_error() {
        let json = serde_json::to_string(&CaptureConditions::user()).unwrap();
        assert!(json.contains("\"fit_error\":{\"joint_deg\":3.0,\"trans_m\":0.01}"), "{json}");
        let back: CaptureConditions = serde_json::from_str(&json).unwrap();
        assert_eq!(back, CaptureConditions::user());
        let renamed = json.replace("\"fit_error\"", "\"fitting_error\"");
        assert_eq!(serde_json::from_str::<CaptureConditions>(&renamed).unwrap(), back);
    }

    #[test]
    fn fitting_errors_have_the_stated_size_and_are_seeded() {
        let e = FittingError { joint_deg: 3.0, trans_m: 0.01 };
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let (mut angles, mut shifts) = (Vec::new(), Vec::new());
        for _ in 0..400 {
            let mut p = BodyParams::default();
            e.apply(&mut p, &mut rng);
            angles.extend(p.pose.iter().map(|r| r.length().to_degrees()));
            shifts.push(p.trans.length());
        }
        let rms = |v: &[f32]| (v.iter().map(|x| x * x).sum::<f32>() / v.len() as f32).sqrt();
        assert!((rms(&angles) - 3.0).abs() < 0.1, "joint RMS {}", rms(&angles));
        assert!((rms(&shifts) - 0.01).abs() < 0.001, "translation RMS {}", rms(&shifts));
        // Composed with an existing rotation, the error is a small extra rotation.
        let mut p = BodyParams::default();
        p.pose[4] = Vec3::new(1.2, 0.0, 0.0);
        let before = Quat::from_scaled_axis(p.pose[4]);
        e.apply(&mut p, &mut ChaCha8Rng::seed_from_u64(1));
        assert!(before.angle_between(Quat::from_scaled_axis(p.pose[4])).to_degrees() < 15.0);
        let again = {
            let mut q = BodyParams::default();
            q.pose[4] = Vec3::new(1.2, 0.0, 0.0);
            e.apply(&mut q, &mut ChaCha8Rng::seed_from_u64(1));
            q
        };
        assert_eq!(again, p);
        let mut exact = BodyParams::default();
        FittingError::NONE.apply(&mut exact, &mut rng);
        assert_eq!(exact, BodyParams::default());
    }

    #[test]
    fn a_capture_is_drawn_by_its_outfit_and_setting_not_by_their_place_in_the_lists() {
        let [user, clean] = <[CaptureConditions; 2]>::try_from(
            CaptureConditions::parse_list("user,clean", None).unwrap(),
        )
        .unwrap();
        let [noisy, misfit] = <[CaptureConditions; 2]>::try_from(
            CaptureConditions::parse_list("noisy,misfit", None).unwrap(),
        )
        .unwrap();
        let seed = |o, c: &CaptureConditions| capture_seed(0, 1001, o, c);
        let dress = crate::synth::Outfit::Dress;
        // The diagnostic settings share the user capture's draw; clean has its own.
        assert_eq!(seed(dress, &noisy), seed(dress, &user));
        assert_eq!(seed(dress, &misfit), seed(dress, &user));
        assert_ne!(seed(dress, &clean), seed(dress, &user));
        assert_ne!(seed(crate::synth::Outfit::PoloLoose, &user), seed(dress, &user));
        assert_ne!(capture_seed(0, 1002, dress, &user), seed(dress, &user));
        // The seeds take an outfit's declaration order: the full preset's list order.
        for (i, o) in crate::synth::ALL_OUTFITS.iter().enumerate() {
            assert_eq!(*o as usize, i, "{o:?}");
        }
    }

    #[test]
    fn conditions_parse_and_turns_stay_in_range() {
        let c = CaptureConditions::parse_list("user,clean", Some("kinect_v1")).unwrap();
        assert_eq!(c[0].noise, Some(DepthNoise::kinect_v1()));
        assert_eq!(c[1], CaptureConditions::clean());
        assert!(
            CaptureConditions::parse_list("dirty", None).unwrap_err().to_string().contains("dirty")
        );
        assert!(CaptureConditions::parse_list("user", Some("kinect_v9")).is_err());
        let user = CaptureConditions::user();
        let clip = crate::motion::MotionClip::new("x", 30.0, vec![BodyParams::default()]);
        let mut turns = Vec::new();
        for s in 0..50 {
            let mut job = SynthJob::new(1, crate::synth::Outfit::Dress, clip.clone());
            user.prepare(&mut job, capture_seed(s, 1001, crate::synth::Outfit::Dress, &user));
            turns.push(job.turn_per_frame_deg);
            assert!(job.noise.is_some());
        }
        assert!(turns.iter().all(|t| (30.0..=60.0).contains(t)));
        assert!(turns.iter().any(|t| *t < 40.0) && turns.iter().any(|t| *t > 50.0), "{turns:?}");
        let mut job = SynthJob::new(1, crate::synth::Outfit::Dress, clip);
        CaptureConditions::clean().prepare(&mut job, 3);
        assert_eq!((job.turn_per_frame_deg, job.noise), (45.0, None));
        assert!(user.describe().contains("3 deg per joint"), "{}", user.describe());
    }
}
