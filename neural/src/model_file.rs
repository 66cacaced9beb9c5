//! The meta-learned model: the hypernetwork (with the meta-SDF its residuals are added to) and
//! the static meta-SDF of Alg. 1 (the paper's pose-independent baseline), in one weights file.
//! The compact model ships inside the binary (assets/model/), so the studio and `fit` work on a
//! fresh machine with no downloads.

use crate::error::{Error, Result};
use crate::flat_params::flatten;
use crate::hyper::{HyperConfig, HyperNet};
use crate::siren::Siren;
use crate::weights_file;
use serde::{Deserialize, Serialize};
use std::path::Path;

pub const MODEL_FORMAT: &str = "avatar-studio-meta-model";
pub const MODEL_VERSION: u32 = 1;
pub const MODEL_KIND: &str = "meta-model";

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelHeader {
    pub format: String,
    pub version: u32,
    pub kind: String,
    pub config: HyperConfig,
    /// Weights: the hypernetwork's, then the static meta-SDF's.
    pub hyper_params: usize,
    pub static_params: usize,
    /// How the weights were made (command, seed, iterations, time).
    pub provenance: String,
}

#[derive(Debug, Clone)]
pub struct MetaModel {
    pub header: ModelHeader,
    pub hyper: Vec<f32>,
    pub static_sdf: Vec<f32>,
}

/// The shipped compact model (meta-trained on synthetic training subjects; docs/neural.md).
const SHIPPED: &[u8] = include_bytes!("../../assets/model/meta-compact.bin");

impl MetaModel {
    /// The compact model embedded in the binary.
    pub fn shipped() -> MetaModel {
        Self::parse(SHIPPED, Path::new("assets/model/meta-compact.bin"))
            .expect("the shipped meta-model is valid (checked by a test)")
    }

    /// A model file, or the shipped one for None.
    pub fn load_or_shipped(path: Option<&Path>) -> Result<MetaModel> {
        match path {
            Some(p) => Self::load(p),
            None => Ok(Self::shipped()),
        }
    }

    pub fn from_parts(
        config: HyperConfig,
        hyper: &HyperNet,
        static_sdf: &Siren,
        provenance: String,
    ) -> MetaModel {
        let hyper = flatten(hyper);
        let static_sdf = flatten(static_sdf);
        MetaModel {
            header: ModelHeader {
                format: MODEL_FORMAT.into(),
                version: MODEL_VERSION,
                kind: MODEL_KIND.into(),
                config,
                hyper_params: hyper.len(),
                static_params: static_sdf.len(),
                provenance,
            },
            hyper,
            static_sdf,
        }
    }

    pub fn save(&self, path: &Path) -> Result<()> {
        let mut w = self.hyper.clone();
        w.extend_from_slice(&self.static_sdf);
        weights_file::write(path, &self.header, &w)
    }

    /// Read a model file: the header is checked (format, kind, sizes) and the file's size
    /// compared with it before the weights are read.
    pub fn load(path: &Path) -> Result<MetaModel> {
        let (header, weights) = weights_file::read_expecting(path, Self::check_header)?;
        Ok(Self::split(header, weights))
    }

    pub fn parse(bytes: &[u8], origin: &Path) -> Result<MetaModel> {
        let (header, weights): (ModelHeader, Vec<f32>) = weights_file::parse(bytes, origin)?;
        let expected = Self::check_header(&header).map_err(|e| e.in_file(origin))?;
        if weights.len() != expected {
            return Err(Error::file(
                origin,
                format!("truncated model file: {} weights, expected {expected}", weights.len()),
            ));
        }
        Ok(Self::split(header, weights))
    }

    /// Format, version, kind and sizes of a header; the number of weights it needs.
    fn check_header(header: &ModelHeader) -> Result<usize> {
        if header.format != MODEL_FORMAT || header.version != MODEL_VERSION {
            return Err(Error::invalid(format!(
                "meta-model format {:?} version {} is not supported by this build (it reads {MODEL_FORMAT:?} version {MODEL_VERSION})",
                header.format, header.version
            )));
        }
        if header.kind != MODEL_KIND {
            return Err(Error::invalid(format!(
                "kind {:?} is not a meta-model ({MODEL_KIND:?}): an avatar or another file under a meta-model header",
                header.kind
            )));
        }
        header.config.check()?;
        if header.hyper_params != header.config.num_params()
            || header.static_params != header.config.siren.num_params()
        {
            return Err(Error::invalid(
                "the header's parameter counts do not match its network configuration",
            ));
        }
        Ok(header.hyper_params + header.static_params)
    }

    fn split(header: ModelHeader, weights: Vec<f32>) -> MetaModel {
        let (hyper, static_sdf) = weights.split_at(header.hyper_params);
        MetaModel { hyper: hyper.to_vec(), static_sdf: static_sdf.to_vec(), header }
    }

    /// The trainable hypernetwork.
    pub fn hyper_net(&self) -> HyperNet {
        trainable_hyper(&self.header.config, &self.hyper, 0).expect("counts checked on load")
    }

    /// The trainable static meta-SDF.
    pub fn static_siren(&self) -> Siren {
        trainable_siren(&self.header.config.siren, &self.static_sdf, 0)
            .expect("counts checked on load")
    }
}

/// The meta-SDF as a trainable SIREN on the training device.
pub fn trainable_siren(
    config: &crate::siren::SirenConfig,
    flat: &[f32],
    seed: u64,
) -> Result<Siren> {
    crate::flat_params::load_flat(config.init(seed, &crate::compute::training_device()), flat)
}

/// The hypernetwork (its base SDF included) as a trainable module on the training device.
pub fn trainable_hyper(config: &HyperConfig, flat: &[f32], seed: u64) -> Result<HyperNet> {
    let device = crate::compute::training_device();
    crate::flat_params::load_flat(
        config.init(config.siren.init(seed, &device), seed, &device),
        flat,
    )
}
