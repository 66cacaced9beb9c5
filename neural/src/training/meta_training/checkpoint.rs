//! The meta-training checkpoint (`OUT/checkpoint.bin`): the options, the stage and iteration
//! reached, then the weights. Written by rank 0 alone; on a restart rank 0 reads it and hands
//! it to every other rank through the collective (`share`), so the ranks need no shared disk.

use super::MetaOptions;
use crate::error::{Error, Result};
use crate::model::weights_file;
use crate::training::collective::Collective;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// What a checkpoint holds besides the weights.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(super) struct Checkpoint {
    format: String,
    version: u32,
    kind: String,
    pub options: MetaOptions,
    /// "sdf" (Alg. 1, weights = the SIREN) or "hyper" (Alg. 2, weights = hypernetwork then the
    /// static meta-SDF of Alg. 1).
    pub stage: String,
    /// Iterations completed in that stage.
    pub iteration: usize,
    pub seconds: f64,
    /// The meta-model whose static meta-SDF stands for Alg. 1 (`start_from_static`), named in
    /// the finished model's provenance (absent: Alg. 1 ran here).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub static_from: Option<String>,
}

impl Checkpoint {
    pub fn new(options: &MetaOptions, stage: &str, iteration: usize, seconds: f64) -> Checkpoint {
        Checkpoint {
            format: "avatar-studio-checkpoint".into(),
            version: 1,
            kind: "meta-checkpoint".into(),
            options: options.clone(),
            stage: stage.into(),
            iteration,
            seconds,
            static_from: None,
        }
    }

    /// The same, its static meta-SDF taken from the meta-model `from` names.
    pub fn with_static_from(self, from: Option<String>) -> Checkpoint {
        Checkpoint { static_from: from, ..self }
    }

    /// Check a checkpoint's header before its weights are read; the number of weights it needs.
    /// An unknown stage is an error: silently restarting would throw the run away.
    pub fn expected_weights(&self) -> Result<usize> {
        if self.format != "avatar-studio-checkpoint"
            || self.version != 1
            || self.kind != "meta-checkpoint"
        {
            return Err(Error::invalid(format!(
                "checkpoint format {:?} version {} kind {:?} is not supported by this build",
                self.format, self.version, self.kind
            )));
        }
        self.options.config.check()?;
        let sdf = self.options.config.siren.num_params();
        match self.stage.as_str() {
            "sdf" => Ok(sdf),
            "hyper" => Ok(self.options.config.num_params() + sdf),
            other => Err(Error::invalid(format!(
                "unknown checkpoint stage {other:?} (sdf or hyper); refusing to restart over it: move it away to start afresh"
            ))),
        }
    }
}

/// Where a run resumes: the stage ("sdf" or "hyper"), the iterations done in it, the seconds
/// spent before, the weights.
pub(super) struct Resume {
    pub stage: &'static str,
    pub iteration: usize,
    pub seconds: f64,
    pub weights: Vec<f32>,
    /// `Checkpoint::static_from` (rank 0's alone: only rank 0 writes files).
    pub static_from: Option<String>,
}

/// Rank 0 reads the checkpoint (`read` on rank 0 only) and every rank gets the same resume
/// point. A refused checkpoint stops every rank: rank 0 with the reason, the others saying
/// that rank 0 refused it.
pub(super) fn share(
    collective: &Collective,
    options: &MetaOptions,
    read: impl FnOnce() -> Result<Option<Resume>>,
) -> Result<Option<Resume>> {
    let local = if collective.is_root() { read() } else { Ok(None) };
    if collective.world() == 1 {
        return local;
    }
    // [refused, stage (0 none, 1 sdf, 2 hyper), iteration / 2^20, iteration % 2^20, seconds]:
    // rank 0 sends, the others add zeros, so the sum is rank 0's exactly.
    let mut head = [0f32; 5];
    match &local {
        Err(_) => head[0] = 1.0,
        Ok(Some(r)) => {
            head[1] = if r.stage == "sdf" { 1.0 } else { 2.0 };
            head[2] = (r.iteration >> 20) as f32;
            head[3] = (r.iteration & 0xF_FFFF) as f32;
            head[4] = r.seconds as f32;
        }
        Ok(None) => {}
    }
    collective.all_reduce_sum(&mut head)?;
    if head[0] > 0.0 {
        return match local {
            Err(e) => Err(e),
            Ok(_) => Err(Error::invalid(
                "rank 0 refused the run's checkpoint (its output says why); no rank started",
            )),
        };
    }
    if head[1] == 0.0 {
        return Ok(None);
    }
    let sdf = options.config.siren.num_params();
    let count = if head[1] == 1.0 { sdf } else { options.config.num_params() + sdf };
    let static_from = local.as_ref().ok().and_then(|r| r.as_ref()?.static_from.clone());
    let mut weights = match local {
        Ok(Some(r)) => r.weights,
        _ => vec![0.0; count],
    };
    collective.all_reduce_sum(&mut weights)?;
    Ok(Some(Resume {
        stage: if head[1] == 1.0 { "sdf" } else { "hyper" },
        iteration: ((head[2] as usize) << 20) | head[3] as usize,
        seconds: f64::from(head[4]),
        weights,
        static_from,
    }))
}

/// Read `path` if it exists and may go on under `options` (`resumes`).
pub(super) fn read(
    path: &Path,
    options: &MetaOptions,
    resumes: fn(&MetaOptions, &MetaOptions) -> bool,
) -> Result<Option<Resume>> {
    if !path.exists() {
        return Ok(None);
    }
    let (ck, weights): (Checkpoint, Vec<f32>) =
        weights_file::read_expecting(path, Checkpoint::expected_weights)?;
    if !resumes(&ck.options, options) {
        return Err(Error::file(
            path,
            "a checkpoint of a run with other options is in the output folder: use another --out or the same options",
        ));
    }
    let stage = if ck.stage == "sdf" { "sdf" } else { "hyper" };
    Ok(Some(Resume {
        stage,
        iteration: ck.iteration,
        seconds: ck.seconds,
        weights,
        static_from: ck.static_from,
    }))
}

/// Refuse to start unless every rank has the same options and data (a 64-bit fingerprint of
/// each, gathered through one all-reduce: rank r fills its own slots).
pub(super) fn check_same_run(collective: &Collective, fingerprint: u64) -> Result<()> {
    if collective.world() == 1 {
        return Ok(());
    }
    let (world, rank) = (collective.world(), collective.rank());
    let mut all = vec![0f32; 4 * world];
    for k in 0..4 {
        all[4 * rank + k] = ((fingerprint >> (16 * k)) & 0xFFFF) as f32;
    }
    collective.all_reduce_sum(&mut all)?;
    let of = |r: usize| (0..4).fold(0u64, |h, k| h | ((all[4 * r + k] as u64) << (16 * k)));
    if let Some(other) = (0..world).find(|&r| of(r) != fingerprint) {
        return Err(Error::invalid(format!(
            "rank {rank} and rank {other} were started with other options or other data: every rank needs the same command and data"
        )));
    }
    Ok(())
}

/// FNV-1a over bytes: a fingerprint that is the same on every machine and build.
pub(super) fn fnv1a(hash: u64, bytes: &[u8]) -> u64 {
    bytes.iter().fold(hash, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01B3))
}

pub(super) const FNV_START: u64 = 0xCBF2_9CE4_8422_2325;
