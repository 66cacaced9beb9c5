//! The meta-learned model: the hypernetwork (with the meta-SDF its residuals are added to) and
//! the static meta-SDF of Alg. 1 (the paper's pose-independent baseline), in one weights file.
//! The compact model ships inside the binary (assets/model/), so the studio and `fit` work on a
//! fresh machine with no downloads.

use crate::error::{Error, Result};
use crate::model::flat_params::flatten;
use crate::model::hyper::{HyperConfig, HyperNet};
use crate::model::siren::Siren;
use crate::model::weights_file;
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
    /// The file it was read from (`None`: made in memory, not read from a file).
    pub origin: Option<PriorRef>,
}

/// Which meta-model (prior) an avatar was fine-tuned from: recorded in the avatar's header and
/// shown by `fit`, `check` and the studio.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PriorRef {
    /// [`SHIPPED_PRIOR`] for the model embedded in the binary, else the model file's path
    /// (absolute).
    pub name: String,
    /// SHA-256 of the model file's bytes, lowercase hex (what `sha256sum` prints).
    pub sha256: String,
    /// The model's own provenance line (command, seed, iterations, time).
    pub provenance: String,
}

/// The name of the prior embedded in the binary.
pub const SHIPPED_PRIOR: &str = "shipped";

impl PriorRef {
    /// Bounded strings and a SHA-256 of 64 hex digits (an avatar header's check).
    pub fn check(&self) -> Result<()> {
        if self.name.is_empty() || self.name.len() > 4096 || self.provenance.len() > 4096 {
            return Err(Error::invalid(
                "\"prior\": its name must be 1 to 4096 bytes and its provenance at most 4096",
            ));
        }
        if self.sha256.len() != 64 || !self.sha256.bytes().all(|b| b.is_ascii_hexdigit()) {
            return Err(Error::invalid("\"prior\": \"sha256\" must be 64 hex digits"));
        }
        Ok(())
    }

    /// "shipped (sha256 0123abcd...)" or "/path/meta-model.bin (sha256 ...)".
    pub fn label(&self) -> String {
        format!("{} (sha256 {})", self.name, &self.sha256[..self.sha256.len().min(12)])
    }
}

/// SHA-256 of bytes, lowercase hex.
pub fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::Digest;
    sha2::Sha256::digest(bytes).iter().map(|b| format!("{b:02x}")).collect()
}

fn sha256_of_file(path: &Path) -> Result<String> {
    use sha2::Digest;
    let mut file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut hasher = sha2::Sha256::new();
    std::io::copy(&mut file, &mut hasher).map_err(|e| Error::io(path, e))?;
    Ok(hasher.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

/// The shipped compact model (meta-trained on synthetic training subjects; docs/neural.md).
const SHIPPED: &[u8] = include_bytes!("../../../assets/model/meta-compact.bin");

impl MetaModel {
    /// The compact model embedded in the binary.
    pub fn shipped() -> MetaModel {
        let mut model = Self::parse(SHIPPED, Path::new("assets/model/meta-compact.bin"))
            .expect("the shipped meta-model is valid (checked by a test)");
        if let Some(origin) = &mut model.origin {
            origin.name = SHIPPED_PRIOR.into();
        }
        model
    }

    /// What an avatar fine-tuned from this model records (`None` for a model made in memory).
    pub fn prior(&self) -> Option<PriorRef> {
        self.origin.clone()
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
            origin: None,
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
        // Another kind of file (an avatar, a checkpoint) is named as such before its header is
        // read as a model's.
        let weights_file::Identity { format, kind, .. } = weights_file::identity(path)?;
        if format != MODEL_FORMAT || kind != MODEL_KIND {
            return Err(Error::file(
                path,
                format!(
                    "a {format:?} file of kind {kind:?}, not a meta-model ({MODEL_FORMAT:?}): give the meta-model.bin that meta-train wrote"
                ),
            ));
        }
        let (header, weights) = weights_file::read_expecting(path, Self::check_header)?;
        let mut model = Self::split(header, weights);
        let name = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
        model.origin = Some(PriorRef {
            name: name.display().to_string(),
            sha256: sha256_of_file(path)?,
            provenance: model.header.provenance.clone(),
        });
        Ok(model)
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
        let mut model = Self::split(header, weights);
        model.origin = Some(PriorRef {
            name: origin.display().to_string(),
            sha256: sha256_hex(bytes),
            provenance: model.header.provenance.clone(),
        });
        Ok(model)
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
        MetaModel { hyper: hyper.to_vec(), static_sdf: static_sdf.to_vec(), header, origin: None }
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

/// The meta-SDF as a trainable SIREN on the CPU's training device (a fit forks it to its own).
pub fn trainable_siren(
    config: &crate::model::siren::SirenConfig,
    flat: &[f32],
    seed: u64,
) -> Result<Siren> {
    crate::model::flat_params::load_flat(config.init(seed, &crate::cpu_training_device()), flat)
}

/// The hypernetwork (its base SDF included) as a trainable module on the CPU's training device
/// (a fit forks it to its own).
pub fn trainable_hyper(config: &HyperConfig, flat: &[f32], seed: u64) -> Result<HyperNet> {
    let device = crate::cpu_training_device();
    crate::model::flat_params::load_flat(
        config.init(config.siren.init(seed, &device), seed, &device),
        flat,
    )
}
