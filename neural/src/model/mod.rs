//! The networks and their files: the SIREN SDF (`siren`, its sine activation `sine`, the fast
//! evaluation path `siren_eval`), the bone encoder (`encoder`), the hypernetwork (`hyper`),
//! parameters as one flat vector (`flat_params`), the weights file (`weights_file`) and the
//! meta-model file (`model_file`: the shipped prior and `PriorRef`). Configs: `SirenConfig`,
//! `HyperConfig` (`config::Check`).

mod config;
pub mod encoder;
pub mod flat_params;
pub mod hyper;
pub mod model_file;
pub mod sine;
pub mod siren;
pub mod siren_eval;
pub mod weights_file;
